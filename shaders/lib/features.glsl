// cellgl: features of the Voronoi cell beyond F1..Fn, exact.
//
// cell_features() takes the result of cell_search() and walks the cells again
// to find, for the sample x with nearest feature point p1 (F1 = |p1 - x|):
//
//   * distance to edge (CELL_EDGE, Euclidean): the distance from x to the
//     border of p1's Voronoi cell, min over the other points pj of the
//     distance to their bisector plane,
//         b_j = dot((p1 + pj) / 2 - x, n_j),   n_j = (pj - p1) / |pj - p1|,
//     and its gradient -n_j of the nearest plane. Exact: a point at distance
//     d from x has |pj - p1| <= d + F1, so b_j >= (d^2 - F1^2) / (2 (d + F1))
//     = (d - F1) / 2; once the best plane is at E, no point further than
//     F1 + 2 E from x can beat it, and the walk visits every cell nearer than
//     that (not a fixed 3^d window, which misses planes next to big cells).
//   * smooth F1 (CELL_SMOOTH, any metric): the exponential smooth minimum
//         S = -k log sum_j exp(-F_j / k) = F1 - k log sum_j w_j,
//         w_j = exp(-(F_j - F1) / k),
//     with the offset to the feature point, the gradient and the cell
//     attribute (cell_id_attribute) averaged with the weights w_j / sum w.
//     Points with F_j >= F1 + CELL_SMOOTH_CUTOFF k (w_j < e^-16 ~ 1.1e-7, under
//     float32 resolution) are left out; every nearer one is visited. k = 0 is
//     the hard minimum (S = F1).
//   * n-sphere radius (CELL_NSPHERE, Euclidean): half the distance from p1 to
//     its nearest other feature point (the radius of the largest ball around
//     p1 inside its cell), found by an exact nearest-neighbour walk around p1.
//
// The walks go ring by ring (Chebyshev rings of cells, as cell_search), skip
// every cell whose nearest possible point is beyond the current reach, stop
// once a whole ring is beyond it, and report CellFeatures.exact = false instead
// of a wrong answer if CELL_FEATURE_MAX_RING rings were not enough, or if the
// loop budget (CELL_LOOP_BUDGET, cellular.glsl) ran out: the walks continue the
// count of the cell_search() they follow (CellFeatures.loops), so search and
// walks together stay inside the budget.
//
// Requires: feature_walk.glsl (included; the walks, and with them
// cellular.glsl and walk.glsl). Macros: those of cellular.glsl, CELL_EDGE,
// CELL_SMOOTH, CELL_NSPHERE (0 or 1, default 0; CELL_SMOOTH 2: smooth F1 as
// Blender's Voronoi node folds it, _cell_poly_smooth below; all 0: nothing
// below is compiled and cell_search is untouched), CELL_FEATURE_MAX_RING,
// CELL_EDGE_ALONE (1: cell_edge_alone, the walk finding the F1 point too),
// CELL_SMOOTH_EXTRA, CELL_WALKS_APART (feature_walk.glsl: each walk on its own
// after one search, cell_features below).

#include "feature_walk.glsl"

#if CELL_EDGE || CELL_SMOOTH || CELL_NSPHERE

// A walk around the sample whose F1 point is at offset d1 (ID id1, distance
// F1), after `loops` loop passes; with CELL_WALKS_APART serving the edge
// (edge_on) and/or smooth F1 (smooth_on), else every compiled feature.
_CellWalk _cell_walk_start(vec4 d1, uint id1, float F1, int loops, float smoothness, bool edge_on, bool smooth_on)
{
    _CellWalk w;
    w.around = false;
    w.d1 = d1;
    w.id1 = id1;
    w.F1 = F1;
    w.k = smoothness;
    w.edge = CELL_FAR;
    w.edge_n = vec4(0.0);
    w.wsum = 0.0;
    w.wdelta = vec4(0.0);
    w.wgrad = vec4(0.0);
    w.wattr = vec4(0.0);
    w.edge_on = edge_on;
    w.smooth_on = smooth_on;
    w.found = false;
    w.o1 = ivec4(0);
    w.q1 = vec4(0.0);
    w.nn = CELL_FAR;
    w.loops = loops;
    w.spent = false;
#if CELL_EDGE_ALONE
    w.nearest = F1 >= CELL_FAR;    // no F1 point given: the walk finds it first
#endif
#if _CELL_FAR_SUM
    w.far = false;
#endif
    return w;
}

