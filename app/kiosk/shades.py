"""The kiosk's "Find my foundation": the three best foundations on the shopper's skin, tap one to wear it.

Her skin is read from her own photograph after "Try it on me" (``skin_source``: the cheeks of her
photograph, colour-corrected when a ColorChecker is in the frame — :mod:`capture.skin`, the reading
``sheer shade match --photo`` makes), else the
configured captured face's fitted diffuse colour, else the head's skin (:meth:`painting.head.Head.skin_rgb`:
the median of its albedo's middle third). The reading and the match run in the thread pool (a checker search takes seconds). It is fitted with the skin model and the library's
foundations ranked on it (:func:`shade.match.match_shades`: own skin as the target, daylight, with the
metamerism check under the store's light F11 and warm indoor light A). Three touch-sized buttons show
the shades over her skin; a line says in plain words which of them change under the shop's light, and
asks her to have the shade confirmed when her skin was hard to read (:func:`shade.match.confidence`).
Tapping one gives the look's foundation layer that shade. The ``found`` signal names the three, so the
kiosk can show each on her face (:meth:`FoundationFinder.set_preview` puts the picture on its button).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from PySide6.QtCore import QSize, Signal
from PySide6.QtGui import QIcon, QImage, QPixmap
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from app.kiosk.pin_pad import big_button

if TYPE_CHECKING:
    from collections.abc import Callable

    from capture.face import Face
    from km.library import Library
    from painting import Document
    from shade.match import ShadeMatch

SHOWN = 3
_PLAIN_LIGHTS = {"D65": "daylight", "F11": "the shop's light", "A": "warm indoor light"}


def plain_warning(shade: ShadeMatch) -> str:
    """One sentence a shopper understands, or "" when the shade holds under every light."""
    if not shade.metameric:
        return ""
    by = shade.de2000_by_illuminant
    worst = max(by, key=lambda k: by[k])
    return f"{shade.name} looks right here but noticeably different in {_PLAIN_LIGHTS.get(worst, worst)}."


class FoundationFinder(QWidget):
    """The kiosk's foundation finder (see the module docstring).

    Args:
        library: the kiosk's library.
        doc: the kiosk's document (its foundation layer gets the shade tapped).
        face: returns the captured face (None without one).
        worn: called after a shade was put on (the kiosk refreshes its labels).
        guard: the kiosk's error guard for handlers.
        skin_source: returns her skin read from her photograph (linear sRGB (3,) and a note), or None.

    Attributes:
        shades: the shades shown, best first.
        note: what the reading of her skin assumes (e.g. an sRGB camera), or "".

    Signals:
        found(list[str]): the names of the shades shown, best first.
    """

    found = Signal(list)

    def __init__(self, library: Library, doc: Document, face: Callable[[], Face | None], worn: Callable[[], Any],
                 guard: Callable[[Callable[..., Any]], Callable[..., Any]],
                 skin_source: Callable[[], tuple[np.ndarray, str] | None] | None = None) -> None:
        super().__init__()
        self.library, self.doc, self.face, self.worn = library, doc, face, worn
        self.guard, self.skin_source = guard, skin_source
        self.shades: list[ShadeMatch] = []
        self.note = ""
        self.busy = False
        self.find_button = big_button("Find my foundation")
        self.find_button.clicked.connect(guard(self.find))
        self.shade_buttons = [big_button("", 64) for _ in range(SHOWN)]
        for i, b in enumerate(self.shade_buttons):
            b.clicked.connect(guard(lambda _c=False, i=i: self.wear(i)))
            b.hide()
        self.message = QLabel("")
        self.message.setWordWrap(True)
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(self.find_button)
        for b in self.shade_buttons:
            lay.addWidget(b)
        lay.addWidget(self.message)

    def skin_rgb(self) -> np.ndarray:
        """Her skin, linear sRGB: from her photograph, else the captured face's diffuse colour, else the head's albedo."""
        read = self.skin_source() if self.skin_source is not None else None
        if read is not None:
            self.note = read[1]
            return np.asarray(read[0], dtype=np.float64)
        self.note = ""
        face = self.face()
        if face is not None:
            return np.asarray(face.params.diffuse, dtype=np.float64)
        return self.doc.head.skin_rgb()

    def find(self) -> None:
        """Read her skin and rank the foundations on it in the thread pool; then show the three best."""
        if self.busy:
            return
        from app.workers import run_task

        self.busy = True
        self.find_button.setEnabled(False)
        self.message.setText("Reading your skin…")
        for b in self.shade_buttons:
            b.hide()

        def job(_progress: Any, _cancelled: Any) -> tuple[list[ShadeMatch], bool]:
            from km.skin import fit_skin
            from shade.match import ShadeBank, confidence, foundations, match_shades

            fit = fit_skin(linear_rgb=self.skin_rgb())
            bank = ShadeBank.from_materials(foundations(self.library))
            # the confidence `sheer shade match` states: low when the model cannot make her skin's colour
            return match_shades(fit.reflectance, fit.reflectance, bank), confidence(fit).hard_to_read

        run_task(None, "", job, self.guard(self._show), self.guard(self._failed), show_progress=False)

    def _failed(self, message: str) -> None:
        self.busy = False
        self.find_button.setEnabled(True)
        raise RuntimeError(f"Find my foundation: {message}")

    def _show(self, result: tuple[list[ShadeMatch], bool]) -> None:
        ranked, hard_to_read = result
        self.busy = False
        self.find_button.setEnabled(True)
        self.shades = ranked[:SHOWN]
        for b, s in zip(self.shade_buttons, self.shades):
            b.setText(f"{s.name}  ·  ΔE {s.de2000:.1f}")
            dark = int(s.swatch_hex[1:3], 16) + int(s.swatch_hex[3:5], 16) + int(s.swatch_hex[5:7], 16) < 384
            b.setStyleSheet(f"background: {s.swatch_hex}; color: {'#f4efe9' if dark else '#1d1b1c'};")
            b.show()
        for b in self.shade_buttons[len(self.shades):]:
            b.hide()
        warnings = [w for w in (plain_warning(s) for s in self.shades) if w]
        words = " ".join(warnings) or "These match in daylight, in the shop and at home."
        if hard_to_read:
            words += " Your skin is hard to read in this photo: please ask us to confirm the shade."
        self.message.setText(words)
        self.found.emit([s.name for s in self.shades])

    def reset(self) -> None:
        """Forget the shades shown (a new shopper)."""
        self.shades = []
        self.note = ""
        for b in self.shade_buttons:
            b.setIcon(QIcon())
            b.hide()
        self.message.setText("")

    def set_preview(self, index: int, image: QImage) -> None:
        """Show shade ``index`` on her face: ``image`` as the icon of its button."""
        b = self.shade_buttons[index]
        side = max(48, b.height() - 12)
        b.setIcon(QIcon(QPixmap.fromImage(image)))
        b.setIconSize(QSize(side, side))

    def wear(self, index: int) -> None:
        """Give the look's foundation layer the shade of button ``index``."""
        shade = self.shades[index]
        layer = next((i for i, lay in enumerate(self.doc.layers)
                      if lay.material in self.library and self.library.get(lay.material).category == "foundation"),
                     None)
        if layer is None:
            self.message.setText("This look has no foundation: pick another look first.")
            return
        self.doc.set_layer(layer, material=shade.name)
        self.doc.clear_history()
        self.message.setText(f"You are wearing {shade.name}.")
        self.worn()
