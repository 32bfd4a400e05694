#version 450 core
// Reference SSS at full resolution: up to three Gaussians of the skin profile (sss_gauss.frag's blur, the
// same taps and follow-surface weights, bit for bit) in one horizontal pass (VERT 0: one target per
// Gaussian) and one vertical pass (VERT 1: reads the three targets, writes their weighted sum). One llvmpipe
// scene per direction instead of one per Gaussian and direction: each scene pays a fixed cost (rasterising
// the head's rectangle, the depth test, the centre fetch, the write) of most of a baseline frame here.
// VERT is a define, not a uniform: with a uniform branch llvmpipe ran each pass 1.5-1.7x slower.
// NG Gaussians (1..3), NT0..NT2 taps each; u_sigma_mm in mm; u_wt: the Gaussians' RGB weights.
in vec2 v_uv;
uniform sampler2D u_src0;
uniform sampler2D u_src1;
uniform sampler2D u_src2;
uniform vec2 u_dir;
uniform vec3 u_sigma_mm;
uniform vec3 u_wt[3];
uniform float u_px_per_mm_at_1;
uniform float u_mm_per_unit;
uniform float u_follow;
layout(location = 0) out vec4 o_0;
layout(location = 1) out vec4 o_1;
layout(location = 2) out vec4 o_2;

// the normalised blur of one Gaussian (SIGMA mm, N taps over +-3 sigma) of SRC around centre C (its alpha:
// depth) into OUT (a macro: each Gaussian's loop has its own compile-time tap count)

// a value cut to half precision (mantissa truncated toward 0, as llvmpipe's additive blending into the
// RGBA16F sum cuts each per-Gaussian pass's result): the sum matches the per-Gaussian passes' bit for bit
vec3 h16(vec3 v) { return uintBitsToFloat(floatBitsToUint(v) & uvec3(0xFFFFE000u)); }

#define BLUR(OUT, SRC, C, SIGMA, N) { \
    vec3 acc_ = vec3(0.0); float wsum_ = 0.0; \
    for (int i = 0; i < N; ++i) { \
        float x_mm = ((float(i) / float(N - 1)) * 2.0 - 1.0) * 3.0 * SIGMA; \
        float w = exp(-0.5 * (x_mm * x_mm) / (SIGMA * SIGMA)); \
        vec4 s = textureLod(SRC, v_uv + u_dir * texel * (x_mm * scale), 0.0); \
        float dz_mm = abs(s.a - C.a) * u_mm_per_unit; \
        float k = s.a <= 0.0 ? 1.0 : clamp(u_follow * dz_mm / max(abs(x_mm), 0.05), 0.0, 1.0); \
        acc_ += mix(s.rgb, C.rgb, k) * w; wsum_ += w; } \
    OUT = acc_ / wsum_; }

void main() {
    vec2 texel = 1.0 / vec2(textureSize(u_src0, 0));
    vec4 c0 = textureLod(u_src0, v_uv, 0.0);      // a: linear depth on skin, -depth off skin, 0 background
#if VERT == 0
    {
        if (c0.a <= 0.0) { o_0 = c0; o_1 = c0; o_2 = c0; return; }
        float scale = u_px_per_mm_at_1 / c0.a;
        vec3 b;
        BLUR(b, u_src0, c0, u_sigma_mm.x, NT0) o_0 = vec4(b, c0.a);
#if NG > 1
        BLUR(b, u_src0, c0, u_sigma_mm.y, NT1) o_1 = vec4(b, c0.a);
#endif
#if NG > 2
        BLUR(b, u_src0, c0, u_sigma_mm.z, NT2) o_2 = vec4(b, c0.a);
#endif
        return;
    }
#else
    // vertical: the centres of the Gaussians' horizontal results (same alpha: the depth)
    vec4 c1 = c0, c2 = c0;
#if NG > 1
    c1 = textureLod(u_src1, v_uv, 0.0);
#endif
#if NG > 2
    c2 = textureLod(u_src2, v_uv, 0.0);
#endif
    float n_g = float(NG);
    if (c0.a <= 0.0) {
        vec3 rgb = h16(c0.rgb * u_wt[0]);
#if NG > 1
        rgb = h16(rgb + c1.rgb * u_wt[1]);
#endif
#if NG > 2
        rgb = h16(rgb + c2.rgb * u_wt[2]);
#endif
        o_0 = vec4(rgb, c0.a * n_g);
        return;
    }
    float scale = u_px_per_mm_at_1 / c0.a;
    vec3 b, sum;
    BLUR(b, u_src0, c0, u_sigma_mm.x, NT0) sum = h16(b * u_wt[0]);
#if NG > 1
    BLUR(b, u_src1, c1, u_sigma_mm.y, NT1) sum = h16(sum + b * u_wt[1]);
#endif
#if NG > 2
    BLUR(b, u_src2, c2, u_sigma_mm.z, NT2) sum = h16(sum + b * u_wt[2]);
#endif
    o_0 = vec4(sum, c0.a * n_g);
#endif
}
