// Shared helpers: constants, sRGB transfer, tone mapping, eight lanes in two vec4s.
const float PI = 3.14159265358979;

vec3 linear_to_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

// ACES filmic curve (Narkowicz 2015 fit), input linear scene colour after exposure.
vec3 tonemap_aces(vec3 x) {
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

// u_tonemap: -1 = raw linear output (float targets, tests), 0 = none (clamp), 1 = ACES fit.
vec3 display(vec3 linear_colour, float exposure, int tonemap) {
    vec3 c = linear_colour * exposure;
    if (tonemap < 0) return c;
    if (tonemap == 1) c = tonemap_aces(c);
    return linear_to_srgb(c);
}

// Lane k (0..7) of eight values packed in two vec4s (lanes 0-3 in lo, 4-7 in hi). The subscript is masked
// so that it is in range for every k: a driver that unrolls a loop over k compiles both arms of the
// ternary for each k, and a strict one (NVIDIA) refuses an index it can see out of range even in the arm
// that is never taken (`hi[k - 4]` for k = 0).
float lane8(vec4 lo, vec4 hi, int k) {
    return k < 4 ? lo[k & 3] : hi[k & 3];
}
