#version 330 core
// cellgl fragment entry (the fragment path, cellgl/gl/dispatch.py): the cellular basis at a list
// of samples or on a grid, as shaders/cellular.comp computes it, for OpenGL 3.3 core and up
// without compute shaders. Thin: read the sample's integer cell and float32 fraction, call
// cell_search() (and cell_features()), write the outputs of this draw to render targets.
// Macros: those of cellular.comp (cellgl/basis/gpu.py, defines_for) and
//   CELL_FRAG_WIDTH       width of the render targets: fragment (x, y) is sample y * width + x
//   CELL_FRAG_DECL        the output declarations of this draw (location 0: the exact flag)
//   CELL_FRAG_WRITE       their assignments, from the rows below (cellgl/gl/dispatch.py)
//   CELL_FRAG_GRID_AXES   (grids) the axes up to the last one longer than one sample
// The split of a position into cell and fraction is cellular.comp's, done in float64 on the CPU
// (OpenGL 3.3 has no doubles): the same bits.

#define CELL_JITTER_UNIFORM 1      // jitter is u_jitter (lib/points.glsl picks its cheaper form)
#if !CELL_OUT_F && !CELL_OUT_DELTA && !CELL_OUT_ID && !CELL_OUT_GRAD
#define CELL_FEATURE_PASS 1      // a feature pass (cellgl.basis.passes): no F1..Fn written
#endif
#include "storage.glsl"
#include "lib/features.glsl"

#define CELL_FEATURES (CELL_EDGE || CELL_SMOOTH || CELL_NSPHERE)
#if CELL_FEATURES
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
uint cell_density_image_level(int index) { return cell_storage_word_7(index); }
#endif
#if CELL_ORBIT
uniform float u_orbit_radius;
uniform uint u_orbit_turn;
#endif
#if CELL_ANISO
uniform vec4 u_axis_scale;
#endif
uniform float u_out_scale;     // distances and deltas are multiplied by this

#if CELL_GRID
// Sample i = u_first + fragment index of the grid u_grid (x fastest); axis a's cell and fraction
// of index v at word u_axis_offset[a] + v of the tables (cellgl/gl/dispatch.py).
uniform isampler2D u_in0;      // axis tables: integer cell, float32 fraction (its bits)
uniform uvec4 u_grid;          // samples along x, y, z, w
uniform ivec4 u_axis_offset;
uniform ivec4 u_axis_cell;     // index 0 of each axis's table
uniform vec4 u_axis_frac;
uniform uint u_first;
#else
// Sample i at texel (i mod width, i / width): its integer cell and float32 fraction; in 2D one
// texel holds both (cell.xy, the fraction's bits).
uniform isampler2D u_in0;
#if CELL_DIM > 2
uniform sampler2D u_in1;
#endif
#endif

// The canary's length (2; cellular.comp): one texel the runner binds, never a uniform a
// compiler could fold into the shader and unroll (cellgl/gl/runner.py)
uniform usampler2D u_loop_canary;
#ifndef CELL_LOOP_PROBE
#define CELL_LOOP_PROBE 0
#endif
#if CELL_LOOP_PROBE
// Measurement build (cellgl.basis.gpu.loop_probe), as cellular.comp's: the search's own count
// and what the driver's limiter had left (row_probe, an int output of the runner's).
uniform int u_loop_probe;
#endif

CELL_FRAG_DECL

// As cellular.comp's (CELL_PRECISE: the same rounding in both entries).
#if CELL_OUT_GRAD
vec4 cell_out_grad(vec4 delta, float F)
{
    CELL_PRECISE vec4 g = cell_metric_gradient(delta, F, u_minkowski_p);
#if CELL_ANISO
    g *= u_axis_scale;
#endif
    return g;
}
#endif
#if CELL_OUT_DELTA
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

