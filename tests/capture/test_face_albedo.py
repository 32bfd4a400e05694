"""A captured face's albedo is a reflectance: the Phong diffuse colour (the photograph's units) scaled so its
median colour has the luminance of the skin the skin model fits to it (capture.face.albedo_scale). Grace
Hopper's portrait (a bright, warm print) gave a quarter of the face's texels a clipped red channel (an
orange face in the studio and in `sheer render --face`); scaled, about 5 %."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pytest

from tests.capture import portraits

if TYPE_CHECKING:
    from pathlib import Path

pytestmark = [pytest.mark.slow, pytest.mark.xdist_group(portraits.GROUP)]


def test_the_albedo_has_the_luminance_of_the_fitted_skin(hopper_face: Path) -> None:
    from capture.face import albedo_scale, load_face
    from km.skin import fit_skin

    face = load_face(hopper_face)
    lin = np.asarray(face.detail, dtype=np.float64) * np.asarray(face.params.diffuse, dtype=np.float64)
    k = albedo_scale(lin)
    texels = lin.reshape(-1, 3)
    median = np.median(texels[texels.sum(axis=1) > 0], axis=0)
    y_skin = ((fit_skin(linear_rgb=median).lab[0] + 16.0) / 116.0) ** 3
    luma = np.array([0.2126, 0.7152, 0.0722])
    assert k < 1.0  # her print is brighter than any skin the model makes
    assert float(k * median @ luma) == pytest.approx(y_skin, rel=1e-9)
    assert albedo_scale(np.zeros((4, 4, 3))) == 1.0  # nothing to scale


def test_the_faces_albedo_is_not_clipped(hopper_face: Path) -> None:
    from capture.face import face_albedo, load_face

    albedo = face_albedo(load_face(hopper_face))
    h, w = albedo.shape[:2]
    centre = albedo[h // 4: 3 * h // 4, w // 4: 3 * w // 4]
    clipped = float((centre[..., 0] >= 254).mean())
    assert clipped < 0.08, clipped  # 0.25 unscaled


def test_an_automatic_capture_records_its_original_absolutely(hopper_face: Path) -> None:
    """face.json ``source_photo``: the photograph's absolute path, which the mirror draws from when the capture
    fitted a reduced copy (``sheer render --view mirror`` without ``--photo``)."""
    from pathlib import Path

    from capture.face import load_face

    source = Path(load_face(hopper_face).data["source_photo"])
    assert source.is_absolute() and source.name == "grace_hopper.jpg" and source.is_file()
