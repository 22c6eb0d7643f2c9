#version 430
// cellgl compute entry: the cellular basis at a list of samples or on a grid.
// Thin: read the sample, call cell_search(), write what was asked for.
// Macros (from cellgl/basis/gpu.py): CELL_DIM, CELL_N, CELL_METRIC, CELL_DIST,
// CELL_MAX_POINTS, CELL_MAX_RING, CELL_GRID, CELL_OUT_F, CELL_OUT_DELTA,
// CELL_OUT_ID, CELL_OUT_GRAD, CELL_LOCAL_SIZE, CELL_SAMPLE_ROW_BITS, CELL_DENSITY_MAP, CELL_ORBIT,
// CELL_ANISO, and those of lib/features.glsl (CELL_EDGE, CELL_SMOOTH, CELL_NSPHERE,
// CELL_FEATURE_MAX_RING); CELL_LOOP_BUDGET (lib/cellular.glsl), CELL_LOOP_PROBE
// (1: measure the loop budget, see below); CELL_SHARED_CELLS (grids: rings 0 and 1 from the
// workgroup's cell cache below, lib/walk.glsl), CELL_CACHE_NX (its cells along x, at most).

layout(local_size_x = CELL_LOCAL_SIZE) in;

#define CELL_JITTER_UNIFORM 1      // jitter is u_jitter (lib/points.glsl picks its cheaper form)
#if !CELL_OUT_F && !CELL_OUT_DELTA && !CELL_OUT_ID && !CELL_OUT_GRAD
#define CELL_FEATURE_PASS 1      // a feature pass (cellgl.basis.passes): no F1..Fn written
#endif
#include "lib/features.glsl"

#define CELL_FEATURES (CELL_EDGE || CELL_SMOOTH || CELL_NSPHERE)
#if CELL_FEATURES
// Per sample CELL_FEATURE_STRIDE floats (cellgl/basis/features.py, layout() and
// unpack()): only the fields the pass was asked for, each at its column
// CELL_FO_<FIELD> (-1: not written): edge, edge gradient (4), n-sphere radius,
// smooth F1, smooth delta (4), smooth gradient (4), smooth attribute (colour, value).
#ifndef CELL_FEATURE_STRIDE
#define CELL_FEATURE_STRIDE 20
#define CELL_FO_EDGE 0
#define CELL_FO_EDGE_GRAD 4
#define CELL_FO_NSPHERE 1
#define CELL_FO_SMOOTH_F 2
#define CELL_FO_SMOOTH_DELTA 8
#define CELL_FO_SMOOTH_GRAD 12
#define CELL_FO_SMOOTH_ATTR 16
#define CELL_FO_WALKS -1
#endif
uniform float u_smoothness;    // k of smooth F1, lattice units
layout(std430, binding = 1) writeonly buffer OutFeatures { float out_features[]; };
#endif

uniform uint u_seed;
uniform float u_jitter;
uniform int u_min_points;
uniform int u_max_points;
uniform uint u_thresholds[CELL_MAX_POINTS];
uniform ivec4 u_period;
uniform float u_minkowski_p;
#if CELL_DENSITY_MAP != CELL_DMAP_NONE
uniform uint u_density_thresholds[CELL_DENSITY_LEVELS * CELL_MAX_POINTS];
uniform ivec4 u_density_axis[4];
uniform ivec4 u_density_info;
#endif
#if CELL_DENSITY_MAP == CELL_DMAP_IMAGE
layout(std430, binding = 7) readonly buffer DensityImage { uint density_image[]; };
uint cell_density_image_level(int index) { return density_image[index]; }
#endif
#if CELL_ORBIT
uniform float u_orbit_radius;
uniform uint u_orbit_turn;
#endif
#if CELL_ANISO
uniform vec4 u_axis_scale;
#endif
uniform float u_out_scale;     // distances and deltas are multiplied by this
uniform uint u_count;          // number of samples in this chunk

#if CELL_GRID
// The grid is dispatched in slabs: invocation (x, y, z) of a slab is grid
// sample (x, u_slab.y + y, u_slab.z + z, u_slab.w); no integer division.
// Sample positions are computed in double precision and then split into an integer cell and a
// float32 fraction, as the point path does: a sample 10^6 cells from the grid origin is as exact
// as one at it.
uniform ivec4 u_origin_cell;   // grid origin, split into cell + fraction
uniform dvec4 u_origin_frac;
uniform dvec4 u_spacing;
uniform ivec4 u_slab;          // first sample of this slab
uniform ivec2 u_slab_size;     // samples along x, rows (y) per slab

