#version 450 core
// Pad texture-space maps beyond chart borders: an uncovered texel (a = 0 in u_src0) takes the mean of
// its covered 3x3 neighbours, so bilinear sampling at UV seams never reads the empty background.
in vec2 v_uv;
uniform sampler2D u_src0;
uniform sampler2D u_src1;
uniform sampler2D u_src2;
layout(location = 0) out vec4 o0;
layout(location = 1) out vec4 o1;
layout(location = 2) out vec4 o2;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 c0 = texelFetch(u_src0, p, 0);
    if (c0.a > 0.0) { o0 = c0; o1 = texelFetch(u_src1, p, 0); o2 = texelFetch(u_src2, p, 0); return; }
    ivec2 size = textureSize(u_src0, 0);
    vec4 a0 = vec4(0.0), a1 = vec4(0.0), a2 = vec4(0.0);
    float n = 0.0;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = clamp(p + ivec2(dx, dy), ivec2(0), size - 1);
            vec4 s = texelFetch(u_src0, q, 0);
            if (s.a > 0.0) { a0 += s; a1 += texelFetch(u_src1, q, 0); a2 += texelFetch(u_src2, q, 0); n += 1.0; }
        }
    if (n > 0.0) { o0 = vec4(a0.rgb / n, 1.0); o1 = a1 / n; o2 = a2 / n; }
    else { o0 = vec4(0.0); o1 = vec4(1.0); o2 = vec4(1.0); }
}
