#version 430
// cellgl compute entry: a texture recipe over a pixel grid (bakes) or a point list.
// Thin: compute the texture-space point, call cell_texture_at(), write the channels.
// Macros (from cellgl/texture/shader.py): those of lib/texture.glsl, CELL_TEX_GRID, CELL_LOCAL_SIZE.

layout(local_size_x = CELL_LOCAL_SIZE) in;

#include "lib/texture.glsl"
#include "texture_uniforms.glsl"

uniform uint u_count;           // samples in this dispatch
uniform uint u_first;           // index of its first sample

#if CELL_TEX_GRID
uniform ivec2 u_size;           // the full image, W x H
uniform ivec2 u_origin;         // first pixel of the tile (x0, y0)
uniform ivec2 u_tile;           // tile width, height
uniform int u_depth;            // volume slices along z (0: one image at z = 0)
#else
layout(std430, binding = 0) readonly buffer Points { vec4 points[]; };   // (u, v, z, -)
#endif
layout(std430, binding = 1) writeonly buffer OutColor { vec4 out_color[]; };
layout(std430, binding = 2) writeonly buffer OutAux { vec4 out_aux[]; };    // height, normal (0..1)
layout(std430, binding = 3) writeonly buffer OutF { vec4 out_F[]; };        // F1..F4, octave 0
layout(std430, binding = 4) writeonly buffer OutGrad { vec4 out_grad[]; };  // dh/du, dh/dv, dh/dz, value
layout(std430, binding = 5) writeonly buffer OutId { uint out_id[]; };

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) {
        return;
    }
#if CELL_TEX_GRID
    // x fastest, then y (rows, top first), then z slices.
    uint s = u_first + i;
    int x = int(s % uint(u_tile.x));
    uint rest = s / uint(u_tile.x);
    int y = int(rest % uint(u_tile.y));
    int k = int(rest / uint(u_tile.y));
    vec3 p = vec3((float(u_origin.x + x) + 0.5) / float(u_size.x),
                  (float(u_origin.y + y) + 0.5) / float(u_size.y),
                  u_depth > 0 ? (float(k) + 0.5) / float(u_depth) : 0.0);
#else
    vec3 p = points[i].xyz;
#endif
    CellTextureParams t = cell_texture_params_load();
    CellTexel c = cell_texture_at(p, t);
    out_color[i] = c.color;
    out_aux[i] = vec4(c.height, c.normal * 0.5 + 0.5);
    out_F[i] = c.F;
    out_grad[i] = vec4(cell_texture_grad_uvz(c, t), c.value);
    out_id[i] = c.id;
}
