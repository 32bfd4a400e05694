#version 450 core
// Draw the mesh unwrapped: each vertex at its UV (texel row 0 = v 0, as every map in Sheer), with the
// world-space varyings of head_vertex.glsl.
#include "head_vertex.glsl"
void main() {
    pass_head_vertex();
    gl_Position = vec4(in_uv * 2.0 - 1.0, 0.0, 1.0);
}
