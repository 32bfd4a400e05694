#version 450 core
// The lit pass (Huang 2013 Fig. 1): irradiance through the makeup, specular, makeup reflection.
// Outputs (linear HDR, display units):
//   o_diffuse: E*T*sqrt(albedo) for the SSS blur; a = linear depth on skin, -depth elsewhere (0: background)
//   o_outer:   R_top*E + specular (not blurred), or the debug view's colour (already final, linear)
//   o_factor:  sqrt(albedo)*T/(1 - R_bottom*albedo) (out-scatter through the makeup); a = linear depth
// Defines (the program is specialised; llvmpipe runs both sides of every branch, so work that a
// uniform would switch off is compiled out instead): NL = number of cosmetic layers, NLIGHTS,
// MAKEUP (1: fetch the KM maps), DEBUG (1: debug views), HAS_SPEC_MAP, HAS_ROUGH_MAP, HAS_SKIN_MASK
// (the skin mask is the albedo texture's alpha), SHADOWED and POINT_LIGHTS (bit i: light i casts
// shadows / is a point light; an unshadowed light needs no visibility fetch, a directional one no
// per-pixel direction or fall-off). CACHED (1: with MAKEUP and without DEBUG) takes the view-independent
// terms (E*T*sqrt(albedo), R_top*E, the out-scatter factor, the skin mask, light 0's visibility, T and the smoothing roughness) from the
// texture-space lighting cache (render/lit_cache.py, lit_cache.frag) instead of computing them here.
#ifndef CACHED
#define CACHED 0
#endif
#ifndef MAKEUP
#define MAKEUP 1
#endif
#ifndef DEBUG
#define DEBUG 1
#endif
#ifndef HAS_SPEC_MAP
#define HAS_SPEC_MAP 1
#endif
#ifndef HAS_ROUGH_MAP
#define HAS_ROUGH_MAP 1
#endif
#ifndef HAS_SKIN_MASK
#define HAS_SKIN_MASK 1
#endif
#include "common.glsl"
#include "lighting.glsl"
#include "specular.glsl"

in vec3 v_pos;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;
in vec2 v_uv_paint;
in float v_depth;

uniform sampler2D u_albedo;      // unit 0, sRGB texture -> linear; a: skin mask
uniform sampler2D u_normal_map;  // unit 1
uniform sampler2D u_spec_map;    // unit 2 (multiplies skin specular)
uniform sampler2D u_rough_map;   // unit 3 (multiplies skin roughness)
uniform sampler2D u_rtop;        // unit 4
uniform sampler2D u_trans;       // unit 5
uniform sampler2D u_rbottom;     // unit 6
uniform sampler2D u_spec0;       // unit 8: per-layer specular weights, layers 0-3 (km.frag)
uniform sampler2D u_spec1;       // unit 16: layers 4-7
uniform sampler2D u_irr;         // unit 25: texture-space irradiance E (rgb), a: visibility of light 0
uniform sampler2D u_vis0;        // unit 26: shadow visibility of lights 1-4
uniform sampler2D u_vis1;        // unit 27: lights 5-7
#if CACHED
// the lighting cache (units 18-22, 32 bits a texel, colours square-root encoded: x = v*v*scale, see lit_cache.py)
uniform sampler2D u_lit_diffuse; // E*T*sqrt(albedo) (scale u_lit_scale), a: skin mask
uniform sampler2D u_lit_outer;   // R_top*E (scale u_lit_scale), a: smoothing coverage
uniform sampler2D u_lit_factor;  // sqrt(albedo)*T/(1 - R_bottom*albedo) (scale 1), a: light 0's visibility
uniform sampler2D u_lit_trans;   // T (linear), a: the smoothing layers' roughness
uniform sampler2D u_lit_spec;    // the layers' highlights as one lobe: sqrt(weight / 4), m, 4 F0
uniform vec3 u_lit_scale;        // the bound of E the colours were encoded with
#endif
#if NL > 0
uniform sampler2D u_layer_thick[NL];  // units 9.. : µm
#endif
uniform vec4 u_layer_spec[8];    // per layer: roughness, F0, smooths skin (1/0), coverage scale (µm)
uniform float u_layer_inv_m2[8]; // per layer: 1 / max(roughness, 0.05)^2 (computed once on the CPU)
uniform float u_lut_max[8];      // µm
uniform float u_opacity[8];      // scales thickness
uniform vec3 u_eye;
uniform float u_normal_strength;
uniform float u_skin_roughness;
uniform float u_skin_f0;
uniform float u_spec_intensity;  // rho_s (the skin's lobe)
uniform float u_layer_spec_intensity;  // the cosmetic layers' lobes (1: their Fresnel reflection)
// The lights' size: a light of angular radius r blurs a Beckmann lobe of roughness m into one of roughness
// sqrt(m^2 + r^2 / 8) (the half vector moves half as far as the light; the slope variances add). Kept
// normalised, so a smooth layer's highlight spreads into a patch the size of the light's reflection instead
// of a point (RenderSettings.light_radius_deg; u_light_spread = r^2 / 8, r in radians).
uniform float u_light_spread;
uniform float u_makeup_on;
uniform ivec3 u_has_maps;        // specular map, roughness map, skin mask present
uniform int u_debug;             // 0 lit, 1 albedo, 2 thickness heat map, 3 R_top, 4 T, 5 irradiance, 6 unlit
uniform int u_debug_layer;

