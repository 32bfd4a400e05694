#version 450 core
// Pad texture-space maps beyond chart borders in one pass: every texel copies the texel that
// u_index names (itself where covered, else the nearest covered texel, precomputed once per layout
// and size: see TextureIrradiance in render/renderer.py), so bilinear sampling at UV seams never reads
// the empty background.
uniform isampler2D u_index;  // rg: (x, y) of the source texel
uniform sampler2D u_src0;
uniform sampler2D u_src1;
uniform sampler2D u_src2;
layout(location = 0) out vec4 o0;
layout(location = 1) out vec4 o1;
layout(location = 2) out vec4 o2;
void main() {
    ivec2 q = texelFetch(u_index, ivec2(gl_FragCoord.xy), 0).xy;
    o0 = texelFetch(u_src0, q, 0);
    o1 = texelFetch(u_src1, q, 0);
    o2 = texelFetch(u_src2, q, 0);
}