void main()
{
#if defined(CELL_STUB) && CELL_STUB   // benchmarks/bench_host.py: constants (F, id), no search
    {
        float row_F[CELL_N];
        uint row_id[CELL_N];
        for (int k = 0; k < CELL_N; k++) { row_F[k] = 0.5; row_id[k] = 7u; }
        o_exact = 1u;
        CELL_FRAG_WRITE
        return;
    }
#endif
    ivec2 xy = ivec2(gl_FragCoord.xy);
    ivec4 cell;
    vec4 frac;
#if CELL_GRID
    uint s = u_first + uint(xy.y) * uint(CELL_FRAG_WIDTH) + uint(xy.x);
    uint rest = s / u_grid.x;
#if CELL_FRAG_GRID_AXES <= 2      // the axes past the second are one sample long: no division
    ivec4 idx = ivec4(int(s - rest * u_grid.x), int(rest), 0, 0);
#elif CELL_FRAG_GRID_AXES == 3
    uint r2 = rest / u_grid.y;
    ivec4 idx = ivec4(int(s - rest * u_grid.x), int(rest - r2 * u_grid.y), int(r2), 0);
#else
    uint r2 = rest / u_grid.y;
    ivec4 idx = ivec4(int(s - rest * u_grid.x), int(rest - r2 * u_grid.y), int(r2 % u_grid.z), int(r2 / u_grid.z));
#endif
    cell = u_axis_cell;            // the axes past CELL_DIM (one sample long)
    frac = u_axis_frac;
    for (int a = 0; a < CELL_DIM; a++) {
        ivec2 e = texelFetch(u_in0, CELL_STORAGE_TEXEL(u_axis_offset[a] + idx[a]), 0).rg;
        cell[a] = e.x;
        frac[a] = intBitsToFloat(e.y);
    }
#else
    // CELL_DIM components per texel (a missing alpha reads 1): the rest are 0
#if CELL_DIM == 2
    ivec4 t = texelFetch(u_in0, xy, 0);
    cell = ivec4(t.xy, 0, 0);
    frac = vec4(intBitsToFloat(t.zw), 0.0, 0.0);
#else
    cell = texelFetch(u_in0, xy, 0) * ivec4(greaterThan(ivec4(CELL_DIM), ivec4(0, 1, 2, 3)));
    frac = texelFetch(u_in1, xy, 0) * vec4(greaterThan(ivec4(CELL_DIM), ivec4(0, 1, 2, 3)));
#endif
#endif

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

    // The rows of this sample (cellular.comp's layout): CELL_FRAG_WRITE picks this draw's part.
#if CELL_SMOOTH == 2 && !CELL_EDGE && !CELL_NSPHERE && defined(CELL_FEATURE_PASS)
    CellFeatures x = cell_poly_features(cell, frac, p, u_smoothness);
    bool exact = x.exact;
    int loops = x.loops;
#else
    CellResult r = cell_search(cell, frac, p);
    // Only the rows this pass writes exist (CELL_FRAG_WRITE reads no other), each written whole.
#if CELL_OUT_F
    float row_F[CELL_N];
#endif
#if CELL_OUT_ID
    uint row_id[CELL_N];
#endif
#if CELL_OUT_DELTA
    float row_delta[CELL_N * CELL_DIM];
#endif
#if CELL_OUT_GRAD
    float row_grad[CELL_N * CELL_DIM];
#endif
    for (int k = 0; k < CELL_N; k++) {
#if CELL_OUT_F
        row_F[k] = r.F[k] * u_out_scale;
#endif
#if CELL_OUT_ID
        row_id[k] = r.id[k];
#endif
#if CELL_OUT_DELTA
        vec4 d = cell_out_delta(r.delta[k]);
        for (int c = 0; c < CELL_DIM; c++) {
            row_delta[k * CELL_DIM + c] = d[c];
        }
#endif
#if CELL_OUT_GRAD
        vec4 g = cell_out_grad(r.delta[k], r.F[k]);
        for (int c = 0; c < CELL_DIM; c++) {
            row_grad[k * CELL_DIM + c] = g[c];
        }
#endif
    }
    bool exact = r.exact;
    int loops = r.loops;
#if CELL_FEATURES
    CellFeatures x = cell_features(cell, frac, p, r, u_smoothness);
    exact = x.exact;
    loops = x.loops;
#endif
#endif
#if CELL_FEATURES
    float row_features[CELL_FEATURE_STRIDE];
    for (int k = 0; k < CELL_FEATURE_STRIDE; k++) {
        row_features[k] = 0.0;
    }
#if CELL_FO_EDGE >= 0
    row_features[CELL_FO_EDGE] = x.edge * u_out_scale;
#endif
#if CELL_FO_NSPHERE >= 0
    row_features[CELL_FO_NSPHERE] = x.nsphere * u_out_scale;
#endif
#if CELL_FO_SMOOTH_F >= 0
    row_features[CELL_FO_SMOOTH_F] = x.smooth_F * u_out_scale;
#endif
    for (int a = 0; a < 4; a++) {
#if CELL_FO_EDGE_GRAD >= 0
        row_features[CELL_FO_EDGE_GRAD + a] = x.edge_grad[a];
#endif
#if CELL_FO_SMOOTH_DELTA >= 0
        row_features[CELL_FO_SMOOTH_DELTA + a] = x.smooth_delta[a] * u_out_scale;
#endif
#if CELL_FO_SMOOTH_GRAD >= 0
        row_features[CELL_FO_SMOOTH_GRAD + a] = x.smooth_grad[a];
#endif
#if CELL_FO_SMOOTH_ATTR >= 0
        row_features[CELL_FO_SMOOTH_ATTR + a] = x.smooth_attr[a];
#endif
    }
#endif
    int canary = 0;
    int canary_passes = int(texelFetch(u_loop_canary, ivec2(0, 0), 0).r);
    for (int k = 0; k < canary_passes; k++) {
        canary += 1;
    }
    exact = exact && canary == canary_passes;
#if CELL_FEATURES && CELL_FO_WALKS >= 0
    // CELL_WALKS_APART: which of the search and the walks were exact, and 16: the
    // canary ran whole (0..31, exact in a float; cellgl/basis/passes.py)
    row_features[CELL_FO_WALKS] = float(x.walks | (canary == canary_passes ? 16 : 0));
#endif
    o_exact = exact ? 1u : 0u;
#if CELL_LOOP_PROBE
    int left = 0;
    for (int k = 0; k < u_loop_probe; k++) {
        left += 1;
    }
    int row_probe[2] = int[2](loops, left);
#endif
    CELL_FRAG_WRITE
}
