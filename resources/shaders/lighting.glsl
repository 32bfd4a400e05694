// Lights (up to 8 directional/point), PCF shadow maps and SH environment irradiance.
// Display units: E is the irradiance; a Lambert surface of reflectance R shows R E.
#define MAX_LIGHTS 8
// A program specialised on a light rig defines SHADOWED and POINT_LIGHTS (bit i: light i casts shadows /
// is a point light); unspecialised, every light may cast shadows and each decides per pixel if it is a point.
#ifndef SHADOWED
#define SHADOWED 255
#endif
#ifndef POINT_LIGHTS
#define POINT_LIGHTS -1
#endif
uniform int u_nlights;
uniform vec4 u_light_vec[MAX_LIGHTS];     // xyz: direction to light (w = 0) or position (w = 1)
uniform vec4 u_light_col[MAX_LIGHTS];     // rgb: colour x intensity; a: reference distance (point)
uniform mat4 u_light_mat[MAX_LIGHTS];     // world -> light clip space
uniform vec4 u_shadow_par[MAX_LIGHTS];    // x: shadows on (1/0), y: PCF radius in shadow-map texels, z: bias (world), w: texel size (world)
uniform vec4 u_shadow_tile[MAX_LIGHTS];   // atlas tile: u offset, v offset, u scale, v scale
uniform sampler2DShadow u_shadow;         // depth atlas of every light
uniform vec3 u_sh[9];                     // irradiance SH (already convolved with the clamped cosine)
uniform float u_env_on;

// rotated grid: 4 taps, each a 2x2 hardware-filtered comparison (16 depth tests in all); the SSS blur
// softens the penumbra further
const vec2 PCF4[4] = vec2[](vec2(-0.375, -0.875), vec2(0.875, -0.375), vec2(0.375, 0.875), vec2(-0.875, 0.375));

vec3 light_direction(int i, vec3 P) {
    vec4 v = u_light_vec[i];
    return v.w > 0.5 ? normalize(v.xyz - P) : normalize(v.xyz);
}

vec3 light_irradiance_normal(int i, vec3 P) {  // irradiance on a surface facing the light
    vec4 v = u_light_vec[i];
    if (v.w > 0.5) {
        float d = max(length(v.xyz - P), 1e-3);
        float r = u_light_col[i].a;
        return u_light_col[i].rgb * (r * r) / (d * d);
    }
    return u_light_col[i].rgb;
}

// Percentage-closer filtering (4 rotated-grid taps of 2x2 filtered comparisons), normal offset.
float shadow_factor(int i, vec3 P, vec3 Ng, vec3 L) {
    vec4 par = u_shadow_par[i];
    if (par.x < 0.5) return 1.0;
    float ndl = clamp(dot(Ng, L), 0.0, 1.0);
    vec3 Po = P + Ng * par.w * (1.5 + 2.0 * (1.0 - ndl)) + L * par.z;
    vec4 c = u_light_mat[i] * vec4(Po, 1.0);
    vec3 p = c.xyz / c.w * 0.5 + 0.5;
    if (p.x <= 0.0 || p.x >= 1.0 || p.y <= 0.0 || p.y >= 1.0 || p.z >= 1.0) return 1.0;
    vec4 tile = u_shadow_tile[i];
    vec2 texel = 1.0 / vec2(textureSize(u_shadow, 0));
    vec2 lo = tile.xy + texel, hi = tile.xy + tile.zw - texel;
    vec2 q = tile.xy + p.xy * tile.zw;
    float s = 0.0;
    for (int k = 0; k < 4; ++k)
        s += texture(u_shadow, vec3(clamp(q + PCF4[k] * par.y * texel, lo, hi), p.z));
    return s * 0.25;
}

vec3 sh_irradiance(vec3 n) {
    if (u_env_on < 0.5) return vec3(0.0);
    float x = n.x, y = n.y, z = n.z;
    vec3 e = u_sh[0] * 0.282095
           + u_sh[1] * 0.488603 * y + u_sh[2] * 0.488603 * z + u_sh[3] * 0.488603 * x
           + u_sh[4] * 1.092548 * x * y + u_sh[5] * 1.092548 * y * z
           + u_sh[6] * 0.315392 * (3.0 * z * z - 1.0) + u_sh[7] * 1.092548 * x * z
           + u_sh[8] * 0.546274 * (x * x - y * y);
    return max(e, vec3(0.0));
}
