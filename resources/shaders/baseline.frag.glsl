#version 450 core
// The benchmark's baseline: albedo texture, one Lambert light, no post-processing.
#include "common.glsl"
in vec3 v_normal;  // from mesh.vert
in vec2 v_uv;
uniform sampler2D u_albedo;
uniform vec3 u_light_dir;
out vec4 o_colour;
void main() {
    vec3 a = texture(u_albedo, v_uv).rgb;
    float ndl = max(dot(normalize(v_normal), u_light_dir), 0.0);
    o_colour = vec4(linear_to_srgb(a * ndl), 1.0);
}
