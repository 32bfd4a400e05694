// The texture-space irradiance cache's three targets (TextureIrradiance), written by irradiance.frag and
// padded by pad_gather.frag. o_irr: rgb = E (display units), a = shadow visibility of light 0.
// o_vis0: lights 1-4; o_vis1.rgb: lights 5-7, o_vis1.a = 1 where covered (the padding's coverage; the
// clear leaves 0 elsewhere).
layout(location = 0) out vec4 o_irr;
layout(location = 1) out vec4 o_vis0;
layout(location = 2) out vec4 o_vis1;