// Grid sample idx: its integer cell and float32 fraction. CELL_PRECISE: a multiply, then an add,
// each rounded once (no fused multiply-add, which a GPU's float64 unit does whenever it may), as
// the fragment path's NumPy computes them (cellgl/basis/gpu_fragment.py): the same bits.
// cellgl.basis.core checks that the grid lies within +-2^30 cells, so int(fl) is in range.
void cell_grid_sample(ivec4 idx, out ivec4 cell, out vec4 frac)
{
    CELL_PRECISE dvec4 pos = u_origin_frac + u_spacing * dvec4(idx);
    dvec4 fl = floor(pos);
    cell = u_origin_cell + ivec4(fl);
    CELL_PRECISE dvec4 rest = pos - fl;
    frac = vec4(rest);
    // A fraction just below 1 can round up to 1.0 in float32.
    for (int a = 0; a < 4; a++) {
        if (frac[a] >= 1.0) {
            cell[a] += 1;
            frac[a] = 0.0;
        }
    }
}
#else
uniform double u_scale;        // positions are multiplied by this first
// Sample positions, float64, tightly packed (CELL_DIM values per sample), as the 32-bit words
// of an RGBA32UI texture 2^CELL_SAMPLE_ROW_BITS texels wide (cellgl/basis/gpu.py,
// upload_samples): CELL_DIM / 2 texels per sample. llvmpipe fetches a texel for every lane of a
// SIMD vector at once, where it loads a storage buffer lane by lane (docs/performance.md).
// They are split into an integer cell and a float32 fraction in double
// precision, so a sample 10^6 cells from the origin is as exact as one at it.
uniform usampler2D u_samples;
uvec4 cell_sample_texel(uint k)
{
    return texelFetch(u_samples, ivec2(k & ((1u << CELL_SAMPLE_ROW_BITS) - 1u), k >> CELL_SAMPLE_ROW_BITS), 0);
}
#endif

// Each sample's outputs are one contiguous row (F and id: CELL_N values, delta and grad: CELL_N
// vectors of CELL_DIM floats), stored as vectors of 2 or 4 where the row's layout allows:
// llvmpipe stores to a storage buffer lane by lane, one loop per store whatever its width.
#if CELL_N % 4 == 0
#define CELL_N_VEC 4
#define CELL_N_VEC_T vec4
#define CELL_N_UVEC_T uvec4
#define CELL_N_ROW(T, a, j) T(a[4 * (j)], a[4 * (j) + 1], a[4 * (j) + 2], a[4 * (j) + 3])
layout(std430, binding = 2) writeonly buffer OutF { vec4 out_F[]; };
layout(std430, binding = 4) writeonly buffer OutId { uvec4 out_id[]; };
#elif CELL_N % 2 == 0
#define CELL_N_VEC 2
#define CELL_N_VEC_T vec2
#define CELL_N_UVEC_T uvec2
#define CELL_N_ROW(T, a, j) T(a[2 * (j)], a[2 * (j) + 1])
layout(std430, binding = 2) writeonly buffer OutF { vec2 out_F[]; };
layout(std430, binding = 4) writeonly buffer OutId { uvec2 out_id[]; };
#else
#define CELL_N_VEC 1
#define CELL_N_VEC_T float
#define CELL_N_UVEC_T uint
#define CELL_N_ROW(T, a, j) a[j]
layout(std430, binding = 2) writeonly buffer OutF { float out_F[]; };
layout(std430, binding = 4) writeonly buffer OutId { uint out_id[]; };
#endif
// CELL_STORE_VECS(buf, v): the row of v(0), ..., v(CELL_N - 1) (vec4s, CELL_DIM components used)
#if CELL_DIM == 4
#define CELL_VEC_T vec4
#define CELL_STORE_VECS(buf, v) \
    for (int k = 0; k < CELL_N; k++) { buf[i * uint(CELL_N) + uint(k)] = v(k); }
#elif CELL_DIM == 2 && CELL_N % 2 == 0
#define CELL_VEC_T vec4
#define CELL_STORE_VECS(buf, v) \
    for (int k = 0; k < CELL_N; k += 2) { buf[i * uint(CELL_N / 2) + uint(k / 2)] = vec4(v(k).xy, v(k + 1).xy); }
