#version 450 core
// Reference SSS at full resolution: up to three Gaussians of the skin profile in one horizontal pass (VERT 0:
// one target per Gaussian) and one vertical pass (VERT 1: reads the three targets, writes their weighted
// sum). One llvmpipe scene per direction instead of one per Gaussian and direction: each scene pays a fixed
// cost (rasterising the head's rectangle, the depth test, the centre fetch, the write) of most of a baseline
// frame here. VERT is a define, not a uniform: with a uniform branch llvmpipe ran each pass 1.5-1.7x slower.
//
// Two tap schemes, both the Gaussian (truncated at +-3 sigma, normalised) of the bilinearly interpolated image:
// - integer taps (the first NI Gaussians, radius RI0..RI2 texels each): the taps sit on whole texels and
//   weigh the Gaussian convolved with the bilinear tent (closed form below), which is that convolution
//   exactly. The horizontal pass fetches each texel within RI (the largest radius) once for all of them
//   (texelFetch: no filtering); the vertical pass fetches each Gaussian's own texels. (Merging adjacent taps
//   into one bilinear fetch, exact on whole texels, saved nothing here: llvmpipe's bilinear fetch costs two
//   point fetches, and the follow-surface mix would then see an interpolated depth.)
// - sub-texel taps (the others, NT0..NT2 taps over +-3 sigma; sss_gauss.frag's): for Gaussians too wide on
//   screen for a bounded number of whole-texel taps (zoomed in); the quadrature of the same integral.
// Follow-surface (Jimenez): each tap mixes towards the centre by its depth step over its distance (per texel
// with integer taps, at the interpolated depth with sub-texel taps).
// NG Gaussians (1..3); u_sigma_mm in mm; u_wt: the Gaussians' RGB weights.
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

#ifndef NI
#define NI 0
#endif
#ifndef RI
#define RI 1
#endif

// a value cut to half precision (mantissa truncated toward 0, as llvmpipe's additive blending into the
// RGBA16F sum cuts each per-Gaussian pass's result): the sum matches the per-Gaussian passes' bit for bit
vec3 h16(vec3 v) { return uintBitsToFloat(floatBitsToUint(v) & uvec3(0xFFFFE000u)); }

// the follow-surface mix of tap S (its alpha: depth) towards centre C at X_MM mm from it
#define FOLLOW(S, C, X_MM) mix(S.rgb, C.rgb, S.a <= 0.0 ? 1.0 : \
    clamp(u_follow * abs(S.a - C.a) * u_mm_per_unit / max(X_MM, 0.05), 0.0, 1.0))

// the normalised blur of one Gaussian (SIGMA mm, N sub-texel taps over +-3 sigma) of SRC around centre C (its
// alpha: depth) into OUT (a macro: each Gaussian's loop has its own compile-time tap count)
#define BLUR(OUT, SRC, C, SIGMA, N) { \
    vec3 acc_ = vec3(0.0); float wsum_ = 0.0; \
    for (int i = 0; i < N; ++i) { \
        float x_mm = ((float(i) / float(N - 1)) * 2.0 - 1.0) * 3.0 * SIGMA; \
        float w = exp(-0.5 * (x_mm * x_mm) / (SIGMA * SIGMA)); \
        vec4 s = textureLod(SRC, v_uv + u_dir * texel * (x_mm * scale), 0.0); \
        acc_ += FOLLOW(s, C, abs(x_mm)) * w; wsum_ += w; } \
    OUT = acc_ / wsum_; }

// W[d], d = 0..RI: the weight of the texel d texels from the centre under a Gaussian of SIG texels truncated
// at +-3 SIG, convolved with the bilinear tent: W[d] = integral over |x| <= 3 SIG of g(x) tent(x - d) dx, from
// the antiderivatives C (upper tail of g: 0.5 erfc, Abramowitz & Stegun 7.1.26, |error| < 1.5e-7; GLSL has
// no erf) and Q (of x g(x): -SIG^2 g) at the whole texels, each clamped to the truncation. Unnormalised
// (the sum of the weights over -RI..RI is the normaliser).
#define TENT(W, SIG_) { \
    float sg_ = max(SIG_, 1e-3), tr_ = 3.0 * sg_; float C_[RI + 2], Q_[RI + 2]; \
    for (int k = 0; k <= RI + 1; ++k) { \
        float x = min(float(k), tr_), e = exp(-0.5 * x * x / (sg_ * sg_)); \
        float t = 1.0 / (1.0 + 0.3275911 * 0.70710678 * x / sg_); \
        C_[k] = 0.5 * e * t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 \
                                                                                         + t * 1.061405429)))); \
        Q_[k] = -0.39894228 * sg_ * e; } \
    W[0] = 1.0 - 2.0 * C_[1] + 2.0 * (Q_[0] - Q_[1]); \
    for (int d = 1; d <= RI; ++d) \
        W[d] = (2.0 * Q_[d] - Q_[d - 1] - Q_[d + 1]) + float(d - 1) * (C_[d] - C_[d - 1]) \
               + float(d + 1) * (C_[d] - C_[d + 1]); }

