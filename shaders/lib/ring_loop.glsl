// cellgl: the ring loop, one function for every walker.
//
// The search (cellular.glsl) and the feature walks (feature_walk.glsl: edge,
// n-sphere, edge alone, the walk around the F1 point) walk the cells around a
// sample the same way: one outer pass a ring (Chebyshev rings of cells,
// walk.glsl), one inner pass a cell of the ring's window, a cell visited when it
// is on the ring and its nearest possible point is nearer than the walker's
// bound, and on to the next ring while a point past the rings done can still
// matter. Both loops are tested at the bottom (every ring holds a pass, every
// window a cell): on llvmpipe a loop tested at the top runs its body once more,
// masked, on every exit. What differs is the walker's state and four hooks, so
// this file is a template: each walker names them with #define and includes it
// (the one file the resolver includes each time, cellgl/gl/glsl.py; the
// snippet exporter prints the function under the walker's name). It #undefs
// its parameters at its end.
//
// Loop budget (walk.glsl): one pass counted a pass of either loop, as the
// search always counted (a loop tested at the bottom spends no pass to leave);
// spent: the walker stopped at CELL_LOOP_BUDGET (the count only grows, so a
// walker that had spent it before the loop finds it spent at its first pass).
//
// Requires: walk.glsl (included).
// Macros (the walker's, defined before each inclusion of this file):
//   _CELL_RINGS          the function's name;
//   _CELL_RINGS_STATE    the walker's state, a struct with `int loops`;
//   _CELL_RINGS_WINDOW   int (int ring, STATE s, vec4 f, CellParams p, out ivec4
//                        lo, out ivec4 hi): ring `ring`'s window lo .. hi and
//                        the loop's passes over it (the search's ring 1: the
//                        rest of it, its table or its last cell);
//   _CELL_RINGS_BOUND    float (STATE s, CellParams p): a cell is visited when
//                        its nearest possible point is nearer (internal units);
//   _CELL_RINGS_PAST     bool (STATE s, int rings, float m, vec4 ma, CellParams
//                        p): whether no point past `rings` full rings can
//                        matter (m, ma: the sample's face distances, walk.glsl);
//   _CELL_RINGS_VISIT    void (inout STATE s, ivec4 cell, vec4 f, ivec4 o,
//                        CellParams p): the visit of the cell at offset o;
//   _CELL_RINGS_TABLE    1: ring 1 in the order of the search's nearest-first
//                        table (_cell_ring1_offset, cellular.glsl), and with
//                        CELL_RING1_PRUNE left once no cell left can be nearer;
//                        0: in window order. CELL_RING1_PRUNE (cellular.glsl).
#pragma cellgl include_each_time

#include "walk.glsl"

// The ring loop of every walker: rings `ring`, ring + 1, ... up to `last`.
// Then `ring` is the first ring not walked (the rings from it on cannot matter,
// it is past `last`, or the budget stopped the walk), and `spent` whether the
// loop budget stopped the walker.
// sh, qn: the order of the table and the sample in its frame
// (_CELL_RINGS_TABLE; _cell_ring1_order).
void _CELL_RINGS(inout _CELL_RINGS_STATE s, ivec4 cell, vec4 f, CellParams p, float m, vec4 ma, inout int ring,
                 int last, out bool spent, ivec4 sh, vec4 qn)
{
#if _CELL_RINGS_TABLE && CELL_RING1_PRUNE
    // The table's least box distance of each tail (as cell_search_budget's 3D ring 1).
    float rest[CELL_RING1_CELLS + 1];
    rest[CELL_RING1_CELLS] = CELL_FAR;
    for (int t = CELL_RING1_CELLS - 1; t >= 0; t--) {
        rest[t] = min(rest[t + 1], _cell_box_distance(_cell_ring1_offset(t, ivec4(0, 4, 8, 0)), qn, p));
    }
#endif
    for (;;) {
        s.loops += 1;
        ivec4 lo, hi;
        int cells = _CELL_RINGS_WINDOW(ring, s, f, p, lo, hi);
        ivec4 o = cell_window_first(lo);
        for (int t = 0; ; ) {
            spent = cell_budget_spent(s.loops);      // the count only grows
            s.loops += 1;
#if _CELL_RINGS_TABLE
            o = ring == 1 ? _cell_ring1_offset(min(t, CELL_RING1_CELLS - 1), sh) : cell_window_next(o, lo, hi);
#else
            o = cell_window_next(o, lo, hi);
#endif
            if (!spent && cell_ring_of(o) == ring && _cell_box_distance(o, f, p) < _CELL_RINGS_BOUND(s, p)) {
                _CELL_RINGS_VISIT(s, cell, f, o, p);
            }
            t++;
#if _CELL_RINGS_TABLE && CELL_RING1_PRUNE
            if (t >= cells || spent || (ring == 1 && rest[min(t, CELL_RING1_CELLS)] >= _CELL_RINGS_BOUND(s, p))) {
#else
            if (t >= cells || spent) {
#endif
                break;
            }
        }
        ring++;
        if (ring > last || spent || _CELL_RINGS_PAST(s, ring - 1, m, ma, p)) {
            break;
        }
    }
}

#undef _CELL_RINGS
#undef _CELL_RINGS_STATE
#undef _CELL_RINGS_WINDOW
#undef _CELL_RINGS_BOUND
#undef _CELL_RINGS_PAST
#undef _CELL_RINGS_VISIT
#undef _CELL_RINGS_TABLE
