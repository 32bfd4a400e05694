// The texture-space irradiance cache's three targets (TextureIrradiance), written by irradiance.frag and
// padded by pad_gather.frag. o_irr: rgb = E (display units), a = shadow visibility of light 0.
// o_vis0: lights 1-4; o_vis1.rgb: lights 5-7, o_vis1.a = 1 where covered (the padding's coverage; the
// clear leaves 0 elsewhere).
// IRR_ONLY (1: no light but light 0 casts shadows, and the padding's index is made): o_irr alone is
// written and padded; the visibility targets are then never read (frame.frag fetches them only for the
// shadowed lights 1-7), and a relight writes a third of the bytes.
#ifndef IRR_ONLY
#define IRR_ONLY 0
#endif
layout(location = 0) out vec4 o_irr;
#if !IRR_ONLY
layout(location = 1) out vec4 o_vis0;
layout(location = 2) out vec4 o_vis1;
#endif
