#version 450 core
// The mirror view (issue 15): the photograph with the makeup composited physically on the face.
// Per pixel, with the capture's fitted Phong model (capture/phong.py; photograph units, linear sRGB):
//   E = k A + F max(n.l, 0)                      the fitted diffuse irradiance (ambient + flash)
//   S = i_s F max(r.v, 0)^s                      the fitted specular
//   a = (photo - S) / E                          the skin's albedo (the photograph divided by its shading)
//   a' = R_top + a T^2 / (1 - R_bottom a)        the cosmetic layers over it (km_compose.glsl)
//   out = E a' + S T^2 + F max(n.l, 0) rho_s sum_k A_k lobe_k     shaded again (+ the layers' own lobes)
// written as photo + (out - E a - S), so that where there is no makeup (R_top 0, T 1, R_bottom 0, A 0)
// the difference is exactly 0 and the photograph comes back unchanged, also where a had to be clamped
// to [0, 1] (clipped highlights, cast shadows the model does not know). The difference fades to 0 at
// the mesh's open boundary (v_edge) and at its silhouette (n.v -> 0).
// MV_NL (define): the number of cosmetic layers whose specular lobes are added (0..8).
#ifndef MV_NL
#define MV_NL 0
#endif
#define KM_LOBES MV_NL
#include "common.glsl"
#include "specular.glsl"
#include "km_compose.glsl"
in vec3 v_pos;
in vec3 v_normal;
in vec2 v_uv;
in float v_edge;
uniform sampler2D u_photo;          // unit 0: 8-bit sRGB bytes as plain RGBA8, bottom row first
uniform sampler2D u_r_top;          // units 1-3: the KM pass's outputs (linear)
uniform sampler2D u_transmittance;
uniform sampler2D u_r_bottom;
uniform sampler2D u_spec0;          // units 4-5: per-layer specular weights (layers 0-3, 4-7)
uniform sampler2D u_spec1;
uniform vec3 u_ambient;             // k A
uniform vec3 u_flash;               // F (luminance 1)
uniform vec3 u_light_dir;           // unit, towards the flash, mesh coordinates
uniform vec3 u_eye;                 // the camera's centre, mesh units
uniform float u_spec;               // i_s
uniform float u_shininess;          // s
uniform float u_edge_nv;            // n.v below which the difference fades out
uniform float u_rho;                // the layers' specular intensity (the renderer's layer_spec_intensity)
out vec4 o_colour;

float srgb_decode1(float c) {
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

void main() {
    vec3 enc = texelFetch(u_photo, ivec2(gl_FragCoord.xy), 0).rgb;
    vec3 photo = vec3(srgb_decode1(enc.r), srgb_decode1(enc.g), srgb_decode1(enc.b));
    vec3 N = normalize(v_normal);
    vec3 V = normalize(u_eye - v_pos);
    vec3 L = u_light_dir;
    float ndl = dot(N, L);
    vec3 E = u_ambient + u_flash * max(ndl, 0.0);
    float lobe = ndl > 0.0 ? pow(max(dot(reflect(-L, N), V), 0.0), u_shininess) : 0.0;
    vec3 S = u_spec * lobe * u_flash;
    vec3 a = clamp((photo - S) / max(E, vec3(1e-3)), 0.0, 1.0);
    vec3 rt = texture(u_r_top, v_uv).rgb;
    vec3 T = texture(u_transmittance, v_uv).rgb;
    vec3 Rb = texture(u_r_bottom, v_uv).rgb;
    vec3 delta = E * (km_over_albedo(rt, T, Rb, a) - a) + S * (T * T - vec3(1.0));
#if MV_NL > 0
    vec4 A0 = texture(u_spec0, v_uv);
    vec4 A1 = texture(u_spec1, v_uv);
    delta += u_flash * (u_rho * layer_lobes(kelemen_shared(N, L, V), A0, A1) * max(ndl, 0.0));
#endif
    float fade = v_edge * smoothstep(0.0, u_edge_nv, dot(N, V));
    o_colour = vec4(linear_to_srgb(clamp(photo + fade * delta, 0.0, 1.0)), 1.0);
}
