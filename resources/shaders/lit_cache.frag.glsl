#version 450 core
// The texture-space cache of view-independent lighting (render/lit_cache.py), at the KM maps' or the
// albedo's resolution, whichever is larger (the paint maps are in the mesh's own UVs: one uv addresses
// the KM maps, the head's albedo and the texture-space irradiance; every input is sampled bilinearly at
// the cache texel's centre, which is the KM texel itself when the sizes agree). Drawn as rectangles over the cache (km_tiles.vert): the whole map, or the
// dirty tiles after a dab. Outputs (linear HDR, display units, RGBA16F):
//   o_diffuse: E*T*sqrt(albedo), the SSS input;             a = 1 on skin, 0 elsewhere (the skin mask)
//   o_outer:   R_top*E, the makeup's own diffuse reflection; a = smoothing coverage (R_top's alpha)
//   o_factor:  sqrt(albedo)*T/(1 - R_bottom*albedo);         a = shadow visibility of light 0
// E = the texture-space irradiance (lights with shadows + SH environment, normal-mapped), bilinear at the
// texel's centre, as the direct path samples it per pixel.
uniform sampler2D u_albedo;   // sRGB -> linear; a: skin mask
uniform sampler2D u_irr;      // E (rgb), a: visibility of light 0
uniform sampler2D u_rtop;     // KM outputs (same size as the cache)
uniform sampler2D u_trans;
uniform sampler2D u_rbottom;
uniform vec2 u_size;          // the cache's size in texels
layout(location = 0) out vec4 o_diffuse;
layout(location = 1) out vec4 o_outer;
layout(location = 2) out vec4 o_factor;
void main() {
    vec2 uv = gl_FragCoord.xy / u_size;
    vec4 am = texture(u_albedo, uv);
    vec3 albedo = am.rgb;
    vec4 irr = texture(u_irr, uv);
    vec4 rt = texture(u_rtop, uv);
    vec3 tr = texture(u_trans, uv).rgb;
    vec3 rb = texture(u_rbottom, uv).rgb;
    vec3 sa = sqrt(max(albedo, vec3(0.0)));
    o_diffuse = vec4(irr.rgb * tr * sa, am.a > 0.5 ? 1.0 : 0.0);
    o_outer = vec4(rt.rgb * irr.rgb, rt.a);
    o_factor = vec4(sa * tr / max(vec3(1.0) - rb * albedo, vec3(1e-4)), irr.a);
}
