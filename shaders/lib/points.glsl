// cellgl: where the feature points are.
//
// Space is diced into integer cells. Each cell hashes (with the seed) to a
// 32-bit word h. h picks the number of points in the cell; point k (k = 1, 2,
// ...) takes its position and ID from an avalanche of h + k * 0x9e3779b9 (the
// jitter distribution's single point from h itself); worley1996 runs the
// book's LCG instead.
// CELL_DIST selects the distribution at compile time (cellgl.basis.enums.Distribution).
//
// Requires: hash.glsl. Macros: CELL_DIM (2..4), CELL_DIST,
// CELL_MAX_POINTS (the size of the threshold table, >= max_points),
// CELL_DENSITY_MAP (CELL_DMAP_NONE, _RAMP, _RADIAL, _IMAGE: spatially varying
// density, poisson only; cellgl/basis/density.py), CELL_ORBIT (1: loopable
// animation, the points orbit inside their cells; cell_orbit), CELL_ANISO (1:
// anisotropic distance, CellParams.axis_scale: stretched cells; cellular.glsl),
// CELL_JITTER_UNIFORM (1: jitter is a uniform; cell_next_point), CELL_COUNT_CONST
// (1: CELL_MIN_POINTS, CELL_MAX_COUNT constant; cell_point_count), CELL_PERIODIC
// (1: a tileable texture; cell_wrap), CELL_PRECISE (the entry's prelude, cellgl/gl/glsl.py:
// `precise` where the compiler has it, else empty).

#include "hash.glsl"

// CELL_PRECISE: `precise` where the compiler has it (cellgl/gl/glsl.py); a point's position is
// rounded as written, the same in every entry (lib/metric.glsl, docs/exactness.md).
#ifndef CELL_PRECISE
#define CELL_PRECISE
#endif

#ifndef CELL_DENSITY_MAP
#define CELL_DENSITY_MAP 0
#endif
#ifndef CELL_ORBIT
#define CELL_ORBIT 0
#endif
#ifndef CELL_ANISO
#define CELL_ANISO 0
#endif
#ifndef CELL_COUNT_CONST
// 1: CELL_MIN_POINTS and CELL_MAX_COUNT are min_points and max_points as
// constants (cellgl/basis/gpu.py), so the count's loop runs over only the
// thresholds that can count (the same count, fewer compares per cell).
#define CELL_COUNT_CONST 0
#endif
#ifndef CELL_JITTER_UNIFORM
// 1: jitter is a run-time value (a uniform), not a constant the compiler folds
// (cell_next_point picks the cheaper form; both give the same bits).
#define CELL_JITTER_UNIFORM 0
#endif
#define CELL_DENSITY_LEVELS 16

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
#if CELL_DENSITY_MAP != CELL_DMAP_NONE
    // Spatially varying density: row L of this table is the Poisson table of
    // density level L (cellgl/basis/density.py), picked per cell by cell_density_level().
    uint density_thresholds[CELL_DENSITY_LEVELS * CELL_MAX_POINTS];
    ivec4 density_axis[4];  // per lattice axis: (o, n, m, b), see cell_density_level
    ivec4 density_info;     // (shift, image width, image height, 0)
#endif
#if CELL_ORBIT
    float orbit_radius;     // radius of each point's circle, in cells, [0, 0.5]
    uint orbit_turn;        // animation time as a fraction of the loop, times 2^32 (wraps)
#endif
#if CELL_ANISO
    vec4 axis_scale;        // weight of each axis in the distance (1 past CELL_DIM)
#endif
};

