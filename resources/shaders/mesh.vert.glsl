#version 450 core
// The head in world (= mesh) space: position, normal, tangent frame, uv and linear view depth.
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;
in vec2 in_uv_paint;   // UV of the thickness / KM maps (= in_uv unless the paint atlas was re-unwrapped)
in vec4 in_tangent;
uniform mat4 u_view_proj;
uniform mat4 u_view;
out vec3 v_pos;
out vec3 v_normal;
out vec4 v_tangent;
out vec2 v_uv;
out vec2 v_uv_paint;
out float v_depth;
void main() {
    v_pos = in_position;
    v_normal = in_normal;
    v_tangent = in_tangent;
    v_uv = in_uv;
    v_uv_paint = in_uv_paint;
    v_depth = -(u_view * vec4(in_position, 1.0)).z;
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
