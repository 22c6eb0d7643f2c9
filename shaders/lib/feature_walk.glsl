// cellgl: the walks of the cell features (features.glsl) around a sample.
//
// After cell_search() has found the F1 point, the features walk the cells
// again (walk.glsl: the ring geometry, the cell source): ring by ring from
// ring 0, each ring's window within a reach that shrinks as the walk goes
// (_cell_walk_rings: edge, n-sphere, edge alone, every walk around the F1
// point), by the search's own ring loop (ring_loop.glsl, included here with
// the walks' state and hooks), or, for smooth F1 alone, whose reach does not
// change, rings 0 and 1 (tuned, CELL_WALK_TUNED: one unrolled block,
// _cell_walk_block) and then one window, every cell of it on ring 2 or beyond
// (_cell_walk_smooth, _cell_walk_window), or the rows of a Euclidean ball
// (_cell_walk_ball, a wide reach). Every walk visits a cell the same way
// (_cell_walk_cell); what a walk does per feature point is _cell_walk_point
// (edge, smooth, n-sphere, edge alone; smooth F1 alone in rings 2 and on,
// _CellWalk.far: the sum alone, _cell_walk_far_point); features.glsl explains
// the maths and the bounds that keep every walk exact.
//
// Requires: cellular.glsl (included; with it walk.glsl), ring_loop.glsl
// (included, with the walks' hooks).
// Macros: those of cellular.glsl (CELL_EDGE, CELL_SMOOTH, CELL_NSPHERE:
// which walks), CELL_FEATURE_MAX_RING, CELL_EDGE_ALONE, CELL_SMOOTH_EXTRA,
// CELL_WALKS_APART (1: one search, then each walk on its own, see below),
// CELL_WALK_FAST (default 1 where CELL_FEATURE_PASS is defined, a pass of
// cellular.comp, or CELL_WALKS_APART is 1, and CELL_WALK_TUNED is 1).

#ifndef CELL_WALKS_APART
// 1 (a pass of cellular.comp/.frag serving several of the basis, the edge, the
// n-sphere radius, smooth F1; cellgl/basis/passes.py): cell_features runs each
// walk on its own after one cell_search(), as in a pass of its own (the same
// bits, flag), not the textures' one walk of every feature. A walk knows what
// it serves at run time (_CellWalk.edge_on, .smooth_on); 0: the switches.
#define CELL_WALKS_APART 0
#endif
#if CELL_WALKS_APART && CELL_NSPHERE
#define CELL_TRACK_F1_CELL 1     // the n-sphere walk starts where the search found F1
#endif

#include "cellular.glsl"

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

#ifndef CELL_WALK_FAST
// 1: the smooth walk's specialised loops below (a pass of cellular.comp with
// the tuned shapes, CELL_WALK_TUNED of walk.glsl; the textures and the
// exported snippets keep the shorter general code).
#if defined(CELL_FEATURE_PASS) || CELL_WALKS_APART
#define CELL_WALK_FAST CELL_WALK_TUNED
#else
#define CELL_WALK_FAST 0
#endif
#endif
// Smooth F1's own walk, without the edge's (alone, or apart from the edge's).
#if CELL_SMOOTH == 1 && (!CELL_EDGE || CELL_WALKS_APART)
#define _CELL_SMOOTH_OWN 1
#else
#define _CELL_SMOOTH_OWN 0
#endif
#if _CELL_SMOOTH_OWN && CELL_WALK_FAST
// Smooth F1 alone, rings 2, 3, ... (_CellWalk.far): a point is summed without
// the tests of the other walks.
#define _CELL_FAR_SUM 1
#else
#define _CELL_FAR_SUM 0
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
    bool edge_on;    // CELL_WALKS_APART: this walk serves the edge
    bool smooth_on;  // CELL_WALKS_APART: this walk serves smooth F1
    bool found;      // the F1 point was seen: its cell offset o1, position q1 in it
    ivec4 o1;
    vec4 q1;
    float nn;
    int loops;       // loop iterations spent (cellular.glsl, "Loop budget")
    bool spent;      // the walk stopped at the loop budget
#if CELL_EDGE_ALONE
    bool nearest;    // the walk looks for the F1 point itself (F1 in internal units)
#endif
#if _CELL_FAR_SUM
    bool far;        // rings 2, 3, ... of smooth F1 alone: the sum alone (_cell_walk_far_point)
#endif
};