#if CELL_DENSITY_MAP == CELL_DMAP_IMAGE
// Provided by the entry point (a storage buffer): the density level (0..15)
// of texel `index` = row * width + column of the density image.
uint cell_density_image_level(int index);
#endif

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
// Exact for every int32 cell: the float32 quotient c / m is off by up to
// |c| 2^-23 + 1 (float(c) itself rounds once |c| > 2^24), so one reduction
// r = c - m floor(c / m) leaves |r| <= 2^8 + 2m for |c| < 2^31; a second
// reduction of that small r has a quotient off by at most 1, which the two
// fix-ups absorb. (One reduction alone gave wrong cells past |c| ~ 10^8.)
ivec4 _cell_wrap_step(ivec4 c, ivec4 m)
{
    return c - m * ivec4(floor(vec4(c) / vec4(m)));
}

ivec4 cell_wrap(ivec4 c, ivec4 period)
{
#if CELL_PERIODIC
    ivec4 m = max(period, ivec4(1));
    ivec4 w = _cell_wrap_step(_cell_wrap_step(c, m), m);
    w += m * ivec4(lessThan(w, ivec4(0)));
    w -= m * ivec4(greaterThanEqual(w, m));
    bvec4 on = greaterThan(period, ivec4(0));
    return ivec4(on.x ? w.x : c.x, on.y ? w.y : c.y, on.z ? w.z : c.z, on.w ? w.w : c.w);
#else
    return c;
#endif
}

#if CELL_DIST == CELL_DIST_BLENDER
// Compiled only for distribution "blender" (other recipes' shader text is unchanged).
// Bob Jenkins' lookup3 hash of 1..4 uint32 words, as Blender's Voronoi node
// hashes the float bits of a cell's coordinates (distribution "blender";
// cellgl/basis/population.py jenkins_hash is the NumPy twin). A rotation, the
// three-word final mix, and the mix that absorbs the first three of four words.
uint _cell_rot(uint x, int k)
{
    return (x << uint(k)) | (x >> uint(32 - k));
}

uint _cell_jenkins_final(uint a, uint b, uint c)
{
    c ^= b; c -= _cell_rot(b, 14);
    a ^= c; a -= _cell_rot(c, 11);
    b ^= a; b -= _cell_rot(a, 25);
    c ^= b; c -= _cell_rot(b, 16);
    a ^= c; a -= _cell_rot(c, 4);
    b ^= a; b -= _cell_rot(a, 14);
    c ^= b; c -= _cell_rot(b, 24);
    return c;
}

uint cell_jenkins1(uint x)
{
    uint s = 0xdeadbeefu + 17u;          // seed: 0xdeadbeef + 4 n + 13, n words
    return _cell_jenkins_final(s + x, s, s);
}

uint cell_jenkins2(uint x, uint y)
{
    uint s = 0xdeadbeefu + 21u;
    return _cell_jenkins_final(s + x, s + y, s);
}

uint cell_jenkins3(uint x, uint y, uint z)
{
    uint s = 0xdeadbeefu + 25u;
    return _cell_jenkins_final(s + x, s + y, s + z);
}

uint cell_jenkins4(uint x, uint y, uint z, uint w)
{
    uint s = 0xdeadbeefu + 29u;
    uint a = s + x;
    uint b = s + y;
    uint c = s + z;
    a -= c; a ^= _cell_rot(c, 4);  c += b;
    b -= a; b ^= _cell_rot(a, 6);  a += c;
    c -= b; c ^= _cell_rot(b, 8);  b += a;
    a -= c; a ^= _cell_rot(c, 16); c += b;
    b -= a; b ^= _cell_rot(a, 19); a += c;
    c -= b; c ^= _cell_rot(b, 4);  b += a;
    return _cell_jenkins_final(a + w, b, c);
}

// A uint32 hash as Blender's float in [0, 1]: float(h) rounded to float32, / 2^32.
float cell_unit_float(uint h)
{
    return float(h) * (1.0 / 4294967296.0);
}

// Blender's Voronoi node: the float bits of an integer cell's coordinates.
uvec4 _cell_blender_words(ivec4 c)
{
    return floatBitsToUint(vec4(c));
}

