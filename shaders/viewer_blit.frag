#version 430
// cellgl viewer: copy a rendered texture to the window (upscaling the reduced-resolution
// preview while a slider is dragged; repeating the tile in the 3x3 view). u_grid > 0 draws
// thin lines at the tile borders, where seams would show.
uniform sampler2D u_tex;
uniform float u_grid;    // line width in texture coordinates, 0: none
in vec2 v_uv;
layout(location = 0) out vec4 frag_color;

void main()
{
    vec4 c = texture(u_tex, v_uv);
    if (u_grid > 0.0) {
        vec2 d = abs(v_uv - round(v_uv));
        if (min(d.x, d.y) < u_grid) {
            c.rgb = mix(c.rgb, vec3(1.0, 0.2, 0.1), 0.5);
        }
    }
    frag_color = vec4(c.rgb, 1.0);
}
