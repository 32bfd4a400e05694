#version 450 core
// Reference SSS (Jimenez et al. 2009): one separable pass of one Gaussian of the skin profile's sum of
// Gaussians (d'Eon et al. 2007). NTAPS taps spanning +-3 sigma; u_sigma_mm in mm; width from depth and
// the head's mm scale; follow-surface like sss_fast. u_weight multiplies the output (the Gaussian's
// RGB weight on the vertical pass, accumulated with additive blending). Gaussians wider than a few
// pixels may run on the half-resolution grid (u_premultiplied: coverage in alpha for the upsampling).
in vec2 v_uv;
uniform sampler2D u_src;
uniform vec2 u_dir;
uniform float u_sigma_mm;
uniform vec3 u_weight;
uniform float u_px_per_mm_at_1;
uniform float u_mm_per_unit;
uniform float u_follow;
uniform int u_premultiplied;   // 1: output (blur * weight, u_cov) on skin and 0 elsewhere (half-resolution sums)
uniform float u_cov;
out vec4 o_colour;

void main() {
    vec2 texel = 1.0 / vec2(textureSize(u_src, 0));
    vec4 c = textureLod(u_src, v_uv, 0.0);      // a: linear depth on skin, -depth off skin, 0 background
    float depth = c.a;
    if (depth <= 0.0) { o_colour = u_premultiplied == 1 ? vec4(0.0) : vec4(c.rgb * u_weight, c.a); return; }
    float scale = u_px_per_mm_at_1 / depth;
    vec3 acc = vec3(0.0);
    float wsum = 0.0;
    for (int i = 0; i < NTAPS; ++i) {
        float t = (float(i) / float(NTAPS - 1)) * 2.0 - 1.0;     // -1..1
        float x_mm = t * 3.0 * u_sigma_mm;
        float w = exp(-0.5 * (x_mm * x_mm) / (u_sigma_mm * u_sigma_mm));
        vec2 uv = v_uv + u_dir * texel * (x_mm * scale);
        vec4 s = textureLod(u_src, uv, 0.0);
        float d = s.a;
        float dz_mm = abs(d - depth) * u_mm_per_unit;
        float k = d <= 0.0 ? 1.0 : clamp(u_follow * dz_mm / max(abs(x_mm), 0.05), 0.0, 1.0);
        acc += mix(s.rgb, c.rgb, k) * w;
        wsum += w;
    }
    o_colour = u_premultiplied == 1 ? vec4(acc / wsum * u_weight, u_cov) : vec4(acc / wsum * u_weight, c.a);
}
