#version 450 core
// Lightweight face (Paris et al. 2003): per light Phong with the fitted skin parameters, modulated by the
// detail texture *after* lighting; the sensor clamp comes only after the modulation (overexposure).
// Cosmetic layers: the skin albedo is detail x diffuse; the texture-space KM outputs (R_top, T, R_bottom)
// are applied as in the physical renderer: out = E (R_top + a T^2 / (1 - R_bottom a)).
#include "common.glsl"
#include "lighting.glsl"
in vec3 v_pos;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;
in float v_depth;
uniform sampler2D u_detail;        // float RGB, [0, 8]
uniform sampler2D u_r_top;
uniform sampler2D u_transmittance;
uniform sampler2D u_r_bottom;
uniform float u_makeup;            // 1 = apply the KM textures
uniform vec3 u_diffuse;            // D (linear, photograph units)
uniform float u_spec;              // i_s
uniform float u_shininess;         // s
uniform vec3 u_ambient;            // k A
uniform vec3 u_eye;
uniform float u_exposure;
out vec4 o_colour;
void main() {
    vec3 N = normalize(v_normal);
    vec3 V = normalize(u_eye - v_pos);
    vec3 E = vec3(0.0);      // irradiance for the diffuse term
    vec3 S = vec3(0.0);      // specular
    for (int i = 0; i < u_nlights; ++i) {
        vec3 L = light_direction(i, v_pos);
        float ndl = dot(N, L);
        if (ndl <= 0.0) continue;
        float sh = shadow_factor(i, v_pos, N, L);
        vec3 Ei = light_irradiance_normal(i, v_pos) * sh;
        E += Ei * ndl;
        vec3 R = reflect(-L, N);
        S += Ei * pow(max(dot(R, V), 0.0), u_shininess);
    }
    E += u_ambient + sh_irradiance(N);
    vec3 detail = texture(u_detail, v_uv).rgb;
    vec3 albedo = detail * u_diffuse;
    vec3 spec = u_spec * S * detail;
    if (u_makeup > 0.5) {
        vec4 rt = texture(u_r_top, v_uv);
        if (rt.a > 0.0) {
            vec3 T = texture(u_transmittance, v_uv).rgb;
            vec3 Rb = texture(u_r_bottom, v_uv).rgb;
            albedo = rt.rgb + albedo * T * T / max(vec3(1.0) - Rb * albedo, vec3(1e-4));
            spec *= T * T;
        }
    }
    vec3 c = (E * albedo + spec) * u_exposure;
    o_colour = vec4(linear_to_srgb(clamp(c, 0.0, 1.0)), 1.0);
}