struct CellFeatures {
    float edge;          // distance to the cell's border (CELL_EDGE)
    vec4 edge_grad;      // its gradient: minus the normal of the nearest bisector plane
    float smooth_F;      // smooth F1 (CELL_SMOOTH)
    vec4 smooth_delta;   // weighted mean of (feature point - sample)
    vec4 smooth_grad;    // d smooth_F / d sample
    vec4 smooth_attr;    // weighted mean of cell_id_attribute
    float nsphere;       // n-sphere radius (CELL_NSPHERE)
    bool exact;          // false if a walk reached CELL_FEATURE_MAX_RING or the loop budget
    int loops;           // loop iterations spent by the search and the walks
    int walks;           // CELL_WALKS_APART: which were exact, CELL_WALK_OK_* (else all)
};

// The bits of CellFeatures.walks (cellgl/basis/passes.py reads them from the
// record, CELL_FO_WALKS): the search, and each walk, exact.
#define CELL_WALK_OK_SEARCH 1
#define CELL_WALK_OK_EDGE 2
#define CELL_WALK_OK_NSPHERE 4
#define CELL_WALK_OK_SMOOTH 8

#if CELL_SMOOTH == 2
// Smooth F1 as Blender's Voronoi node folds it (CELL_SMOOTH 2): a running
// polynomial smooth minimum over the 5^d block of cells around the sample's,
// in the node's order (x fastest, then y, z, w), starting from 8:
//     h = smoothstep(0, 1, 1/2 + (s - d) / (2 k)),  c = k h (1 - h),
//     s <- mix(s, d, h) - c,
// with k = smoothness / 2; the point's position and cell colour are folded with
// the same h and c / (1 + 3 k) (and the cell value, for the texture layer). The fold depends on the order (a point far
// from the sample, visited before the nearest one, can still pull s down), so
// it is the node's definition over the node's window, not a minimum over all
// points. Its gradient is carried along by the chain rule. smoothness 0: the
// hard minimum (the first point of least distance).
float _cell_smoothstep_slope(float t)
{
    return (t > 0.0 && t < 1.0) ? 6.0 * t * (1.0 - t) : 0.0;
}

void _cell_poly_smooth(inout CellFeatures o, ivec4 cell, vec4 f, CellParams p, float smoothness)
{
    // CELL_PRECISE (metric.glsl): the fold rounded as written, the same in every entry
    float k = 0.5 * smoothness;
    CELL_PRECISE float s = 8.0;
    CELL_PRECISE vec4 gs = vec4(0.0);            // d s / d sample
    CELL_PRECISE vec4 pos = vec4(0.0);           // folded point position, relative to the sample's cell
    CELL_PRECISE vec4 col = vec4(0.0);           // folded cell colour and cell value (cell_id_value)
#if CELL_DIM >= 4
    for (int v = -2; v <= 2; v++)
#else
    for (int v = 0; v <= 0; v++)
#endif
#if CELL_DIM >= 3
    for (int z = -2; z <= 2; z++)
#else
    for (int z = 0; z <= 0; z++)
#endif
    for (int y = -2; y <= 2; y++)
    for (int x = -2; x <= 2; x++) {
        ivec4 o4 = ivec4(x, y, z, v);
        ivec4 c;
        uint state;
        int count = _cell_open(cell, o4, p, c, state);
        for (int j = 0; j < count; j++) {
            uint id;
            CELL_PRECISE vec4 q = cell_dims(vec4(o4) + cell_next_point(state, c, p, id));
            CELL_PRECISE vec4 delta = q - f;
            CELL_PRECISE float d = cell_metric_finish(cell_metric_length(delta, p.minkowski_p), p.minkowski_p);
            CELL_PRECISE float h, dh_ds;
            if (k > 0.0) {
                CELL_PRECISE float t = 0.5 + 0.5 * (s - d) / k;
                h = smoothstep(0.0, 1.0, t);
                dh_ds = _cell_smoothstep_slope(t) * 0.5 / k;     // d h / d (s - d)
            } else {
                h = d < s ? 1.0 : 0.0;
                dh_ds = 0.0;
            }
            float c0 = k * h * (1.0 - h);
#if CELL_SMOOTH_EXTRA
            vec4 gd = cell_metric_gradient(delta, d, p.minkowski_p);
            // d s_new = (1 - h) ds + h dd + ((d - s) - k (1 - 2 h)) dh, dh = dh_ds (ds - dd)
            vec4 gh = dh_ds * (gs - gd);
            gs = (1.0 - h) * gs + h * gd + ((d - s) - k * (1.0 - 2.0 * h)) * gh;
#endif
            s = mix(s, d, h) - c0;
#if CELL_SMOOTH_EXTRA
            float c1 = c0 / (1.0 + 3.0 * k);
#if CELL_DIST == CELL_DIST_BLENDER
            vec4 cc = vec4(cell_blender_color(c), cell_id_value(id));
#else
            vec4 cc = cell_id_attribute(id);
#endif
            col = mix(col, cc, h) - c1;
            pos = mix(pos, q, h) - c1;
#endif
        }
    }
    o.smooth_F = s;
#if CELL_SMOOTH_EXTRA
    o.smooth_delta = cell_dims(pos - f);
    o.smooth_grad = cell_dims(gs);
    o.smooth_attr = col;
#endif
}
#endif

