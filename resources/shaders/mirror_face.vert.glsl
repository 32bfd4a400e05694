#version 450 core
// The mirror view's face: the head drawn with the photograph's own camera (render/pinhole.py). Its
// attributes and world-space varyings are head_vertex.glsl's (the mirror binds no tangents: its fragment
// shader reads no v_tangent), plus the mesh's open-boundary fade.
#include "head_vertex.glsl"
in float in_edge;          // 0 at the mesh's open boundary, 1 a few mm inside (render/mirror.py)
uniform mat4 u_view_proj;
out float v_edge;
void main() {
    pass_head_vertex();
    v_edge = in_edge;
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
