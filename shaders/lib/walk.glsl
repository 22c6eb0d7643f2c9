// cellgl: the cell walker's pieces, shared by every walk over cells.
//
// Every walk (cell_search in cellular.glsl; the edge, smooth, n-sphere and
// edge-alone walks in feature_walk.glsl; the polynomial smooth fold) is the same
// thing: cells around a sample, ring by ring (Chebyshev rings of cells) or
// window by window, each cell opened once (_cell_open: its wrapped lattice
// cell, its hash state, its point count) and its feature points handed to
// what the walk does per point. This file holds what they share:
//   * the sentinel CELL_FAR ("nothing found yet", greater than any distance);
//   * the loop budget (CELL_LOOP_BUDGET, cell_budget_spent; below);
//   * the geometry of rings and windows: a cell's box distance, the sample's
//     face distance, the window of a ring within a reach, the lower bound on
//     everything past a ring, the odometer that walks a window in one flat
//     loop, and the rows of a Euclidean ball (the wide smooth walk);
//   * the cell source (_cell_open): the per-cell setup, written once. It
//     hashes the cell (points.glsl); it is the seam where a source that reads
//     cells computed ahead (a workgroup's shared cache on grids) goes.
//
// Loop budget. Drivers cut or kill long shaders: Mesa's llvmpipe stops every
// loop of an invocation once 65535 loop iterations were spent in it (all
// loops together, per SIMD vector of invocations; docs/exactness.md), other
// GPUs have watchdogs. So the search counts its loop iterations in
// CellResult.loops, as llvmpipe does (each pass through a loop whose length
// is not a compile-time constant, plus one for the pass that leaves it), and
// stops, marking the result inexact, rather than go past CELL_LOOP_BUDGET.
// cell_features() (features.glsl) continues the same count. A caller that
// searches several times in one invocation passes the count on
// (cell_search_budget) so the bound holds for the invocation as a whole.
//
// The loops' shapes: one switch, CELL_WALK_TUNED (below). 0: the plain
// version, one ring loop for every walker (ring_loop.glsl: one outer pass a
// ring, one inner pass a cell of the ring's window): the search's rings from
// ring 1, its first pass (2D, 3D: in the order of its table; cellular.glsl),
// every feature walk's from ring 0 (feature_walk.glsl). 1 (the
// default): the shapes measured fastest on llvmpipe, chosen per case
// (docs/performance.md): the search's ring 1 unrolled (jitter) or pruned by a
// loop of its own (3D), its later rings one flat loop (2D jitter, 3D pruned);
// smooth F1's rings 0 and 1 unrolled, its window or ball rows in a pass of
// cellular.comp (CELL_WALK_FAST). The same cells in the same order either way:
// the same answers, bit for bit (the loop passes counted differ, so a search
// cut by the loop budget may stop at another place).
//
// Requires: hash.glsl, metric.glsl, points.glsl (included).
// Macros: CELL_DIM (2..4), CELL_METRIC, CELL_ANISO, CELL_MAX_POINTS,
//         CELL_LOOP_BUDGET (loop iterations one invocation may spend),
//         CELL_SHARED_CELLS (1: a cache of cells computed ahead, below; only
//         a compute entry that provides it defines it), CELL_WALK_TUNED (the
//         loops' shapes, above; default 1).

#include "hash.glsl"
#include "metric.glsl"
#include "points.glsl"

// Greater than any distance: "no point found yet" (below the float maximum,
// so a sum or a square root of it stays finite where the walks take one).
#define CELL_FAR 3.0e38

#ifndef CELL_WALK_TUNED
#define CELL_WALK_TUNED 1
#endif

#ifndef CELL_LOOP_BUDGET
// 6144 per invocation: the 8 invocations of one llvmpipe SIMD vector (AVX2)
// then spend at most 49152 of its 65535 together, the rest is margin for the
// caller's own loops. Measured in docs/exactness.md; a search needing more is
// flagged (cellgl recomputes it with the NumPy reference).
#define CELL_LOOP_BUDGET 6144
#endif
// The most one step of a search loop can spend: one pass of a window loop and
// the point loop of one cell (up to CELL_MAX_POINTS points, plus its exit).
#define CELL_LOOP_STEP (CELL_MAX_POINTS + 2)