// Whether walk w serves the edge, smooth F1 (exp): the compile-time switch, and
// with CELL_WALKS_APART the walk's own flag.
bool _cell_do_edge(_CellWalk w)
{
    return CELL_EDGE != 0 && (CELL_WALKS_APART == 0 || w.edge_on);
}

bool _cell_do_smooth(_CellWalk w)
{
    return CELL_SMOOTH == 1 && (CELL_WALKS_APART == 0 || w.smooth_on);
}

// True distance from the walk's centre beyond which no point matters (now).
float _cell_walk_reach(_CellWalk w)
{
    if (w.around) {
        return w.nn;
    }
    float reach = w.F1;
#if CELL_EDGE
    if (_cell_do_edge(w)) {
        reach = max(reach, w.F1 + 2.0 * min(w.edge, 1.0e30));
    }
#endif
#if CELL_SMOOTH == 1
    if (_cell_do_smooth(w)) {
        reach = max(reach, w.F1 + CELL_SMOOTH_CUTOFF * w.k);
    }
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
// _cell_smooth_weight: exp((F1 - d) / k) for k > 0 only (k = 0: inf, S NaN),
// at most 1 (d a rounding below F1, FMA contraction, with a tiny k: inf).
float _cell_smooth_weight(float F1, float d, float k)
{
    return exp(min(F1 - d, 0.0) / k);
}

void _cell_smooth_add(inout _CellWalk w, vec4 delta, float d, uint id, bool is_p1, CellParams p)
{
    if (is_p1 || (w.k > 0.0 && d < w.F1 + CELL_SMOOTH_CUTOFF * w.k)) {
        float wt = 1.0;
        if (!is_p1) {            // (then k > 0)
            wt = _cell_smooth_weight(w.F1, d, w.k);
        }
        w.wsum += wt;
#if CELL_SMOOTH_EXTRA
        w.wdelta += wt * delta;
        w.wgrad += wt * cell_metric_gradient(delta, d, p.minkowski_p);
        w.wattr += wt * cell_id_attribute(id);
#endif
    }
}
#endif

#if _CELL_FAR_SUM
// What smooth F1 alone does per point in rings 2, 3, ...: the sum of
// _cell_walk_point. The F1 point (there if the search needed ring 2) is told by
// its ID and offset as there (not by d == F1: two computations a compiler may
// contract differently), and counts with d = F1, weight 1.
void _cell_walk_far_point(inout _CellWalk w, vec4 delta, uint id, CellParams p)
{
    float d = cell_metric_finish(cell_metric_length(delta, p.minkowski_p), p.minkowski_p);
#if CELL_SMOOTH_EXTRA
    vec4 e = delta - w.d1;
    bool is_p1 = id == w.id1 && dot(e, e) < 1e-10;
    _cell_smooth_add(w, delta, is_p1 ? w.F1 : d, id, is_p1, p);
#else
    // Smooth F1 alone needs no ID: the F1 point (d == F1, or a rounding off,
    // capped) weighs 1 as is_p1 gives it; with k = 0 nothing is added: S = F1.
    if (w.k > 0.0 && d < w.F1 + CELL_SMOOTH_CUTOFF * w.k) {
        w.wsum += _cell_smooth_weight(w.F1, d, w.k);
    }
#endif
}
#endif

// What a walk does per feature point: the point q (ID id) of the cell at
// offset o, delta = its offset from the walk's centre.
void _cell_walk_point(inout _CellWalk w, vec4 delta, uint id, ivec4 o, vec4 q, CellParams p)
{
    delta = cell_dims(delta);
#if _CELL_FAR_SUM
    if (w.far) {
        _cell_walk_far_point(w, delta, id, p);
        return;
    }
#endif
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
    if (_cell_do_edge(w) && !is_p1 && e2 > 0.0) {
        float inv = inversesqrt(e2);
        float b = dot(0.5 * (delta + w.d1), e) * inv;
        if (b < w.edge) {
            w.edge = b;
            w.edge_n = e * inv;
        }
    }
#endif
#if CELL_SMOOTH == 1
    if (_cell_do_smooth(w)) {
        float d = is_p1 ? w.F1 : cell_metric_finish(cell_metric_length(delta, p.minkowski_p), p.minkowski_p);
        _cell_smooth_add(w, delta, d, id, is_p1, p);
    }
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

// Every feature point of the cell at offset o (the cell source, walk.glsl).
void _cell_walk_cell(inout _CellWalk w, ivec4 cell, vec4 f, ivec4 o, CellParams p)
{
    ivec4 c;
    uint state;
    int count = _cell_open(cell, o, p, c, state);
    vec4 base = vec4(o) - f;
    w.loops += count + 1;
    for (int k = 0; k < count; k++) {
        uint id;
        vec4 q = cell_next_point(state, c, p, id);
        _cell_walk_point(w, base + q, id, o, q, p);
    }
}

// The ring loop's hooks for the walks (ring_loop.glsl): each ring's window
// within the reach (which shrinks as the walk goes), a cell visited when its
// nearest possible point is within the reach, on while a point past the rings
// done can be.
int _cell_walk_ring_window(int ring, _CellWalk w, vec4 f, CellParams p, out ivec4 lo, out ivec4 hi)
{
    cell_ring_window(ring, min(_cell_walk_reach(w), float(ring + 2)), f, lo, hi);
    ivec4 n = hi - lo + 1;
    return n.x * n.y * n.z * n.w;
}

float _cell_walk_bound(_CellWalk w, CellParams p)
{
    return cell_metric_term(_cell_walk_reach(w), p.minkowski_p);
}

bool _cell_walk_past(_CellWalk w, int rings, float m, vec4 ma, CellParams p)
{
    return float(rings) + m >= _cell_walk_reach(w);
}

#define _CELL_RINGS _cell_walk_ring_loop
#define _CELL_RINGS_STATE _CellWalk
#define _CELL_RINGS_WINDOW _cell_walk_ring_window
#define _CELL_RINGS_BOUND _cell_walk_bound
#define _CELL_RINGS_PAST _cell_walk_past
#define _CELL_RINGS_VISIT _cell_walk_cell
#define _CELL_RINGS_TABLE 0
#include "ring_loop.glsl"

// Visit, ring by ring, every cell that can hold a point within the reach.
// Rings `first` .. `last` by the ring loop of every walker (the search's,
// ring_loop.glsl), until a whole ring is beyond the reach; returns as _cell_walk.
bool _cell_walk_rings(inout _CellWalk w, ivec4 cell, vec4 f, CellParams p, int first, int last)
{
    float m = cell_face_distance(f);
    int ring = first;
    bool spent;
    _cell_walk_ring_loop(w, cell, f, p, m, vec4(0.0), ring, last, spent, ivec4(0), vec4(0.0));
    w.spent = spent;
    return !spent && (ring <= last || float(last) + m >= _cell_walk_reach(w));
}

#if _CELL_SMOOTH_OWN
// The smooth window of smooth F1 alone (_cell_walk_smooth): every cell of the
// window lo .. hi on ring `ring` or beyond (the reach fixed: each point's own
// cut-off decides). Tested at the bottom (a window holds a cell, hi its last);
// the passes counted as a loop tested at the top spends them (after the
// budget is spent the count no longer matters). Stops at the loop budget
// (w.spent).
void _cell_walk_window(inout _CellWalk w, ivec4 cell, vec4 f, CellParams p, ivec4 lo, ivec4 hi, int ring)
{
    ivec4 o = cell_window_first(lo);
    w.loops += 1;             // the pass that leaves the window loop
    for (;;) {
        w.spent = w.spent || cell_budget_spent(w.loops);
        w.loops += 1;
        o = cell_window_next(o, lo, hi);
        if (!w.spent && cell_ring_of(o) >= ring) {
            _cell_walk_cell(w, cell, f, o, p);
        }
        if (all(equal(o, hi)) || w.spent) {
            break;
        }
    }
}

#if CELL_WALK_FAST && CELL_METRIC == CELL_METRIC_EUCLIDEAN && !CELL_ANISO
// Smooth F1 alone with a wide reach (last >= 4 rings): only the cells of its
// ball, row by row, not the whole (2 last + 1)^d window (the ball is 0.79 of
// the square, 0.52 of the cube, 0.31 in 4D): llvmpipe runs the body of an `if`
// even when no lane takes it, so a skipped cell of the window costs as much as
// a visited one. The window's cells within the reach, in its order (the ranges,
// _cell_ball_reset, hold every one of them). For a narrow reach the rows' own
// cost outweighs that: measured 0.73-0.89x the time at k = 0.25, 1.04-1.12x at
// k = 0.1 with rows from ring 3 (llvmpipe, 2D and 3D).
bool _cell_walk_ball(inout _CellWalk w, ivec4 cell, vec4 f, CellParams p, float m, float reach, int last)
{
    // (Every component set: _cell_ball_reset sets the axes below CELL_DIM,
    // the others stay 0 and are copied in and out, never read.)
    ivec4 lo = ivec4(0);
    ivec4 hi = ivec4(0);
    ivec4 o = ivec4(0);
    _cell_ball_reset(o, lo, hi, f, reach, last, 0);
    w.far = true;
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
            _cell_walk_cell(w, cell, f, o, p);
            z = (inner && z == -2) ? 2 : z + 1;
        } while (z <= hi[CELL_DIM - 1]);
        o = _cell_ball_next_row(o, lo, hi, f, reach, last);
    } while (o.x <= hi.x && !w.spent);
    return !w.spent && float(last) + m >= reach;
}
#endif