// Blender's point in cell c before Randomness, each coordinate in [0, 1]
// (CELL_DIM coordinates; x from the hash of the coordinates, the others from
// the coordinates with 1.0 or 2.0 appended, or rotated in 4D).
vec4 cell_blender_point(ivec4 c)
{
    uvec4 k = _cell_blender_words(c);
    const uint one = 0x3f800000u;     // float bits of 1.0
    const uint two = 0x40000000u;     // and of 2.0
#if CELL_DIM == 2
    return vec4(cell_unit_float(cell_jenkins2(k.x, k.y)), cell_unit_float(cell_jenkins3(k.x, k.y, one)),
                0.0, 0.0);
#elif CELL_DIM == 3
    return vec4(cell_unit_float(cell_jenkins3(k.x, k.y, k.z)),
                cell_unit_float(cell_jenkins4(k.x, k.y, k.z, one)),
                cell_unit_float(cell_jenkins4(k.x, k.y, k.z, two)), 0.0);
#else
    return vec4(cell_unit_float(cell_jenkins4(k.x, k.y, k.z, k.w)),
                cell_unit_float(cell_jenkins4(k.w, k.x, k.y, k.z)),
                cell_unit_float(cell_jenkins4(k.z, k.w, k.x, k.y)),
                cell_unit_float(cell_jenkins4(k.y, k.z, k.w, k.x)));
#endif
}

// Blender's colour of cell c (the node's Color output for a point in it).
vec3 cell_blender_color(ivec4 c)
{
    uvec4 k = _cell_blender_words(c);
    const uint one = 0x3f800000u;
    const uint two = 0x40000000u;
#if CELL_DIM == 2
    return vec3(cell_unit_float(cell_jenkins2(k.x, k.y)), cell_unit_float(cell_jenkins3(k.x, k.y, one)),
                cell_unit_float(cell_jenkins3(k.x, k.y, two)));
#elif CELL_DIM == 3
    return vec3(cell_unit_float(cell_jenkins3(k.x, k.y, k.z)),
                cell_unit_float(cell_jenkins4(k.x, k.y, k.z, one)),
                cell_unit_float(cell_jenkins4(k.x, k.y, k.z, two)));
#else
    return vec3(cell_unit_float(cell_jenkins4(k.x, k.y, k.z, k.w)),
                cell_unit_float(cell_jenkins4(k.z, k.x, k.w, k.y)),
                cell_unit_float(cell_jenkins4(k.w, k.z, k.y, k.x)));
#endif
}

// The cell's point ID: the first hash of its coordinates (cell_blender_point's x).
uint cell_cell_seed(ivec4 c, uint seed)
{
    uvec4 k = _cell_blender_words(c);
#if CELL_DIM == 2
    return cell_jenkins2(k.x, k.y);
#elif CELL_DIM == 3
    return cell_jenkins3(k.x, k.y, k.z);
#else
    return cell_jenkins4(k.x, k.y, k.z, k.w);
#endif
}
#elif CELL_DIST == CELL_DIST_WORLEY1996
// The book's cube seed: 702395077 x + 915488749 y + 2120969693 z (mod 2^32),
// plus the cellgl seed times an odd constant (0 leaves the original untouched).
uint cell_cell_seed(ivec4 c, uint seed)
{
    return 702395077u * uint(c.x) + 915488749u * uint(c.y) + 2120969693u * uint(c.z)
         + seed * 2654435769u;
}
#else
// Hash an integer cell and the seed to the cell's 32-bit random word h (the start
// of its stream):
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
#elif CELL_DIST == CELL_DIST_JITTER || CELL_DIST == CELL_DIST_BLENDER
    return 1;
#else
    // count = min_points + #{k in [min_points, max_points) : u >= thresholds[k]},
    // u = the cell's hash. A fixed-length loop with constant indices once
    // unrolled, so the table stays in registers.
    uint u = state;
#if CELL_COUNT_CONST
    // min_points and max_points known at compile time: only the compares that count.
    int count = CELL_MIN_POINTS;
    for (int k = CELL_MIN_POINTS; k < CELL_MAX_COUNT; k++) {
        count += u >= p.thresholds[k] ? 1 : 0;
    }
