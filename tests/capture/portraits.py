"""The public-domain portraits captured once per test process, for every module that captures the same
photograph the same way (the fixtures ``portrait_capture`` and ``hopper_face`` in tests/conftest.py):

- :func:`points_capture`: a portrait (``astronaut`` or ``grace_hopper``) fitted to the sample head from its
  hand-picked points (tests/data/capture/``<name>_points.json``) and captured with a 512² detail texture —
  ``sheer capture --points``'s pipeline (tests/capture/test_photos.py, tests/render/test_mirror.py);
- :func:`cli_capture`: ``sheer capture --photo PHOTO --out DIR`` run through the command line in this
  process, the automatic capture with its defaults (tests/render/test_mirror.py,
  tests/app/commands/test_look_cli.py).

The modules that share one are in one ``xdist_group`` (:data:`GROUP`), so a worker makes it once. Its
arrays are read-only: a test that changed them in place would change what the next test sees.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from capture.camera import Camera
    from capture.pipeline import CaptureResult
    from painting.head import Head

#: The xdist group of the modules that share these captures.
GROUP = "portrait-captures"
DATA = Path(__file__).resolve().parents[1] / "data" / "capture"


@dataclass(frozen=True)
class PointsCapture:
    """A portrait captured on the sample head from its hand-picked points.

    Attributes:
        spec: the points file's JSON. photo_path: the photograph (from the assets' search path).
        head: the sample head. photo: the photograph, linear (H, W, 3). camera: calibrated from the
        points. result: the capture (texture 512²).
    """

    spec: dict[str, Any]
    photo_path: Path
    head: Head
    photo: np.ndarray
    camera: Camera
    result: CaptureResult


def _read_only(value: object) -> None:
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for f in dataclasses.fields(value):
            _read_only(getattr(value, f.name))


@cache
def points_capture(name: str) -> PointsCapture:
    """``name``'s portrait captured from its points (once per process)."""
    from capture.camera import load_points
    from capture.pipeline import capture, read_photo
    from core.assets import find_asset
    from painting.head import load_head

    spec = json.loads((DATA / f"{name}_points.json").read_text())
    photo_path = find_asset(spec["photo"])
    head = load_head()
    photo = read_photo(photo_path)
    camera = load_points(DATA / f"{name}_points.json", photo.shape[1], photo.shape[0])
    result = capture(head, photo, camera, texture_size=512)
    _read_only(photo)
    _read_only(result)
    return PointsCapture(spec, photo_path, head, photo, camera, result)


def cli_capture(photo: Path, out: Path) -> Path:
    """``sheer capture --photo PHOTO --out OUT`` (the automatic capture, its defaults) in this process;
    returns ``out``. Fails with the command's standard error if it does not exit 0."""
    from app.cli import main

    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["capture", "--photo", str(photo), "--out", str(out)])
    assert code == 0, err.getvalue()
    return out
