#version 450 core
// Texture-space diffuse irradiance (the idea of d'Eon et al. 2007): per texel of the head's UV space,
// the irradiance E from every light (PCF-shadowed) and the environment (SH), with the normal map.
// Lights are fixed to the head, so this is recomputed only when a light or the environment changes;
// frames then fetch E instead of shading lights and shadows per pixel.
// Outputs: E and the shadow visibility of every light, in the cache's targets (irradiance_targets.glsl).
// Defines (specialised per light rig, see TextureIrradiance.program): NLIGHTS, SHADOWED and
// POINT_LIGHTS (bit i: light i casts shadows / is a point light), ENV (1: SH environment).
#ifndef NLIGHTS
#define NLIGHTS 8
#define DYNAMIC_LIGHTS 1
#endif
#ifndef ENV
#define ENV 1
#endif
#include "common.glsl"
#include "lighting.glsl"
#include "irradiance_targets.glsl"
in vec3 v_pos;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;
uniform sampler2D u_normal_map;
uniform float u_normal_strength;

void main() {
    vec3 Ng = normalize(v_normal);
    vec3 nt = texture(u_normal_map, v_uv).xyz * 2.0 - 1.0;
    nt.xy *= u_normal_strength;
    vec3 T = normalize(v_tangent.xyz - Ng * dot(Ng, v_tangent.xyz));
    vec3 B = cross(Ng, T) * v_tangent.w;
    vec3 N = normalize(T * nt.x + B * nt.y + Ng * max(nt.z, 1e-3));
#if ENV
    vec3 E = sh_irradiance(N);
#else
    vec3 E = vec3(0.0);
#endif
    float vis[8] = float[](1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0);
    for (int i = 0; i < NLIGHTS; ++i) {  // unrolled: i is a constant in each copy
#ifdef DYNAMIC_LIGHTS
        if (i >= u_nlights) break;
#endif
#if POINT_LIGHTS < 0
        bool point = u_light_vec[i].w > 0.5;
#else
        bool point = ((POINT_LIGHTS >> i) & 1) != 0;
#endif
        vec3 L = point ? light_direction(i, v_pos) : u_light_vec[i].xyz;  // directional: unit on the CPU
        float ndl = dot(N, L);
        float sh = ((SHADOWED >> i) & 1) != 0 ? shadow_factor(i, v_pos, Ng, L) : 1.0;
        vis[i] = sh;
        E += (point ? light_irradiance_normal(i, v_pos) : u_light_col[i].rgb) * sh * max(ndl, 0.0);
    }
    o_irr = vec4(E, vis[0]);
#if !IRR_ONLY
    o_vis0 = vec4(vis[1], vis[2], vis[3], vis[4]);
    o_vis1 = vec4(vis[5], vis[6], vis[7], 1.0);
#endif
}
