// cellgl: the cellular basis F1..Fn (Worley 1996), exact.
//
// cell_search() returns the CELL_N nearest feature points to a sample, in
// ascending distance, with the delta vector (feature - sample) and the ID of
// each. The answer equals a brute-force search over all cells: cells are
// visited ring by ring (Chebyshev rings of cells around the sample's cell), and
//   * a cell is skipped when its nearest possible point is no closer than the
//     current F_n (Worley's pruning);
//   * the search stops before ring r once (r - 1) + m >= F_n, where m is the
//     sample's distance to the nearest face of its own cell: no point in ring r
//     or beyond can then be closer than F_n;
//   * if ring CELL_MAX_RING is finished without that guarantee, the result is
//     marked inexact (CellResult.exact = false) instead of being silently wrong.
//
// Loop budget (walk.glsl): the search counts its loop passes in
// CellResult.loops and stops, flagged inexact, before CELL_LOOP_BUDGET;
// cell_features() (features.glsl) continues the same count.
//
// The sample is an integer cell plus a float fraction in [0, 1): precision does not depend on where.
//
// Anisotropic distance (CELL_ANISO, stretched cells): a vector v has length
// |p.axis_scale * v| (each axis weighted), so the Voronoi cells of the
// feature points stretch along the axes of small weight. The box distances
// and the ring bounds above are taken in those units, per axis, so the answer
// is still exactly that of a brute-force search under the weighted metric.
//
// Requires: walk.glsl (included; with it hash.glsl, metric.glsl, points.glsl).
// Macros: CELL_DIM (2..4), CELL_N (1..8), CELL_METRIC, CELL_DIST,
//         CELL_MAX_POINTS, CELL_MAX_RING, CELL_DENSITY_MAP, CELL_ANISO,
//         CELL_RING1_PRUNE (default: 1 but for the jitter distribution),
//         CELL_LOOP_BUDGET (loop iterations one invocation may spend),
//         CELL_EDGE, CELL_SMOOTH, CELL_NSPHERE (the features of features.glsl
//         wanted; default 0: here only whether the search tracks the F1
//         point's cell for the n-sphere radius alone), CELL_TRACK_F1_CELL
//         (derived from those unless defined: 1 for the n-sphere radius alone),
//         CELL_SHARED_CELLS (walk.glsl: rings 0 and 1 from a workgroup's cache),
//         CELL_WALK_TUNED (walk.glsl: the shapes of the loops, tuned or plain),
//         CELL_PRECISE (below).

// CELL_PRECISE: `precise` where the compiler has it (the entry's prelude, cellgl/gl/glsl.py), on
// the arithmetic whose rounding decides an answer (lib/metric.glsl, docs/exactness.md).
#ifndef CELL_PRECISE
#define CELL_PRECISE
#endif
#include "walk.glsl"

#ifndef CELL_EDGE
#define CELL_EDGE 0
#endif
#ifndef CELL_SMOOTH
#define CELL_SMOOTH 0
#endif
#ifndef CELL_NSPHERE
#define CELL_NSPHERE 0
#endif
// The n-sphere radius alone (features.glsl) needs only the cell of the F1 point
// and its position in it: the search keeps them instead of a second walk.
#if CELL_NSPHERE && !CELL_EDGE && !CELL_SMOOTH
#define CELL_TRACK_F1_CELL 1
#endif
#ifndef CELL_TRACK_F1_CELL
#define CELL_TRACK_F1_CELL 0
#endif
#ifndef CELL_RING1_PRUNE
#if CELL_DIST == CELL_DIST_JITTER
#define CELL_RING1_PRUNE 0
#else
#define CELL_RING1_PRUNE 1
#endif
#endif

