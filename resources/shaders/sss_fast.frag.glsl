#version 450 core
// Separable SSS (Jimenez et al. 2015): one pass of a pre-integrated 1D kernel along u_dir.
// Kernel taps: u_kernel[i] = (rgb weight, offset in mm), tap 0 the centre. Offsets scale to pixels of
// u_src by the linear depth (u_px_per_mm_at_1 / depth, in u_src's pixels). Follow-surface: a tap whose
// depth differs from the centre's is replaced by the centre colour in proportion to the difference (mm)
// relative to the tap's distance.
// Horizontal pass (u_final = 0): output the blurred colour, a = the centre's coded depth.
// Vertical pass (u_final = 1): output (blur - c^2 * E(centre), 1) on skin, 0 elsewhere: the composite adds
// c^2 * E at full resolution (c = centre weight), so the kernel's sub-pixel core keeps full detail while
// the wide lobes may be computed on a half-resolution grid. Premultiplied: a = coverage.
in vec2 v_uv;
uniform sampler2D u_src;      // rgb; a = linear depth (mesh units) on skin, -depth off skin, 0 background
uniform vec2 u_dir;           // (1,0) or (0,1)
uniform vec4 u_kernel[NTAPS];
uniform float u_px_per_mm_at_1;  // pixels of u_src per mm at depth 1 mesh unit
uniform float u_mm_per_unit;
uniform float u_follow;          // follow-surface strength
uniform float u_width;           // kernel scale (1 = the skin profile)
uniform int u_final;
uniform sampler2D u_centre;      // vertical pass: the unblurred full-resolution diffuse
out vec4 o_colour;

void main() {
    vec2 texel = 1.0 / vec2(textureSize(u_src, 0));
    vec4 c = textureLod(u_src, v_uv, 0.0);
    float depth = c.a;
    if (depth <= 0.0) { o_colour = u_final == 1 ? vec4(0.0) : c; return; }
    float scale = u_width * u_px_per_mm_at_1 / depth;     // source pixels per mm here
    vec3 acc = c.rgb * u_kernel[0].rgb;
    for (int i = 1; i < NTAPS; ++i) {
        vec2 uv = v_uv + u_dir * texel * (u_kernel[i].a * scale);
        vec4 s = textureLod(u_src, uv, 0.0);
        float dz_mm = abs(s.a - depth) * u_mm_per_unit;
        float k = s.a <= 0.0 ? 1.0 : clamp(u_follow * dz_mm / max(abs(u_kernel[i].a) * u_width, 0.05), 0.0, 1.0);
        acc += mix(s.rgb, c.rgb, k) * u_kernel[i].rgb;
    }
    if (u_final == 1) {
        vec3 c2 = u_kernel[0].rgb * u_kernel[0].rgb;
        o_colour = vec4(acc - c2 * textureLod(u_centre, v_uv, 0.0).rgb, 1.0);
    } else {
        o_colour = vec4(acc, depth);
    }
}