layout(location = 0) out vec4 o_diffuse;
layout(location = 1) out vec4 o_outer;
layout(location = 2) out vec4 o_factor;

vec3 heat(float t) {  // 0 -> dark blue, 1 -> yellow-white
    t = clamp(t, 0.0, 1.0);
    return vec3(smoothstep(0.3, 0.8, t), smoothstep(0.0, 0.6, t) * smoothstep(1.2, 0.6, t) + smoothstep(0.8, 1.0, t),
                0.3 + 0.7 * smoothstep(0.0, 0.3, t) * (1.0 - smoothstep(0.3, 0.7, t)));
}

void main() {
    vec3 Ng = normalize(v_normal);
    vec3 V = normalize(u_eye - v_pos);
    if (dot(Ng, V) < 0.0) Ng = -Ng;  // back faces seen through holes
    vec3 rtop = vec3(0.0), tr = vec3(1.0), rbot = vec3(0.0);
    // foundation smoothing (from the KM pass): coverage of smoothing layers flattens the normal detail
    // and their roughness replaces the skin's
    float smooth_cov = 0.0, smooth_rough = u_skin_roughness;
    vec4 A0 = vec4(0.0), A1 = vec4(0.0);
#if CACHED
    vec4 c_d = texture(u_lit_diffuse, v_uv_paint);
    vec4 c_o = texture(u_lit_outer, v_uv_paint);
    vec4 c_f = texture(u_lit_factor, v_uv_paint);
    vec4 t_full = texture(u_lit_trans, v_uv_paint);
    tr = t_full.rgb;
    smooth_cov = c_o.a;
    smooth_rough = smooth_cov > 0.0 ? t_full.a : u_skin_roughness;
    vec4 c_s = texture(u_lit_spec, v_uv_paint);
    float layer_a = c_s.r * c_s.r * 4.0;
    float layer_m = max(c_s.g, 0.05);
    float layer_inv_m2 = 1.0 / (layer_m * layer_m + u_light_spread);
    float layer_f0 = c_s.b * 0.25;
    bool skin = c_d.a > 0.5;
#else
    vec4 albedo_mask = texture(u_albedo, v_uv);
    vec3 albedo = albedo_mask.rgb;
#if HAS_SKIN_MASK
    bool skin = albedo_mask.a > 0.5;
#else
    bool skin = true;
#endif

    // makeup in texture space
#if MAKEUP
    if (u_makeup_on > 0.5) {
        vec4 rt_full = texture(u_rtop, v_uv_paint);
        vec4 t_full = texture(u_trans, v_uv_paint);
        rtop = rt_full.rgb;
        tr = t_full.rgb;
        rbot = texture(u_rbottom, v_uv_paint).rgb;
        smooth_cov = rt_full.a;
        smooth_rough = smooth_cov > 0.0 ? t_full.a : u_skin_roughness;
        A0 = texture(u_spec0, v_uv_paint);
#if NL > 4
        A1 = texture(u_spec1, v_uv_paint);
#endif
    }
#endif
#endif

    vec3 nt = texture(u_normal_map, v_uv).xyz * 2.0 - 1.0;
    nt.xy *= u_normal_strength * (1.0 - 0.7 * smooth_cov);
    vec3 T = normalize(v_tangent.xyz - Ng * dot(Ng, v_tangent.xyz));
    vec3 B = cross(Ng, T) * v_tangent.w;
    vec3 N = normalize(T * nt.x + B * nt.y + Ng * max(nt.z, 1e-3));
    if (dot(N, V) < 0.0) N = normalize(N - V * dot(N, V) * 1.01);

#if HAS_ROUGH_MAP
    float rough_map = u_has_maps.y != 0 ? texture(u_rough_map, v_uv).r : 1.0;
#else
    float rough_map = 1.0;
#endif
#if HAS_SPEC_MAP
    float spec_map = u_has_maps.x != 0 ? texture(u_spec_map, v_uv).r : 1.0;
#else
    float spec_map = 1.0;
#endif
    float skin_m = mix(u_skin_roughness * rough_map, smooth_rough, smooth_cov);
    float skin_rho = u_spec_intensity * spec_map;
    float skin_m2 = max(skin_m, 0.05);
    float skin_inv_m2 = 1.0 / (skin_m2 * skin_m2 + u_light_spread);

    // diffuse irradiance (lights, shadows, environment) from the texture-space cache
#if CACHED
    vec4 irr = vec4(0.0, 0.0, 0.0, c_f.a);  // only light 0's visibility is needed here
#else
    vec4 irr = texture(u_irr, v_uv);
    vec3 E = irr.rgb;
#endif
#if (SHADOWED & 30) != 0
    vec4 vis0 = texture(u_vis0, v_uv);
#else
    vec4 vis0 = vec4(1.0);
#endif
#if (SHADOWED & 224) != 0
    vec4 vis1 = texture(u_vis1, v_uv);
#else
    vec4 vis1 = vec4(1.0);
#endif
    vec3 spec = vec3(0.0);
    // NLIGHTS (a define: the program is specialised per light count) lets the loop unroll
    for (int i = 0; i < NLIGHTS; ++i) {
        // the loop unrolls, so these tests on the constant i and the defines vanish at compile time
#if POINT_LIGHTS < 0
        bool point = u_light_vec[i].w > 0.5;  // not specialised: decided per pixel
#else
        bool point = ((POINT_LIGHTS >> i) & 1) != 0;
#endif
        vec3 L = point ? light_direction(i, v_pos) : u_light_vec[i].xyz;  // directional: unit on the CPU
        float ndl = dot(N, L);
        // light 0's visibility is the irradiance's alpha, lights 1-4 vis0's lanes, 5-7 vis1's
        float sh = ((SHADOWED >> i) & 1) == 0 ? 1.0 : i == 0 ? irr.a : lane8(vis0, vis1, i - 1);
        vec3 Ei = (point ? light_irradiance_normal(i, v_pos) : u_light_col[i].rgb) * sh;
        // layered specular, bottom-up (Huang 2013 Sec. 3.3): skin, then each layer on top, the
        // highlight below attenuated by the transmittance of the layer above it
        vec4 ksh = kelemen_shared(N, L, V);
        vec3 s = tr * (skin_rho * kelemen_lobe(ksh, skin_inv_m2, u_skin_f0));
#if CACHED
        // the layers' highlights merged into one lobe in the cache (lit_cache.frag)
        s += vec3(layer_a * kelemen_lobe(ksh, layer_inv_m2, layer_f0) * u_layer_spec_intensity);
#elif NL > 0 && MAKEUP
        // zero-coverage layers add a * lobe = 0 (a branch would not save work on llvmpipe)
        float ls = 0.0;
        for (int k = 0; k < NL; ++k) {
            float a = lane8(A0, A1, k);
            ls += a * kelemen_lobe(ksh, 1.0 / (1.0 / u_layer_inv_m2[k] + u_light_spread), u_layer_spec[k].y);
        }
        s += vec3(ls * u_layer_spec_intensity);
#endif
        spec += s * Ei * max(ndl, 0.0);  // no `continue`: llvmpipe runs both sides anyway
    }

#if CACHED
    o_diffuse = vec4(c_d.rgb * c_d.rgb * u_lit_scale, skin ? v_depth : -v_depth);
    o_outer = vec4(c_o.rgb * c_o.rgb * u_lit_scale + spec, 1.0);
    o_factor = vec4(c_f.rgb * c_f.rgb, v_depth);
#else
    vec3 sa = sqrt(max(albedo, vec3(0.0)));
    vec3 out_factor = sa * tr / max(vec3(1.0) - rbot * albedo, vec3(1e-4));
    o_diffuse = vec4(E * tr * sa, skin ? v_depth : -v_depth);
    o_outer = vec4(rtop * E + spec, 1.0);
    o_factor = vec4(out_factor, v_depth);
#endif

#if DEBUG
    if (u_debug != 0) {
        vec3 c = vec3(0.0);
        if (u_debug == 1) c = albedo;
        else if (u_debug == 2) {
#if NL > 0
            int k = clamp(u_debug_layer, 0, NL - 1);
            float Xk = 0.0;
            for (int i = 0; i < NL; ++i)
                if (i == k) Xk = max(texture(u_layer_thick[i], v_uv_paint).r, 0.0) * u_opacity[i];
            c = Xk > 0.0 ? heat(Xk / max(u_lut_max[k], 1e-3)) : vec3(0.02);
#endif
        }
        else if (u_debug == 3) c = rtop;
        else if (u_debug == 4) c = tr;
        else if (u_debug == 5) c = E * 0.25;
        else if (u_debug == 6) c = rtop + albedo * tr * tr / max(vec3(1.0) - rbot * albedo, vec3(1e-4));
        o_outer = vec4(c, 1.0);
    }
#endif
}