#elif CELL_DIM == 2
#define CELL_VEC_T vec2
#define CELL_STORE_VECS(buf, v) \
    for (int k = 0; k < CELL_N; k++) { buf[i * uint(CELL_N) + uint(k)] = v(k).xy; }
#elif CELL_N % 2 == 0
#define CELL_VEC_T vec2
#define CELL_STORE_VECS(buf, v) \
    for (int k = 0; k < CELL_N; k += 2) { \
        vec4 a_ = v(k), b_ = v(k + 1); \
        uint o_ = i * uint(3 * CELL_N / 2) + uint(3 * k / 2); \
        buf[o_] = a_.xy; buf[o_ + 1u] = vec2(a_.z, b_.x); buf[o_ + 2u] = b_.yz; \
    }
#else
#define CELL_VEC_T float
#define CELL_STORE_VECS(buf, v) \
    for (int k = 0; k < CELL_N; k++) { \
        vec4 a_ = v(k); \
        for (int c_ = 0; c_ < 3; c_++) { buf[(i * uint(CELL_N) + uint(k)) * 3u + uint(c_)] = a_[c_]; } \
    }
#endif
layout(std430, binding = 3) writeonly buffer OutDelta { CELL_VEC_T out_delta[]; };
layout(std430, binding = 5) writeonly buffer OutGrad { CELL_VEC_T out_grad[]; };

// The flag: how many samples were flagged, the canary's length (below; written by the
// runner, cellgl/gl/runner.py), then their indices.
layout(std430, binding = 6) buffer Inexact { uint inexact_count; uint loop_canary; uint inexact_index[]; };

// The driver's own loop limit (docs/exactness.md). llvmpipe (and lavapipe, under
// zink) counts the loop passes of a whole SIMD vector of invocations against one
// limiter; once it is spent, every loop still to come runs exactly one pass. This
// loop of loop_canary (= 2) passes therefore runs twice unless the limiter ran out
// somewhere in the invocation: then the sample is flagged, whatever the search's
// own count said. Its length is read from storage, never a constant or a uniform: a
// compiler that folds uniforms into the shader (zink does) would unroll it, and an
// unrolled loop never meets the limiter.
#ifndef CELL_LOOP_PROBE
#define CELL_LOOP_PROBE 0
#endif
#if CELL_LOOP_PROBE
// Measurement build (cellgl.basis.gpu.loop_probe): per sample the search's own count
// and what the driver's limiter had left: a loop of u_loop_probe passes (far
// more than any limiter) runs until the limiter stops it.
uniform int u_loop_probe;
layout(std430, binding = 8) writeonly buffer LoopProbe { int loop_probe[]; };
#endif

#if CELL_OUT_GRAD
vec4 cell_out_grad(vec4 delta, float F)
{
    CELL_PRECISE vec4 g = cell_metric_gradient(delta, F, u_minkowski_p);
#if CELL_ANISO
    g *= u_axis_scale;     // d|w (q - x)|/dx = w * (the gradient in weighted units)
#endif
    return g;
}
#endif
#if CELL_OUT_DELTA
// A delta as stored: in sample units (stretched cells: divided by the axis weights), scaled.
vec4 cell_out_delta(vec4 delta)
{
#if CELL_ANISO
    CELL_PRECISE vec4 d = delta / u_axis_scale * u_out_scale;
#else
    CELL_PRECISE vec4 d = delta * u_out_scale;
#endif
    return d;
}
#endif

// The basis parameters, from the uniforms.
CellParams cell_load_params()
{
    CellParams p;
    p.seed = u_seed;
    p.jitter = u_jitter;
    p.min_points = u_min_points;
    p.max_points = u_max_points;
    for (int k = 0; k < CELL_MAX_POINTS; k++) {
        p.thresholds[k] = u_thresholds[k];
    }
    p.period = u_period;
    p.minkowski_p = u_minkowski_p;
#if CELL_DENSITY_MAP != CELL_DMAP_NONE
    for (int k = 0; k < CELL_DENSITY_LEVELS * CELL_MAX_POINTS; k++) {
        p.density_thresholds[k] = u_density_thresholds[k];
    }
    for (int a = 0; a < 4; a++) {
        p.density_axis[a] = u_density_axis[a];
    }
    p.density_info = u_density_info;
#endif
#if CELL_ORBIT
    p.orbit_radius = u_orbit_radius;
    p.orbit_turn = u_orbit_turn;
#endif
#if CELL_ANISO
    p.axis_scale = u_axis_scale;
#endif
    return p;
}

