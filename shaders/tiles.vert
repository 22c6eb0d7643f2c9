#version 330 core
// cellgl fragment path (cellgl/gl/dispatch.py): a triangle covering the viewport, from
// gl_VertexID alone (draw 3 vertices, no buffers). Each draw's viewport is one tile of the
// render targets; fragment (x, y) is sample y * CELL_FRAG_WIDTH + x.

void main()
{
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
