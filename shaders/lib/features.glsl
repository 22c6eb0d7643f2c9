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
// Requires: cellular.glsl. Macros: those of cellular.glsl, CELL_EDGE,
// CELL_SMOOTH, CELL_NSPHERE (0 or 1; CELL_SMOOTH 2: smooth F1 as Blender's
// Voronoi node folds it, _cell_poly_smooth below; all 0: nothing below is
// compiled and cell_search is untouched), CELL_FEATURE_MAX_RING,
// CELL_EDGE_ALONE (1: cell_edge_alone, the walk finding the F1 point too).

#include "cellular.glsl"

#ifndef CELL_EDGE
#define CELL_EDGE 0
#endif
#ifndef CELL_SMOOTH
#define CELL_SMOOTH 0
#endif
#ifndef CELL_NSPHERE
#define CELL_NSPHERE 0
#endif
#ifndef CELL_EDGE_ALONE
// 1: cell_edge_alone() below, the distance to the edge without cell_search()
// (the basis snippets, cellgl export --basis edge: one ring walker's code);
// with CELL_EDGE alone (no other feature), Euclidean.
#define CELL_EDGE_ALONE 0
#endif
#ifndef CELL_SMOOTH_EXTRA
// 0: only smooth F1 itself is wanted; its offset, gradient and attribute are
// not accumulated (they stay those of the F1 point), a shader specialised per
// requested output.
#define CELL_SMOOTH_EXTRA 1
#endif

// The colour of the cell of feature point `id`: bytes 0, 8 and 16 of its hash,
// each / 255 (the false colour of `cellgl bake --channels id`).
vec3 cell_id_color(uint id)
{
    uint h = cell_hash_u32(id);
    return vec3(float(h & 255u), float((h >> 8) & 255u), float((h >> 16) & 255u)) * (1.0 / 255.0);
}

// A value in [0, 1) constant over the cell of feature point `id` (the texture
// layer's per-cell ramp index).
float cell_id_value(uint id)
{
    return float(cell_hash_u32(id ^ 0x2545f491u) >> 8) * (1.0 / 16777216.0);
}

// Everything smooth F1 averages per feature point: (colour, value).
vec4 cell_id_attribute(uint id)
{
    return vec4(cell_id_color(id), cell_id_value(id));
}

#if CELL_EDGE || CELL_SMOOTH || CELL_NSPHERE

#define CELL_SMOOTH_CUTOFF 16.0

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
};

// State of one walk. Around the sample (around = false): the F1 point's offset
// d1 and ID, and the sums of the features; around the F1 point (around = true,
// d1 = 0): the distance to its nearest other point.
struct _CellWalk {
    bool around;
    vec4 d1;
    uint id1;
    float F1;
    float k;
    float edge;
    vec4 edge_n;
    float wsum;
    vec4 wdelta;
    vec4 wgrad;
    vec4 wattr;
    bool found;      // the F1 point was seen: its cell offset o1, position q1 in it
    ivec4 o1;
    vec4 q1;
    float nn;
    int loops;       // loop iterations spent (cellular.glsl, "Loop budget")
    bool spent;      // the walk stopped at the loop budget
#if CELL_EDGE_ALONE
    bool nearest;    // the walk looks for the F1 point itself (F1 in internal units)
#endif
};

// True distance from the walk's centre beyond which no point matters (now).
float _cell_walk_reach(_CellWalk w)
{
    if (w.around) {
        return w.nn;
    }
    float reach = w.F1;
#if CELL_EDGE
    reach = max(reach, w.F1 + 2.0 * min(w.edge, 1.0e30));
#endif
#if CELL_SMOOTH == 1
    reach = max(reach, w.F1 + CELL_SMOOTH_CUTOFF * w.k);
#endif
#if CELL_EDGE_ALONE
    reach = w.nearest ? sqrt(w.F1) : reach;     // F1 in internal units, Euclidean (as CELL_EDGE)
#endif
    // A margin for rounding: visiting more is always safe.
    return reach * 1.000001 + 1e-6;
}

#if CELL_SMOOTH == 1
// Smooth F1 (exp): add the point at true distance d (delta, id) to the sums when its weight
// exp(-(d - F1) / k) is inside the cut-off; the F1 point itself (is_p1) weighs 1.
void _cell_smooth_add(inout _CellWalk w, vec4 delta, float d, uint id, bool is_p1, CellParams p)
{
    if (is_p1 || (w.k > 0.0 && d < w.F1 + CELL_SMOOTH_CUTOFF * w.k)) {
        float wt = is_p1 ? 1.0 : exp((w.F1 - d) / w.k);
        w.wsum += wt;
#if CELL_SMOOTH_EXTRA
        w.wdelta += wt * delta;
        w.wgrad += wt * cell_metric_gradient(delta, d, p.minkowski_p);
        w.wattr += wt * cell_id_attribute(id);
#endif
    }
}
#endif

