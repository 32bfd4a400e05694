// The head's vertex attributes (GpuHead's buffers, bound by name) and the world (= mesh) space varyings
// of every pass that draws the head: position, normal, tangent frame (w: handedness) and uv.
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;
out vec3 v_pos;
out vec3 v_normal;
out vec4 v_tangent;
out vec2 v_uv;

// Copy the attributes into the varyings unchanged (the head is drawn in mesh space).
void pass_head_vertex() {
    v_pos = in_position;
    v_normal = in_normal;
    v_tangent = in_tangent;
    v_uv = in_uv;
}
