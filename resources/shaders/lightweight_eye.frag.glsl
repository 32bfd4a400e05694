#version 450 core
// Eye highlights (Paris et al. 2003, §5): purely specular cornea spheres, very high exponent, added on top.
#include "common.glsl"
#include "lighting.glsl"
in vec3 v_pos;
in vec3 v_normal;
uniform vec3 u_eye;
uniform float u_shininess;
uniform float u_exposure;
out vec4 o_colour;
void main() {
    vec3 N = normalize(v_normal);
    vec3 V = normalize(u_eye - v_pos);
    vec3 S = vec3(0.0);
    for (int i = 0; i < u_nlights; ++i) {
        vec3 L = light_direction(i, v_pos);
        if (dot(N, L) <= 0.0) continue;
        S += light_irradiance_normal(i, v_pos) * pow(max(dot(reflect(-L, N), V), 0.0), u_shininess);
    }
    // Added to the face's display value (blend ONE, ONE); the display is clamped by the blend target.
    o_colour = vec4(linear_to_srgb(clamp(S * u_exposure, 0.0, 1.0)), 0.0);
}
