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
// Her lips (render/mirror_lips.py; u_lip_box.z > 0 where the face has her landmarks and a lip layer is on):
// u_lips holds, over a box of the photograph, the lips' antialiased coverage c of her own outer contour and
// her lips' micro-shading m (the photograph's luminance over its low-pass on the lips). The micro-geometry
// shades the layers as it shades the bare lip, so it is divided out of the albedo and multiplies the made-up
// colour: a_m = a / m, out = E m KM(a_m) + ...; the lip layers show only within her contour:
//   delta = mix(delta_rest, delta_all, c)
// with delta_rest the same difference for the other layers alone (u_rest_*: a KM pass without the lip
// layers) and the lip layers' lobes scaled by c. Without lip layers or landmarks this is the plain formula.
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
uniform sampler2D u_rest_r_top;     // units 6-8: the KM pass's outputs without the lip layers
uniform sampler2D u_rest_transmittance;
uniform sampler2D u_rest_r_bottom;
uniform sampler2D u_lips;           // unit 9: RG32F over u_lip_box: her lips' coverage c, micro-shading m
uniform ivec4 u_lip_box;            // x0, y0 (framebuffer pixels, bottom row 0), width, height; width 0: off
#if MV_NL > 0
uniform float u_layer_lip[8];       // per active layer: 1 for a lip layer (clipped to her lips)
#endif
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
    float clip_lips = 1.0;
    vec3 delta;
    if (u_lip_box.z > 0) {
        ivec2 q = ivec2(gl_FragCoord.xy) - u_lip_box.xy;
        vec2 cm = all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, u_lip_box.zw))
            ? texelFetch(u_lips, q, 0).rg : vec2(0.0, 1.0);
        clip_lips = cm.x;
        float m = cm.y;
        vec3 am = clamp(a / m, 0.0, 1.0);
        // E m (KM(a_m) - a_m): exactly 0 without layers, like the plain formula
        vec3 d_all = E * m * (rt + am * (T * T / max(vec3(1.0) - Rb * am, vec3(1e-4)) - vec3(1.0)))
            + S * (T * T - vec3(1.0));
        vec3 rrt = texture(u_rest_r_top, v_uv).rgb;
        vec3 rT = texture(u_rest_transmittance, v_uv).rgb;
        vec3 rRb = texture(u_rest_r_bottom, v_uv).rgb;
        vec3 d_rest = E * (km_over_albedo(rrt, rT, rRb, a) - a) + S * (rT * rT - vec3(1.0));
        delta = mix(d_rest, d_all, clip_lips);
    } else {
        delta = E * (km_over_albedo(rt, T, Rb, a) - a) + S * (T * T - vec3(1.0));
    }
#if MV_NL > 0
    vec4 A0 = texture(u_spec0, v_uv);
    vec4 A1 = texture(u_spec1, v_uv);
    vec4 ksh = kelemen_shared(N, L, V);
    float ls = 0.0;
    for (int k = 0; k < MV_NL; ++k) {
        float w = lane8(A0, A1, k) * (u_layer_lip[k] > 0.5 ? clip_lips : 1.0);
        ls += w * kelemen_lobe(ksh, u_layer_inv_m2[k], u_layer_spec[k].y);
    }
    delta += u_flash * (u_rho * ls * max(ndl, 0.0));
#endif
    float fade = v_edge * smoothstep(0.0, u_edge_nv, dot(N, V));
    o_colour = vec4(linear_to_srgb(clamp(photo + fade * delta, 0.0, 1.0)), 1.0);
}
