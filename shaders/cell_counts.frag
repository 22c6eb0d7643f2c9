#version 330 core
// cellgl fragment entry (the fragment path, cellgl/gl/dispatch.py): the number of feature points
// (and the density level) of a list of integer cells, as shaders/cell_counts.comp computes it
// (tests: GPU vs NumPy). Cell i is fragment (i mod CELL_FRAG_WIDTH, i / CELL_FRAG_WIDTH) of the
// input texture and of the output. Macros: those of cellular.comp (CELL_GRID 0, no outputs).

#include "storage.glsl"
#include "lib/cellular.glsl"

uniform uint u_seed;
uniform float u_jitter;
uniform int u_min_points;
uniform int u_max_points;
uniform uint u_thresholds[CELL_MAX_POINTS];
uniform ivec4 u_period;
#if CELL_DENSITY_MAP != CELL_DMAP_NONE
uniform uint u_density_thresholds[CELL_DENSITY_LEVELS * CELL_MAX_POINTS];
uniform ivec4 u_density_axis[4];
uniform ivec4 u_density_info;
#endif
#if CELL_DENSITY_MAP == CELL_DMAP_IMAGE
uint cell_density_image_level(int index) { return cell_storage_word_7(index); }
#endif

uniform isampler2D u_in0;      // the cells (RGBA32I)
CELL_FRAG_DECL             // row_count: count, level (cellgl/gl/dispatch.py)

void main()
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
    p.minkowski_p = 2.0;
    // every field set (a struct passed on with a field never written copies an undefined value)
#if CELL_ORBIT
    p.orbit_radius = 0.0;
    p.orbit_turn = 0u;
#endif
#if CELL_ANISO
    p.axis_scale = vec4(1.0);
#endif
    int level = 0;
#if CELL_DENSITY_MAP != CELL_DMAP_NONE
    for (int k = 0; k < CELL_DENSITY_LEVELS * CELL_MAX_POINTS; k++) {
        p.density_thresholds[k] = u_density_thresholds[k];
    }
    for (int a = 0; a < 4; a++) {
        p.density_axis[a] = u_density_axis[a];
    }
    p.density_info = u_density_info;
#endif
    ivec4 c = cell_wrap(texelFetch(u_in0, ivec2(gl_FragCoord.xy), 0), p.period);
#if CELL_DENSITY_MAP != CELL_DMAP_NONE
    level = cell_density_level(c, p);
#endif
    uint state = cell_cell_seed(c, p.seed);
    int row_count[2] = int[2](cell_point_count_at(state, c, p), level);
    CELL_FRAG_WRITE
}
