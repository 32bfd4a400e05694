// Kelemen/Szirmay-Kalos specular (Huang 2013 Eq. 5): P_H(H) F(H.L) / (2 (1 + L.V)), with the Beckmann
// distribution for P_H and Schlick's Fresnel. Returns the BRDF times pi (display units: a Lambert
// surface of reflectance R shows R E), so multiply by E cos(theta) of the light.
float beckmann(float ndoth, float m) {
    float c2 = max(ndoth * ndoth, 1e-4);
    float m2 = m * m;
    return exp((c2 - 1.0) / (m2 * c2)) / (PI * m2 * c2 * c2);
}

float fresnel_schlick(float cos_theta, float f0) {
    float b = 1.0 - clamp(cos_theta, 0.0, 1.0);
    float b5 = b * b * b * b * b;
    return f0 + (1.0 - f0) * b5;
}

float kelemen(vec3 N, vec3 L, vec3 V, float m, float f0) {
    vec3 h = L + V;
    float hh = dot(h, h);
    if (hh < 1e-8) return 0.0;
    vec3 H = h * inversesqrt(hh);
    float ndoth = dot(N, H);
    if (ndoth <= 0.0) return 0.0;
    float ph = beckmann(ndoth, m);
    float f = fresnel_schlick(dot(H, V), f0);
    return PI * max(ph * f / hh, 0.0);   // hh = 2 (1 + L.V)
}

// The same model for several (m, f0) pairs at one (N, L, V): the half vector, N.H and the Fresnel
// power are shared (kelemen_shared), each pair then costs one Beckmann term (kelemen_lobe).
// shared = (N.H, Schlick's (1 - H.V)^5, PI / hh, valid 1/0)
vec4 kelemen_shared(vec3 N, vec3 L, vec3 V) {
    vec3 h = L + V;
    float hh = dot(h, h);
    if (hh < 1e-8) return vec4(1.0, 0.0, 0.0, 0.0);
    vec3 H = h * inversesqrt(hh);
    float ndoth = dot(N, H);
    float b = 1.0 - clamp(dot(H, V), 0.0, 1.0);
    float b5 = b * b * b * b * b;
    return vec4(ndoth, b5, PI / hh, ndoth > 0.0 ? 1.0 : 0.0);
}

float kelemen_lobe(vec4 sh, float m, float f0) {
    float ph = beckmann(sh.x, m);
    float f = f0 + (1.0 - f0) * sh.y;
    return sh.w * max(ph * f * sh.z, 0.0);
}