// How cell_search_budget walks the rings after ring 0 (CELL_WALK_TUNED, walk.glsl):
// nested loops, a pass per ring and per cell (plain: every case), or one flat loop
// over the cells of rings 2, 3, ... (2D jitter, 3D pruned); ring 1 from its table in
// the nested loops' first pass (2D pruned; plain: 2D, 3D), or a window (4D pruned).
#if CELL_WALK_TUNED && ((CELL_RING1_PRUNE && CELL_DIM == 3) || (!CELL_RING1_PRUNE && CELL_DIM == 2))
#define _CELL_NESTED 0
#else
#define _CELL_NESTED 1
#endif
#if CELL_DIM <= 3 && (!CELL_WALK_TUNED || (CELL_RING1_PRUNE && CELL_DIM == 2))
#define _CELL_RING1_TABLE 1
#else
#define _CELL_RING1_TABLE 0
#endif
#if CELL_DIM == 4 && CELL_RING1_PRUNE
#define _CELL_FIRST_WINDOW 1
#else
#define _CELL_FIRST_WINDOW 2
#endif

// Ring 1 nearest first (2D, 3D). The 3^d - 1 cells around the sample's own, in
// the order of their box distances for a typical sample, on axes sorted by the
// sample's distance to the nearer face (rank 0 the nearest). Per sample
// (cell_search_budget) rank k stands for the axis that is k-th nearest to its
// nearer face, and -1 for the step across that face. Hex digit k of an entry
// (from the right) is rank k's step: 8 for -1 (near), 5 for 0, 2 for +1 (far);
// a digit holds the step in its low two bits plus 1, and the flipped step in its
// high two, so one shift (_cell_ring1_offset) maps it onto the lattice. The
// order is that of the Euclidean box distances at the expected face distances
// of the sorted axes (1/6, 1/3 in 2D; 1/8, 1/4, 3/8 in 3D), ties by fewer far
// steps: F_n shrinks early, more of the later cells are pruned, and the loop
// leaves sooner. The order decides only which of two exactly equal distances
// comes first (cellgl/basis/reference.py visits in the same order).
#if CELL_DIM == 2
#define CELL_RING1_CELLS 8
const int _cell_ring1[8] = int[8](0x558, 0x585, 0x588, 0x525, 0x528, 0x552, 0x582, 0x522);
#elif CELL_DIM == 3
#define CELL_RING1_CELLS 26
const int _cell_ring1[26] = int[26](0x558, 0x585, 0x588, 0x855, 0x858, 0x885, 0x888, 0x255, 0x258, 0x285, 0x288, 0x525, 0x528, 0x825, 0x828, 0x552, 0x582, 0x852, 0x225, 0x882, 0x228, 0x252, 0x282, 0x522, 0x822, 0x222);
#endif

#if CELL_DIM <= 3
// The lattice offset of entry t of _cell_ring1 for a sample whose axes have the shifts sh: 4 rank + 2 if flipped.
ivec4 _cell_ring1_offset(int t, ivec4 sh)
{
    return ivec4(_cell_ring1[t] >> sh.x & 3, _cell_ring1[t] >> sh.y & 3, _cell_ring1[t] >> sh.z & 3, 1) - 1;
}
#endif

struct CellResult {
    float F[CELL_N];      // distances, ascending (true distances after cell_search)
    vec4 delta[CELL_N];   // feature point - sample (components past CELL_DIM are 0)
    uint id[CELL_N];      // feature point IDs
#if CELL_TRACK_F1_CELL
    ivec4 o1;             // the F1 point's cell, as an offset from the sample's
    vec4 q1;              // and its position in that cell
#endif
    bool exact;           // false if the ring cap or the loop budget was reached
    int loops;            // loop passes so far: a search stops at CELL_LOOP_BUDGET, as llvmpipe cuts loops silently
};

// Insert one candidate (internal-unit distance d) into the sorted lists.
// Strict comparisons: of two equal distances the one found first stays first.
// Only constant array indices (after unrolling), so the lists stay in
// registers instead of spilling to memory.
void _cell_insert(inout CellResult r, float d, vec4 delta, uint id)
{
    for (int k = CELL_N - 1; k > 0; k--) {
        if (d < r.F[k - 1]) {
            r.F[k] = r.F[k - 1];
            r.delta[k] = r.delta[k - 1];
            r.id[k] = r.id[k - 1];
        } else if (d < r.F[k]) {
            r.F[k] = d;
            r.delta[k] = delta;
            r.id[k] = id;
        }
    }
    if (d < r.F[0]) {
        r.F[0] = d;
        r.delta[0] = delta;
        r.id[0] = id;
    }
}

