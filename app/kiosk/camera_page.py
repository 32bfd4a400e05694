"""The "Try it on me" camera screen: a live preview with a framing guide, friendly prompts, a countdown.

The preview is the camera's picture mirrored (as a mirror shows her) with an oval where her face should
be. About three times a second the newest frame is checked off the GUI thread by the capture's quality
gate (:func:`check_frame`: face detection and :func:`capture.quality.assess`); its first message is the
prompt ("Turn your face towards the camera", …). When a check passes, a 3-second countdown starts (a
failed check stops it); at zero the shutter takes the newest frame, unmirrored, and :attr:`CameraPage.shot`
carries it. With a watched folder (no camera) the screen asks for the photo and the first one to arrive
is the shot. A camera that stops giving pictures emits :attr:`CameraPage.failed`.

Nothing is written: frames live in memory only.
"""

from __future__ import annotations

import logging
import threading
from typing import TYPE_CHECKING, Any

import numpy as np
from PySide6.QtCore import QRectF, Qt, QTimer, Signal
from PySide6.QtGui import QColor, QImage, QPainter, QPen, QPixmap
from PySide6.QtWidgets import QLabel, QSizePolicy, QVBoxLayout, QWidget

from app.kiosk.pin_pad import big_button

if TYPE_CHECKING:
    from app.camera_source import FrameSource

log = logging.getLogger("sheer.kiosk")

#: What the screen says about the shopper's photograph (and the try-on screen too).
PRIVACY_LINE = ("Your photo stays in this kiosk's memory only while you use it and is deleted when you tap "
                "Done or walk away. Only Save Photo keeps a picture.")
#: Seconds of countdown before the shutter.
COUNTDOWN_S = 3
#: Milliseconds between preview frames, and between quality checks.
FRAME_MS, CHECK_MS = 66, 300
#: Frames are checked at most this many pixels on the long side (the gate's size test is relative).
CHECK_SIDE = 640
#: The prompt while nothing has been checked yet, and when a check passes.
LOOKING, HOLD_STILL = "Look at the camera, with your face inside the oval", "Hold still…"


def check_frame(rgb: np.ndarray) -> list[tuple[str, str]]:
    """The quality gate's verdict on a frame: (code, friendly message) per problem, [] when it would pass.

    The frame is reduced to :data:`CHECK_SIDE` first (a check takes ~30 ms then).
    """
    from app.camera_source import fit_frame
    from capture.landmarks import detect_faces
    from capture.quality import assess

    h, w = rgb.shape[:2]
    small = rgb
    if max(h, w) > CHECK_SIDE:
        import cv2

        s = CHECK_SIDE / max(h, w)
        small = np.ascontiguousarray(cv2.resize(rgb, (round(w * s), round(h * s)), interpolation=cv2.INTER_AREA))
    small = fit_frame(small)
    report = assess(small, detect_faces(small))
    return [(i.code, i.message) for i in report.issues]


def guide_image(rgb: np.ndarray, ok: bool) -> QImage:
    """The frame mirrored, with the framing oval (green when the last check passed); a new QImage."""
    mirrored = np.ascontiguousarray(rgb[:, ::-1])
    h, w = mirrored.shape[:2]
    img = QImage(mirrored.data, w, h, 3 * w, QImage.Format.Format_RGB888).copy()
    p = QPainter(img)
    p.setRenderHint(QPainter.RenderHint.Antialiasing)
    p.setPen(QPen(QColor("#7fd68a" if ok else "#f4efe9"), max(2.0, h / 120.0)))
    oh = 0.62 * h  # the gate wants the face ≥ 30 % of the frame's height: the oval asks for about 60 %
    ow = 0.72 * oh
    p.drawEllipse(QRectF((w - ow) / 2, (h - oh) / 2 - 0.03 * h, ow, oh))
    p.end()
    return img


