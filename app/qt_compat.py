"""Work-arounds for the Qt bindings in use.

PySide6 6.12.0 on CPython 3.11 drops one reference to ``None`` (and, for some calls, to ``True`` or
``False``) on many calls of void Qt methods from Python (e.g. ``QLabel.setText``): measured here, 100 calls
of ``QLabel.setText`` lower ``sys.getrefcount(None)`` by 100. A long session then deallocates ``None``
and aborts ("Fatal Python error: none_dealloc"), typically at exit. CPython 3.12+ makes these
singletons immortal; on 3.11 we give them a reference count so large that the leak can never reach zero
(they are never freed anyway). Called once, before the QApplication is created.
"""

from __future__ import annotations

import ctypes
import sys

_PINNED = False
_HEADROOM = 1 << 40


def pin_singletons() -> None:
    """Make ``None``, ``True`` and ``False`` effectively immortal on CPython < 3.12 (idempotent)."""
    global _PINNED
    if _PINNED or sys.version_info >= (3, 12) or sys.implementation.name != "cpython":
        return
    for obj in (None, True, False, ()):
        ctypes.c_ssize_t.from_address(id(obj)).value += _HEADROOM
    _PINNED = True


def qimage_to_rgb(image: object) -> object:
    """A QImage as a uint8 numpy array (H, W, 3), RGB."""
    import numpy as np
    from PySide6.QtGui import QImage

    img = image.convertToFormat(QImage.Format.Format_RGB32)  # type: ignore[attr-defined]
    w, h = img.width(), img.height()
    arr = np.frombuffer(img.constBits(), np.uint8).reshape(h, img.bytesPerLine() // 4, 4)[:, :w]
    return arr[..., [2, 1, 0]].copy()