// What the search does per feature point: the point q (ID id) of the cell at
// offset o, base = o - f, becomes a candidate.
void _cell_visit_point(inout CellResult r, vec4 base, ivec4 o, vec4 q, uint id, CellParams p)
{
    CELL_PRECISE vec4 delta = _cell_axis_scale(base + q, p);
    CELL_PRECISE float d = cell_metric_length(delta, p.minkowski_p);
#if CELL_TRACK_F1_CELL
    if (d < r.F[0]) {          // the test that makes it the new F1 in _cell_insert
        r.o1 = o;
        r.q1 = q;
    }
#endif
    _cell_insert(r, d, delta, id);
}

// Test every feature point of the cell at offset o from the sample's cell.
void _cell_visit(inout CellResult r, ivec4 cell, vec4 f, ivec4 o, CellParams p)
{
    ivec4 c;
    uint state;
    int count = _cell_open(cell, o, p, c, state);
    CELL_PRECISE vec4 base = vec4(o) - f;
    r.loops += count + 1;
    // Tested at the end of each pass: on SIMD CPUs (llvmpipe) an `if` does not
    // branch, it masks, so a loop whose lanes all leave at its top still runs
    // its body once more under an empty mask; this way a cell of k points costs k.
    if (cell_min_count(p) > 0 || count > 0) {
        for (int k = 0; ; ) {
            uint id;
            vec4 q = cell_next_point(state, c, p, id);
            _cell_visit_point(r, base, o, q, id, p);
            k++;
            if (k >= count) {
                break;
            }
        }
    }
}

#if CELL_SHARED_CELLS
#define _CELL_VISIT_NEAR _cell_visit_near
// _cell_visit for a cell of rings 0 and 1 (offset o: -1..1 on every axis):
// read from the workgroup's cache of cells where it has them (a grid on the
// compute path, walk.glsl), the same points in the same order as hashing
// gives them; hashed otherwise. Same count of loop passes either way.
void _cell_visit_near(inout CellResult r, ivec4 cell, vec4 f, ivec4 o, CellParams p)
{
    if (cell_shared_on()) {
        int count;
        int slot = cell_shared_open(cell, o, count);
        CELL_PRECISE vec4 base = vec4(o) - f;
        r.loops += count + 1;
        if (cell_min_count(p) > 0 || count > 0) {
            for (int k = 0; ; ) {
                uint id;
                vec4 q = cell_shared_point(slot, k, id);
                _cell_visit_point(r, base, o, q, id, p);
                k++;
                if (k >= count) {
                    break;
                }
            }
        }
    } else {
        _cell_visit(r, cell, f, o, p);
    }
}
#else
#define _CELL_VISIT_NEAR _cell_visit
#endif

// The window of ring `ring` of cell_search_budget: the cells that can hold a
// point nearer than Fn (internal units; CELL_FAR: none found yet, the whole ring).
void _cell_search_window(int ring, float Fn, vec4 f, CellParams p, out ivec4 lo, out ivec4 hi)
{
    CELL_PRECISE float reach = Fn < CELL_FAR ? cell_metric_finish(Fn, p.minkowski_p) * 1.000001 + 1e-6 : float(ring + 2);
#if CELL_ANISO
    lo = ivec4(0);
    hi = ivec4(0);
    for (int a = 0; a < CELL_DIM; a++) {
        // In lattice units on this axis (no point found yet: the whole ring).
        CELL_PRECISE float ra = Fn < CELL_FAR ? reach / p.axis_scale[a] : reach;
        hi[a] = min(ring, int(ceil(ra + f[a])) - 1);
        lo[a] = -min(ring, int(ceil(ra + 1.0 - f[a])) - 1);
    }
#else
    cell_ring_window(ring, reach, f, lo, hi);
#endif
}

