// Kelemen/Szirmay-Kalos specular (Huang 2013 Eq. 5): P_H(H) F(H.L) / (2 (1 + L.V)), with the Beckmann
// distribution for P_H and Schlick's Fresnel. Returns the BRDF times pi (display units: a Lambert
// surface of reflectance R shows R E), so multiply by E cos(theta) of the light.
//
// Beckmann: P_H = exp(-tan^2(a) / m^2) / (pi m^2 cos^4(a)), a the angle between N and H.
// Several lobes (the skin and each cosmetic layer) share N, L and V: kelemen_shared computes what does
// not depend on (m, f0) once, and kelemen_lobe then costs one exp and a few multiplies per lobe. The
// divisions are hoisted (llvmpipe's divide is many times dearer than a multiply): a lobe takes 1/m^2.

// shared = (tan^2(a), Schlick's (1 - H.V)^5, 1 / (cos^4(a) hh) where hh = |L + V|^2 = 2 (1 + L.V),
//           valid 1/0: N.H > 0 and L != -V)
vec4 kelemen_shared(vec3 N, vec3 L, vec3 V) {
    vec3 h = L + V;
    float hh = max(dot(h, h), 1e-8);
    vec3 H = h * inversesqrt(hh);
    float ndoth = dot(N, H);
    float c2 = max(ndoth * ndoth, 1e-4);
    float inv_c2 = 1.0 / c2;
    float b = 1.0 - clamp(dot(H, V), 0.0, 1.0);
    float b2 = b * b;
    return vec4((1.0 - c2) * inv_c2, b2 * b2 * b, inv_c2 * inv_c2 / hh, ndoth > 0.0 && hh > 1e-6 ? 1.0 : 0.0);
}

// One lobe: inv_m2 = 1 / m^2 (Beckmann roughness m), f0 = Fresnel reflectance at normal incidence.
// pi P_H F / hh = exp(-tan^2 / m^2) / (m^2 cos^4 hh) * F
float kelemen_lobe(vec4 sh, float inv_m2, float f0) {
    return sh.w * exp(-sh.x * inv_m2) * inv_m2 * sh.z * (f0 + (1.0 - f0) * sh.y);
}

// The single-lobe model (m: Beckmann roughness > 0).
float kelemen(vec3 N, vec3 L, vec3 V, float m, float f0) {
    return kelemen_lobe(kelemen_shared(N, L, V), 1.0 / (m * m), f0);
}
