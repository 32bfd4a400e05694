#version 450 core
// Lightweight face (Paris et al. 2003): Phong with the fitted skin parameters (lit per vertex, see
// lightweight_face.vert.glsl), modulated by the detail texture *after* lighting; the sensor clamp comes
// only after the modulation, so overexposure loses the detail in the highlights (the paper's Fig. 10a).
// Cosmetic layers: the skin albedo is detail x diffuse; the texture-space KM outputs (R_top, T, R_bottom)
// are applied as in the physical renderer: out = E (R_top + a T^2 / (1 - R_bottom a)).
// Specialised at compile time (llvmpipe runs every instruction of a fragment shader, taken or not):
// LW_NLIGHTS (0..8), LW_SHADOWS (0 off, 1 per pixel, 2 per vertex: folded into v_e0/v_s0), LW_ENV,
// LW_MAKEUP (0/1), LW_NL (the layers' own specular lobes, 0..8); defaults in lightweight.glsl.
#include "lightweight.glsl"
#if LW_MAKEUP
#define KM_LOBES LW_NL
#endif
#include "common.glsl"
#include "lighting.glsl"
#include "km_compose.glsl"
in vec2 v_uv;
in vec3 v_e0;
in vec3 v_s0;
#if LW_NLIGHTS > 0 && LW_SHADOWS == 1
in vec4 v_ls[LW_PAIRS];
in vec4 v_lpos[LW_NLIGHTS];
#endif
uniform sampler2D u_detail;        // RGBA16F, [0, 8]
uniform sampler2D u_r_top;
uniform sampler2D u_transmittance;
uniform sampler2D u_r_bottom;
uniform vec3 u_diffuse;            // D (linear, photograph units)
uniform float u_spec;              // i_s
uniform float u_exposure;
#if LW_MAKEUP && LW_NL > 0
in vec3 v_pos;
in vec3 v_nrm;
uniform sampler2D u_spec0;         // per-layer specular weights (km.frag): layers 0-3, 4-7
uniform sampler2D u_spec1;
uniform vec3 u_eye;
uniform float u_rho;               // the layers' specular intensity (the renderer's layer_spec_intensity)
#endif
out vec4 o_colour;

#if LW_NLIGHTS > 0 && LW_SHADOWS == 1
// One hardware-filtered (2x2 PCF) comparison per light (lighting.glsl's 4 rotated taps cost 4x more on
// llvmpipe, and with 8 lights that was most of the frame).
float lw_shadow(int i) {
    if (u_shadow_par[i].x < 0.5) return 1.0;
    vec3 p = v_lpos[i].xyz / v_lpos[i].w * 0.5 + 0.5;
    if (p.x <= 0.0 || p.x >= 1.0 || p.y <= 0.0 || p.y >= 1.0 || p.z >= 1.0) return 1.0;
    vec4 tile = u_shadow_tile[i];
    return texture(u_shadow, vec3(tile.xy + p.xy * tile.zw, p.z));
}
#endif

void main() {
    vec3 E = v_e0;
    vec3 S = v_s0;
#if LW_NLIGHTS > 0 && LW_SHADOWS == 1
    for (int i = 0; i < LW_NLIGHTS; ++i) {
        vec3 c = u_light_col[i].rgb * lw_shadow(i);
        vec2 ls = (i & 1) == 0 ? v_ls[i >> 1].xy : v_ls[i >> 1].zw;
        E += c * ls.x;
        S += c * ls.y;
    }
#endif
    vec3 detail = texture(u_detail, v_uv).rgb;
    vec3 albedo = detail * u_diffuse;
    vec3 spec = u_spec * S * detail;
#if LW_MAKEUP
    // no test for "makeup here": without layers R_top = 0, T = 1, R_bottom = 0 and this is the identity
    // (a test on R_top's alpha, the smoothing layers' coverage, missed texels with only lipstick)
    vec3 rt = texture(u_r_top, v_uv).rgb;
    vec3 T = texture(u_transmittance, v_uv).rgb;
    vec3 Rb = texture(u_r_bottom, v_uv).rgb;
    albedo = km_over_albedo(rt, T, Rb, albedo);
    spec *= T * T;
#if LW_NL > 0
    // the layers' own lobes, per pixel and light (shadowed per pixel with LW_SHADOWS 1, else not)
    vec4 A0 = texture(u_spec0, v_uv);
    vec4 A1 = texture(u_spec1, v_uv);
    vec3 N = normalize(v_nrm);
    vec3 V = normalize(u_eye - v_pos);
    for (int i = 0; i < LW_NLIGHTS; ++i) {
        vec3 L = light_direction(i, v_pos);
        vec3 Ei = light_irradiance_normal(i, v_pos);
#if LW_SHADOWS == 1 && LW_NLIGHTS > 0
        Ei *= lw_shadow(i);
#endif
        spec += Ei * (u_rho * layer_lobes(kelemen_shared(N, L, V), A0, A1) * max(dot(N, L), 0.0));
    }
#endif
#endif
    vec3 c = (E * albedo + spec) * u_exposure;
    o_colour = vec4(linear_to_srgb(clamp(c, 0.0, 1.0)), 1.0);
}
