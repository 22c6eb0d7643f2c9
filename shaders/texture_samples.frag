#version 330 core
// cellgl fragment entry (the fragment path, cellgl/gl/dispatch.py): a texture recipe over a pixel
// grid (bakes) or a point list, as shaders/texture.comp computes it, for OpenGL 3.3 core and up
// without compute shaders. Thin: sample i of this chunk is fragment (i mod width, i / width);
// compute its texture-space point and footprint, call cell_texture_filtered() (once, or over a
// grid of sub-pixels), write the channels asked for to render targets.
// Macros (cellgl/texture/dispatch.py): those of texture.comp, CELL_FRAG_WIDTH,
//   CELL_TEX_WANT_COLOR, _AUX, _F, _GRAD, _ID, _MATERIAL: the outputs written, and the runner's
//   CELL_FRAG_DECL / CELL_FRAG_WRITE (location 0: 1 where the driver's loop limit left the sample
//   alone, the canary).

#include "lib/texture.glsl"
#include "texture_uniforms.glsl"

uniform uint u_first;           // index of this chunk's first sample

#if CELL_TEX_GRID
uniform ivec2 u_size;           // the full image, W x H
uniform ivec2 u_origin;         // first pixel of the tile (x0, y0)
uniform ivec2 u_tile;           // tile width, height
uniform int u_depth;            // volume slices along z (0: one image at z = 0)
#else
uniform sampler2D u_in0;        // the points (u, v, z, group), sample i at texel (i mod width, i / width)
uniform vec3 u_filter_width;    // footprint of every point in texture space (0: point samples)
#ifndef CELL_TEX_GROUPS
#define CELL_TEX_GROUPS 0
#endif
#if CELL_TEX_GROUPS             // far points: each group's origins (lib/texture_groups.glsl)
#include "lib/texture_groups.glsl"
#endif
#endif
uniform usampler2D u_loop_canary;  // one texel: the canary's length, 2 (texture.comp; not a uniform a compiler can fold)

#ifndef CELL_LOOP_PROBE
#define CELL_LOOP_PROBE 0
#endif
#if CELL_LOOP_PROBE
uniform int u_loop_probe;       // texture.comp's probe: runs until llvmpipe's limiter stops it
#endif

// The outputs (cellgl/gl/dispatch.py): o_canary at location 0, then a render target per
// row_<output> written (CELL_TEX_WANT_<OUTPUT>).
CELL_FRAG_DECL
#ifndef CELL_TEX_WANT_MATERIAL
#define CELL_TEX_WANT_MATERIAL 0
#endif

void main()
{
    ivec2 xy = ivec2(gl_FragCoord.xy);
    CellTextureParams t = cell_texture_params_load();
#if CELL_TEX_GRID
    // x fastest, then y (rows, top first), then z slices.
    uint s = u_first + uint(xy.y) * uint(CELL_FRAG_WIDTH) + uint(xy.x);
    int x = int(s % uint(u_tile.x));
    uint rest = s / uint(u_tile.x);
    int y = int(rest % uint(u_tile.y));
    int k = int(rest / uint(u_tile.y));
    // CELL_PRECISE here and below: the same rounding in texture.comp and texture_samples.frag
    // (docs/exactness.md), so that a bake's bytes do not depend on the path.
    CELL_PRECISE vec3 p = vec3((float(u_origin.x + x) + 0.5) / float(u_size.x),
                  (float(u_origin.y + y) + 0.5) / float(u_size.y),
                  u_depth > 0 ? (float(k) + 0.5) / float(u_depth) : 0.0);
    vec3 duvz = vec3(1.0 / float(u_size.x), 1.0 / float(u_size.y), 0.0);
#else
    vec4 row = texelFetch(u_in0, xy, 0);
    vec3 p = row.xyz;
    vec3 duvz = u_filter_width;
#if CELL_TEX_GROUPS
    cell_texture_group(t, int(row.w));
#endif
#endif
    CELL_PRECISE vec4 local = cell_texture_local(p, t);
#if CELL_TEX_GRID && CELL_TEX_SUPERSAMPLE > 1
    // Supersampling as texture.comp: sub-pixel centres x fastest; colour, height and gradient
    // averaged, normals summed and renormalised; ID, F1..F4 and the value of the pixel centre.
    const int n = CELL_TEX_SUPERSAMPLE;
    float r = cell_texture_footprint(vec3(duvz.xy / float(n), duvz.z), t);
    CELL_PRECISE vec4 color = vec4(0.0), grad = vec4(0.0);
    CELL_PRECISE float height = 0.0;
    CELL_PRECISE vec3 normal = vec3(0.0);
#if CELL_TEX_WANT_MATERIAL
    CELL_PRECISE vec3 material = vec3(0.0);
#endif
    for (int sy = 0; sy < n; sy++)
    for (int sx = 0; sx < n; sx++) {
        CELL_PRECISE vec2 off = (vec2(float(sx), float(sy)) + 0.5) / float(n) - 0.5;
        CELL_PRECISE vec3 ps = p + vec3(off * duvz.xy, 0.0);
        CellTexel c = cell_texture_filtered(cell_texture_local(ps, t), r, t);
        color += c.color;
        height += c.height;
        normal += c.normal;
        grad += c.grad;
#if CELL_TEX_WANT_MATERIAL
        material += cell_texture_material(c, t);
#endif
    }
    float inv = 1.0 / float(n * n);
    color *= inv;
    height *= inv;
    grad *= inv;
    normal = normalize(normal);
#if CELL_TEX_WANT_MATERIAL
    material *= inv;
#endif
#if CELL_TEX_WANT_F || CELL_TEX_WANT_GRAD || CELL_TEX_WANT_ID
    CellTexel c = cell_texture_filtered(local, cell_texture_footprint(duvz, t), t);
#endif
#else
    CellTexel c = cell_texture_filtered(local, cell_texture_footprint(duvz, t), t);
    CELL_PRECISE vec4 color = c.color, grad = c.grad;
    CELL_PRECISE float height = c.height;
    CELL_PRECISE vec3 normal = c.normal;
#if CELL_TEX_WANT_MATERIAL
    CELL_PRECISE vec3 material = cell_texture_material(c, t);
#endif
#endif
#if CELL_TEX_WANT_MATERIAL
    vec4 row_material = vec4(material, 0.0);
#endif
#if CELL_TEX_WANT_COLOR
    vec4 row_color = color;
#endif
#if CELL_TEX_WANT_AUX
    CELL_PRECISE vec4 row_aux = vec4(height, normal * 0.5 + 0.5);     // a product, then a sum
#endif
#if CELL_TEX_WANT_F
    vec4 row_F = c.F;
#endif
#if CELL_TEX_WANT_GRAD
    c.grad = grad;
    vec4 row_grad = vec4(cell_texture_grad_uvz(c, t), c.value);
#endif
#if CELL_TEX_WANT_ID
    uint row_id[1] = uint[1](c.id);
#endif
    int canary = 0;
    int canary_passes = int(texelFetch(u_loop_canary, ivec2(0, 0), 0).r);
    for (int k = 0; k < canary_passes; k++) {
        canary += 1;
    }
    o_canary = canary == canary_passes ? 1u : 0u;
#if CELL_LOOP_PROBE
    int left = 0;
    for (int k = 0; k < u_loop_probe; k++) {
        left += 1;
    }
    int row_loops[1] = int[1](left);
#endif
    CELL_FRAG_WRITE
}
