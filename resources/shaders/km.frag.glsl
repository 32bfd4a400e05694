#version 450 core
// Texture-space Kubelka-Munk stack, spectral per texel (see render/km_pass.py).
// Defines: NW (wavelength count), MAX_LAYERS, NL (layers this draw evaluates).
// A draw evaluates only the layers that are non-zero somewhere in the texels it covers (llvmpipe does
// not skip a branch, so a layer that is zero everywhere would still cost its 81 wavelengths): sampler
// i and u_scale[i] / u_layer_spec[i] are the draw's i-th layer (bottom first), u_slot[i] its index in
// the stack, which places its specular weight in o_spec0/o_spec1. Layers left out are zero in every
// texel of the draw, where they would change nothing (R0 = 0, T = 1, coverage 0).
// SRGB_OUT = 1: the colour outputs go to GL_SRGB8_ALPHA8 maps (written as they are, no
// GL_FRAMEBUFFER_SRGB): encode them here; the lit pass's sampler decodes them to linear.
#ifndef SRGB_OUT
#define SRGB_OUT 0
#endif
#include "km.glsl"
#include "common.glsl"

vec3 encode_out(vec3 c) {
#if SRGB_OUT
    return linear_to_srgb(c);
#else
    return c;
#endif
}

layout(std140, binding = 0) uniform KMParams {
    vec4 u_skb[MAX_LAYERS * NW];   // per layer, per wavelength: S, K (per mm), beta = sqrt(K^2 + 2KS)
    vec4 u_rgb[NW];                // wavelength -> linear sRGB weights (xyz); w: luminance weight
};
uniform vec4 u_layer_spec[MAX_LAYERS];   // roughness, F0, smooths skin (1/0), coverage scale (µm)
uniform sampler2D u_thick[MAX_LAYERS];  // µm
uniform float u_scale[MAX_LAYERS];       // µm -> mm times opacity
uniform int u_nlayers;  // == NL (the program is specialised per layer count)
uniform int u_slot[MAX_LAYERS];          // stack index of the draw's i-th layer
uniform ivec2 u_offset;                  // texel = pixel + u_offset (0, or a tile drawn in the scratch target)

layout(location = 0) out vec4 o_rtop;
layout(location = 1) out vec4 o_t;
layout(location = 2) out vec4 o_rbottom;
// specular weights for the lit pass (Huang 2013 Sec. 3.3, bottom-up): layer k's highlight is weighted
// by its coverage c_k = 1 - exp(-X_k / scale_k) and attenuated by the luminance transmittance of every
// layer above it; the skin's highlight is attenuated by T (o_t.rgb).
layout(location = 3) out vec4 o_spec0;   // layers 0-3
layout(location = 4) out vec4 o_spec1;   // layers 4-7

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy) + u_offset;
    float X[NL + 1];
    bool any_layer = false;
    for (int i = 0; i < NL; ++i) {
        X[i] = 0.0;
        if (i < NL) {
            X[i] = max(texelFetch(u_thick[i], p, 0).r, 0.0) * u_scale[i];
            any_layer = any_layer || X[i] > 0.0;
        }
    }
    if (!any_layer) {
        o_rtop = vec4(0.0); o_t = vec4(1.0, 1.0, 1.0, 0.0); o_rbottom = vec4(0.0);  // encode: 0 -> 0, 1 -> 1
        o_spec0 = vec4(0.0); o_spec1 = vec4(0.0);
        return;
    }
    vec3 rt = vec3(0.0), tt = vec3(0.0), rb = vec3(0.0);
    float tl[NL + 1];  // per layer: luminance of its own transmittance
    for (int i = 0; i < NL; ++i) tl[i] = 0.0;
    for (int w = 0; w < NW; ++w) {
        float R = 0.0, Rb = 0.0, T = 1.0;
        for (int i = 0; i < NL; ++i) {
            // X = 0 gives R0 = 0, T = 1 exactly: skipping is only faster (regions of one layer are
            // coherent, so llvmpipe skips whole blocks)
            if (X[i] <= 0.0) continue;
            vec4 skb = u_skb[u_slot[i] * NW + w];
            vec2 rt0 = km_layer(skb.x, skb.y, skb.z, X[i]);
            km_put_on_top(rt0.x, rt0.y, R, Rb, T);
            tl[i] += u_rgb[w].w * rt0.y;
        }
        vec3 m = u_rgb[w].xyz;
        rt += m * R; tt += m * T; rb += m * Rb;
    }
    for (int i = 0; i < NL; ++i)
        if (X[i] <= 0.0) tl[i] = 1.0;
    float A[8] = float[](0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    float above = 1.0, smooth_cov = 0.0, smooth_rough = 0.0;
    for (int i = NL - 1; i >= 0; --i) {
        vec4 ls = u_layer_spec[i];
        float c = 1.0 - exp(-1000.0 * X[i] / max(ls.w, 1e-3));  // X in mm, the scale in µm
        A[i] = c * above;
        above *= clamp(tl[i], 0.0, 1.0);
        if (ls.z > 0.5 && c > smooth_cov) { smooth_cov = c; smooth_rough = ls.x; }
    }
    o_rtop = vec4(encode_out(rt), smooth_cov); o_t = vec4(encode_out(tt), smooth_rough);
    o_rbottom = vec4(encode_out(rb), 1.0);
    vec4 s0 = vec4(0.0), s1 = vec4(0.0);
    for (int i = 0; i < NL; ++i) {
        int k = u_slot[i];
        s0 += vec4(equal(ivec4(0, 1, 2, 3), ivec4(k))) * A[i];
        s1 += vec4(equal(ivec4(4, 5, 6, 7), ivec4(k))) * A[i];
    }
    o_spec0 = s0;
    o_spec1 = s1;
}
