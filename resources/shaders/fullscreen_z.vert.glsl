#version 450 core
// fullscreen.vert at a chosen depth: u_z is the NDC z of the triangle, so a depth test against a mask
// (sss_mask.frag) skips the pixels an SSS pass does not need (llvmpipe skips whole blocks that fail an
// early depth test; it does not skip branches).
out vec2 v_uv;
uniform float u_z;
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    v_uv = p;
    gl_Position = vec4(p * 2.0 - 1.0, u_z, 1.0);
}