void _cell_walk_point(inout _CellWalk w, vec4 delta, uint id, ivec4 o, vec4 q, CellParams p)
{
    delta = cell_dims(delta);
    vec4 e = delta - w.d1;                  // pj - p1
    float e2 = dot(e, e);
    bool is_p1 = id == w.id1 && e2 < 1e-10;
    if (w.around) {
        if (!is_p1) {
            w.nn = min(w.nn, sqrt(e2));
        }
        return;
    }
    if (is_p1) {
        w.found = true;
        w.o1 = o;
        w.q1 = q;
    }
#if CELL_EDGE
    if (!is_p1 && e2 > 0.0) {
        float inv = inversesqrt(e2);
        float b = dot(0.5 * (delta + w.d1), e) * inv;
        if (b < w.edge) {
            w.edge = b;
            w.edge_n = e * inv;
        }
    }
#endif
#if CELL_SMOOTH == 1
    float d = is_p1 ? w.F1 : cell_metric_finish(cell_metric_length(delta, p.minkowski_p), p.minkowski_p);
    _cell_smooth_add(w, delta, d, id, is_p1, p);
#endif
#if CELL_EDGE_ALONE
    // Nearest mode: the F1 point as cell_search finds it, the least internal-unit
    // distance (the edge above is then against a moving d1: cell_edge_alone resets it).
    float dn = cell_metric_length(delta, p.minkowski_p);
    if (w.nearest && dn < w.F1) {
        w.F1 = dn;
        w.d1 = delta;
        w.id1 = id;
    }
#endif
}

void _cell_walk_cell(inout _CellWalk w, ivec4 cell, vec4 f, ivec4 o, CellParams p)
{
    ivec4 c = cell_wrap(cell + o, p.period);
    uint state = cell_cell_seed(c, p.seed);
    int count = cell_point_count_at(state, c, p);
    vec4 base = vec4(o) - f;
    w.loops += count + 1;
    for (int k = 0; k < count; k++) {
        uint id;
        vec4 q = cell_next_point(state, c, p, id);
        _cell_walk_point(w, base + q, id, o, q, p);
    }
}

#ifndef CELL_WALK_FAST
// 1: the smooth walk's specialised loops below (a pass of cellular.comp; the
// textures and the exported snippets keep the shorter general code).
#ifdef CELL_FEATURE_PASS
#define CELL_WALK_FAST 1
#else
#define CELL_WALK_FAST 0
#endif
#endif

#if CELL_SMOOTH == 1 && !CELL_EDGE && CELL_WALK_FAST
// _cell_walk_cell for smooth F1 alone in rings 2, 3, ...: a point there is
// summed as _cell_walk_point sums it, without its tests for the other walks.
// The F1 point (only there when the search needed ring 2) has d == F1 to the
// bit (the same sum of the same terms), so it is told by its ID and distance.
void _cell_walk_far_cell(inout _CellWalk w, ivec4 cell, vec4 f, ivec4 o, CellParams p)
{
    ivec4 c = cell_wrap(cell + o, p.period);
    uint state = cell_cell_seed(c, p.seed);
    int count = cell_point_count_at(state, c, p);
    vec4 base = vec4(o) - f;
    w.loops += count + 1;
    for (int k = 0; k < count; k++) {
        uint id;
        vec4 delta = cell_dims(base + cell_next_point(state, c, p, id));
        float d = cell_metric_finish(cell_metric_length(delta, p.minkowski_p), p.minkowski_p);
#if CELL_SMOOTH_EXTRA
        _cell_smooth_add(w, delta, d, id, id == w.id1 && d == w.F1, p);
#else
        // Smooth F1 alone needs no ID: the F1 point (d == F1) weighs exp(0) = 1
        // as is_p1 gives it, and with k = 0 the sum does not change S = F1.
        if (d < w.F1 + CELL_SMOOTH_CUTOFF * w.k) {
            w.wsum += exp((w.F1 - d) / w.k);
        }
#endif
    }
}
#endif

