// Cosmetic layers over a diffuse albedo, as the physical renderer composes the texture-space KM outputs
// (render/km_pass.py, km.frag: R_top over black, total transmittance T, R_bottom seen from the skin):
// the light comes in through the stack (T), reflects off the skin (a), inter-reflects between the skin
// and the stack's underside (1 / (1 - R_bottom a)) and goes out through it again (T). Without layers
// (R_top 0, T 1, R_bottom 0) this is a exactly.
vec3 km_over_albedo(vec3 r_top, vec3 T, vec3 r_bottom, vec3 a) {
    return r_top + a * T * T / max(vec3(1.0) - r_bottom * a, vec3(1e-4));
}
