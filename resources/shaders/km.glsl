// Kubelka-Munk layer maths (Huang 2013 Eq. 1-4), stable for S -> 0 and K -> 0.
// With x = bSX = sqrt(K^2 + 2KS) X, f = exp(-x), h = (1 - f^2) / x:
//   R0 = S X h / ((S + K) X h + 1 + f^2),   T = 2 f / ((S + K) X h + 1 + f^2)
// (Eq. 1-2 multiplied through by 2 e^{-x} / b).  S, K per mm; X mm.
vec2 km_layer(float S, float K, float beta, float X) {
    float x = beta * X;
    float f = exp(-x);
    float h = x < 1e-3 ? 2.0 - 2.0 * x + (4.0 / 3.0) * x * x : (1.0 - f * f) / x;
    float inv = 1.0 / ((S + K) * X * h + 1.0 + f * f);
    return vec2(S * X * h * inv, 2.0 * f * inv);
}

// Put a layer (r0, t0) on top of a stack (R seen from above, Rb seen from below, T), Eq. 3-4.
void km_put_on_top(float r0, float t0, inout float R, inout float Rb, inout float T) {
    float d = 1.0 / (1.0 - r0 * R);
    Rb = Rb + T * T * r0 * d;
    R = r0 + t0 * t0 * R * d;
    T = t0 * T * d;
}