#else
    int count = p.min_points;
    for (int k = 0; k < CELL_MAX_POINTS; k++) {
        count += (k >= p.min_points && k < p.max_points && u >= p.thresholds[k]) ? 1 : 0;
    }
#endif
    return count;
#endif
}

#if CELL_DENSITY_MAP != CELL_DMAP_NONE
// The density level (0..15) of an integer (wrapped) cell, from its centre, in
// integers only so that every GPU and the NumPy reference agree on every cell.
// Per axis a fixed-point affine term of the cell centre (2t + 1) / 2:
//   e_a = ((2 clamp(c_a - o_a, 0, n_a) + 1) m_a + b_a) >> shift
// (>> of a signed int is a floor; every value stays below 2^30).
int cell_density_level(ivec4 c, CellParams p)
{
    int shift = p.density_info.x;
    ivec4 e = ivec4(0);
    for (int a = 0; a < CELL_DIM; a++) {
        ivec4 q = p.density_axis[a];
        int t = clamp(c[a] - q.x, 0, q.y);
        e[a] = ((2 * t + 1) * q.z + q.w) >> shift;
    }
#if CELL_DENSITY_MAP == CELL_DMAP_RAMP
    // e in levels: 15 v + 0.5 along the ramp axis (0 on the others).
    return clamp(e.x + e.y + e.z + e.w, 0, CELL_DENSITY_LEVELS - 1);
#elif CELL_DENSITY_MAP == CELL_DMAP_RADIAL
    // e in units of radius / 15360: level k where d >= (2k - 1) / 30 radius.
    e = clamp(e, ivec4(-15361), ivec4(15361));
    int d2 = e.x * e.x + e.y * e.y + e.z * e.z + e.w * e.w;
    int level = 0;
    for (int k = 1; k < CELL_DENSITY_LEVELS; k++) {
        int r = (2 * k - 1) * 512;
        level += d2 >= r * r ? 1 : 0;
    }
    return level;
#else
    // e.x, e.y: the texel column and row of the cell centre, clamped to the edge.
    int tx = clamp(e.x, 0, p.density_info.y - 1);
    int ty = clamp(e.y, 0, p.density_info.z - 1);
    return int(cell_density_image_level(ty * p.density_info.y + tx));
#endif
}
#endif

// The fewest points a cell can hold (the count's lower bound).
int cell_min_count(CellParams p)
{
#if CELL_DIST == CELL_DIST_WORLEY1996
    return 0;
#elif CELL_DIST == CELL_DIST_JITTER || CELL_DIST == CELL_DIST_BLENDER
    return 1;
#else
    return p.min_points;
#endif
}

// cell_point_count for the cell `cell` (wrapped): with a density map the count
// is drawn from the cell's own row of the threshold table.
int cell_point_count_at(inout uint state, ivec4 cell, CellParams p)
{
#if CELL_DENSITY_MAP != CELL_DMAP_NONE && CELL_DIST == CELL_DIST_POISSON
    uint u = state;
    int row = cell_density_level(cell, p) * CELL_MAX_POINTS;
    int count = p.min_points;
    for (int k = 0; k < CELL_MAX_POINTS; k++) {
        count += (k >= p.min_points && k < p.max_points && u >= p.density_thresholds[row + k]) ? 1 : 0;
    }
    return count;
#else
    return cell_point_count(state, p);
#endif
}

