#version 450 core
// Pad the texture-space irradiance cache (irradiance_targets.glsl) beyond chart borders in one pass:
// every texel copies the texel that u_index names (itself where covered, else the nearest covered
// texel, precomputed once per layout and size: see TextureIrradiance in render/irradiance.py), so
// bilinear sampling at UV seams never reads the empty background.
#include "irradiance_targets.glsl"
uniform isampler2D u_index;  // rg: (x, y) of the source texel
uniform sampler2D u_src0;    // the unpadded cache: o_irr's, o_vis0's and o_vis1's texture
#if !IRR_ONLY
uniform sampler2D u_src1;
uniform sampler2D u_src2;
#endif
void main() {
    ivec2 q = texelFetch(u_index, ivec2(gl_FragCoord.xy), 0).xy;
    o_irr = texelFetch(u_src0, q, 0);
#if !IRR_ONLY
    o_vis0 = texelFetch(u_src1, q, 0);
    o_vis1 = texelFetch(u_src2, q, 0);
#endif
}
