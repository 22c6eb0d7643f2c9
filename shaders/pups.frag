#version 430
// cellgl: PUPs texture in a fragment shader (viewer). Same buffers and uniforms as
// shaders/pups.comp; pixel (i, j) of the render target is pixel (i, j) of the compute
// output. Thin entry: read the buffers, call shaders/lib/pups.glsl, write.
//
// Output: rgb = value (mode as in pups.comp: CELL_PUPS_MODE 0 interpolated, 1 heaviest
// point, 2 weighted sum), a = label of the heaviest point as a float (-1: none).

#ifndef CELL_PUPS_MODE
#define CELL_PUPS_MODE 0
#endif
#define CELL_PUPS_FETCH 1

layout(std430, binding = 0) readonly buffer PupsCells { uvec4 cells[]; };    // per grid cell
layout(std430, binding = 1) readonly buffer PupsStream { uvec4 records[]; }; // candidates

uniform ivec2 u_size;
uniform vec2 u_origin;
uniform vec2 u_pixel;
uniform int u_tile;
uniform int u_grid_w;
uniform float u_epsilon;

in vec2 v_uv;
layout(location = 0) out vec4 frag_color;

uvec4 cell_pups_fetch(uint k) { return records[k]; }

#include "lib/pups.glsl"

void main()
{
    ivec2 px = min(ivec2(gl_FragCoord.xy), u_size - 1);
    vec2 u = u_origin + vec2(px) * u_pixel;
    int cell = (px.y / u_tile) * u_grid_w + px.x / u_tile;
    CellPupsAcc acc = cell_pups_eval(u, cells[cell], u_epsilon);
#if CELL_PUPS_MODE == 1
    vec4 v = acc.best;
#elif CELL_PUPS_MODE == 2
    vec4 v = acc.sum;
#else
    vec4 v = cell_pups_acc_value(acc);
#endif
    frag_color = vec4(v.rgb, float(acc.label));
}
