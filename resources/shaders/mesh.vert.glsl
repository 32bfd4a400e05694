#version 450 core
// The head in world (= mesh) space: position, normal, tangent frame, uv (head_vertex.glsl), the paint
// atlas's uv and linear view depth.
#include "head_vertex.glsl"
in vec2 in_uv_paint;   // UV of the thickness / KM maps (= in_uv unless the paint atlas was re-unwrapped)
uniform mat4 u_view_proj;
uniform mat4 u_view;
out vec2 v_uv_paint;
out float v_depth;
void main() {
    pass_head_vertex();
    v_uv_paint = in_uv_paint;
    v_depth = -(u_view * vec4(in_position, 1.0)).z;
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
