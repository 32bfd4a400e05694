"""A skin colour from a photograph: the colour checker's correction, the face's cheeks (capture.skin), the refusals."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from core.assets import find_asset
from km.colour import delta_e2000, linear_rgb_to_lab
from km.skin import lab_of
from shade.photo import (
    SRGB_ASSUMPTION,
    PhotoError,
    checker_reference_rgb,
    detect_checker,
    read_photo,
    skin_from_photo,
)
from tests.shade.photos import SKIN_BOX, write_photo


@pytest.fixture(scope="module")
def tinted(tmp_path_factory: pytest.TempPathFactory) -> tuple[object, np.ndarray]:
    """A checker and a medium skin photographed under CIE LED-B3 (a bluish 4100 K LED), not white balanced."""
    path = tmp_path_factory.mktemp("photo") / "checker.png"
    return path, write_photo(path, "LED-B3", (0.06, 0.012))


def test_the_checker_corrects_a_tinted_camera_to_within_de_2(tinted: tuple[object, np.ndarray]) -> None:
    path, skin_r = tinted
    encoded = read_photo(path)
    found = detect_checker(encoded)
    assert found is not None
    swatches, de = found
    # the uncorrected patches are far off (the light's tint) ...
    raw = delta_e2000(linear_rgb_to_lab(swatches), linear_rgb_to_lab(checker_reference_rgb()))
    assert raw.mean() > 5.0
    # ... and within ΔE2000 2 on every patch once corrected
    assert de.max() < 2.0
    # the skin in the same photograph comes out as its D65 colour, within the same bound
    skin = skin_from_photo(path, SKIN_BOX)
    assert skin.checker and skin.checker_de2000 is not None and skin.checker_de2000[1] < 2.0
    assert float(delta_e2000(linear_rgb_to_lab(skin.linear_rgb), lab_of(skin_r))) < 2.0


def test_without_a_checker_the_srgb_assumption_is_stated(tmp_path) -> None:
    path = tmp_path / "plain.png"
    write_photo(path, "D65", (0.06, 0.012), checker=False)
    skin = skin_from_photo(path, SKIN_BOX)
    assert not skin.checker and skin.note == SRGB_ASSUMPTION and "sRGB camera" in skin.to_json()["note"]


def test_a_face_is_found_and_its_cheeks_sampled() -> None:
    """The face's cheek band is found by capture.skin (MediaPipe's landmarks), inside the photograph."""
    from capture.skin import skin_from_portrait

    photo = find_asset("photos/grace_hopper.jpg")
    skin = skin_from_portrait(photo, use_checker=False)
    assert skin.source == "face" and len(skin.boxes) == 1
    h, w = np.asarray(Image.open(photo)).shape[:2]
    for x, y, bw, bh in skin.boxes:
        assert x >= 0 and x + bw <= w and y >= 0 and y + bh <= h
    lin = skin.linear_rgb
    assert lin[0] > lin[1] > lin[2] > 0.0  # a skin colour: red over green over blue


def test_refusals(tmp_path) -> None:
    blank = tmp_path / "blank.png"
    Image.fromarray(np.full((120, 160, 3), 128, np.uint8)).save(blank)
    from capture.skin import skin_from_portrait

    with pytest.raises(PhotoError, match="no face found in the photograph; give the skin's region"):
        skin_from_portrait(blank)
    with pytest.raises(PhotoError, match=r"region 150,100,20,30 is outside the photograph \(160×120 px"):
        skin_from_photo(blank, (150, 100, 20, 30))
    junk = tmp_path / "junk.png"
    junk.write_bytes(b"not an image")
    with pytest.raises(PhotoError, match="junk.png: cannot read the photograph"):
        read_photo(junk)
    with pytest.raises(PhotoError, match="no such photograph"):
        read_photo(tmp_path / "missing.png")