#if CELL_GRID && CELL_SHARED_CELLS
// The workgroup's cell cache (lib/walk.glsl, "A second cell source"). The CELL_LOCAL_SIZE
// invocations of a workgroup are consecutive samples of one grid row: their cells differ only
// along x, from the first sample's to the last's. The cache holds the cells of rings 0 and 1
// around all of them: x from the first's - 1 to the last's + 1 (at most CELL_CACHE_NX), 3 on
// each other axis, at slot ((x * 3 + y) * 3 + z) * 3 + w (the axes of the dimension, each
// from the block's low corner), up to CELL_CACHE_POINTS points a slot: the count, then the
// positions and IDs in the hash's order (structure of arrays).
#if CELL_DIST == CELL_DIST_JITTER || CELL_DIST == CELL_DIST_BLENDER
#define CELL_CACHE_POINTS 1
#elif CELL_COUNT_CONST && CELL_DIST == CELL_DIST_POISSON && CELL_DENSITY_MAP == CELL_DMAP_NONE
#define CELL_CACHE_POINTS CELL_MAX_COUNT
#else
#define CELL_CACHE_POINTS CELL_MAX_POINTS
#endif
#define CELL_CACHE_ROW (CELL_DIM == 2 ? 3 : (CELL_DIM == 3 ? 9 : 27))   // slots per x
#define CELL_CACHE_CELLS (CELL_CACHE_NX * CELL_CACHE_ROW)
shared int s_cell_count[CELL_CACHE_CELLS];
shared vec4 s_cell_q[CELL_CACHE_CELLS * CELL_CACHE_POINTS];
shared uint s_cell_id[CELL_CACHE_CELLS * CELL_CACHE_POINTS];
// The block's low corner and whether it fits (the same for the whole workgroup: from the
// uniforms and the workgroup's ID alone).
ivec4 cell_cache_lo;
bool cell_cache_fits;

bool cell_shared_on()
{
    return cell_cache_fits;
}

int _cell_cache_slot(ivec4 s)
{
#if CELL_DIM == 2
    return s.x * 3 + s.y;
#elif CELL_DIM == 3
    return (s.x * 3 + s.y) * 3 + s.z;
#else
    return ((s.x * 3 + s.y) * 3 + s.z) * 3 + s.w;
#endif
}

int cell_shared_open(ivec4 cell, ivec4 o, out int count)
{
    int slot = _cell_cache_slot(cell + o - cell_cache_lo);
    count = s_cell_count[slot];
    return slot;
}

vec4 cell_shared_point(int slot, int k, out uint id)
{
    id = s_cell_id[slot * CELL_CACHE_POINTS + k];
    return s_cell_q[slot * CELL_CACHE_POINTS + k];
}

// Fill the cache: every invocation hashes every CELL_LOCAL_SIZE-th cell of the block
// (_cell_open, cell_next_point: what the search would do), then the workgroup meets.
void cell_cache_fill(CellParams p)
{
    ivec4 first = ivec4(u_slab.x + int(gl_WorkGroupID.x) * CELL_LOCAL_SIZE, u_slab.y + int(gl_WorkGroupID.y),
                        u_slab.z + int(gl_WorkGroupID.z), u_slab.w);
    ivec4 last = first;
    last.x = min(first.x + CELL_LOCAL_SIZE, u_slab.x + u_slab_size.x) - 1;
    ivec4 c0, c1;
    vec4 f0, f1;
    cell_grid_sample(first, c0, f0);
    cell_grid_sample(last, c1, f1);
    cell_cache_lo = min(c0, c1) - _cell_axes;
    int nx = max(c0.x, c1.x) + 1 - cell_cache_lo.x + 1;
    cell_cache_fits = nx <= CELL_CACHE_NX && all(equal(c0.yzw, c1.yzw));
    if (cell_cache_fits) {
        int cells = nx * CELL_CACHE_ROW;
        for (int t = int(gl_LocalInvocationIndex); t < cells; t += CELL_LOCAL_SIZE) {
            ivec4 o = ivec4(t / CELL_CACHE_ROW, 0, 0, 0);
#if CELL_DIM == 2
            o.y = t % 3;
#elif CELL_DIM == 3
            o.yz = ivec2(t / 3 % 3, t % 3);
#else
            o.yzw = ivec3(t / 9 % 3, t / 3 % 3, t % 3);
#endif
            ivec4 c;
            uint state;
            int count = _cell_open(cell_cache_lo, o, p, c, state);
            s_cell_count[t] = count;
            for (int k = 0; k < count; k++) {
                uint id;
                s_cell_q[t * CELL_CACHE_POINTS + k] = cell_next_point(state, c, p, id);
                s_cell_id[t * CELL_CACHE_POINTS + k] = id;
            }
        }
    }
    memoryBarrierShared();
    barrier();
}
#endif