class CameraPage(QWidget):
    """The camera screen (see the module docstring).

    Signals:
        shot(np.ndarray): the photo taken (uint8 sRGB (H, W, 3), unmirrored).
        failed(str): the camera stopped working (the message is for the log; the screen says it kindly).
        unreadable(str): the photo from the watched folder could not be read (truncated, not an image).
        cancelled(): the shopper tapped Cancel.
        present(): a check found her face in the frame (she is there: the kiosk is not idle).
    """

    shot = Signal(object)
    present = Signal()
    unreadable = Signal(str)
    failed = Signal(str)
    cancelled = Signal()

    def __init__(self) -> None:
        super().__init__()
        self.source: FrameSource | None = None
        self.frame: np.ndarray | None = None
        self.issues: list[tuple[str, str]] = []
        self.checks = 0
        self.countdown: int | None = None
        self._checking = False
        self._check_lock = threading.Lock()
        self.preview = QLabel()
        self.preview.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.preview.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Ignored)
        self.preview.setMinimumSize(160, 120)  # not the pixmap's size: the page must fit any screen
        self.prompt = QLabel(LOOKING)
        self.prompt.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.prompt.setWordWrap(True)
        self.prompt.setStyleSheet("font-size: 34px;")
        self.count_label = QLabel("")
        self.count_label.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.count_label.setStyleSheet("font-size: 72px; font-weight: 600;")
        self.privacy = QLabel(PRIVACY_LINE)
        self.privacy.setWordWrap(True)
        self.privacy.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.privacy.setStyleSheet("color: #b8b0a8; font-size: 16px;")
        self.cancel_button = big_button("Cancel", 72)
        self.cancel_button.setMaximumWidth(420)
        self.cancel_button.clicked.connect(self._cancel)
        lay = QVBoxLayout(self)
        lay.addWidget(self.prompt)
        lay.addWidget(self.preview, 1)
        lay.addWidget(self.count_label)
        lay.addWidget(self.privacy)
        lay.addWidget(self.cancel_button, 0, Qt.AlignmentFlag.AlignHCenter)
        self.frame_timer = QTimer(self)
        self.frame_timer.setInterval(FRAME_MS)
        self.frame_timer.timeout.connect(self._tick)
        self.check_timer = QTimer(self)
        self.check_timer.setInterval(CHECK_MS)
        self.check_timer.timeout.connect(self._check)
        self.count_timer = QTimer(self)
        self.count_timer.setInterval(1000)
        self.count_timer.timeout.connect(self._count)

    # ------------------------------------------------------------------ running
    def start(self, source: FrameSource) -> None:
        """Show the preview from ``source`` (a camera: live, checked, counted down; a folder: waiting)."""
        self.stop()
        self.source = source
        self.issues, self.checks, self.countdown = [], 0, None
        self.count_label.setText("")
        if source.live:
            self.prompt.setText(LOOKING)
            self.check_timer.start()
        else:
            self.prompt.setText("Take your photo with the kiosk's camera: it appears here in a moment")
            self.preview.clear()
        self.frame_timer.start()

    def stop(self) -> None:
        """Stop the preview, release the source and forget the frames."""
        for t in (self.frame_timer, self.check_timer, self.count_timer):
            t.stop()
        if self.source is not None:
            self.source.close()
            self.source = None
        self.frame = None
        self.countdown = None
        self.preview.clear()

    def say(self, message: str) -> None:
        """Show a prompt (e.g. the capture's refusal after the shutter)."""
        self.prompt.setText(message)

    def _cancel(self) -> None:
        self.stop()
        self.cancelled.emit()

    def _tick(self) -> None:
        from app.camera_source import CameraError, CameraGone

        if self.source is None:
            return
        try:
            frame = self.source.read()
        except CameraGone as exc:
            self.stop()
            self.failed.emit(str(exc))
            return
        except CameraError as exc:
            self.stop()
            self.unreadable.emit(str(exc))
            return
        if frame is None:
            return
        self.frame = frame
        if not self.source.live:  # a photo from the watched folder: that is the shot
            self.stop()
            self.shot.emit(frame)
            return
        ok = self.checks > 0 and not self.issues
        pix = QPixmap.fromImage(guide_image(frame, ok))
        self.preview.setPixmap(pix.scaled(self.preview.size(), Qt.AspectRatioMode.KeepAspectRatio,
                                          Qt.TransformationMode.SmoothTransformation))

    # ------------------------------------------------------------------ the gate and the countdown
    def _check(self) -> None:
        """Check the newest frame in the thread pool (one check at a time)."""
        if self.frame is None or self._checking:
            return
        from app.workers import run_task

        frame = self.frame
        self._checking = True

        def job(_progress: Any, _cancelled: Any) -> list[tuple[str, str]]:
            with self._check_lock:
                return check_frame(frame)

        run_task(None, "", job, self._checked, self._check_failed, show_progress=False)

    def _check_failed(self, message: str) -> None:
        self._checking = False
        log.warning("kiosk: the live quality check failed: %s", message)
        self._checked([("check", LOOKING)])

    def _checked(self, issues: list[tuple[str, str]]) -> None:
        self._checking = False
        if self.source is None:
            return
        self.checks += 1
        self.issues = issues
        if not any(code in ("no_face", "check") for code, _ in issues):
            self.present.emit()
        if issues:
            self.prompt.setText(issues[0][1])
            if self.countdown is not None:
                self.countdown = None
                self.count_timer.stop()
                self.count_label.setText("")
            return
        if self.countdown is None:
            self.prompt.setText(HOLD_STILL)
            self.countdown = COUNTDOWN_S
            self.count_label.setText(str(self.countdown))
            self.count_timer.start()

    def _count(self) -> None:
        if self.countdown is None:
            return
        self.countdown -= 1
        if self.countdown > 0:
            self.count_label.setText(str(self.countdown))
            return
        frame = self.frame
        self.stop()
        self.count_label.setText("")
        if frame is not None:
            self.shot.emit(frame)
