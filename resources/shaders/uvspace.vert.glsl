#version 450 core
// Draw the mesh unwrapped: each vertex at its UV (texel row 0 = v 0, as every map in Sheer).
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;
out vec3 v_pos;
out vec3 v_normal;
out vec4 v_tangent;
out vec2 v_uv;
void main() {
    v_pos = in_position;
    v_normal = in_normal;
    v_tangent = in_tangent;
    v_uv = in_uv;
    gl_Position = vec4(in_uv * 2.0 - 1.0, 0.0, 1.0);
}