// Whether a search that has spent `loops` passes must stop (one more step
// could pass CELL_LOOP_BUDGET).
bool cell_budget_spent(int loops)
{
    return loops > CELL_LOOP_BUDGET - CELL_LOOP_STEP;
}

// A vector in the units distances are measured in (CELL_ANISO: axes weighted).
vec4 _cell_axis_scale(vec4 v, CellParams p)
{
#if CELL_ANISO
    return v * p.axis_scale;
#else
    return v;
#endif
}

// Internal-unit distance from the sample (fraction f of its cell) to the
// nearest point of the cell at offset o.
float _cell_box_distance(ivec4 o, vec4 f, CellParams p)
{
    // Per axis o - f above, -o - 1 + f below (the larger), 0 in the sample's own slab.
    CELL_PRECISE vec4 g = _cell_axis_scale(max(max(vec4(o) - f, vec4(-o - 1) + f), vec4(0.0)), p);
    CELL_PRECISE float b = cell_metric_length(g, p.minkowski_p);
    return b;
}

// The sample's distance to the nearest face of its own cell (f: its fraction).
float cell_face_distance(vec4 f)
{
    CELL_PRECISE vec4 g = min(f, 1.0 - f);
#if CELL_DIM == 2
    return min(g.x, g.y);
#elif CELL_DIM == 3
    return min(min(g.x, g.y), g.z);
#else
    return min(min(g.x, g.y), min(g.z, g.w));
#endif
}

// 1 on the axes of the dimension, 0 past them.
#if CELL_DIM >= 4
const ivec4 _cell_axes = ivec4(1, 1, 1, 1);
#elif CELL_DIM == 3
const ivec4 _cell_axes = ivec4(1, 1, 1, 0);
#else
const ivec4 _cell_axes = ivec4(1, 1, 0, 0);
#endif

// The ring of the cell at offset o (its Chebyshev distance from the sample's).
int cell_ring_of(ivec4 o)
{
    return max(max(abs(o.x), abs(o.y)), max(abs(o.z), abs(o.w)));
}

// The window of ring `ring` that a point within true distance `reach` of the
// sample (fraction f of its cell) can lie in: offsets lo..hi per axis.
void cell_ring_window(int ring, float reach, vec4 f, out ivec4 lo, out ivec4 hi)
{
    hi = min(ivec4(ring), ivec4(ceil(reach + f)) - 1) * _cell_axes;
    lo = -min(ivec4(ring), ivec4(ceil(reach + 1.0 - f)) - 1) * _cell_axes;
}

// Internal-unit lower bound on the distance to any point beyond `rings` full
// rings of cells around the sample's: such a point's offset is +-(rings + 1)
// on some axis a, so it is at least rings + (distance to the nearer face of
// the sample's cell on a) away, m the least of those. Weighted (CELL_ANISO):
// the least over the axes of axis_scale[a] rings + ma[a], ma = axis_scale *
// (the per-axis face distances).
float _cell_ring_bound(float rings, float m, vec4 ma, CellParams p)
{
#if CELL_ANISO
    CELL_PRECISE float b = CELL_FAR;
    for (int a = 0; a < CELL_DIM; a++) {
        b = min(b, cell_metric_term(p.axis_scale[a] * rings + ma[a], p.minkowski_p));
    }
#else
    CELL_PRECISE float b = cell_metric_term(rings + m, p.minkowski_p);
#endif
    return b;
}

// The cells of the window lo .. hi in the order of nested x, y, z, w loops
// (the last axis fastest): cell_window_first(lo), then cell_window_next for
// each. The windows are walked by one flat loop: one pass per cell, where
// nested loops of run-time length would also spend a pass on every exit of the
// inner loops. (An odometer, not a division of the pass index: integer
// division is slow on SIMD CPUs.)
ivec4 cell_window_first(ivec4 lo)
{
#if CELL_DIM >= 4
    return lo - ivec4(0, 0, 0, 1);
#elif CELL_DIM == 3
    return lo - ivec4(0, 0, 1, 0);
#else
    return lo - ivec4(0, 1, 0, 0);
#endif
}

