#version 430
// cellgl compute entry: the number of feature points (and the density level)
// of a list of integer cells, as the search sees them (tests: GPU vs NumPy).
// Macros: those of cellular.comp (CELL_GRID 0, no outputs), CELL_LOCAL_SIZE.

layout(local_size_x = CELL_LOCAL_SIZE) in;

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
layout(std430, binding = 7) readonly buffer DensityImage { uint density_image[]; };
uint cell_density_image_level(int index) { return density_image[index]; }
#endif
uniform uint u_count;

layout(std430, binding = 0) readonly buffer Cells { ivec4 cells[]; };
layout(std430, binding = 2) writeonly buffer OutCount { ivec2 out_count[]; };   // count, level

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) {
        return;
    }
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
    ivec4 c = cell_wrap(cells[i], p.period);
#if CELL_DENSITY_MAP != CELL_DMAP_NONE
    level = cell_density_level(c, p);
#endif
    uint state = cell_cell_seed(c, p.seed);
    out_count[i] = ivec2(cell_point_count_at(state, c, p), level);
}
