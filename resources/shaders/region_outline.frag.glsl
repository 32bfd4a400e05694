#version 450 core
// Facial regions' outlines over a kept frame (with mesh.vert; render/region_overlay.py, issue #16).
// u_masks: the shown regions' soft masks in the paint atlas's UV space (one layer each, row 0 = v 0, as
// the thickness maps); each outline is the mask's 0.5 level, about 2 pixels wide at any zoom, over a faint
// tint of the region's inside. The mask's screen-space rate of change is its texture-space gradient
// (central differences over one texel) times the UVs' screen derivatives: fwidth(mask) itself would
// jump at every UV chart edge (the 2x2 pixel quads' helper lanes sample outside the chart), streaking
// the regions with false outlines.
// u_depth: the depth of the same mesh drawn with the same matrix, so hidden surface is left alone.
uniform sampler2DArray u_masks;
uniform sampler2D u_depth;
uniform int u_count;
uniform vec4 u_colours[16];  // rgb, inside tint alpha
in vec2 v_uv_paint;
out vec4 f_color;
void main() {
    if (gl_FragCoord.z > texelFetch(u_depth, ivec2(gl_FragCoord.xy), 0).r + 1e-6) discard;
    vec4 acc = vec4(0.0);
    vec2 texel = 1.0 / vec2(textureSize(u_masks, 0).xy);
    vec2 duv_dx = dFdx(v_uv_paint), duv_dy = dFdy(v_uv_paint);
    for (int i = 0; i < u_count; ++i) {
        float layer = float(i);
        float m = texture(u_masks, vec3(v_uv_paint, layer)).r;
        vec2 g = vec2(texture(u_masks, vec3(v_uv_paint + vec2(texel.x, 0.0), layer)).r
                      - texture(u_masks, vec3(v_uv_paint - vec2(texel.x, 0.0), layer)).r,
                      texture(u_masks, vec3(v_uv_paint + vec2(0.0, texel.y), layer)).r
                      - texture(u_masks, vec3(v_uv_paint - vec2(0.0, texel.y), layer)).r) / (2.0 * texel);
        float per_px = abs(dot(g, duv_dx)) + abs(dot(g, duv_dy));  // mask change per pixel
        float px = abs(m - 0.5) / max(per_px, 1e-4);  // pixels from the 0.5 level
        float line = 1.0 - smoothstep(0.6, 1.6, px);
        float a = max(line, step(0.5, m) * u_colours[i].a);
        // "over" compositing, front to back in list order
        acc.rgb += (1.0 - acc.a) * a * u_colours[i].rgb;
        acc.a += (1.0 - acc.a) * a;
    }
    if (acc.a <= 0.0) discard;
    f_color = vec4(acc.rgb / acc.a, acc.a);
}
