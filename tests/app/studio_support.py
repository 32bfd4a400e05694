"""Shared set-up of a studio window for the Qt tests (a real window under Xvfb with Mesa GL)."""

from __future__ import annotations

import contextlib
import os
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from collections.abc import Iterator

    import pytest


@contextlib.contextmanager
def open_studio_window(qapp: object, tmp_path_factory: pytest.TempPathFactory, *,
                       wait_full_quality: bool = True, check_gl_release: bool = True) -> Iterator[Any]:
    """An 800×600 studio window with its own settings file and recovery folder, shown and drawn once.

    Dialogs dismiss themselves; on exit unsaved work is discarded, the environment restored and, with
    ``check_gl_release``, the viewport must have released its GL objects without a GL error.
    """
    from PySide6.QtCore import QSettings
    from pytestqt.qtbot import QtBot

    from app import dialogs
    from app.main_window import StudioWindow

    dialogs.AUTO_DISMISS_MS = 30
    old_recovery = os.environ.get("SHEER_RECOVERY_DIR")
    os.environ["SHEER_RECOVERY_DIR"] = str(tmp_path_factory.mktemp("recovery"))
    ini = tmp_path_factory.mktemp("settings") / "studio.ini"
    # 512² maps: the behaviour under test does not depend on the resolution, and the default (2048²)
    # triples the module's run time; `sheer bench studio` measures the default
    win = StudioWindow(qsettings=QSettings(str(ini), QSettings.Format.IniFormat), resolution=512)
    win.resize(800, 600)
    win.show()
    if wait_full_quality:
        QtBot(qapp).waitUntil(lambda: win.viewport.frames > 0 and win.viewport.full_quality_ready, timeout=60000)
    else:
        QtBot(qapp).waitUntil(lambda: win.viewport.frames > 0, timeout=60000)
    try:
        yield win
    finally:
        dialogs.AUTO_ANSWER = "discard"
        win.close()
        dialogs.AUTO_ANSWER = None
        if old_recovery is None:
            os.environ.pop("SHEER_RECOVERY_DIR", None)
        else:
            os.environ["SHEER_RECOVERY_DIR"] = old_recovery
    if check_gl_release:
        assert win.viewport.gl_error_at_release == "GL_NO_ERROR"
    win.deleteLater()


def write_test_face(folder: Any) -> Any:
    """A small captured-face folder (``face.json`` + ``detail.exr``, as ``sheer capture`` writes) for the
    sample head: fitted Phong parameters and a detail texture with a visible pattern."""
    import json
    from pathlib import Path

    import numpy as np
    import OpenEXR

    from capture.phong import PhongParams
    from capture.pipeline import FACE_SCHEMA_VERSION

    d = Path(folder)
    d.mkdir(parents=True, exist_ok=True)
    p = PhongParams(diffuse=np.array([0.55, 0.38, 0.3]), specular=0.08, exponent=24.0, ambient_scale=1.0,
                    flash_rgb=np.ones(3), ambient_rgb=np.full(3, 0.05))
    (d / "face.json").write_text(json.dumps({"schema_version": FACE_SCHEMA_VERSION, "phong": p.to_json()}))
    yy, xx = np.mgrid[0:128, 0:128]
    detail = np.repeat((0.8 + 0.4 * (((xx // 16) + (yy // 16)) % 2))[..., None], 3, axis=2).astype(np.float32)
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(hdr, {"RGB": detail}).write(str(d / "detail.exr"))
    return d