void main()
{
#if defined(CELL_STUB) && CELL_STUB   // benchmarks/bench_host.py: constants (F, id), no search
#if CELL_GRID
    uint is = (gl_GlobalInvocationID.z * uint(u_slab_size.y) + gl_GlobalInvocationID.y) * uint(u_slab_size.x)
        + gl_GlobalInvocationID.x;
    if (gl_GlobalInvocationID.x >= uint(u_slab_size.x)) return;
#else
    uint is = gl_GlobalInvocationID.x;
    if (is >= u_count) return;
#endif
    for (int j = 0; j < CELL_N / CELL_N_VEC; j++) {
        if (CELL_OUT_F != 0) out_F[is * uint(CELL_N / CELL_N_VEC) + uint(j)] = CELL_N_VEC_T(0.5);
        if (CELL_OUT_ID != 0) out_id[is * uint(CELL_N / CELL_N_VEC) + uint(j)] = CELL_N_UVEC_T(7u);
    }
    return;
#endif
    ivec4 cell;
    vec4 frac;
#if CELL_GRID
#if CELL_SHARED_CELLS
    cell_cache_fill(cell_load_params());      // before any invocation leaves
#endif
    uvec3 g = gl_GlobalInvocationID;
    if (g.x >= uint(u_slab_size.x)) {
        return;
    }
    // Output index within the slab, x fastest.
    uint i = (g.z * uint(u_slab_size.y) + g.y) * uint(u_slab_size.x) + g.x;
    ivec4 idx = ivec4(u_slab.x + int(g.x), u_slab.y + int(g.y), u_slab.z + int(g.z), u_slab.w);
    cell_grid_sample(idx, cell, frac);
#else
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) {
        return;
    }
    dvec4 pos = dvec4(0.0LF);
#if CELL_DIM == 2
    uvec4 t0 = cell_sample_texel(i);
    pos.xy = dvec2(packDouble2x32(t0.xy), packDouble2x32(t0.zw));
#elif CELL_DIM == 3
    // a texel and a half per sample: an odd sample starts in the second half of texel 3i/2
    uint first = (3u * i) >> 1;
    uvec4 t0 = cell_sample_texel(first);
    uvec4 t1 = cell_sample_texel(first + 1u);
    bool odd = (i & 1u) != 0u;
    pos.xyz = dvec3(packDouble2x32(odd ? t0.zw : t0.xy), packDouble2x32(odd ? t1.xy : t0.zw),
                    packDouble2x32(odd ? t1.zw : t1.xy));
#else
    uvec4 t0 = cell_sample_texel(2u * i);
    uvec4 t1 = cell_sample_texel(2u * i + 1u);
    pos = dvec4(packDouble2x32(t0.xy), packDouble2x32(t0.zw), packDouble2x32(t1.xy), packDouble2x32(t1.zw));
#endif
    // Coordinates must lie within +-2^30 cells (cellgl.basis.core.COORD_LIMIT): the library checks
    // them on the CPU before the upload, with its error message (core.cellular). This guard only
    // keeps int(fl) defined whatever arrives (a float-to-int conversion out of range is undefined):
    // a coordinate outside is searched at 0 and its sample flagged. It is not the check: a driver
    // compiling with fast-math semantics need not make a comparison with NaN false.
    bool in_range = true;
    cell = ivec4(0);
    frac = vec4(0.0);
    for (int a = 0; a < CELL_DIM; a++) {
        CELL_PRECISE double x = pos[a] * u_scale;
        bool ok = abs(x) < 1073741824.0LF;
        in_range = in_range && ok;
        x = ok ? x : 0.0LF;
        double fl = floor(x);
        CELL_PRECISE float fr = float(x - fl);     // exact in float64, then rounded once
        // A fraction just below 1 can round up to 1.0 in float32.
        cell[a] = int(fl) + (fr >= 1.0 ? 1 : 0);
        frac[a] = fr >= 1.0 ? 0.0 : fr;
    }
