#version 450 core
// The brush ring on the visible surface (with mesh.vert): a bright band at the brush radius and a dot at
// its centre, alpha-blended over the kept frame. u_brush: centre (mesh units) and radius (mesh units);
// u_depth: the frame's depth of the same mesh with the same matrix, so hidden surface is left alone.
uniform vec4 u_brush;
uniform sampler2D u_depth;
in vec3 v_pos;
out vec4 f_color;
void main() {
    if (gl_FragCoord.z > texelFetch(u_depth, ivec2(gl_FragCoord.xy), 0).r + 1e-6) discard;
    float d = length(v_pos - u_brush.xyz);
    float w = max(u_brush.w * 0.08, 0.004);
    if (abs(d - u_brush.w) < w) f_color = vec4(1.0, 1.0, 1.0, 0.85);
    else if (d < w) f_color = vec4(1.0, 1.0, 1.0, 0.6);
    else discard;
}