#if CELL_SMOOTH == 2 && !CELL_EDGE && !CELL_NSPHERE
// Smooth F1 as Blender's node folds it, alone: a fixed block of cells, so it
// needs neither cell_search() nor a walk (a caller that wants no F1..Fn skips
// the search). Always exact: the fold over its window is the definition.
CellFeatures cell_poly_features(ivec4 cell, vec4 f, CellParams p, float smoothness)
{
    CellFeatures o;
    o.edge = 0.0;
    o.edge_grad = vec4(0.0);
    o.nsphere = 0.0;
    o.smooth_delta = vec4(0.0);
    o.smooth_grad = vec4(0.0);
    o.smooth_attr = vec4(0.0);
    o.exact = true;
    o.loops = 0;
    o.walks = 15;
    _cell_poly_smooth(o, cell, f, p, smoothness);
    return o;
}
#endif

#if CELL_EDGE_ALONE
// The distance to the edge alone (the basis snippets): the ring walk finds the
// F1 point itself first (nearest mode: every cell that can hold a point nearer
// than the nearest so far, the least internal-unit distance, as cell_search),
// then walks around the sample for the edge; the same value as cell_search
// and cell_features, in one walker's code.
float cell_edge_alone(ivec4 cell, vec4 f, CellParams p)
{
    _CellWalk w = _cell_walk_start(vec4(0.0), 0u, CELL_FAR, 0, 0.0, true, false);
    _cell_walk_rings(w, cell, f, p, 0, CELL_FEATURE_MAX_RING);
    w.nearest = false;
    w.F1 = cell_metric_finish(w.F1, p.minkowski_p);
    w.edge = CELL_FAR;
    _cell_walk_rings(w, cell, f, p, 0, CELL_FEATURE_MAX_RING);
    return max(w.edge, 0.0);
}
#endif

#if CELL_SMOOTH == 1
// Smooth F1 (and its delta, gradient, attribute) from the walk's weights, where it has any
// (else the search's F1 stays).
void _cell_smooth_finish(inout CellFeatures o, _CellWalk w)
{
    if (w.wsum > 0.0) {
        float inv = 1.0 / w.wsum;
        o.smooth_F = w.F1 - w.k * log(w.wsum);
#if CELL_SMOOTH_EXTRA
        o.smooth_delta = w.wdelta * inv;
        o.smooth_grad = w.wgrad * inv;
        o.smooth_attr = w.wattr * inv;
#endif
    }
}
#endif