#endif

    CellParams p = cell_load_params();

#if CELL_SMOOTH == 2 && !CELL_EDGE && !CELL_NSPHERE && defined(CELL_FEATURE_PASS)
    // The polynomial smooth F1 pass: a fixed block, no search (features.glsl).
    CellFeatures x = cell_poly_features(cell, frac, p, u_smoothness);
    bool exact = x.exact;
    int loops = x.loops;
#else
    CellResult r = cell_search(cell, frac, p);

#if CELL_OUT_F
    for (int j = 0; j < CELL_N / CELL_N_VEC; j++) {
        out_F[i * uint(CELL_N / CELL_N_VEC) + uint(j)] = CELL_N_ROW(CELL_N_VEC_T, r.F, j) * u_out_scale;
    }
#endif
#if CELL_OUT_ID
    for (int j = 0; j < CELL_N / CELL_N_VEC; j++) {
        out_id[i * uint(CELL_N / CELL_N_VEC) + uint(j)] = CELL_N_ROW(CELL_N_UVEC_T, r.id, j);
    }
#endif
#if CELL_OUT_DELTA
#define CELL_DELTA_OUT(k) cell_out_delta(r.delta[k])
    CELL_STORE_VECS(out_delta, CELL_DELTA_OUT)
#endif
#if CELL_OUT_GRAD
#define CELL_GRAD_OUT(k) cell_out_grad(r.delta[k], r.F[k])
    CELL_STORE_VECS(out_grad, CELL_GRAD_OUT)
#endif
    bool exact = r.exact;
    int loops = r.loops;
#if CELL_FEATURES
    CellFeatures x = cell_features(cell, frac, p, r, u_smoothness);
    exact = x.exact;
    loops = x.loops;
#endif
#endif
#if CELL_FEATURES
    uint b = i * uint(CELL_FEATURE_STRIDE);
#if CELL_FO_EDGE >= 0
    out_features[b + uint(CELL_FO_EDGE)] = x.edge * u_out_scale;
#endif
#if CELL_FO_NSPHERE >= 0
    out_features[b + uint(CELL_FO_NSPHERE)] = x.nsphere * u_out_scale;
#endif
#if CELL_FO_SMOOTH_F >= 0
    out_features[b + uint(CELL_FO_SMOOTH_F)] = x.smooth_F * u_out_scale;
#endif
    for (int a = 0; a < 4; a++) {
#if CELL_FO_EDGE_GRAD >= 0
        out_features[b + uint(CELL_FO_EDGE_GRAD + a)] = x.edge_grad[a];
#endif
#if CELL_FO_SMOOTH_DELTA >= 0
        out_features[b + uint(CELL_FO_SMOOTH_DELTA + a)] = x.smooth_delta[a] * u_out_scale;
#endif
#if CELL_FO_SMOOTH_GRAD >= 0
        out_features[b + uint(CELL_FO_SMOOTH_GRAD + a)] = x.smooth_grad[a];
#endif
#if CELL_FO_SMOOTH_ATTR >= 0
        out_features[b + uint(CELL_FO_SMOOTH_ATTR + a)] = x.smooth_attr[a];
#endif
    }
#endif
    int canary = 0;
    int canary_passes = int(loop_canary);
    for (int k = 0; k < canary_passes; k++) {
        canary += 1;
    }
    exact = exact && canary == canary_passes;
#if CELL_FEATURES && CELL_FO_WALKS >= 0
    // CELL_WALKS_APART: which of the search and the walks were exact, and 16: the
    // canary ran whole (0..31, exact in a float; cellgl/basis/passes.py)
    out_features[b + uint(CELL_FO_WALKS)] = float(x.walks | (canary == canary_passes ? 16 : 0));
#endif
#if !CELL_GRID
    exact = exact && in_range;
#endif
#if CELL_LOOP_PROBE
    int left = 0;
    for (int k = 0; k < u_loop_probe; k++) {
        left += 1;
    }
    loop_probe[2u * i] = loops;
    loop_probe[2u * i + 1u] = left;
#endif
    if (!exact) {
        inexact_index[atomicAdd(inexact_count, 1u)] = i;
    }
}