#if CELL_SMOOTH == 1 && !CELL_EDGE && CELL_WALK_FAST && CELL_METRIC == CELL_METRIC_EUCLIDEAN && !CELL_ANISO
// The ball of radius `reach` (Euclidean) around the sample (fraction f), in
// rings up to `last`: the cells are walked in window order (axis 0 slowest),
// each axis over the range its prefix leaves, t = sqrt(reach^2 - the prefix's
// squared box distance) (widened for rounding, and holding 0 so that no range
// is empty). Sets axes `from` .. CELL_DIM - 1 of o to the start of their
// ranges, given o's axes before `from`.
void _cell_ball_reset(inout ivec4 o, inout ivec4 lo, inout ivec4 hi, vec4 f, float reach, int last, int from)
{
    float r2 = reach * reach;
    float s = 0.0;
    for (int a = 0; a < CELL_DIM; a++) {
        if (a >= from) {
            float t = sqrt(max(r2 - s, 0.0)) * 1.000001 + 1e-6;
            hi[a] = clamp(int(ceil(t + f[a])) - 1, 0, last);
            lo[a] = -clamp(int(ceil(t + 1.0 - f[a])) - 1, 0, last);
            o[a] = lo[a];
        }
        float g = o[a] > 0 ? float(o[a]) - f[a] : (o[a] < 0 ? float(-o[a] - 1) + f[a] : 0.0);
        s += g * g;
    }
}

// The first cell of the row after o's in the ball (o.x > hi.x once all rows
// were passed): the axes before the last counted on, the later ones reset.
ivec4 _cell_ball_next_row(ivec4 o, inout ivec4 lo, inout ivec4 hi, vec4 f, float reach, int last)
{
    bool carry = true;
    int from = CELL_DIM - 1;
    for (int a = CELL_DIM - 2; a >= 0; a--) {
        if (carry) {
            o[a] += 1;
            carry = a > 0 && o[a] > hi[a];
            from = carry ? from : a + 1;
        }
    }
    _cell_ball_reset(o, lo, hi, f, reach, last, from);
    return o;
}
#endif

