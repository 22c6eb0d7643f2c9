#version 330 core
// cellgl: PUPs by rasterisation, fragment stage (see shaders/pups_raster.vert). Weights pixel
// (i, j) for one control point with shaders/lib/pups.glsl, from the point's flat inputs
// alone (no buffer reads), and writes (w * value, w); the render target (RGBA32F) adds the
// points up with ONE, ONE blending, in primitive order (the compute path's candidate
// order). Pixel (i, j) of the target is pixel (i, j) of shaders/pups.comp's output.
//
// The axis loop has a fixed trip count and no early exit, as cell_pups_eval: a zero-padded
// axis gives a factor of exactly 1, a factor of 0 keeps the product at 0.

#ifndef CELL_PUPS_RASTER_PAIRS
#define CELL_PUPS_RASTER_PAIRS 4
#endif

uniform vec2 u_origin;     // domain position of the centre of pixel (0, 0)
uniform vec2 u_pixel;      // domain size of one pixel
uniform float u_epsilon;   // orientation strength, [0, 1)

flat in vec4 v_point;
flat in vec4 v_value;
#if CELL_PUPS_RASTER_PAIRS > 0
flat in vec4 v_axes[CELL_PUPS_RASTER_PAIRS];
#endif

layout(location = 0) out vec4 frag_color;

#include "lib/pups.glsl"

void main()
{
    vec2 u = u_origin + vec2(ivec2(gl_FragCoord.xy)) * u_pixel;
    vec2 d = u - v_point.xy;
    float w = 1.0;
#if CELL_PUPS_RASTER_PAIRS > 0
    for (int i = 0; i < CELL_PUPS_RASTER_PAIRS; ++i) {
        w *= cell_pups_axial(dot(d, v_axes[i].xy));
        w *= cell_pups_axial(dot(d, v_axes[i].zw));
    }
#endif
    w = cell_pups_orient(w, d, v_point.zw, u_epsilon);
    if (w <= 0.0) {
        discard;
    }
    frag_color = vec4(w * v_value.xyz, w);
}