#if CELL_DIM <= 3 && CELL_RING1_PRUNE
// The order of ring 1 for the sample (fraction f): the shifts sh of
// _cell_ring1_offset and the sample in the frame of the table (qn).
void _cell_ring1_order(vec4 f, out ivec4 sh, out vec4 qn)
{
    // The axes' ranks by the distance to their nearer face (ties: the lower axis
    // first; stretched cells, CELL_ANISO: as they are) and flips (the nearer face
    // above): the shifts of _cell_ring1_offset, 4 rank + 2 if flipped.
#if CELL_ANISO
    sh = ivec4(0, 4, 8, 12) + 2 - 2 * ivec4(lessThan(f, vec4(0.5)));
#elif CELL_DIM == 2
    int c = min(f, 1.0 - f).y < min(f, 1.0 - f).x ? 1 : 0;
    sh = 4 * ivec4(c, 1 - c, 2, 3) + 2 - 2 * ivec4(lessThan(f, vec4(0.5)));
#else
    ivec3 c = ivec3(lessThan(min(f, 1.0 - f).yzz, min(f, 1.0 - f).xxy));     // y < x, z < x, z < y
    sh = 4 * ivec4(c.x + c.y, 1 - c.x + c.z, 2 - c.y - c.z, 3) + 2 - 2 * ivec4(lessThan(f, vec4(0.5)));
#endif
    // The sample in the frame of the table as listed: its distances to the near
    // faces in rank order. A cell's box distance there has the same terms as on the
    // lattice (summed in rank order) and, for a constant t (the unrolled pass
    // below), needs no decoding.
    qn = vec4(dot(vec4(equal(sh / 4, ivec4(0))), min(f, 1.0 - f)), dot(vec4(equal(sh / 4, ivec4(1))), min(f, 1.0 - f)), dot(vec4(equal(sh / 4, ivec4(2))), min(f, 1.0 - f)), 0.0);
}
#endif

// A search result with nothing found yet, after `loops` loop passes.
CellResult _cell_result_start(int loops)
{
    CellResult r;
    for (int k = 0; k < CELL_N; k++) {
        r.F[k] = CELL_FAR;
        r.delta[k] = vec4(0.0);
        r.id[k] = 0u;
    }
#if CELL_TRACK_F1_CELL
    r.o1 = ivec4(0);
    r.q1 = vec4(0.0);
#endif
    // set at the end of the search; never copied undefined before that
    r.exact = false;
    r.loops = loops;
    return r;
}

// Ring 1, the rest of the 3^d block (2D, 3D: nearest first, _cell_ring1), then
// rings 2, 3, ... while a point there could still be closer than F_n, each ring's
// window of cells that can reach. A cell is skipped when its nearest possible point
// is no closer than F_n (such a point could not be inserted). On llvmpipe every
// loop runs at least one pass, masked if need be: a loop of their own for rings 2,
// 3, ..., which almost no sample needs, cost every SIMD vector a masked pass. So
// they are walked by a loop whose first pass is ring 1's own work (3D pruned,
// tuned: a flat loop entered from an empty pass, the cheapest to enter).

#if !CELL_RING1_PRUNE && !_CELL_RING1_TABLE
// Unpruned (a test costs more than jitter's one point per cell) and
// unrolled, but for its last cell (_cell_axes, all +1), the loop's first pass.
void _cell_search_ring1_all(inout CellResult r, ivec4 cell, vec4 f, CellParams p, inout bool spent)
{
#if CELL_DIM <= 3
    // (A loop over the whole table: NIR unrolls a loop that indexes an array
    // as long as its trip count.)
    for (int t = 0; t < CELL_RING1_CELLS; t++) {
        if (cell_budget_spent(r.loops)) {
            spent = true;
        } else if (t < CELL_RING1_CELLS - 1) {
            _CELL_VISIT_NEAR(r, cell, f, _cell_ring1_offset(t, ivec4(0, 4, 8, 0)), p);      // as listed (the reference's order on ties)
        }
    }
#else
    for (int x = -1; x <= 1; x++)
    for (int y = -1; y <= 1; y++)
    for (int z = -1; z <= 1; z++)
    for (int w = -1; w <= 1; w++) {
        ivec4 o = ivec4(x, y, z, w);
        if (any(notEqual(o, ivec4(0))) && any(notEqual(o, _cell_axes))) {
            if (cell_budget_spent(r.loops)) {
                spent = true;
            } else {
                _CELL_VISIT_NEAR(r, cell, f, o, p);
            }
        }
    }
#endif
}
#endif