ivec4 cell_window_next(ivec4 o, ivec4 lo, ivec4 hi)
{
#if CELL_DIM >= 4
    o.w += 1;
    if (o.w > hi.w) {
        o.w = lo.w;
        o.z += 1;
    }
#elif CELL_DIM == 3
    o.z += 1;
#else
    o.y += 1;
#endif
#if CELL_DIM >= 3
    if (o.z > hi.z) {
        o.z = lo.z;
        o.y += 1;
    }
#endif
    if (o.y > hi.y) {
        o.y = lo.y;
        o.x += 1;
    }
    return o;
}

#if CELL_METRIC == CELL_METRIC_EUCLIDEAN && !CELL_ANISO
// The ball of radius `reach` (Euclidean) around the sample (fraction f), in
// rings up to `last`: the cells are walked in window order (axis 0 slowest),
// each axis over the range its prefix leaves, t = sqrt(reach^2 - the prefix's
// squared box distance) (widened for rounding, and holding 0 so that no range
// is empty). Sets axes `from` .. CELL_DIM - 1 of o to the start of their
// ranges, given o's axes before `from`.
void _cell_ball_reset(inout ivec4 o, inout ivec4 lo, inout ivec4 hi, vec4 f, float reach, int last, int from)
{
    CELL_PRECISE float r2 = reach * reach;
    CELL_PRECISE float s = 0.0;
    for (int a = 0; a < CELL_DIM; a++) {
        if (a >= from) {
            CELL_PRECISE float t = sqrt(max(r2 - s, 0.0)) * 1.000001 + 1e-6;
            hi[a] = clamp(int(ceil(t + f[a])) - 1, 0, last);
            lo[a] = -clamp(int(ceil(t + 1.0 - f[a])) - 1, 0, last);
            o[a] = lo[a];
        }
        CELL_PRECISE float g = o[a] > 0 ? float(o[a]) - f[a] : (o[a] < 0 ? float(-o[a] - 1) + f[a] : 0.0);
        s += g * g;
    }
    // the axes past CELL_DIM: 0, as cell_ring_window's (a caller's lo, hi may arrive undefined)
#if CELL_DIM < 4
    lo.w = 0;
    hi.w = 0;
#endif
#if CELL_DIM < 3
    lo.z = 0;
    hi.z = 0;
#endif
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

// The cell source: the cell at offset o from the sample's `cell`, wrapped (c),
// its hash state (the generator of its points, cell_next_point) and its point
// count, the per-cell setup of every walk.
int _cell_open(ivec4 cell, ivec4 o, CellParams p, out ivec4 c, out uint state)
{
    c = cell_wrap(cell + o, p.period);
    state = cell_cell_seed(c, p.seed);
    return cell_point_count_at(state, c, p);
}

#ifndef CELL_SHARED_CELLS
#define CELL_SHARED_CELLS 0
#endif
#if CELL_SHARED_CELLS
// A second cell source: cells computed ahead. On a grid the samples of one
// compute workgroup are neighbours and visit almost the same cells; the
// workgroup hashes the cells of rings 0 and 1 around all of its samples once,
// into shared memory (shaders/cellular.comp), and the search reads them there
// (cellular.glsl, _cell_visit_near). The points are those the hash gives, in
// its order: the same answers, bit for bit. Provided by the entry point (this
// library declares no shared memory: its fragment-shader users cannot):
//   cell_shared_on()     whether the cache holds rings 0 and 1 of every sample
//                        of this workgroup (the same value for all of them);
//   cell_shared_open     the slot of the cell at offset o (-1..1 per axis)
//                        from the sample's `cell`, and its point count;
//   cell_shared_point    point k of a slot: its position in its cell, its ID.
bool cell_shared_on();
int cell_shared_open(ivec4 cell, ivec4 o, out int count);
vec4 cell_shared_point(int slot, int k, out uint id);
#endif
