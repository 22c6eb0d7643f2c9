#version 430
// cellgl viewer: fullscreen triangle whose v_uv spans a chosen window of texture space, so the
// texture entry (shaders/texture.frag) draws a panned / zoomed / animated region. With
// u_uv0 = (0, 0) and u_uv_size = (1, 1) this is shaders/fullscreen.vert.
uniform vec2 u_uv0;      // texture coordinate at the viewport's lower-left corner
uniform vec2 u_uv_size;  // texture-coordinate extent of the viewport
out vec2 v_uv;

void main()
{
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    v_uv = u_uv0 + p * u_uv_size;
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
