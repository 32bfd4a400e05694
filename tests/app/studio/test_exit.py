"""A whole studio session (start, first full-quality frame, a stroke, close — answering the real "Save
the changes?" question with Discard) in a child process ends cleanly: exit status 0, no GL error at release,
no crash or traceback while Python and Qt tear down."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

pytestmark = [pytest.mark.qt, pytest.mark.gl]

SESSION = textwrap.dedent("""
    import sys, tempfile
    from pathlib import Path
    from app.application import make_application
    app = make_application()
    from PySide6.QtCore import QPoint, QSettings, Qt, QTimer
    from PySide6.QtTest import QTest
    from PySide6.QtWidgets import QApplication, QMessageBox
    from app.studio.main_window import StudioWindow
    from app.session import Session
    def discard():  # the user answers the unsaved-changes question
        for box in QApplication.topLevelWidgets():
            if isinstance(box, QMessageBox) and box.isVisible():
                print("asked:", box.text(), flush=True)
                next(b for b in box.buttons() if b.text() == "Discard").click()
    answering = QTimer()
    answering.timeout.connect(discard)
    answering.start(20)
    ini = Path(tempfile.mkdtemp()) / "s.ini"
    win = StudioWindow(Session.open(look="natural"), qsettings=QSettings(str(ini), QSettings.Format.IniFormat))
    win.resize(640, 480)
    win.show()
    def step():
        vp = win.viewport
        if not (vp.frames and vp.full_quality_ready):
            QTimer.singleShot(50, step)
            return
        c = QPoint(vp.width() // 2, vp.height() // 2)
        QTest.mousePress(vp, Qt.MouseButton.LeftButton, pos=c)
        QTest.mouseMove(vp, QPoint(c.x() + 10, c.y()))
        QTest.mouseRelease(vp, Qt.MouseButton.LeftButton, pos=QPoint(c.x() + 10, c.y()))
        win.close()
        print("GL at release:", vp.gl_error_at_release, flush=True)
        app.quit()
    QTimer.singleShot(0, step)
    sys.exit(app.exec())
""")


def test_studio_session_exits_cleanly(tmp_path: object) -> None:
    if not os.environ.get("DISPLAY"):
        pytest.skip("needs a display (run under xvfb-run)")
    env = dict(os.environ, SHEER_RECOVERY_DIR=str(tmp_path))
    proc = subprocess.run([sys.executable, "-c", SESSION], capture_output=True, text=True, timeout=180, env=env)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "GL at release: GL_NO_ERROR" in proc.stdout
    assert "asked: Save the changes to Untitled?" in proc.stdout, "the stroke left no unsaved changes to ask about"
    for bad in ("Fatal Python error", "Segmentation fault", "Traceback"):
        assert bad not in proc.stderr, proc.stderr[-2000:]
