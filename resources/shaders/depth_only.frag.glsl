#version 450 core
// Depth only (with mesh.vert and colour writes masked off): the mesh's depth for the brush ring's test.
out vec4 f_color;
void main() { f_color = vec4(0.0); }
