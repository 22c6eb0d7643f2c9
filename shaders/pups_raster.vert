#version 330 core
// cellgl: PUPs by rasterisation (cellgl.pups, method="raster"). Per control point (or
// periodic copy) the triangles of a convex polygon that holds every pixel centre of its
// support (cellgl.pups._raster_polygons: the support cut by the axes, pushed out by a pixel,
// and clipped to its pixel box), all in one plain indexed draw (no instancing: llvmpipe runs
// an instanced draw instance by instance), in instance order. Every vertex carries its
// point's data, passed on as flat outputs, so the fragment shader
// (shaders/pups_raster.frag) reads no buffer; the blending adds the points up.
//
// Defines (set by cellgl/pups/):
//   CELL_PUPS_RASTER_PAIRS  axis pairs per point: half the largest axis count, rounded up;
//                           shorter lists are padded with zero axes (factor exactly 1)

#ifndef CELL_PUPS_RASTER_PAIRS
#define CELL_PUPS_RASTER_PAIRS 4
#endif

in vec2 in_corner;  // polygon vertex, pixel units (pixel (i, j) centred at (i + .5, j + .5))
in vec4 in_point;   // position xy, orientation xy (domain units)
in vec4 in_value;   // value rgb (channel 0 only for intensities), label (as a float)
#if CELL_PUPS_RASTER_PAIRS > 0
in vec4 in_axes[CELL_PUPS_RASTER_PAIRS];  // pre-scaled axes, two per vec4, zero-padded
flat out vec4 v_axes[CELL_PUPS_RASTER_PAIRS];
#endif

uniform ivec2 u_size;  // render target size in pixels

flat out vec4 v_point;
flat out vec4 v_value;

void main()
{
    gl_Position = vec4(in_corner / vec2(u_size) * 2.0 - 1.0, 0.0, 1.0);
    v_point = in_point;
    v_value = in_value;
#if CELL_PUPS_RASTER_PAIRS > 0
    for (int i = 0; i < CELL_PUPS_RASTER_PAIRS; ++i) {
        v_axes[i] = in_axes[i];
    }
#endif
}