#if CELL_ORBIT
// Loopable animation: the point at f (in [0, 1]^d of its cell) circles in the
// xy plane, once per loop, around f pulled towards the cell centre by the
// radius r (so the whole circle stays inside the cell and the exact search's
// bounds hold):
//     c = 0.5 + (1 - 2 r) (f - 0.5),   f' = c + r (cos a, sin a),
//     a = 2 pi ((phase + s turn) mod 2^32) / 2^32,
// phase and the direction s = +-1 from a hash of the point's ID. The angle is
// integer arithmetic until the last step, so turn and turn + 2^32 (the next
// loop) give the same bits.
vec4 cell_orbit(vec4 f, uint id, CellParams p)
{
    uint h = cell_hash_u32(id ^ 0x3c6ef372u);
    uint turn = (h & 1u) != 0u ? p.orbit_turn : 0u - p.orbit_turn;
    CELL_PRECISE float a = float((h + turn) >> 8) * (6.283185307179586 / 16777216.0);
    float r = p.orbit_radius;
    CELL_PRECISE vec4 g = f;
    g.x = 0.5 + (1.0 - 2.0 * r) * (f.x - 0.5) + r * cos(a);
    g.y = 0.5 + (1.0 - 2.0 * r) * (f.y - 0.5) + r * sin(a);
    return g;
}
#endif

// The next feature point of the stream of (wrapped) cell c: its ID, and its
// position relative to the cell's lower corner, each coordinate in [0, 1].
vec4 cell_next_point(inout uint state, ivec4 c, CellParams p, out uint id)
{
    CELL_PRECISE vec4 f = vec4(0.0);
#if CELL_DIST == CELL_DIST_BLENDER
    // Blender: the hash times Randomness (p.jitter), a float32 product as in the node.
    id = state;
    f = cell_blender_point(c) * p.jitter;
#elif CELL_DIST == CELL_DIST_WORLEY1996
    id = state;
    state = 1402024253u * state + 586950981u;
    f.x = (float(state) + 0.5) * (1.0 / 4294967296.0);
    state = 1402024253u * state + 586950981u;
    f.y = (float(state) + 0.5) * (1.0 / 4294967296.0);
    state = 1402024253u * state + 586950981u;
    f.z = (float(state) + 0.5) * (1.0 / 4294967296.0);
    state = 1402024253u * state + 586950981u;
#else
#if CELL_DIST == CELL_DIST_JITTER
    // One point: the cell's hash itself is its random word.
    uint u = state;
#else
    // Point k of the cell: an avalanche of the Weyl sequence h + k 0x9e3779b9
    // (independent of the count, which used h itself).
    state += 0x9e3779b9u;
    uint u = cell_hash_u32(state);
#endif
    // x and y from the two halves of u; z and w from a second word derived from
    // u; the ID from a third (computed only when a caller uses it).
    id = cell_hash_u32(u ^ 0x5bd1e995u);
#if CELL_DIM >= 3
    uint v = (u ^ (u >> 15)) * 0x2c1b3c6du;
    v ^= v >> 12;
#endif
#if CELL_DIST == CELL_DIST_JITTER && CELL_JITTER_UNIFORM
    // 0.5 + jitter (cell_u16(k) - 0.5) for the 16-bit values k (-0.5 on unused
    // axes), the same bits in two operations fewer per axis while jitter is a
    // run-time value: cell_u16(k) - 0.5 is (k - 32767.5) / 65536 exactly, and
    // a power-of-two scale commutes with rounding.
    vec4 k = vec4(float(int(u >> 16)), float(int(u & 0xffffu)), -0.5, -0.5);
#if CELL_DIM >= 3
    k.z = float(int(v >> 16));
    k.w = float(int(v & 0xffffu));
#endif
    f = 0.5 + (p.jitter * (1.0 / 65536.0)) * (k - 32767.5);
#else
    f.x = cell_u16(u >> 16);
    f.y = cell_u16(u & 0xffffu);
#if CELL_DIM >= 3
    f.z = cell_u16(v >> 16);
#endif
#if CELL_DIM >= 4
    f.w = cell_u16(v & 0xffffu);
#endif
#if CELL_DIST == CELL_DIST_JITTER
    // (A constant jitter of 1 may fold away: 0.5 + (x - 0.5) is x exactly here.)
    f = 0.5 + p.jitter * (f - 0.5);
#endif
#endif
#endif
#if CELL_ORBIT
    f = cell_orbit(f, id, p);
#endif
    return f;
}