// the integer-tap blur of SRC around centre C (its alpha: depth) by weights W over the R whole texels either side
// along u_dir (the follow-surface mix per texel; the weights are symmetric: the two sides' mixes are added first)
#define WHOLE(OUT, SRC, C, W, R) { \
    vec3 acc_ = C.rgb * W[0]; float wsum_ = W[0]; \
    for (int d = 1; d <= R; ++d) { \
        vec4 sl = texelFetch(SRC, clamp(p - d * dir, ivec2(0), lim), 0); \
        vec4 sr = texelFetch(SRC, clamp(p + d * dir, ivec2(0), lim), 0); \
        acc_ += (FOLLOW(sl, C, float(d) / scale) + FOLLOW(sr, C, float(d) / scale)) * W[d]; wsum_ += 2.0 * W[d]; } \
    OUT = acc_ / wsum_; }

// the vertical pass's Gaussian K (1, 2) added to SUM, cut to half precision as the per-Gaussian passes'
// blending cuts it: its horizontal result SRC around centre C, SIGMA mm, over R whole texels (SUM_WHOLE,
// weights in W) or N sub-texel taps (SUM_BLUR); B receives the Gaussian's blur
#define SUM_WHOLE(SUM, B, W, K, SRC, C, SIGMA, R) { \
    TENT(W, SIGMA * scale) WHOLE(B, SRC, C, W, R) SUM = h16(SUM + B * u_wt[K]); }
#define SUM_BLUR(SUM, B, K, SRC, C, SIGMA, N) { BLUR(B, SRC, C, SIGMA, N) SUM = h16(SUM + B * u_wt[K]); }

void main() {
    vec2 texel = 1.0 / vec2(textureSize(u_src0, 0));
    ivec2 p = ivec2(gl_FragCoord.xy), lim = textureSize(u_src0, 0) - 1, dir = ivec2(u_dir);
    vec4 c0 = textureLod(u_src0, v_uv, 0.0);      // a: linear depth on skin, -depth off skin, 0 background
#if VERT == 0
    {
        if (c0.a <= 0.0) { o_0 = c0; o_1 = c0; o_2 = c0; return; }
        float scale = u_px_per_mm_at_1 / c0.a;
        vec3 b;
#if NI > 0
        // whole texels within RI, fetched once for every integer-tap Gaussian (symmetric weights: the two
        // sides' mixes are added first)
        float w0[RI + 1], w1[RI + 1], w2[RI + 1];
        TENT(w0, u_sigma_mm.x * scale)
        vec3 a0 = c0.rgb * w0[0]; float n0 = w0[0];
#if NI > 1
        TENT(w1, u_sigma_mm.y * scale)
        vec3 a1 = c0.rgb * w1[0]; float n1 = w1[0];
#endif
#if NI > 2
        TENT(w2, u_sigma_mm.z * scale)
        vec3 a2 = c0.rgb * w2[0]; float n2 = w2[0];
#endif
        for (int d = 1; d <= RI; ++d) {
            vec4 sl = texelFetch(u_src0, clamp(p - d * dir, ivec2(0), lim), 0);
            vec4 sr = texelFetch(u_src0, clamp(p + d * dir, ivec2(0), lim), 0);
            vec3 m = FOLLOW(sl, c0, float(d) / scale) + FOLLOW(sr, c0, float(d) / scale);
            a0 += m * w0[d]; n0 += 2.0 * w0[d];
#if NI > 1
            a1 += m * w1[d]; n1 += 2.0 * w1[d];
#endif
#if NI > 2
            a2 += m * w2[d]; n2 += 2.0 * w2[d];
#endif
        }
        o_0 = vec4(a0 / n0, c0.a);
#else
        BLUR(b, u_src0, c0, u_sigma_mm.x, NT0) o_0 = vec4(b, c0.a);
#endif
#if NI > 1
        o_1 = vec4(a1 / n1, c0.a);
#elif NG > 1
        BLUR(b, u_src0, c0, u_sigma_mm.y, NT1) o_1 = vec4(b, c0.a);
#endif
#if NI > 2
        o_2 = vec4(a2 / n2, c0.a);
#elif NG > 2
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
#if NI > 0
    float w[RI + 1];
    TENT(w, u_sigma_mm.x * scale)
    WHOLE(b, u_src0, c0, w, RI0)
#else
    BLUR(b, u_src0, c0, u_sigma_mm.x, NT0)
#endif
    sum = h16(b * u_wt[0]);
#if NI > 1
    SUM_WHOLE(sum, b, w, 1, u_src1, c1, u_sigma_mm.y, RI1)
#elif NG > 1
    SUM_BLUR(sum, b, 1, u_src1, c1, u_sigma_mm.y, NT1)
#endif
#if NI > 2
    SUM_WHOLE(sum, b, w, 2, u_src2, c2, u_sigma_mm.z, RI2)
#elif NG > 2
    SUM_BLUR(sum, b, 2, u_src2, c2, u_sigma_mm.z, NT2)
#endif
    o_0 = vec4(sum, c0.a * n_g);
#endif
}
