#version 430
// cellgl fragment entry (viewer): a texture recipe over the viewport.
// Thin: the uv of this fragment and its footprint fwidth(uv), cell_texture_at_filtered(),
// one channel out.
// Uniforms: the recipe's u_<param> (cellgl.texture.set_uniforms), plus
//   u_view     uv = u_view.xy + (v_uv.x, 1 - v_uv.y) * u_view.zw (v = 0 at the top, as bakes);
//              cellgl.texture.set_view puts the pan into the split origins (float64) and
//              sets u_view.xy = 0, so a view far from the origin stays sharp
//   u_channel  0 color, 1 height, 2 normal, 3 id (cell value), 4..7 F1..F4, 8..10 roughness, ao,
//              metallic (with CELL_TEX_MATERIAL 1) (cellgl.texture.schema.CHANNELS)

#include "lib/texture.glsl"
#include "texture_uniforms.glsl"

uniform vec4 u_view = vec4(0.0, 0.0, 1.0, 1.0);
uniform int u_channel = 0;

in vec2 v_uv;
layout(location = 0) out vec4 frag_color;

void main()
{
    vec2 uv = u_view.xy + vec2(v_uv.x, 1.0 - v_uv.y) * u_view.zw;
    CellTextureParams t = cell_texture_params_load();
    // Band-limited to this fragment's footprint in uv (lib/texture.glsl: the antialiasing).
    CellTexel c = cell_texture_at_filtered(vec3(uv, 0.0), vec3(fwidth(uv), 0.0), t);
    if (u_channel == 1) {
        frag_color = vec4(vec3(c.height), 1.0);
    } else if (u_channel == 2) {
        frag_color = vec4(c.normal * 0.5 + 0.5, 1.0);
    } else if (u_channel == 3) {
        frag_color = vec4(vec3(cell_texture_cell_value(c.id)), 1.0);
#if CELL_TEX_MATERIAL
    } else if (u_channel >= 8) {
        frag_color = vec4(vec3(cell_texture_material(c, t)[min(u_channel - 8, 2)]), 1.0);
#endif
    } else if (u_channel >= 4) {
        frag_color = vec4(vec3(c.F[min(u_channel - 4, 3)]), 1.0);
    } else {
        frag_color = c.color;
    }
}
