#version 450 core
// Copy the KM outputs of a tile evaluated in the scratch target (see KMTextureSpace._draw_tiles) into
// the output maps: texel p of the maps is scratch texel p - u_offset.
uniform sampler2D u_src[5];
uniform ivec2 u_offset;
layout(location = 0) out vec4 o0;
layout(location = 1) out vec4 o1;
layout(location = 2) out vec4 o2;
layout(location = 3) out vec4 o3;
layout(location = 4) out vec4 o4;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy) - u_offset;
    o0 = texelFetch(u_src[0], p, 0);
    o1 = texelFetch(u_src[1], p, 0);
    o2 = texelFetch(u_src[2], p, 0);
    o3 = texelFetch(u_src[3], p, 0);
    o4 = texelFetch(u_src[4], p, 0);
}