// Smooth F1 alone, rings 2 .. R (the last the ring loop would enter): the
// reach F1 + cutoff k does not change during the walk, so they are one window
// loop. No test of a cell against the reach (it costs, llvmpipe runs the
// skipped cell anyway): each point's own cut-off decides, and a cell beyond
// the reach holds no point under it, so the same points are summed in the
// same order. m: the sample's face distance; returns as _cell_walk.
bool _cell_walk_smooth(inout _CellWalk w, ivec4 cell, vec4 f, CellParams p, float m)
{
    float reach = _cell_walk_reach(w);
    int last = int(ceil(min(reach - m, float(CELL_FEATURE_MAX_RING))));
#if CELL_WALK_FAST && CELL_METRIC == CELL_METRIC_EUCLIDEAN && !CELL_ANISO
    if (last >= 4) {
        return _cell_walk_ball(w, cell, f, p, m, reach, last);
    }
#endif
    ivec4 lo, hi;
    cell_ring_window(last, min(reach, float(last + 2)), f, lo, hi);
#if _CELL_FAR_SUM
    w.far = true;
#endif
    _cell_walk_window(w, cell, f, p, lo, hi, 2);
    return !w.spent && float(last) + m >= reach;
}
#endif

#if _CELL_SMOOTH_OWN && CELL_WALK_TUNED
// Smooth F1 (tuned): rings 0 and 1 as one block of constant bounds, unrolled
// into straight-line SIMD code, every cell of it, in window order (the order
// of the ring loop). Its reach F1 + 16 k seldom prunes a cell of ring 1, and
// llvmpipe runs the body of an `if` even when no lane takes it: the ring
// loop's pruned windows cost 1.08-1.18x here (2D; docs/performance.md). A
// point beyond the reach changes nothing (its weight is cut). Constant loops
// spend no loop passes: only the visits are counted. Returns whether the walk
// goes on past ring 1 (not when the reach ends in ring 0 or the budget is spent).
bool _cell_walk_block(inout _CellWalk w, ivec4 cell, vec4 f, CellParams p, float m)
{
    if (cell_budget_spent(w.loops)) {
        w.spent = true;
        return false;
    }
    _cell_walk_cell(w, cell, f, ivec4(0), p);
    if (m >= _cell_walk_reach(w)) {
        return false;
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
    return true;
}
#endif

// Visit every cell around (cell, f) that can hold a point within the reach.
// Returns whether the walk finished before CELL_FEATURE_MAX_RING rings and
// inside the loop budget (w.spent: it stopped at the budget). Every walk is
// the ring loop from ring 0 (rings 0 and 1 windows pruned against the reach,
// as every later ring: measured faster than visiting the whole 3^d block),
// but smooth F1 alone around the sample: rings 0 and 1, then the rest of its
// fixed reach as one window or the ball's rows (_cell_walk_smooth).
bool _cell_walk(inout _CellWalk w, ivec4 cell, vec4 f, CellParams p)
{
#if _CELL_FAR_SUM
    w.far = false;            // rings 0 and 1: every test (a walk around the F1 point: all rings)
#endif
#if _CELL_SMOOTH_OWN
    if (!w.around && !_cell_do_edge(w)) {
        float m = cell_face_distance(f);
#if CELL_WALK_TUNED
        if (!_cell_walk_block(w, cell, f, p, m)) {
            return !w.spent;
        }
#else
        _cell_walk_rings(w, cell, f, p, 0, 1);
#endif
        return _cell_walk_smooth(w, cell, f, p, m);
    }
#endif
    return _cell_walk_rings(w, cell, f, p, 0, CELL_FEATURE_MAX_RING);
}

#endif
