#version 450 core
// Lightweight face, per-vertex lighting (the paper's engine used OpenGL's fixed-function GL_LIGHTING,
// i.e. Phong evaluated at the vertices and interpolated). Per light, the vertex passes n·l and the
// specular term (point-light falloff folded in) and, with shadows, its light-space position (normal
// offset applied here); the fragment shader only fetches the detail texture and one shadow-map
// comparison per light. Specialised with LW_NLIGHTS, LW_SHADOWS (0 off, 1 per pixel, 2 per vertex), LW_ENV
// (defaults in lightweight.glsl).
#include "lightweight.glsl"
#include "common.glsl"
#include "lighting.glsl"
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;
uniform mat4 u_view_proj;
uniform vec3 u_eye;
uniform float u_shininess;
uniform vec3 u_ambient;
out vec2 v_uv;
out vec3 v_e0;                 // irradiance of the ambient (+ environment) and of unshadowed lights
out vec3 v_s0;                 // specular of unshadowed lights
#if LW_MAKEUP && LW_NL > 0
out vec3 v_pos;                // for the layers' own lobes, per pixel
out vec3 v_nrm;
#endif
#if LW_NLIGHTS > 0 && LW_SHADOWS == 1
out vec4 v_ls[LW_PAIRS];       // per light: n·l x falloff, (r·v)^s x falloff (two lights per vec4)
out vec4 v_lpos[LW_NLIGHTS];   // light clip-space position (normal offset applied)
#endif
void main() {
    vec3 P = in_position;
    vec3 N = normalize(in_normal);
    vec3 V = normalize(u_eye - P);
    v_uv = in_uv;
#if LW_MAKEUP && LW_NL > 0
    v_pos = P;
    v_nrm = N;
#endif
    v_e0 = u_ambient;
    v_s0 = vec3(0.0);
#if LW_ENV
    v_e0 += sh_irradiance(N);
#endif
#if LW_NLIGHTS > 0
    for (int i = 0; i < LW_NLIGHTS; ++i) {
        vec4 lv = u_light_vec[i];
        vec3 L = lv.w > 0.5 ? normalize(lv.xyz - P) : normalize(lv.xyz);
        float fall = 1.0;
        if (lv.w > 0.5) {
            float d = max(length(lv.xyz - P), 1e-3);
            float r = u_light_col[i].a;
            fall = r * r / (d * d);
        }
        float ndl = dot(N, L);
        float spec = ndl > 0.0 ? pow(max(dot(reflect(-L, N), V), 0.0), u_shininess) : 0.0;
        vec2 ls = vec2(max(ndl, 0.0), spec) * fall;
#if LW_SHADOWS
        vec4 par = u_shadow_par[i];
        float c = clamp(ndl, 0.0, 1.0);
        vec3 Po = P + N * par.w * (1.5 + 2.0 * (1.0 - c)) + L * par.z;
        vec4 lpos = u_light_mat[i] * vec4(Po, 1.0);
#endif
#if LW_SHADOWS == 1
        if ((i & 1) == 0) v_ls[i >> 1].xy = ls; else v_ls[i >> 1].zw = ls;
        v_lpos[i] = lpos;
#else
#if LW_SHADOWS == 2
        // Per-vertex shadows (many lights): one hardware-filtered comparison per light at the vertex.
        if (par.x > 0.5) {
            vec3 q = lpos.xyz / lpos.w * 0.5 + 0.5;
            if (q.x > 0.0 && q.x < 1.0 && q.y > 0.0 && q.y < 1.0 && q.z < 1.0) {
                vec4 tile = u_shadow_tile[i];
                ls *= texture(u_shadow, vec3(tile.xy + q.xy * tile.zw, q.z));
            }
        }
#endif
        v_e0 += u_light_col[i].rgb * ls.x;
        v_s0 += u_light_col[i].rgb * ls.y;
#endif
    }
#endif
#if LW_SHADOWS == 1 && (LW_NLIGHTS & 1) == 1
    v_ls[LW_PAIRS - 1].zw = vec2(0.0);
#endif
    gl_Position = u_view_proj * vec4(P, 1.0);
}
