"""``python -m app.screenshots OUT_DIR``: real screenshots of the running studio and kiosk, for the README.

Run under a display (or ``xvfb-run -a -s "-screen 0 1920x1080x24"``).
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path


def _wait(cond: object, timeout: float = 90.0) -> None:
    from PySide6.QtWidgets import QApplication

    end = time.time() + timeout
    while not cond() and time.time() < end:  # type: ignore[operator]
        QApplication.processEvents()
        time.sleep(0.01)
    for _ in range(20):
        QApplication.processEvents()


def _screen_grab(win: object) -> object:
    """The window's pixels as the X server shows them (``QScreen.grabWindow``).

    ``QWidget.grab`` renders the widgets again and leaves the viewport's native GL window blank; the
    screen's copy is what a user sees, the GL frame and its overlay included.
    """
    _wait(lambda: True)
    return win.screen().grabWindow(win.winId())  # type: ignore[attr-defined]


def kiosk_shots(out: Path, tmp: Path) -> None:
    """The kiosk's pictures, written into ``out`` (``tmp``: a scratch folder).

    kiosk_start.png (the attract mode under the invitation), kiosk_tryon.png (the sample face, evening
    look, warm light), kiosk_camera.png ("Try it on me": the preview with its oval and prompt; the camera
    is a video of the Grace Hopper portrait), kiosk_her_face.png (her face, red lip, before/after) and
    kiosk_turn.png (Turn and relight: her face on the full head, turned by a drag).
    """
    import numpy as np
    from PIL import Image

    from app.kiosk.config import KioskConfig, hash_pin
    from app.kiosk.window import KioskWindow
    from core.assets import find_asset

    portrait = find_asset("photos/grace_hopper.jpg")  # the asset search path (SHEER_ASSETS, …)
    with Image.open(portrait) as im:
        rgb = np.asarray(im.convert("RGB"), dtype=np.uint8)
    import cv2

    camera = tmp / "camera.avi"
    writer = cv2.VideoWriter(str(camera), cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (rgb.shape[1], rgb.shape[0]))
    for _ in range(600):
        writer.write(np.ascontiguousarray(rgb[:, :, ::-1]))
    writer.release()
    cfg = KioskConfig(pin_hash=hash_pin("0000"), snapshot_dir=str(tmp / "photos"), fullscreen=False,
                      camera=str(camera))
    kiosk = KioskWindow(cfg)
    kiosk.resize(1600, 1000)
    kiosk.show()
    _wait(lambda: kiosk.isVisible() and kiosk.viewport.frames > 0)
    _wait(lambda: False, 3.0)  # the face turns a little
    _screen_grab(kiosk).save(str(out / "kiosk_start.png"))
    kiosk.show_main()
    kiosk.set_look("evening")
    kiosk.set_light("warm indoor")
    _wait(lambda: kiosk.viewport.frames > 0 and kiosk.viewport.full_quality_ready and kiosk.viewport.settled)
    kiosk.viewport.repaint()
    _wait(lambda: True)
    _screen_grab(kiosk).save(str(out / "kiosk_tryon.png"))
    kiosk.show_start()
    kiosk.tryon_button.click()
    page = kiosk.tryon.camera_page
    _wait(lambda: page.countdown is not None)
    _screen_grab(kiosk).save(str(out / "kiosk_camera.png"))
    _wait(lambda: kiosk.tryon.shopper_view.image is not None, 120.0)
    if kiosk.tryon.renderer is None:
        raise RuntimeError(f"the try-on did not come up ({kiosk.screen_name}): "
                           f"{kiosk.last_error or kiosk.tryon.last_refusal}")
    frames = kiosk.tryon.renderer.frames
    kiosk.set_look("red-lip")
    kiosk.split.setValue(40)
    _wait(lambda: kiosk.tryon.renderer.frames > frames)  # (the two requests may be drawn as one frame)
    _wait(lambda: False, 2.0)
    _screen_grab(kiosk).save(str(out / "kiosk_her_face.png"))
    kiosk.split.setValue(0)
    kiosk.set_view("relight")
    view = kiosk.tryon.shopper_view
    frames = kiosk.tryon.renderer.frames
    view.yaw, view.pitch = view.limits.clamp(15.0, -5.0)  # a drag: her face on her head, turned
    view.turned.emit(view.yaw, view.pitch)
    _wait(lambda: kiosk.tryon.renderer.frames > frames)
    _wait(lambda: False, 2.0)
    _screen_grab(kiosk).save(str(out / "kiosk_turn.png"))
    print(f"try-on: shutter to her first made-up frame {kiosk.tryon.timings.get('tryon_first_frame_s', 0):.2f} s")
    kiosk.close_without_pin()


def main(argv: list[str]) -> int:
    """Write studio_*.png and kiosk_*.png into ``argv[0]`` (default docs/images) and list them; returns 0.

    ``--kiosk`` after the folder: the kiosk's pictures only.
    """
    out = Path(argv[0] if argv else "docs/images")
    out.mkdir(parents=True, exist_ok=True)
    from PySide6.QtCore import QSettings

    from app.application import make_application

    make_application()
    tmp = Path(tempfile.mkdtemp(prefix="sheer-shots-"))
    if "--kiosk" in argv[1:]:
        kiosk_shots(out, tmp)
        print("\n".join(str(p) for p in sorted(out.glob("kiosk_*.png"))))
        return 0
    from app.session import Session
    from app.studio.main_window import StudioWindow

    os.environ["SHEER_RECOVERY_DIR"] = str(tmp / "recovery")  # no recovery offer in the pictures
    win = StudioWindow(Session.open(look="natural"), qsettings=QSettings(str(tmp / "s.ini"), QSettings.Format.IniFormat))
    win.resize(1600, 1000)
    win.show()
    vp = win.viewport
    _wait(lambda: vp.frames > 0 and vp.full_quality_ready and vp.settled)
    if "Lipstick Nude" in win.library:
        win.library_dock.select("Lipstick Nude")
    from PySide6.QtCore import QPointF

    vp.brush_ring = vp.pick(QPointF(vp.width() * 0.62, vp.height() * 0.62))  # the brush ring on a cheek
    vp.repaint()
    _wait(lambda: True)
    _screen_grab(win).save(str(out / "studio_main.png"))
    vp.brush_ring = None
    win.change_settings(split=0.5)
    vp.repaint()
    _wait(lambda: True)
    vp.grabFramebuffer().save(str(out / "studio_before_after.png"))
    win.change_settings(split=0.0)
    win.close()

    kiosk_shots(out, tmp)
    print("\n".join(str(p) for p in sorted(out.glob("*_*.png")) if p.name.startswith(("studio_", "kiosk_"))))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
