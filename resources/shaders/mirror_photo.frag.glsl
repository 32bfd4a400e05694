#version 450 core
// The mirror view's background: the photograph's bytes copied unchanged (u_photo holds the 8-bit sRGB
// values as plain RGBA8, bottom row first, so texel = framebuffer pixel).
uniform sampler2D u_photo;
out vec4 o_colour;
void main() {
    o_colour = vec4(texelFetch(u_photo, ivec2(gl_FragCoord.xy), 0).rgb, 1.0);
}
