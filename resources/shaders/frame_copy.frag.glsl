#version 450 core
// The kept frame's colour (see frame_copy.vert).
uniform sampler2D u_src;
in vec2 v_uv;
out vec4 f_color;
void main() { f_color = texture(u_src, v_uv); }