#if _CELL_NESTED
// Rings 1, 2, ... of cell_search_budget as the ring loop of every walker
// (ring_loop.glsl), with the search's hooks: ring 1 the loop's first pass (what
// is left of it: its table in the order sh, its last cell, or, 4D pruned, its
// window), each later ring its window of cells that can reach; a cell visited
// when it can hold a point nearer than F_n; on while a point past the rings
// done can be (_cell_ring_bound).
int _cell_search_ring_window(int ring, CellResult r, vec4 f, CellParams p, out ivec4 lo, out ivec4 hi)
{
#if _CELL_RING1_TABLE
    lo = ivec4(0);
    int cells = CELL_RING1_CELLS;     // the table
#else
    lo = _cell_axes;                  // its last cell (the rest: _cell_search_ring1_all)
    int cells = 1;
#endif
    hi = lo;
    if (ring >= _CELL_FIRST_WINDOW) {    // its window (4D pruned: ring 1 too)
        _cell_search_window(ring, r.F[CELL_N - 1], f, p, lo, hi);
        ivec4 n = hi - lo + 1;
        cells = n.x * n.y * n.z * n.w;
    }
    return cells;
}

float _cell_search_bound(CellResult r, CellParams p)
{
    return r.F[CELL_N - 1];
}

bool _cell_search_past(CellResult r, int rings, float m, vec4 ma, CellParams p)
{
    return _cell_ring_bound(float(rings), m, ma, p) >= r.F[CELL_N - 1];
}

#define _CELL_RINGS _cell_search_rings
#define _CELL_RINGS_STATE CellResult
#define _CELL_RINGS_WINDOW _cell_search_ring_window
#define _CELL_RINGS_BOUND _cell_search_bound
#define _CELL_RINGS_PAST _cell_search_past
#define _CELL_RINGS_VISIT _cell_visit
#define _CELL_RINGS_TABLE _CELL_RING1_TABLE
#include "ring_loop.glsl"
#else
// Rings `ring`, ring + 1, ... of cell_search_budget as one flat loop over the
// cells of the rings (the cells of each ring's window that are on the ring), on
// to the next ring after a window's last cell. (Tested at the top for the budget
// alone: a lane leaves at a ring's bound.)
void _cell_search_flat(inout CellResult r, ivec4 cell, vec4 f, CellParams p, float m, vec4 ma, inout int ring,
                       inout bool spent, inout ivec4 lo, inout ivec4 hi)
{
    ivec4 o = lo;
    for (; !spent; ) {
        spent = cell_budget_spent(r.loops);          // the count only grows
        r.loops += 1;
        ivec4 ao = abs(o);
        if (!spent && max(max(ao.x, ao.y), max(ao.z, ao.w)) == ring
            && _cell_box_distance(o, f, p) < r.F[CELL_N - 1]) {
            _cell_visit(r, cell, f, o, p);
        }
        o = cell_window_next(o, lo, hi);
        if (o.x > hi.x) {
            ring++;
            if (ring > CELL_MAX_RING || _cell_ring_bound(float(ring - 1), m, ma, p) >= r.F[CELL_N - 1]) {
                break;
            }
            _cell_search_window(ring, r.F[CELL_N - 1], f, p, lo, hi);
            o = lo;
        }
    }
}
#endif

