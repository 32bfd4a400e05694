// Cosmetic layers over a diffuse albedo, as the physical renderer composes the texture-space KM outputs
// (render/km_pass.py, km.frag: R_top over black, total transmittance T, R_bottom seen from the skin):
// the light comes in through the stack (T), reflects off the skin (a), inter-reflects between the skin
// and the stack's underside (1 / (1 - R_bottom a)) and goes out through it again (T). Without layers
// (R_top 0, T 1, R_bottom 0) this is a exactly.
vec3 km_over_albedo(vec3 r_top, vec3 T, vec3 r_bottom, vec3 a) {
    return r_top + a * T * T / max(vec3(1.0) - r_bottom * a, vec3(1e-4));
}

// The layers' own specular lobes (Huang 2013 Sec. 3.3, as frame.frag): sum over the KM_LOBES layers
// (a define of the includer, 0..8) of weight x Kelemen lobe, the weights from km.frag's spec maps
// (coverage x the luminance transmittance of the layers above: A0 layers 0-3, A1 layers 4-7).
#ifndef KM_LOBES
#define KM_LOBES 0
#endif
#if KM_LOBES > 0
#include "common.glsl"
#include "specular.glsl"
uniform vec4 u_layer_spec[8];       // per layer: roughness, F0, smooths skin, coverage scale
uniform float u_layer_inv_m2[8];    // 1 / max(roughness, 0.05)^2
float layer_lobes(vec4 ksh, vec4 A0, vec4 A1) {
    float ls = 0.0;
    for (int k = 0; k < KM_LOBES; ++k) {
        float w = lane8(A0, A1, k);
        ls += w * kelemen_lobe(ksh, u_layer_inv_m2[k], u_layer_spec[k].y);
    }
    return ls;
}
#endif
