#version 450 core
// The SSS passes' pixel classes as depth, sampled exactly as those passes sample their centre:
// skin (a > 0) -> 0.25, head but not skin (a < 0) -> 0.5, background (a = 0) -> 1.
in vec2 v_uv;
uniform sampler2D u_src;   // the unblurred diffuse: a = linear depth on skin, -depth off skin, 0 background
void main() {
    float a = textureLod(u_src, v_uv, 0.0).a;
    gl_FragDepth = a > 0.0 ? 0.25 : (a < 0.0 ? 0.5 : 1.0);
}
