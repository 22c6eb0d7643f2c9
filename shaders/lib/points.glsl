// cellgl: where the feature points are.
//
// Space is diced into integer cells. Each cell hashes (with the seed) to a
// 32-bit value that starts a small random stream; the stream gives the number
// of points in the cell and then, point by point, an ID and the position.
// CELL_DIST selects the distribution at compile time (cellgl.enums.Distribution).
//
// Requires: hash.glsl. Macros: CELL_DIM (2..4), CELL_DIST,
// CELL_MAX_POINTS (the size of the threshold table, >= max_points).

// Run-time parameters of the basis (everything that does not change the
// shape of the code).
struct CellParams {
    uint seed;          // any uint32
    float jitter;       // jitter distribution: displacement scale in [0, 1]
    int min_points;     // poisson: clamp of the per-cell count
    int max_points;
    // poisson: thresholds[k] = floor(2^32 * P(X <= k)) for X ~ Poisson(density).
    // This is the population table in run-length form: hash value u gives the
    // count k with thresholds[k-1] <= u < thresholds[k].
    uint thresholds[CELL_MAX_POINTS];
    ivec4 period;       // > 0: cells repeat with this period on that axis
    float minkowski_p;  // minkowski metric exponent
};

// The classic 1996 population table (Texturing & Modeling, 256 entries,
// indexed by the 8 high bits of the cube seed; mean 2.598).
const int _cell_w96_table[256] = int[256](
    4, 3, 1, 1, 1, 2, 4, 2, 2, 2, 5, 1, 0, 2, 1, 2, 2, 0, 4, 3, 2, 1, 2, 1, 3, 2, 2, 4, 2, 2, 5, 1,
    2, 3, 2, 2, 2, 2, 2, 3, 2, 4, 2, 5, 3, 2, 2, 2, 5, 3, 3, 5, 2, 1, 3, 3, 4, 4, 2, 3, 0, 4, 2, 2,
    2, 1, 3, 2, 2, 2, 3, 3, 3, 1, 2, 0, 2, 1, 1, 2, 2, 2, 2, 5, 3, 2, 3, 2, 3, 2, 2, 1, 0, 2, 1, 1,
    2, 1, 2, 2, 1, 3, 4, 2, 2, 2, 5, 4, 2, 4, 2, 2, 5, 4, 3, 2, 2, 5, 4, 3, 3, 3, 5, 2, 2, 2, 2, 2,
    3, 1, 1, 4, 2, 1, 3, 3, 4, 3, 2, 4, 3, 3, 3, 4, 5, 1, 4, 2, 4, 3, 1, 2, 3, 5, 3, 2, 1, 3, 1, 3,
    3, 3, 2, 3, 1, 5, 5, 4, 2, 2, 4, 1, 3, 4, 1, 5, 3, 3, 5, 3, 4, 3, 2, 2, 1, 1, 1, 1, 1, 2, 4, 5,
    4, 5, 4, 2, 1, 5, 1, 1, 2, 3, 3, 3, 2, 5, 2, 3, 3, 2, 0, 2, 1, 1, 4, 2, 1, 3, 2, 1, 2, 2, 3, 2,
    5, 5, 3, 4, 5, 5, 2, 4, 4, 5, 3, 2, 2, 2, 1, 4, 2, 3, 3, 4, 2, 5, 4, 2, 4, 2, 2, 2, 4, 5, 3, 2
);

// Wrap a cell onto the periodic lattice (axes with period 0 are not wrapped).
// Compiled only when CELL_PERIODIC is 1, so ordinary textures pay nothing.
// Callers keep |c| well below 2^24 (the sample's own cell is wrapped first),
// so the float quotient is exact enough; the two fix-ups absorb its rounding.
ivec4 cell_wrap(ivec4 c, ivec4 period)
{
#if CELL_PERIODIC
    ivec4 m = max(period, ivec4(1));
    ivec4 w = c - m * ivec4(floor(vec4(c) / vec4(m)));
    w += m * ivec4(lessThan(w, ivec4(0)));
    w -= m * ivec4(greaterThanEqual(w, m));
    bvec4 on = greaterThan(period, ivec4(0));
    return ivec4(on.x ? w.x : c.x, on.y ? w.y : c.y, on.z ? w.z : c.z, on.w ? w.w : c.w);
#else
    return c;
#endif
}

#if CELL_DIST == CELL_DIST_WORLEY1996
// The book's cube seed: 702395077 x + 915488749 y + 2120969693 z (mod 2^32),
// plus the cellgl seed times an odd constant (0 leaves the original untouched).
uint cell_cell_seed(ivec4 c, uint seed)
{
    return 702395077u * uint(c.x) + 915488749u * uint(c.y) + 2120969693u * uint(c.z)
         + seed * 2654435769u;
}
#else
// Hash an integer cell and the seed to the start of the cell's random stream:
// one avalanche of a wrapping linear combination with large odd constants.
uint cell_cell_seed(ivec4 c, uint seed)
{
    uint h = seed * 0x27d4eb2fu + uint(c.x) * 0x8da6b343u + uint(c.y) * 0xd8163841u;
#if CELL_DIM >= 3
    h += uint(c.z) * 0xcb1ab31fu;
#endif
#if CELL_DIM >= 4
    h += uint(c.w) * 0x165667b1u;
#endif
    return cell_hash_u32(h);
}
#endif

// Number of feature points in the cell whose stream starts at `state`;
// advances the stream past the count.
int cell_point_count(inout uint state, CellParams p)
{
#if CELL_DIST == CELL_DIST_WORLEY1996
    int count = _cell_w96_table[state >> 24];
    state = 1402024253u * state + 586950981u;
    return count;
#elif CELL_DIST == CELL_DIST_JITTER
    return 1;
#else
    // count = min_points + #{k in [min_points, max_points) : u >= thresholds[k]}.
    // A fixed-length loop with constant indices once unrolled, so the table
    // stays in registers.
    uint u = cell_rng_next(state);
    int count = p.min_points;
    for (int k = 0; k < CELL_MAX_POINTS; k++) {
        count += (k >= p.min_points && k < p.max_points && u >= p.thresholds[k]) ? 1 : 0;
    }
    return count;
#endif
}

// The next feature point of the stream: its ID, and its position relative to
// the cell's lower corner, each coordinate in [0, 1].
vec4 cell_next_point(inout uint state, CellParams p, out uint id)
{
    vec4 f = vec4(0.0);
#if CELL_DIST == CELL_DIST_WORLEY1996
    id = state;
    state = 1402024253u * state + 586950981u;
    f.x = (float(state) + 0.5) * (1.0 / 4294967296.0);
    state = 1402024253u * state + 586950981u;
    f.y = (float(state) + 0.5) * (1.0 / 4294967296.0);
    state = 1402024253u * state + 586950981u;
    f.z = (float(state) + 0.5) * (1.0 / 4294967296.0);
    state = 1402024253u * state + 586950981u;
#else
    id = cell_rng_next(state);
    uint u = cell_rng_next(state);
    f.x = cell_u16(u >> 16);
    f.y = cell_u16(u & 0xffffu);
#if CELL_DIM >= 3
    u = cell_rng_next(state);
    f.z = cell_u16(u >> 16);
    f.w = cell_u16(u & 0xffffu);
#endif
#if CELL_DIST == CELL_DIST_JITTER
    f = 0.5 + p.jitter * (f - 0.5);
#endif
#endif
    return f;
}
