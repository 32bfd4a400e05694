"""km.cache: the spectral → RGB matrix on disk equals km.colour's, survives a broken file, and a process
that reads it does not import colour-science."""

from __future__ import annotations

import subprocess
import sys
from typing import TYPE_CHECKING

import numpy as np
import pytest

from core.cache import cache_dir, load_array, save_array
from km.cache import _matrix_path, spectral_rgb_matrix_cached

if TYPE_CHECKING:
    from pathlib import Path


@pytest.fixture(autouse=True)
def _private_cache(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("SHEER_CACHE_DIR", str(tmp_path))


def test_equals_km_colour_and_is_written_once(tmp_path: Path) -> None:
    from km.colour import spectral_rgb_matrix

    wl = np.arange(380.0, 781.0, 10.0)
    first = spectral_rgb_matrix_cached(wl)
    path = _matrix_path(wl, "D65", "CAT02")
    assert path.is_file() and path.parent == cache_dir("colour") and str(path).startswith(str(tmp_path))
    again = spectral_rgb_matrix_cached(wl)
    np.testing.assert_array_equal(first, spectral_rgb_matrix(wl))
    np.testing.assert_array_equal(again, first)
    assert not again.flags.writeable
    other = spectral_rgb_matrix_cached(wl, "D50")  # another key, another file
    assert not np.array_equal(other, first)


@pytest.mark.parametrize("damage", [b"", b"not a numpy file", b"\x93NUMPY\x01\x00garbage"])
def test_a_broken_cache_file_is_made_again(damage: bytes) -> None:
    from km.colour import spectral_rgb_matrix

    wl = np.arange(400.0, 701.0, 20.0)
    path = _matrix_path(wl, "D65", "CAT02")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(damage)
    np.testing.assert_array_equal(spectral_rgb_matrix_cached(wl), spectral_rgb_matrix(wl))
    assert load_array(path, 1).shape == (wl.size, 3)


def test_wrong_shape_in_the_cache_is_not_trusted() -> None:
    wl = np.arange(380.0, 781.0, 10.0)
    path = _matrix_path(wl, "D65", "CAT02")
    save_array(path, np.ones((3, 3)), 1)  # a well-formed entry of the wrong shape
    assert spectral_rgb_matrix_cached(wl).shape == (wl.size, 3)


def test_reading_the_cache_does_not_import_colour_science(tmp_path: Path) -> None:
    wl = np.arange(380.0, 781.0, 10.0)
    spectral_rgb_matrix_cached(wl)  # fill it
    code = ("import sys, numpy as np\n"
            "from km.cache import spectral_rgb_matrix_cached\n"
            "spectral_rgb_matrix_cached(np.arange(380.0, 781.0, 10.0))\n"
            "print('colour' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"SHEER_CACHE_DIR": str(tmp_path), "PATH": "/usr/bin:/bin"})
    assert out.stdout.strip() == "False"


def test_swatches_equal_km_colour_and_srgb_encoding_equals_colour_science() -> None:
    import colour

    import km
    from km.colour import spectrum_to_rgb
    from km.srgb import srgb_encode

    x = np.concatenate([np.linspace(-0.1, 1.2, 400), [0.0031308, 0.0031309, 1.0]])
    clipped = np.clip(x, 0, 1)
    np.testing.assert_allclose(srgb_encode(clipped), colour.cctf_encoding(clipped, function="sRGB"),
                               rtol=0, atol=1e-12)
    for mat in list(km.default_library())[:6]:
        for bg, illum in (("opaque", "D65"), ("black", "D50"), (0.4, "A")):
            refl = mat.r_inf() if bg == "opaque" else mat.reflectance_over(bg, None)
            want = spectrum_to_rgb(refl, mat.wavelengths, illuminant=illum)
            np.testing.assert_allclose(mat.swatch_rgb(bg, illuminant=illum, encoded=False), want, rtol=1e-13,
                                       atol=1e-15)