// Exact: ring r = 2, 3, ... is searched while (r - 1) + m < F_n (m: distance to the cell's nearest face).
// cell_search for an invocation that has already spent `loops` loop passes:
// it stops, flagged inexact, before the invocation's count reaches CELL_LOOP_BUDGET
// (6144 unless defined), since drivers cut longer loops without a word
// (llvmpipe: 65535 passes per SIMD vector; docs/exactness.md).
CellResult cell_search_budget(ivec4 cell, vec4 f, CellParams p, int loops)
{
    CellResult r = _cell_result_start(loops);
    bool spent = cell_budget_spent(loops);

    // Ring 0, the sample's own cell.
    if (!spent) {
        _CELL_VISIT_NEAR(r, cell, f, ivec4(0), p);
    }
    float m = cell_face_distance(f);
    vec4 ma = _cell_axis_scale(min(f, 1.0 - f), p);

    // Ring 1, then rings 2, 3, ... (_cell_search_rings, _cell_search_flat).
    int ring = 1;
#if CELL_DIM <= 3 && CELL_RING1_PRUNE
    ivec4 sh;
    vec4 qn;
    _cell_ring1_order(f, sh, qn);
#else
    ivec4 sh = ivec4(0, 4, 8, 0);     // unpruned: the table as listed (_cell_search_ring1_all)
    vec4 qn = f;
#endif
    // The part of ring 1 before the loop below (the loop's first pass: what is left).
#if CELL_RING1_PRUNE && CELL_DIM == 3 && !_CELL_RING1_TABLE
    // The cells' nearest possible distances in visiting order, and the least of
    // each tail: the walk leaves its loop once no cell left can beat F_n. A
    // run-time loop on purpose: in straight-line SIMD code a pruned cell still
    // runs while any lane of the vector needs it, a lane that left a loop costs
    // nothing. Tested at the end of each pass, as the point loop (_cell_visit).
    CELL_PRECISE float rest[CELL_RING1_CELLS + 1];
    rest[CELL_RING1_CELLS] = CELL_FAR;
    for (int t = CELL_RING1_CELLS - 1; t >= 0; t--) {
        rest[t] = min(rest[t + 1], _cell_box_distance(_cell_ring1_offset(t, ivec4(0, 4, 8, 0)), qn, p));
    }
    for (int t = 0; ; ) {
        r.loops += 1;
        if (_cell_box_distance(_cell_ring1_offset(t, ivec4(0, 4, 8, 0)), qn, p) < r.F[CELL_N - 1]) {
            spent = cell_budget_spent(r.loops);      // the count only grows
            if (!spent) {
                _CELL_VISIT_NEAR(r, cell, f, _cell_ring1_offset(t, sh), p);
            }
        }
        t++;
        if (t >= CELL_RING1_CELLS || spent || rest[t] >= r.F[CELL_N - 1]) {
            break;
        }
    }
    ivec4 lo = ivec4(0), hi = lo;     // nothing left (ring 0)
#elif !CELL_RING1_PRUNE && !_CELL_RING1_TABLE
    _cell_search_ring1_all(r, cell, f, p, spent);
#if !_CELL_NESTED
    ivec4 lo = _cell_axes, hi = lo;   // its last cell left
#endif
#endif
#if _CELL_NESTED
    _cell_search_rings(r, cell, f, p, m, ma, ring, CELL_MAX_RING, spent, sh, qn);
#else
    _cell_search_flat(r, cell, f, p, m, ma, ring, spent, lo, hi);
#endif
    // Rings 0 .. ring - 1 searched: exact unless a point beyond can be nearer,
    // or the loop budget stopped the search (a nearer point may be missed).
    r.exact = !spent && _cell_ring_bound(float(ring - 1), m, ma, p) >= r.F[CELL_N - 1];
    for (int k = 0; k < CELL_N; k++) {
        r.F[k] = cell_metric_finish(r.F[k], p.minkowski_p);
    }
    return r;
}

// The CELL_N nearest feature points of the sample (cell, f); flagged inexact
// rather than cut past CELL_LOOP_BUDGET loop passes (cell_search_budget).
CellResult cell_search(ivec4 cell, vec4 f, CellParams p)
{
    return cell_search_budget(cell, f, p, 0);
}
