#version 450 core
// Final composite: skin diffuse after SSS, out-scatter through the makeup (factor = sqrt(albedo) T /
// (1 - R_bottom albedo)), plus the makeup's reflection and the specular (outer); exposure, tone map, sRGB.
// u_mode: 0 = no SSS; 1 = reference: w0 E + the accumulated blurred Gaussians (w0: the narrowest
// Gaussian, below a pixel); 2 = fast: c^2 E + the (half-resolution, premultiplied) wide part.
// u_debug != 0: show outer (the debug view's colour) as it is.
#include "common.glsl"
// Drawn with the head's convex hull (render/cover.py) or the head itself (composite.vert; the lit pass's
// transform and culling): every head pixel runs it; the hull's other pixels (no diffuse written: alpha 0)
// write u_clear_colour, the target's clear colour, so both covers give the same image.
uniform sampler2D u_src;      // unblurred diffuse; a = coded depth (see frame.frag)
uniform sampler2D u_accum;    // mode 1: sum of weighted Gaussians (full res); mode 2: wide part (rgb, coverage)
uniform sampler2D u_factor;   // rgb: out-scatter factor; a = linear depth (0 = background)
uniform sampler2D u_outer;
uniform vec3 u_w0;
uniform sampler2D u_accum_half; // mode 1: the Gaussians summed on the half-resolution grid (premultiplied)
uniform vec3 u_whalf;          // their total weight (fallback where no skin sample is near)
uniform int u_mode;
uniform int u_debug;
uniform vec3 u_clear_colour;  // the target's clear colour as stored (sRGB-encoded unless raw)
uniform float u_exposure;
uniform int u_tonemap;
uniform ivec2 u_origin;       // the viewport's origin in the target framebuffer
out vec4 o_colour;
// MODE and DEBUG may be defined (specialised programs: llvmpipe runs both sides of a branch, so only
// the fetches the mode needs are compiled in); undefined, the uniforms choose.
#ifndef MODE
#define MODE u_mode
#endif
#ifndef DEBUG
#define DEBUG u_debug
#endif
// linear -> sRGB (IEC 61966-2-1) with three square roots instead of pow: 1.055 c^(1/2.4) - 0.055 fitted
// (minimax) by sqrt(c), c^(1/4), c^(1/8), c and 1 over [0.0031308, 1]; off by at most 0.008/255, so the
// 8-bit result differs from the exact curve's by one level for 0.5 % of the values. llvmpipe evaluates
// pow as exp2(log2(x) * y), two polynomials per channel; this pass alone paid 0.35 baseline frames for it.
vec3 linear_to_srgb_fast(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    vec3 x = sqrt(c), y = sqrt(x), z = sqrt(y);
    vec3 hi = 0.6539890402678461 * x + 0.6887033893170562 * y - 0.3184658216934523 * z
              - 0.02018860699529245 * c - 0.004069313761769029;
    return mix(c * 12.92, hi, step(vec3(0.0031308), c));
}

vec3 display_fast(vec3 linear_colour, float exposure, int tonemap) {  // display() of common.glsl, faster
    vec3 c = linear_colour * exposure;
    if (tonemap < 0) return c;
    if (tonemap == 1) c = tonemap_aces(c);
    return linear_to_srgb_fast(c);
}

void main() {
    // full-resolution inputs fetched at this pixel (no filtering: cheaper on llvmpipe)
    ivec2 p = ivec2(gl_FragCoord.xy) - u_origin;
    vec4 src = texelFetch(u_src, p, 0);  // a: coded depth, 0 where the lit pass drew nothing (cleared)
    vec2 v_uv = (vec2(p) + 0.5) / vec2(textureSize(u_src, 0));
    if (src.a == 0.0) {
        o_colour = vec4(u_clear_colour, 1.0);
        return;
    }
    vec4 f = texelFetch(u_factor, p, 0);
    vec3 outer = texelFetch(u_outer, p, 0).rgb;
    if (DEBUG != 0) { o_colour = vec4(linear_to_srgb(outer), 1.0); return; }
    vec3 d = src.rgb;
    if (src.a > 0.0) {
        if (MODE == 1) {
            vec4 half_sum = textureLod(u_accum_half, v_uv, 0.0);
            vec3 wide = half_sum.a > 1e-3 ? half_sum.rgb / half_sum.a : src.rgb * u_whalf;
            d = src.rgb * u_w0 + texelFetch(u_accum, p, 0).rgb + wide;
        } else if (MODE == 2) {
            vec4 wide = textureLod(u_accum, v_uv, 0.0);
            if (wide.a > 1e-3) d = src.rgb * u_w0 + wide.rgb / wide.a;
        }
    }
    vec3 c = d * f.rgb + outer;
    o_colour = vec4(display_fast(c, u_exposure, u_tonemap), 1.0);
}
