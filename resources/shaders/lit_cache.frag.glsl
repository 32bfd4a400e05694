#version 450 core
// The texture-space cache of view-independent lighting (render/lit_cache.py), at the KM maps' or the
// albedo's resolution, whichever is larger (the paint maps are in the mesh's own UVs: one uv addresses
// the KM maps, the head's albedo and the texture-space irradiance; every input is sampled bilinearly at
// the cache texel's centre, which is the KM texel itself when the sizes agree). Drawn as rectangles over the cache (km_tiles.vert): the whole map, or the
// dirty tiles after a dab. Outputs (RGBA8; colours square-root encoded: v = sqrt(x / scale), the frame
// decodes x = v*v*scale; scale = u_inv_scale's inverse for E's products, 1 for the factor, which is <= 1):
//   o_diffuse: E*T*sqrt(albedo), the SSS input;             a = 1 on skin, 0 elsewhere (the skin mask)
//   o_outer:   R_top*E, the makeup's own diffuse reflection; a = smoothing coverage (R_top's alpha)
//   o_factor:  sqrt(albedo)*T/(1 - R_bottom*albedo);         a = shadow visibility of light 0
//   o_trans:   T (linear);                                   a = the smoothing layers' roughness (T's alpha)
//   o_spec:    the layers' highlights as one lobe: r = sqrt(A / 4), A = the sum of their specular weights
//              (spec0, spec1); g = the lobe's Beckmann roughness m (sqrt of the weight-averaged m^2, the
//              lobes' mean square slope); b = 4 F0 (the weight-averaged F0); a = 0. Exact where one layer
//              has a highlight (most texels); where layers overlap, their lobes are merged into one.
// A coarser level of the cache (1/2, 1/4 of the side) is drawn by the same program at its own size: each
// texel samples the inputs at its centre (for maps twice its resolution, the mean of the 2x2 texels).
// E = the texture-space irradiance (lights with shadows + SH environment, normal-mapped), bilinear at the
// texel's centre, as the direct path samples it per pixel.
#include "common.glsl"
uniform sampler2D u_albedo;   // sRGB -> linear; a: skin mask
uniform sampler2D u_irr;      // E (rgb), a: visibility of light 0
uniform sampler2D u_rtop;     // KM outputs (same size as the cache)
uniform sampler2D u_trans;
uniform sampler2D u_rbottom;
uniform sampler2D u_spec0;    // per-layer specular weights, layers 0-3
uniform sampler2D u_spec1;    // layers 4-7 (define SPEC1: with more than four layers)
uniform vec4 u_layer_spec[8]; // per layer: roughness, F0, smooths skin (1/0), coverage scale (µm)
uniform vec2 u_size;          // the cache's size in texels
uniform vec3 u_inv_scale;     // 1 / the bound of E (render.lit_cache.irradiance_bound), per channel
layout(location = 0) out vec4 o_diffuse;
layout(location = 1) out vec4 o_outer;
layout(location = 2) out vec4 o_factor;
layout(location = 3) out vec4 o_trans;
layout(location = 4) out vec4 o_spec;
vec3 encode(vec3 x) { return sqrt(clamp(x, 0.0, 1.0)); }
void main() {
    vec2 uv = gl_FragCoord.xy / u_size;
    vec4 am = texture(u_albedo, uv);
    vec3 albedo = am.rgb;
    vec4 irr = texture(u_irr, uv);
    vec4 rt = texture(u_rtop, uv);
    vec4 t = texture(u_trans, uv);
    vec3 tr = t.rgb;
    vec3 rb = texture(u_rbottom, uv).rgb;
    vec3 sa = sqrt(max(albedo, vec3(0.0)));
    vec3 e = irr.rgb * u_inv_scale;
    o_diffuse = vec4(encode(e * tr * sa), am.a > 0.5 ? 1.0 : 0.0);
    o_outer = vec4(encode(rt.rgb * e), rt.a);
    o_factor = vec4(encode(sa * tr / max(vec3(1.0) - rb * albedo, vec3(1e-4))), irr.a);
    o_trans = t;
    vec4 a0 = texture(u_spec0, uv);
#if SPEC1
    vec4 a1 = texture(u_spec1, uv);
#else
    vec4 a1 = vec4(0.0);  // at most four layers: layers 4-7 have no weight
#endif
    float A = 0.0, m2 = 0.0, f0 = 0.0;
    for (int k = 0; k < 8; ++k) {
        float a = lane8(a0, a1, k);
        float m = u_layer_spec[k].x;
        A += a;
        m2 += a * m * m;
        f0 += a * u_layer_spec[k].y;
    }
    float inv = A > 0.0 ? 1.0 / A : 0.0;
    o_spec = vec4(sqrt(clamp(A * 0.25, 0.0, 1.0)), sqrt(m2 * inv), clamp(4.0 * f0 * inv, 0.0, 1.0), 0.0);
}
