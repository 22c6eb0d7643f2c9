#version 430
// cellgl compute entry: a texture recipe over a pixel grid (bakes) or a point list.
// Thin: compute the texture-space point and its footprint, call cell_texture_filtered()
// (once, or over a grid of sub-pixels), write the channels asked for.
// Macros (from cellgl/texture/dispatch.py): those of lib/texture.glsl, CELL_TEX_GRID, CELL_LOCAL_SIZE,
//   CELL_TEX_SUPERSAMPLE  n: average an n x n grid of sub-pixel centres (grid only; 1: none)
//   CELL_TEX_OUT          bit mask of the outputs written: 1 colour, 2 height + normal,
//                         4 F1..F4, 8 gradient + value, 16 id, 32 roughness + ao + metallic
//                         (with CELL_TEX_MATERIAL 1: lib/texture_material.glsl)
//   CELL_LOOP_PROBE       1: measure the driver's loop budget (cellgl/texture/dispatch.py)
//   CELL_TEX_GROUPS       1: points carry a group index; its origins in storage buffer 11

layout(local_size_x = CELL_LOCAL_SIZE) in;

#include "lib/texture.glsl"
// The u_<param> uniforms and their loader; a bake compiles the recipe's values as constants
// in its place (cellgl/texture/dispatch.py).
#include "texture_uniforms.glsl"

uniform uint u_count;           // samples in this dispatch
uniform uint u_first;           // index of its first sample

#if CELL_TEX_GRID
uniform ivec2 u_size;           // the full image, W x H
uniform ivec2 u_origin;         // first pixel of the tile (x0, y0)
uniform ivec2 u_tile;           // tile width, height
uniform int u_depth;            // volume slices along z (0: one image at z = 0)
#else
layout(std430, binding = 0) readonly buffer Points { vec4 points[]; };   // (u, v, z, group)
uniform vec3 u_filter_width;    // footprint of every point in texture space (0: point samples)
#ifndef CELL_TEX_GROUPS
#define CELL_TEX_GROUPS 0
#endif
#if CELL_TEX_GROUPS             // far points: each group's origins (lib/texture_groups.glsl)
#include "lib/texture_groups.glsl"
#endif
#endif
layout(std430, binding = 1) writeonly buffer OutColor { vec4 out_color[]; };
layout(std430, binding = 2) writeonly buffer OutAux { vec4 out_aux[]; };    // height, normal (0..1)
// F1..F_k of octave 0, k = CELL_TEX_F_COMPS (the last one asked for: F1 alone is one float)
#ifndef CELL_TEX_F_COMPS
#define CELL_TEX_F_COMPS 4
#endif
layout(std430, binding = 3) writeonly buffer OutF { float out_F[]; };
layout(std430, binding = 4) writeonly buffer OutGrad { vec4 out_grad[]; };  // dh/du, dh/dv, dh/dz, value
layout(std430, binding = 5) writeonly buffer OutId { uint out_id[]; };
#if CELL_TEX_MATERIAL
layout(std430, binding = 8) writeonly buffer OutMaterial { vec4 out_material[]; };   // roughness, ao, metallic, 0
#endif

// The driver's own loop limit (docs/exactness.md; as in cellular.comp): llvmpipe (and
// lavapipe, under zink) stops every loop of a SIMD vector of invocations once 65535 loop
// passes were spent in it, and then each loop still to come runs once. This loop of
// loop_canary (= 2) passes runs twice unless that happened: otherwise the sample is
// counted, and cellgl raises. Its length is read from storage (written by the runner), so
// no compiler can fold it and unroll the loop (zink folds uniforms into the shader).
layout(std430, binding = 9) buffer LoopCut { uint loop_cut_count; uint loop_canary; };   // 6, 7: the cell and density images
#ifndef CELL_LOOP_PROBE
#define CELL_LOOP_PROBE 0
#endif
#if CELL_LOOP_PROBE
uniform int u_loop_probe;       // far more passes than any limiter: runs until it stops it
layout(std430, binding = 10) writeonly buffer LoopProbe { int loop_probe[]; };
#endif

#define CELL_TEX_WANT(bit) ((CELL_TEX_OUT & (bit)) != 0)

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) {
        return;
    }
    CellTextureParams t = cell_texture_params_load();
