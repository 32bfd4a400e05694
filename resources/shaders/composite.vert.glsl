#version 450 core
// The composite's geometry: the head or its convex hull (render/cover.py), positions only. The composite
// reads its inputs at its own pixel, so any geometry covering the head's pixels will do.
in vec3 in_position;
uniform mat4 u_view_proj;
void main() {
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
