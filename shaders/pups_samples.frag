#version 330 core
// cellgl fragment entry (the fragment path, cellgl/gl/dispatch.py): PUPs over a pixel grid, as
// shaders/pups.comp computes it, for OpenGL 3.3 core and up without compute shaders.
// Thin: sample s (u_first + fragment (s mod CELL_FRAG_WIDTH, s / CELL_FRAG_WIDTH)) is
// pixel (s mod width, s / width); read the candidate grid from textures, call
// shaders/lib/pups.glsl, write the value (and the label).
// Defines (cellgl/pups/gpu.py): CELL_PUPS_MODE (as pups.comp), CELL_FRAG_WIDTH.

#ifndef CELL_PUPS_MODE
#define CELL_PUPS_MODE 0
#endif
#define CELL_PUPS_FETCH 1

// pups.comp's storage buffers as RGBA32UI textures 2^CELL_STORAGE_ROW_BITS texels wide:
uniform usampler2D u_in0;  // the grid cells' headers
uniform usampler2D u_in1;  // the candidate records

uniform ivec2 u_size;      // image width, height in pixels
uniform vec2 u_origin;     // domain position of the centre of pixel (0, 0)
uniform vec2 u_pixel;      // domain size of one pixel
uniform int u_tile;        // candidate-grid cell size in pixels
uniform int u_grid_w;      // candidate-grid cells per row

uniform float u_epsilon;   // orientation strength, [0, 1)

#define CELL_PUPS_TEXEL(k) ivec2(int(uint(k) & ((1u << CELL_STORAGE_ROW_BITS) - 1u)), int(uint(k) >> CELL_STORAGE_ROW_BITS))
uvec4 cell_pups_fetch(uint k) { return texelFetch(u_in1, CELL_PUPS_TEXEL(k), 0); }

#include "lib/pups.glsl"

uniform uint u_first;      // the first sample of this chunk

// The outputs (cellgl/gl/dispatch.py): row_values in a float target, row_labels in an int one
// (an integer in a float target could come back as a canonicalised NaN or a flushed denormal).
CELL_FRAG_DECL

void main()
{
    ivec2 xy = ivec2(gl_FragCoord.xy);
    uint s = u_first + uint(xy.y) * uint(CELL_FRAG_WIDTH) + uint(xy.x);
    ivec2 px = ivec2(int(s % uint(u_size.x)), int(s / uint(u_size.x)));
    ivec2 pc = min(px, u_size - 1);
    int cell = (pc.y / u_tile) * u_grid_w + pc.x / u_tile;
    vec2 u = u_origin + vec2(px) * u_pixel;
    CellPupsAcc acc = cell_pups_eval(u, texelFetch(u_in0, CELL_PUPS_TEXEL(cell), 0), u_epsilon);
#if CELL_PUPS_MODE == 1
    vec4 v = acc.best;
#elif CELL_PUPS_MODE == 2
    vec4 v = acc.sum;
#else
    vec4 v = cell_pups_acc_value(acc);
#endif
    vec4 row_values = v;
    int row_labels[1] = int[1](acc.label);
    CELL_FRAG_WRITE
}
