// The lightweight face's specialisation, shared by lightweight_face.vert and .frag: the defaults of a
// program compiled without defines. LW_NLIGHTS (0..8), LW_SHADOWS (0 off, 1 per pixel, 2 per vertex),
// LW_ENV (1: SH environment), LW_MAKEUP (1: apply the texture-space KM outputs), LW_NL (below).
#ifndef LW_NLIGHTS
#define LW_NLIGHTS 1
#endif
#ifndef LW_SHADOWS
#define LW_SHADOWS 1
#endif
#ifndef LW_ENV
#define LW_ENV 0
#endif
#ifndef LW_MAKEUP
#define LW_MAKEUP 0
#endif
// LW_NL (0..8, with LW_MAKEUP): the cosmetic layers whose own specular lobes are added, per pixel
#ifndef LW_NL
#define LW_NL 0
#endif
// with per-pixel shadows (LW_NLIGHTS > 0 && LW_SHADOWS == 1) the vertex passes the n·l and specular
// terms of two lights per vec4: v_ls[LW_PAIRS]
#define LW_PAIRS ((LW_NLIGHTS + 1) / 2)
