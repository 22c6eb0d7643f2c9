#version 330 core
// cellgl: PUPs texture in a fragment shader (viewer). Same data and uniforms as
// shaders/pups.comp, its storage buffers as RGBA32UI textures 2^CELL_STORAGE_ROW_BITS texels
// wide (cellgl/gl/dispatch.py); pixel (i, j) of the render target is pixel (i, j) of the compute
// output. Thin entry: read the candidate grid, call shaders/lib/pups.glsl, write.
//
// Output: rgb = value (mode as in pups.comp: CELL_PUPS_MODE 0 interpolated, 1 heaviest
// point, 2 weighted sum), a = label of the heaviest point as a float (-1: none).

#ifndef CELL_PUPS_MODE
#define CELL_PUPS_MODE 0
#endif
#define CELL_PUPS_FETCH 1

uniform usampler2D u_in0;  // the grid cells' headers
uniform usampler2D u_in1;  // the candidate records
#define CELL_PUPS_TEXEL(k) ivec2(int(uint(k) & ((1u << CELL_STORAGE_ROW_BITS) - 1u)), int(uint(k) >> CELL_STORAGE_ROW_BITS))

uniform ivec2 u_size;
uniform vec2 u_origin;
uniform vec2 u_pixel;
uniform int u_tile;
uniform int u_grid_w;
uniform float u_epsilon;

layout(location = 0) out vec4 frag_color;

uvec4 cell_pups_fetch(uint k) { return texelFetch(u_in1, CELL_PUPS_TEXEL(k), 0); }

#include "lib/pups.glsl"

void main()
{
    ivec2 px = min(ivec2(gl_FragCoord.xy), u_size - 1);
    vec2 u = u_origin + vec2(px) * u_pixel;
    int cell = (px.y / u_tile) * u_grid_w + px.x / u_tile;
    CellPupsAcc acc = cell_pups_eval(u, texelFetch(u_in0, CELL_PUPS_TEXEL(cell), 0), u_epsilon);
#if CELL_PUPS_MODE == 1
    vec4 v = acc.best;
#elif CELL_PUPS_MODE == 2
    vec4 v = acc.sum;
#else
    vec4 v = cell_pups_acc_value(acc);
#endif
    frag_color = vec4(v.rgb, float(acc.label));
}
