#version 430
// cellgl viewer: fullscreen triangle for drawing a rendered texture into a viewport;
// v_uv = u_offset + [0, 1]^2 * u_scale (scale 3 with repeat wrapping gives the 3x3 tiled view).
uniform vec2 u_offset;
uniform vec2 u_scale;
out vec2 v_uv;

void main()
{
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    v_uv = u_offset + p * u_scale;
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
