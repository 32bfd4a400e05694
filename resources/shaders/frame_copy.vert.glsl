#version 450 core
// A kept frame drawn over the viewport's columns from the left edge to NDC x = u_right (1 = all of it;
// the before/after split draws the bare frame up to the split line): a triangle strip of 4 vertices
// from gl_VertexID, v_uv the matching part of the frame's texture.
uniform float u_right;
out vec2 v_uv;
void main() {
    vec2 p = vec2(gl_VertexID & 1, gl_VertexID >> 1);
    v_uv = vec2(p.x * (u_right + 1.0) * 0.5, p.y);
    gl_Position = vec4(mix(-1.0, u_right, p.x), p.y * 2.0 - 1.0, 0.0, 1.0);
}
