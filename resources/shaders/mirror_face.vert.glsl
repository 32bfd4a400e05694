#version 450 core
// The mirror view's face: the head drawn with the photograph's own camera (render/pinhole.py).
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;
in float in_edge;          // 0 at the mesh's open boundary, 1 a few mm inside (render/mirror.py)
uniform mat4 u_view_proj;
out vec3 v_pos;
out vec3 v_normal;
out vec2 v_uv;
out float v_edge;
void main() {
    v_pos = in_position;
    v_normal = in_normal;
    v_uv = in_uv;
    v_edge = in_edge;
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