// Visit every cell around (cell, f) that can hold a point within the reach.
// Returns whether the walk finished before CELL_FEATURE_MAX_RING rings and
// inside the loop budget (w.spent: it stopped at the budget).
bool _cell_walk(inout _CellWalk w, ivec4 cell, vec4 f, CellParams p)
{
    float m = cell_face_distance(f);
#if CELL_EDGE_ALONE
    // The snippet's shorter code: rings 0 and 1 are windows of the ring loop
    // below too (the same points within the reach, so the same answer).
    int first = 0;
#else
    int first = 2;
    if (cell_budget_spent(w.loops)) {
        w.spent = true;
        return false;
    }
    _cell_walk_cell(w, cell, f, ivec4(0), p);
    // Ring 1 as a block of constant bounds, unrolled into straight-line SIMD
    // code as in cell_search (most walks end in it); the same cells in the same
    // order as the window loop below would visit, every one of them: llvmpipe
    // runs the body of an `if` even when no lane takes it, so testing a cell
    // against the reach costs more than it saves (a point beyond the reach
    // changes nothing: its plane is further than the nearest, its smooth
    // weight is cut, it is further than the nearest neighbour). Constant
    // loops spend no loop passes: only the visits are counted.
    if (m >= _cell_walk_reach(w)) {
        return true;
    }
    for (int x = -1; x <= 1; x++)
    for (int y = -1; y <= 1; y++)
#if CELL_DIM >= 3
    for (int z = -1; z <= 1; z++)
#else
    for (int z = 0; z <= 0; z++)
#endif
#if CELL_DIM >= 4
    for (int v = -1; v <= 1; v++)
#else
    for (int v = 0; v <= 0; v++)
#endif
    {
        ivec4 o = ivec4(x, y, z, v);
        if (any(notEqual(o, ivec4(0)))) {
            w.spent = w.spent || cell_budget_spent(w.loops);
            if (!w.spent) {
                _cell_walk_cell(w, cell, f, o, p);
            }
        }
    }
#endif
#if CELL_SMOOTH == 1 && !CELL_EDGE
    if (!w.around) {
        // Smooth F1 alone: the reach F1 + cutoff k does not change during the
        // walk, so rings 2 .. R (the last the ring loop would enter) are one
        // window loop. No test of a cell against the reach (it costs, llvmpipe
        // runs the skipped cell anyway): each point's own cut-off decides, and
        // a cell beyond the reach holds no point under it, so the same points
        // are summed in the same order.
        float reach = _cell_walk_reach(w);
        int last = int(ceil(min(reach - m, float(CELL_FEATURE_MAX_RING))));
#if CELL_WALK_FAST && CELL_METRIC == CELL_METRIC_EUCLIDEAN && !CELL_ANISO
        if (last >= 4) {
            // A wide reach: only the cells of its ball, row by row, not the whole
            // (2 last + 1)^d window (the ball is 0.79 of the square, 0.52 of the
            // cube, 0.31 in 4D): llvmpipe runs the body of an `if` even when no
            // lane takes it, so a skipped cell of the window costs as much as a
            // visited one. The window's cells within the reach, in its order
            // (the ranges, _cell_ball_reset, hold every one of them). For a
            // narrow reach the rows' own cost outweighs that:
            // measured 0.73-0.89x the time at k = 0.25, 1.04-1.12x at k = 0.1
            // with rows from ring 3 (llvmpipe, 2D and 3D).
            ivec4 lo, hi;
            ivec4 o = ivec4(0);
            _cell_ball_reset(o, lo, hi, f, reach, last, 0);
            //
            // Both loops are tested at the bottom: no range is empty (the first
            // row is o.x = lo.x, a row's range holds 0, and with reach > 3 a row
            // through rings 0 and 1 reaches past them on both sides: its t >
            // sqrt(9 - 3)), and a loop tested at the top runs its body once more,
            // masked, on every exit (a cell's whole cost per row). The passes are
            // counted as the top-tested loops would spend them (the same budget).
            w.loops += 1;             // the pass that left the loop over the rows
            do {
                w.loops += 2;         // this pass, and the one that left the row
                // One row: the last axis over its range, given the row's other
                // axes, over the block of rings 0 and 1 (visited before).
                ivec4 ao = abs(o);
                ao[CELL_DIM - 1] = 0;
                bool inner = max(max(ao.x, ao.y), max(ao.z, ao.w)) <= 1;
                int z = inner ? (lo[CELL_DIM - 1] >= -1 ? 2 : lo[CELL_DIM - 1]) : lo[CELL_DIM - 1];
                do {
                    if (cell_budget_spent(w.loops)) {
                        w.spent = true;
                        break;
                    }
                    w.loops += 1;
                    o[CELL_DIM - 1] = z;
                    _cell_walk_far_cell(w, cell, f, o, p);
                    z = (inner && z == -2) ? 2 : z + 1;
                } while (z <= hi[CELL_DIM - 1]);
                o = _cell_ball_next_row(o, lo, hi, f, reach, last);
            } while (o.x <= hi.x && !w.spent);
            return !w.spent && float(last) + m >= reach;
        }
#endif
        ivec4 lo, hi;
        cell_ring_window(last, min(reach, float(last + 2)), f, lo, hi);
        ivec4 n = hi - lo + 1;
        int cells = n.x * n.y * n.z * n.w;
        ivec4 o = cell_window_first(lo);
        w.loops += 1;             // the pass that leaves the window loop
        for (int i = 0; i < cells; i++) {
            if (cell_budget_spent(w.loops)) {
                w.spent = true;
                break;
            }
            w.loops += 1;
            o = cell_window_next(o, lo, hi);
            ivec4 ao = abs(o);
            if (max(max(ao.x, ao.y), max(ao.z, ao.w)) >= 2) {
#if CELL_WALK_FAST
                _cell_walk_far_cell(w, cell, f, o, p);
#else
                _cell_walk_cell(w, cell, f, o, p);
#endif
            }
        }
        return !w.spent && float(last) + m >= reach;
    }
#endif
    w.loops += 1;                 // the pass that leaves the ring loop
    for (int ring = first; ring <= CELL_FEATURE_MAX_RING; ring++) {
        w.loops += 1;
        float reach = _cell_walk_reach(w);
        if (float(ring - 1) + m >= reach) {
            return !w.spent;
        }
        ivec4 lo, hi;
        cell_ring_window(ring, min(reach, float(ring + 2)), f, lo, hi);
        ivec4 n = hi - lo + 1;
        int cells = n.x * n.y * n.z * n.w;
        ivec4 o = cell_window_first(lo);
        w.loops += 1;
        for (int i = 0; i < cells; i++) {
            if (cell_budget_spent(w.loops)) {
                w.spent = true;
                return false;
            }
            w.loops += 1;
            o = cell_window_next(o, lo, hi);
            ivec4 ao = abs(o);
            if (max(max(ao.x, ao.y), max(ao.z, ao.w)) == ring
                && _cell_box_distance(o, f, p)
                   < cell_metric_term(_cell_walk_reach(w), p.minkowski_p)) {
                _cell_walk_cell(w, cell, f, o, p);
            }
        }
    }
    return !w.spent && float(CELL_FEATURE_MAX_RING) + m >= _cell_walk_reach(w);
}

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
    float k = 0.5 * smoothness;
    float s = 8.0;
    vec4 gs = vec4(0.0);            // d s / d sample
    vec4 pos = vec4(0.0);           // folded point position, relative to the sample's cell
    vec4 col = vec4(0.0);           // folded cell colour and cell value (cell_id_value)
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
        ivec4 c = cell_wrap(cell + o4, p.period);
        uint state = cell_cell_seed(c, p.seed);
        int count = cell_point_count_at(state, c, p);
        for (int j = 0; j < count; j++) {
            uint id;
            vec4 q = cell_dims(vec4(o4) + cell_next_point(state, c, p, id));
            vec4 delta = q - f;
            float d = cell_metric_finish(cell_metric_length(delta, p.minkowski_p), p.minkowski_p);
            float h, dh_ds;
            if (k > 0.0) {
                float t = 0.5 + 0.5 * (s - d) / k;
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
    _cell_poly_smooth(o, cell, f, p, smoothness);
    return o;
}
#endif

// A walk around the sample whose F1 point is at offset d1 (ID id1, distance
// F1), after `loops` loop passes.
_CellWalk _cell_walk_start(vec4 d1, uint id1, float F1, int loops, float smoothness)
{
    _CellWalk w;
    w.around = false;
    w.d1 = d1;
    w.id1 = id1;
    w.F1 = F1;
    w.k = smoothness;
    w.edge = 3.0e38;
    w.edge_n = vec4(0.0);
    w.wsum = 0.0;
    w.wdelta = vec4(0.0);
    w.wgrad = vec4(0.0);
    w.wattr = vec4(0.0);
    w.found = false;
    w.o1 = ivec4(0);
    w.q1 = vec4(0.0);
    w.nn = 3.0e38;
    w.loops = loops;
    w.spent = false;
#if CELL_EDGE_ALONE
    w.nearest = F1 >= 3.0e38;    // no F1 point given: the walk finds it first
#endif
    return w;
}

#if CELL_EDGE_ALONE
// The distance to the edge alone (the basis snippets): the ring walk finds the
// F1 point itself first (nearest mode: every cell that can hold a point nearer
// than the nearest so far, the least internal-unit distance, as cell_search),
// then walks around the sample for the edge; the same value as cell_search
// and cell_features, in one walker's code.
float cell_edge_alone(ivec4 cell, vec4 f, CellParams p)
{
    _CellWalk w = _cell_walk_start(vec4(0.0), 0u, 3.0e38, 0, 0.0);
    _cell_walk(w, cell, f, p);
    w.nearest = false;
    w.F1 = cell_metric_finish(w.F1, p.minkowski_p);
    w.edge = 3.0e38;
    _cell_walk(w, cell, f, p);
    return max(w.edge, 0.0);
}
#endif

// The features of the sample (cell, f) whose cell_search() result is r;
// smoothness: k of smooth F1 in lattice units (>= 0).
CellFeatures cell_features(ivec4 cell, vec4 f, CellParams p, CellResult r, float smoothness)
{
    _CellWalk w = _cell_walk_start(cell_dims(r.delta[0]), r.id[0], r.F[0], r.loops, smoothness);
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
    if (w.wsum > 0.0) {
        float inv = 1.0 / w.wsum;
        o.smooth_F = w.F1 - w.k * log(w.wsum);
#if CELL_SMOOTH_EXTRA
        o.smooth_delta = w.wdelta * inv;
        o.smooth_grad = w.wgrad * inv;
        o.smooth_attr = w.wattr * inv;
#endif
    }
#endif
#if CELL_NSPHERE
    // Around the F1 point: the cell it lies in (unwrapped, as the walk wraps
    // each visit) and its position in that cell.
    _CellWalk v = w;
    v.around = true;
    v.d1 = vec4(0.0);
    v.nn = 3.0e38;
    if (w.found && o.exact) {
        o.exact = _cell_walk(v, cell + w.o1, w.q1, p);
        o.nsphere = 0.5 * v.nn;
    } else {
        o.exact = false;
    }
    w.loops = v.loops;
#endif
    o.loops = w.loops;
    return o;
}

#endif
