#version 430
// cellgl: PUPs texture evaluation over a pixel grid (bake and Python API).
// Thin entry: read the buffers, call shaders/lib/pups.glsl, write.
//
// Defines (set by cellgl/pups/):
//   CELL_PUPS_CHANNELS  1 or 3 floats written per pixel
//   CELL_PUPS_MODE      0: the interpolated value (3); 1: the heaviest point's
//                       value and label; 2: the sum of value * weight
//                       (cellgl.pups.PupsMode)

#ifndef CELL_PUPS_CHANNELS
#define CELL_PUPS_CHANNELS 1
#endif
#ifndef CELL_PUPS_MODE
#define CELL_PUPS_MODE 0
#endif
#define CELL_PUPS_FETCH 1

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = 0) readonly buffer PupsCells { uvec4 cells[]; };    // per grid cell
layout(std430, binding = 1) readonly buffer PupsStream { uvec4 records[]; }; // candidates

layout(std430, binding = 2) writeonly buffer PupsValues { float out_values[]; };
layout(std430, binding = 3) writeonly buffer PupsLabels { int out_labels[]; };

uniform ivec2 u_size;      // image width, height in pixels
uniform vec2 u_origin;     // domain position of the centre of pixel (0, 0)
uniform vec2 u_pixel;      // domain size of one pixel
uniform int u_tile;        // candidate-grid cell size in pixels
uniform int u_grid_w;      // candidate-grid cells per row
uniform float u_epsilon;   // orientation strength, [0, 1)
uniform int u_tile_groups; // work groups per grid-cell side (CELL_PUPS_GROUP_CELLS)
uniform int u_row0;        // first image row of this dispatch (a band of rows: the runner's tile;
                           // a multiple of the grid-cell size with CELL_PUPS_GROUP_CELLS)

uvec4 cell_pups_fetch(uint k) { return records[k]; }

#include "lib/pups.glsl"

void main()
{
    ivec2 px = ivec2(gl_GlobalInvocationID.xy) + ivec2(0, u_row0);
#ifdef CELL_PUPS_GROUP_CELLS
    ivec2 wg = ivec2(gl_WorkGroupID.xy) + ivec2(0, u_row0 / int(gl_WorkGroupSize.y));
    int cell = (wg.y / u_tile_groups) * u_grid_w + wg.x / u_tile_groups;
#else
    ivec2 pc = min(px, u_size - 1);
    int cell = (pc.y / u_tile) * u_grid_w + pc.x / u_tile;
#endif
    vec2 u = u_origin + vec2(px) * u_pixel;
    CellPupsAcc acc = cell_pups_eval(u, cells[cell], u_epsilon);
    if (px.x >= u_size.x || px.y >= u_size.y) {
        return;
    }
    int o = (px.y - u_row0) * u_size.x + px.x;   // the band's own rows
#if CELL_PUPS_MODE == 1
    vec4 v = acc.best;
    out_labels[o] = acc.label;
#elif CELL_PUPS_MODE == 2
    vec4 v = acc.sum;
#else
    vec4 v = cell_pups_acc_value(acc);
#endif
#if CELL_PUPS_CHANNELS == 1
    out_values[o] = v.x;
#else
    out_values[3 * o] = v.x;
    out_values[3 * o + 1] = v.y;
    out_values[3 * o + 2] = v.z;
#endif
}