#if CELL_TEX_GRID
    // x fastest, then y (rows, top first), then z slices.
    uint s = u_first + i;
    int x = int(s % uint(u_tile.x));
    uint rest = s / uint(u_tile.x);
    int y = int(rest % uint(u_tile.y));
    int k = int(rest / uint(u_tile.y));
    // CELL_PRECISE here and below: the same rounding in texture.comp and texture_samples.frag
    // (docs/exactness.md), so that a bake's bytes do not depend on the path.
    CELL_PRECISE vec3 p = vec3((float(u_origin.x + x) + 0.5) / float(u_size.x),
                  (float(u_origin.y + y) + 0.5) / float(u_size.y),
                  u_depth > 0 ? (float(k) + 0.5) / float(u_depth) : 0.0);
    // The pixel in texture space (a volume's slices too are band-limited in the image plane
    // only, so that slice k equals the image bake at its z).
    vec3 duvz = vec3(1.0 / float(u_size.x), 1.0 / float(u_size.y), 0.0);
#else
    vec3 p = points[i].xyz;
    vec3 duvz = u_filter_width;
#if CELL_TEX_GROUPS
    cell_texture_group(t, int(points[i].w));
#endif
#endif
    CELL_PRECISE vec4 local = cell_texture_local(p, t);
#if CELL_TEX_GRID && CELL_TEX_SUPERSAMPLE > 1
    // Supersampling: the centres of an n x n grid of sub-pixels (x fastest), each band-limited
    // to its own footprint; colour, height and gradient averaged, normals summed and
    // renormalised. ID, F1..F4 and the value stay those of the pixel centre (below).
    const int n = CELL_TEX_SUPERSAMPLE;
    float r = cell_texture_footprint(vec3(duvz.xy / float(n), duvz.z), t);
    CELL_PRECISE vec4 color = vec4(0.0), grad = vec4(0.0);
    CELL_PRECISE float height = 0.0;
    CELL_PRECISE vec3 normal = vec3(0.0);
#if CELL_TEX_WANT(32)
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
#if CELL_TEX_WANT(32)
        material += cell_texture_material(c, t);
#endif
    }
    float inv = 1.0 / float(n * n);
    color *= inv;
    height *= inv;
    grad *= inv;
    normal = normalize(normal);
#if CELL_TEX_WANT(32)
    material *= inv;
#endif
#if CELL_TEX_WANT(4 | 8 | 16)
    CellTexel c = cell_texture_filtered(local, cell_texture_footprint(duvz, t), t);
#endif
#else
    CellTexel c = cell_texture_filtered(local, cell_texture_footprint(duvz, t), t);
    CELL_PRECISE vec4 color = c.color, grad = c.grad;
    CELL_PRECISE float height = c.height;
    CELL_PRECISE vec3 normal = c.normal;
#if CELL_TEX_WANT(32)
    CELL_PRECISE vec3 material = cell_texture_material(c, t);
#endif
#endif
#if CELL_TEX_WANT(32)
    out_material[i] = vec4(material, 0.0);
#endif
#if CELL_TEX_WANT(1)
    out_color[i] = color;
#endif
#if CELL_TEX_WANT(2)
    CELL_PRECISE vec4 aux = vec4(height, normal * 0.5 + 0.5);     // a product, then a sum
    out_aux[i] = aux;
#endif
#if CELL_TEX_WANT(4)
    uint f0 = i * uint(CELL_TEX_F_COMPS);
    out_F[f0] = c.F.x;
#if CELL_TEX_F_COMPS > 1
    out_F[f0 + 1u] = c.F.y;
#endif
#if CELL_TEX_F_COMPS > 2
    out_F[f0 + 2u] = c.F.z;
#endif
#if CELL_TEX_F_COMPS > 3
    out_F[f0 + 3u] = c.F.w;
#endif
#endif
#if CELL_TEX_WANT(8)
    c.grad = grad;
    out_grad[i] = vec4(cell_texture_grad_uvz(c, t), c.value);
#endif
#if CELL_TEX_WANT(16)
    out_id[i] = c.id;
#endif
    int canary = 0;
    int canary_passes = int(loop_canary);
    for (int k = 0; k < canary_passes; k++) {
        canary += 1;
    }
    if (canary != canary_passes) {
        atomicAdd(loop_cut_count, 1u);
    }
#if CELL_LOOP_PROBE
    int left = 0;
    for (int k = 0; k < u_loop_probe; k++) {
        left += 1;
    }
    loop_probe[i] = left;
#endif
}
#undef CELL_TEX_WANT
