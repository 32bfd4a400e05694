#version 450 core
// Texture-space KM draws: triangles given in NDC (a full-screen triangle, or two per dirty tile).
in vec2 in_pos;
void main() {
    gl_Position = vec4(in_pos, 0.0, 1.0);
}
