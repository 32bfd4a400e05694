"""What a frame looks like: :class:`RenderSettings` (one plain object), the debug views and the SSS modes.

No GPU needed: the renderer reads these fields at every :meth:`render.renderer.Renderer.render`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from render.errors import RenderError

#: Debug views (``RenderSettings.debug_view``) → shader code.
DEBUG_VIEWS: dict[str, int] = {
    "none": 0, "albedo": 1, "thickness": 2, "r_top": 3, "transmittance": 4, "irradiance": 5, "unlit": 6,
}
#: subsurface-scattering modes (``RenderSettings.mode``)
MODES = ("fast", "reference", "off")
#: tap counts of the fast mode's kernel (``RenderSettings.taps``)
FAST_TAPS = (11, 17, 25)


@dataclass
class RenderSettings:
    """Everything that changes how a frame looks (one plain object; set fields, then render).

    Attributes:
        mode: ``"fast"`` (Jimenez 2015 separable SSS), ``"reference"`` (Jimenez 2009 sum of Gaussians)
            or ``"off"`` (no subsurface scattering).
        taps: fast-mode kernel taps, 11, 17 or 25.
        exposure: multiplier before tone mapping. tonemap: ``"aces"``, ``"none"`` (clamp) or ``"raw"``
            (linear values, for float targets and tests).
        debug_view: a key of :data:`DEBUG_VIEWS`; debug_layer: layer index for ``"thickness"``.
        makeup: render the cosmetic layers (False = bare skin, for before/after).
        sss_width: scale of the skin profile (1 = d'Eon's measured skin). follow_surface: strength of
            the depth test that stops the blur at silhouettes.
        skin_roughness (Beckmann m), skin_f0 (Fresnel at normal incidence), spec_intensity (rho_s, the
            skin lobe's scale: d'Eon and Luebke's empirical 0.18 for skin).
        layer_spec_intensity: the scale of the cosmetic layers' own lobes; 1 (the default) is their
            Fresnel reflection (Huang 2013 Eq. 5: Kelemen's lobe with Schlick's Fresnel from the layer's
            IOR), which the skin's rho_s does not scale.
        light_radius_deg: the lights' angular radius (degrees) as the face sees them, for the highlights
            only: a studio's soft lights are not points, and a smooth layer reflects each as a patch its
            size (every lobe's roughness m becomes sqrt(m² + r²/8), normalised); 0: point lights.
        normal_strength: tangent-space normal map strength. background: linear RGB.
        shadow_size: shadow-map side (texels); pcf_radius: PCF radius in shadow-map texels.
        irradiance_size: side of the texture-space irradiance cache (texels).
        cull_back_faces: skip triangles facing away (the head and the baseline alike).
        interactive: a frame drawn while the user moves the view or a light (progressive refinement):
            a light that moved is relit at half the irradiance cache's side, and the lighting cache is
            not rebuilt whole (the direct path draws) until a frame that is not interactive.
        lighting_cache: take the view-independent lighting from the texture-space cache
            (:mod:`render.lit_cache`); False computes it per pixel (the direct path, for comparison).
        reference_full_resolution: run every Gaussian of the reference mode at full resolution (default:
            Gaussians wider than 3 pixels run on the half-resolution grid, like the fast mode's wide lobes).
    """

    mode: str = "fast"
    taps: int = 17
    exposure: float = 1.0
    tonemap: str = "aces"
    debug_view: str = "none"
    debug_layer: int = 0
    makeup: bool = True
    sss_width: float = 1.0
    follow_surface: float = 1.0
    skin_roughness: float = 0.35
    skin_f0: float = 0.028
    spec_intensity: float = 0.18
    layer_spec_intensity: float = 1.0
    light_radius_deg: float = 12.0
    normal_strength: float = 1.0
    background: tuple[float, float, float] = (0.045, 0.047, 0.052)
    shadow_size: int = 1024
    pcf_radius: float = 2.5
    irradiance_size: int = 1024
    reference_full_resolution: bool = False
    cull_back_faces: bool = True
    lighting_cache: bool = True
    interactive: bool = False

    def validate(self) -> None:
        """Check every field a frame reads.

        Raises:
            RenderError: an unknown mode, tap count, debug view or tone map, or a negative or non-finite
                exposure, SSS width, follow-surface strength, skin roughness or specular intensity.
        """
        if self.mode not in MODES:
            raise RenderError(f"render mode must be one of {', '.join(MODES)}, got {self.mode!r}")
        if self.taps not in FAST_TAPS:
            raise RenderError(f"fast SSS taps must be one of {FAST_TAPS}, got {self.taps!r}")
        if self.debug_view not in DEBUG_VIEWS:
            raise RenderError(f"unknown debug view {self.debug_view!r} (known: {', '.join(DEBUG_VIEWS)})")
        if self.tonemap not in ("aces", "none", "raw"):
            raise RenderError(f"tonemap must be 'aces', 'none' or 'raw', got {self.tonemap!r}")
        for name in ("exposure", "sss_width", "follow_surface", "skin_roughness", "spec_intensity",
                     "layer_spec_intensity", "light_radius_deg"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise RenderError(f"render setting {name} must be a finite number ≥ 0, got {v!r}")
