#version 430
// cellgl viewer, 3D view: a mesh (viewer/meshes.py) with its object-space position passed on
// for solid texturing.
in vec3 in_position;
in vec3 in_normal;
uniform mat4 u_model;
uniform mat4 u_view;
uniform mat4 u_proj;
out vec3 v_object;   // object-space position (the solid texture's domain)
out vec3 v_world;
out vec3 v_normal;   // world-space normal

void main()
{
    vec4 w = u_model * vec4(in_position, 1.0);
    v_object = in_position;
    v_world = w.xyz;
    v_normal = mat3(u_model) * in_normal;
    gl_Position = u_proj * u_view * w;
}