#if CELL_WALKS_APART
// The features of the sample (cell, f) whose cell_search() result is r, each
// walk on its own (CELL_WALKS_APART, feature_walk.glsl): what each gives in a
// pass of its own, one search for all. Each walk starts from the search's loop
// count (r.loops), as there: together they may spend more than one walk's
// budget, and where llvmpipe's own limit then cut a loop the canary of
// cellular.comp flags the sample (cellgl/basis/passes.py then runs the walks
// in passes of their own). o.walks: which were exact; o.exact: all.
CellFeatures cell_features(ivec4 cell, vec4 f, CellParams p, CellResult r, float smoothness)
{
    CellFeatures o;
    o.edge = 0.0;
    o.edge_grad = vec4(0.0);
    o.smooth_F = r.F[0];
    o.smooth_delta = r.delta[0];
    o.smooth_grad = cell_metric_gradient(r.delta[0], r.F[0], p.minkowski_p);
    o.smooth_attr = cell_id_attribute(r.id[0]);
    o.nsphere = 0.0;
    o.walks = r.exact ? CELL_WALK_OK_SEARCH | CELL_WALK_OK_EDGE | CELL_WALK_OK_NSPHERE | CELL_WALK_OK_SMOOTH : 0;
    o.loops = r.loops;
    // A walk runs only after an exact search (as r.exact && _cell_walk(...) alone).
#if CELL_EDGE
    if (r.exact) {
        _CellWalk w = _cell_walk_start(cell_dims(r.delta[0]), r.id[0], r.F[0], r.loops, smoothness, true, false);
        bool ok = _cell_walk(w, cell, f, p);
        o.edge = max(w.edge, 0.0);
        o.edge_grad = -w.edge_n;
        o.walks &= ok ? ~0 : ~CELL_WALK_OK_EDGE;
        o.loops = max(o.loops, w.loops);
    }
#endif
#if CELL_SMOOTH == 1
    if (r.exact) {
        _CellWalk w = _cell_walk_start(cell_dims(r.delta[0]), r.id[0], r.F[0], r.loops, smoothness, false, true);
        bool ok = _cell_walk(w, cell, f, p);
        _cell_smooth_finish(o, w);
        o.walks &= ok ? ~0 : ~CELL_WALK_OK_SMOOTH;
        o.loops = max(o.loops, w.loops);
    }
#elif CELL_SMOOTH == 2
    // (a fixed block, no search: exact whatever the search, as alone)
    _cell_poly_smooth(o, cell, f, p, smoothness);
    o.walks |= CELL_WALK_OK_SMOOTH;
#endif
#if CELL_NSPHERE
    // Around the F1 point, from the cell and place the search found it in
    // (as the pass of the n-sphere radius alone, CELL_TRACK_F1_CELL).
    if (r.exact) {
        _CellWalk v = _cell_walk_start(vec4(0.0), r.id[0], r.F[0], r.loops, smoothness, false, false);
        v.around = true;
        v.nn = CELL_FAR;
        bool ok = _cell_walk(v, cell + r.o1, r.q1, p);
        o.nsphere = 0.5 * v.nn;
        o.walks &= ok ? ~0 : ~CELL_WALK_OK_NSPHERE;
        o.loops = max(o.loops, v.loops);
    }
#endif
    o.exact = o.walks == (CELL_WALK_OK_SEARCH | CELL_WALK_OK_EDGE | CELL_WALK_OK_NSPHERE | CELL_WALK_OK_SMOOTH);
    return o;
}
#else
// The features of the sample (cell, f) whose cell_search() result is r;
// smoothness: k of smooth F1 in lattice units (>= 0).
CellFeatures cell_features(ivec4 cell, vec4 f, CellParams p, CellResult r, float smoothness)
{
    _CellWalk w = _cell_walk_start(cell_dims(r.delta[0]), r.id[0], r.F[0], r.loops, smoothness, true, true);
    CellFeatures o;
#if CELL_TRACK_F1_CELL
    // n-sphere radius alone: the search already knows the F1 point's cell.
    w.found = true;
    w.o1 = r.o1;
    w.q1 = r.q1;
    o.exact = r.exact;
#elif CELL_EDGE || CELL_SMOOTH == 1 || CELL_NSPHERE
    o.exact = r.exact && _cell_walk(w, cell, f, p);
#else
    o.exact = r.exact;            // the polynomial fold alone needs no walk
#endif
    o.edge = max(w.edge, 0.0);
    o.edge_grad = -w.edge_n;
    o.smooth_F = r.F[0];
    o.smooth_delta = r.delta[0];
    o.smooth_grad = cell_metric_gradient(r.delta[0], r.F[0], p.minkowski_p);
    o.smooth_attr = cell_id_attribute(r.id[0]);
    o.nsphere = 0.0;
#if CELL_SMOOTH == 2
    _cell_poly_smooth(o, cell, f, p, smoothness);
#elif CELL_SMOOTH
    _cell_smooth_finish(o, w);
#endif
#if CELL_NSPHERE
    // Around the F1 point: the cell it lies in (unwrapped, as the walk wraps
    // each visit) and its position in that cell.
    _CellWalk v = w;
    v.around = true;
    v.d1 = vec4(0.0);
    v.nn = CELL_FAR;
    if (w.found && o.exact) {
        o.exact = _cell_walk(v, cell + w.o1, w.q1, p);
        o.nsphere = 0.5 * v.nn;
    } else {
        o.exact = false;
    }
    w.loops = v.loops;
#endif
    o.loops = w.loops;
    o.walks = o.exact ? 15 : 0;
    return o;
}
#endif

#endif
