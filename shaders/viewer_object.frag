#version 430
// cellgl viewer, 3D view: the recipe as a solid texture on a lit object, with bump mapping.
// Thin entry: the texture (colour, height and its analytic gradient) comes from
// lib/texture.glsl at texture-space point p = object * u_object_scale + 0.5, exactly as a
// volume bake or cellgl.texture.evaluate(recipe, p) computes it.
//
// Bump mapping: the height gradient in object space, g = dh/dp * u_object_scale, minus its
// normal component, tilts the surface normal: n' = normalize(n - bump * (g - (g.n) n)), with
// bump = u_bump_view * u_bump / frequency (the recipe's bump is in height units per cell).
//
// Outputs: colour, and the object-space position (w = 1 on the object) for the viewer's
// readout under the cursor.

#include "lib/texture.glsl"
#include "texture_uniforms.glsl"

uniform vec3 u_eye;
uniform float u_object_scale;
uniform float u_bump_view;   // viewer multiplier of the recipe's bump strength
in vec3 v_object;
in vec3 v_world;
in vec3 v_normal;
layout(location = 0) out vec4 frag_color;
layout(location = 1) out vec4 frag_position;

void main()
{
    CellTextureParams t = cell_texture_params_load();
    vec3 p = v_object * u_object_scale + 0.5;
    // Band-limited to the fragment's footprint in texture space (lib/texture.glsl).
    CellTexel x = cell_texture_at_filtered(p, fwidth(p), t);

    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing) {
        n = -n;
    }
    vec3 g = cell_texture_grad_uvz(x, t) * u_object_scale;
    float bump = u_bump_view * t.bump / max(t.frequency, 1e-6);
    n = normalize(n - bump * (g - dot(g, n) * n));

    vec3 V = normalize(u_eye - v_world);
    vec3 L1 = normalize(vec3(0.6, 0.8, 0.5));
    vec3 L2 = normalize(vec3(-0.7, 0.2, -0.4));
    vec3 H = normalize(L1 + V);
    float diffuse = max(dot(n, L1), 0.0) + 0.35 * max(dot(n, L2), 0.0);
    float spec = pow(max(dot(n, H), 0.0), 48.0) * 0.25;
    vec3 rgb = x.color.rgb * (0.18 + 0.82 * diffuse) + vec3(spec);
    frag_color = vec4(clamp(rgb, 0.0, 1.0), 1.0);
    frag_position = vec4(v_object, 1.0);
}
