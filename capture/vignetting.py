"""The lens's light falloff towards the image's corners (vignetting), and the photograph corrected for it.

A lens passes less light towards the corners of its image: the natural cos⁴ falloff of the field angle
and, wide open, the mechanical vignetting of its barrel. The capture's model (:mod:`capture.phong`) has
no term for it, and nothing in one photograph of a face separates it from the skin's own regional
albedo (measured: a radial falloff fitted to the photograph ÷ the fitted model over the skin reads the
40 % of bench/capture_truth.py's sensor as 0.34–0.48 with it drawn, and −0.33 to +0.34 with none drawn,
on eight GPU-drawn scenes of our own — the face's darker periphery and the ambient's n-dependence are as
large as the falloff itself). Where it is known — a lens profile, a flat-field shot — the photograph is
divided by it before the capture (:func:`flat_field`).

What it costs when it is not: the specular lobe lies near the image's centre, but the lobe's amplitude
is read as i_s × the falloff there, so i_s comes out low by about the falloff at the lobe (a 40 % corner
falloff: 1.6–3.6 % low on eight GPU-drawn scenes of our own from the true camera, the lobe at 0.07–0.09
of the half-diagonal squared), and D absorbs the falloff's mean over the skin.

The model is lensfun's ``pa`` vignetting model (the one its lens profiles give), a polynomial in the
distance r from the image's centre normalised to the half-diagonal (r = 1 in the corners):

    v(r) = 1 + k1·r² + k2·r⁴ + k3·r⁶,

the fraction of the light reaching the sensor there (1 at the centre). bench/capture_truth.py's
``Sensor(vignetting=a)`` is k1 = −a.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.errors import SheerError


class VignettingError(SheerError, ValueError):
    """A falloff that is not one: its coefficients are not numbers, or it leaves no light somewhere."""


@dataclass(frozen=True)
class LensFalloff:
    """The lens's vignetting, lensfun's ``pa`` model (see the module docstring).

    Attributes:
        k1, k2, k3: the coefficients of r², r⁴ and r⁶ (dimensionless; r = 1 in the image's corners).
    """

    k1: float
    k2: float = 0.0
    k3: float = 0.0

    def __post_init__(self) -> None:
        k = np.array([self.k1, self.k2, self.k3], dtype=float)
        if not np.all(np.isfinite(k)):
            raise VignettingError(f"vignetting coefficients must be finite numbers, got {k.tolist()}")
        r2 = np.linspace(0.0, 1.0, 1001)
        v = self.at(r2)
        if v.min() <= 0.05 or v.max() > 1.0 + 1e-9:
            raise VignettingError(
                f"vignetting k1={self.k1:g}, k2={self.k2:g}, k3={self.k3:g} gives a falloff of {v.min():.3f}–"
                f"{v.max():.3f} across the image; a lens passes 0.05–1 of the centre's light everywhere")

    @classmethod
    def parse(cls, text: str) -> LensFalloff:
        """From ``"K1[,K2[,K3]]"`` (the command line's ``--vignetting``); :class:`VignettingError` if malformed."""
        parts = [p.strip() for p in str(text).split(",")]
        if not 1 <= len(parts) <= 3:
            raise VignettingError(f"--vignetting takes K1[,K2[,K3]] (lensfun's pa model), got {text!r}")
        try:
            values = [float(p) for p in parts]
        except ValueError:
            raise VignettingError(f"--vignetting takes numbers K1[,K2[,K3]], got {text!r}") from None
        return cls(*values)

    def at(self, r2: np.ndarray) -> np.ndarray:
        """The falloff v at squared normalised radii ``r2`` (any shape, 0 at the centre, 1 in the corners)."""
        r2 = np.asarray(r2, dtype=np.float64)
        return 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3))

    def image(self, height: int, width: int) -> np.ndarray:
        """The falloff at each pixel's centre of a ``height`` × ``width`` image, float64 (H, W) in (0, 1]."""
        yy, xx = np.mgrid[0:height, 0:width]
        r2 = ((xx + 0.5 - width / 2) ** 2 + (yy + 0.5 - height / 2) ** 2) / ((width / 2) ** 2 + (height / 2) ** 2)
        return self.at(r2)


def flat_field(photo_lin: np.ndarray, falloff: LensFalloff) -> np.ndarray:
    """The photograph as the lens would have recorded it without ``falloff``, linear RGB (H, W, 3) in [0, 1].

    Each pixel is divided by the falloff at its centre, then clipped to 1: a pixel the sensor clipped
    (at v·I = 1) reads 1/v ≥ 1 before the clip and 1 after, as the capture's model clips (at I = 1); a
    pixel that did not clip but exceeds 1 once divided is set to 1 too, so it is treated as clipped —
    the model clips it there as well (its true value is ≥ 1), so nothing is biased, a few pixels at the
    highlight's rim are only left out.
    """
    photo = np.asarray(photo_lin, dtype=np.float64)
    gain = falloff.image(*photo.shape[:2])
    return np.clip(photo / gain[..., None], 0.0, 1.0)
