"""The lens's falloff (capture.vignetting) and ``sheer capture --vignetting``."""

from __future__ import annotations

import contextlib
import io
import json
from typing import TYPE_CHECKING

import numpy as np
import pytest
from PIL import Image

from bench.capture_truth import Sensor
from capture.pipeline import linear_to_srgb8
from capture.vignetting import LensFalloff, VignettingError, flat_field

if TYPE_CHECKING:
    from pathlib import Path


def test_the_falloff_is_lensfuns_pa_model_and_flat_field_undoes_it() -> None:
    falloff = LensFalloff(-0.4)
    img = falloff.image(40, 60)
    assert img.max() <= 1.0 and img[20, 30] > 0.999  # the centre
    assert img[0, 0] == pytest.approx(1.0 - 0.4 * ((29.5 ** 2 + 19.5 ** 2) / (30 ** 2 + 20 ** 2)))
    # The bench's sensor with 40 % vignetting, noise-free, is k1 = -0.4: dividing by it gives the scene back.
    scene = np.random.default_rng(1).uniform(0.05, 0.9, (40, 60, 3))
    recorded = Sensor(vignetting=0.4).apply(scene)
    np.testing.assert_allclose(flat_field(recorded, falloff), scene, atol=1e-12)
    # A pixel the sensor clipped stays clipped (1), and one pushed past 1 by the division is clipped there too.
    assert flat_field(np.ones((40, 60, 3)), falloff).max() == 1.0
    assert LensFalloff(-0.3, 0.1, -0.05).at(1.0) == pytest.approx(0.75)


@pytest.mark.parametrize("text", ["abc", "-0.1,0,0,0", "", "-0.99", "0.2", "nan", "-0.5,-0.6"])
def test_a_falloff_that_is_not_one_is_refused(text: str) -> None:
    with pytest.raises(VignettingError, match="vignetting"):
        LensFalloff.parse(text)


@pytest.fixture(scope="module")
def vignetted(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The validation's CPU scene (256², s 24, i_s 0.18) recorded through a lens losing 40 % in the corners."""
    from bench.capture_synthetic import make_scene, read_env
    from core.assets import find_asset
    from km.srgb import srgb_decode
    from painting.head import load_head

    d = tmp_path_factory.mktemp("vignetting")
    scene = make_scene(load_head(), read_env(str(find_asset("environments/warehouse.exr"))), size=256,
                       probe_size=128)
    photo = srgb_decode(scene.photo_srgb8 / 255.0)
    Image.fromarray(scene.photo_srgb8).save(d / "plain.png")
    Image.fromarray(linear_to_srgb8(Sensor(vignetting=0.4).apply(photo))).save(d / "photo.png")
    Image.fromarray(scene.probe_srgb8).save(d / "probe.png")
    (d / "camera.json").write_text(json.dumps({"P": scene.camera.P.tolist()}))
    return d


def _capture(d: Path, photo: str, out: str, *extra: str) -> tuple[int, str, float]:
    from app.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        rc = main(["capture", "--photo", str(d / photo), "--camera", str(d / "camera.json"), "--probe",
                   str(d / "probe.png"), "--texture-size", "64", "--out", str(d / out), *extra])
    if rc != 0:
        return rc, err.getvalue(), float("nan")
    return rc, err.getvalue(), json.loads((d / out / "face.json").read_text())["phong"]["specular_intensity"]


@pytest.mark.slow
def test_capture_divides_the_photo_by_the_lenss_falloff(vignetted: Path) -> None:
    """Measured: the plain photograph's i_s 0.1816; through the lens 0.1769 (-2.5 %: the lobe's amplitude
    times the falloff where it lies), and 0.1817 with ``--vignetting -0.4``."""
    _, _, plain = _capture(vignetted, "plain.png", "plain")
    _, _, darkened = _capture(vignetted, "photo.png", "darkened")
    rc, err, fixed = _capture(vignetted, "photo.png", "fixed", "--vignetting", "-0.4")
    assert rc == 0, err
    assert "divided by the lens's falloff" in err
    assert darkened < 0.98 * plain  # the falloff at the lobe, read as a darker highlight
    assert abs(fixed / plain - 1.0) < 0.005
    # face.json says which photographs were divided by a falloff, and by which
    record = json.loads((vignetted / "fixed" / "face.json").read_text())["vignetting"]
    assert record == {"k1": -0.4, "k2": 0.0, "k3": 0.0}
    assert "vignetting" not in json.loads((vignetted / "darkened" / "face.json").read_text())


@pytest.mark.slow
@pytest.mark.parametrize(("extra", "message"), [(("--vignetting", "0.3"), "0.05–1"),
                                                (("--vignetting", "x"), "numbers")])
def test_a_bad_vignetting_is_one_line(vignetted: Path, extra: tuple[str, ...], message: str,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main

    rc = main(["capture", "--photo", str(vignetted / "photo.png"), "--camera", str(vignetted / "camera.json"),
               "--out", str(vignetted / "bad"), *extra])
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith("sheer: error")]
    assert rc == 2 and len(lines) == 1 and message in lines[0] and "Traceback" not in err
