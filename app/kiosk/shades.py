"""The kiosk's "Find my foundation": the three best foundations on the shopper's skin, tap one to wear it.

Her skin is read from her own photograph after "Try it on me" (``skin_source``: the cheeks of her
photograph, colour-corrected when a ColorChecker is in the frame — :mod:`capture.skin`, the reading
``sheer shade match --photo`` makes), else the
configured captured face's fitted diffuse colour, else the head's skin (:meth:`painting.head.Head.skin_rgb`:
the median of its albedo's middle third). The reading and the match run in the thread pool (a checker search takes seconds). It is fitted with the skin model and the library's
foundations ranked on it (:func:`shade.match.match_shades`: own skin as the target, daylight, with the
metamerism check under the store's light F11 and warm indoor light A). Three touch-sized tiles side by
side show the shades over her skin, each named with a shopper's word for how well it matches
(:func:`match_words`: "great match", "good match" or "nearest we have"; the ΔE figures belong in the
studio); a line says in plain words which of them change under the shop's light, and asks her to have
the shade confirmed when her skin was hard to read (:func:`shade.match.confidence`).
Tapping one gives the look's foundation layer that shade. The ``found`` signal names the three, so the
kiosk can show each on her face (:meth:`FoundationFinder.set_preview` puts the picture on its tile,
:data:`THUMB_PX` tall).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from PySide6.QtCore import QSize, Qt, Signal
from PySide6.QtGui import QIcon, QImage, QPixmap
from PySide6.QtWidgets import QHBoxLayout, QLabel, QSizePolicy, QToolButton, QVBoxLayout, QWidget

from app.kiosk.pin_pad import big_button

if TYPE_CHECKING:
    from collections.abc import Callable

    from capture.face import Face
    from km.library import Library
    from painting import Document
    from shade.match import ShadeMatch

SHOWN = 3
_PLAIN_LIGHTS = {"D65": "daylight", "F11": "the shop's light", "A": "warm indoor light"}
#: The height of her face on a shade's tile, pixels (at 1080 lines: a tenth of a landscape screen).
THUMB_PX = 128
#: A shade's tile: her face above, the shade's name and its match word below, pixels tall.
TILE_PX = THUMB_PX + 76
#: ΔE2000 (under daylight) up to which a shade is a "great match", then a "good match"; beyond: the
#: "nearest we have". 2 is about what a shopper notices side by side on skin.
GREAT_DE2000, GOOD_DE2000 = 2.0, 5.0
_WORDS = ("great match", "good match", "nearest we have")


def match_words(shade: ShadeMatch, level: str = "high") -> str:
    """How well ``shade`` matches, in a shopper's words (never a ΔE figure).

    Args:
        shade: the match (its ``de2000`` under daylight).
        level: how well her skin was read (:func:`shade.match.confidence`'s level: high, medium, low);
            a medium reading says at best "good match", a low one "nearest we have".
    """
    rank = 0 if shade.de2000 <= GREAT_DE2000 else 1 if shade.de2000 <= GOOD_DE2000 else 2
    floor = {"high": 0, "medium": 1}.get(level, 2)
    return _WORDS[max(rank, floor)]


def shade_tile() -> QToolButton:
    """A shade's touch tile: her face (an icon, :data:`THUMB_PX` tall) over two lines of words."""
    b = QToolButton()
    b.setToolButtonStyle(Qt.ToolButtonStyle.ToolButtonTextUnderIcon)
    b.setFocusPolicy(Qt.FocusPolicy.NoFocus)
    b.setMinimumSize(120, TILE_PX)
    b.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
    b.setIconSize(QSize(THUMB_PX, THUMB_PX))
    return b


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
        self._round = 0  # counts resets: a reading finished after one (the shopper left) is dropped
        self.find_button = big_button("Find my foundation", 60)
        self.find_button.clicked.connect(guard(self.find))
        self.shade_buttons = [shade_tile() for _ in range(SHOWN)]
        tiles = QHBoxLayout()
        for i, b in enumerate(self.shade_buttons):
            b.clicked.connect(guard(lambda _c=False, i=i: self.wear(i)))
            b.hide()
            tiles.addWidget(b)
        self.message = QLabel("")
        self.message.setWordWrap(True)
        self.message.setStyleSheet("font-size: 18px;")
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(self.find_button)
        lay.addLayout(tiles)
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
        started = self._round
        self.find_button.setEnabled(False)
        self.message.setText("Reading your skin…")
        for b in self.shade_buttons:
            b.hide()

        def job(_progress: Any, _cancelled: Any) -> tuple[list[ShadeMatch], bool, str]:
            from km.skin import fit_skin
            from shade.match import ShadeBank, confidence, foundations, match_shades

            fit = fit_skin(linear_rgb=self.skin_rgb())
            bank = ShadeBank.from_materials(foundations(self.library))
            # the confidence `sheer shade match` states: low when the model cannot make her skin's colour
            read = confidence(fit)
            return match_shades(fit.reflectance, fit.reflectance, bank), read.hard_to_read, read.level

        def show(result: tuple[list[ShadeMatch], bool, str]) -> None:
            if started == self._round:  # else the shopper who asked has gone
                self._show(result)

        def failed(message: str) -> None:
            if started == self._round:
                self._failed(message)

        run_task(None, "", job, self.guard(show), self.guard(failed), show_progress=False)

    def _failed(self, message: str) -> None:
        self.busy = False
        self.find_button.setEnabled(True)
        raise RuntimeError(f"Find my foundation: {message}")

    def _show(self, result: tuple[list[ShadeMatch], bool, str]) -> None:
        ranked, hard_to_read, level = result
        self.busy = False
        self.find_button.setEnabled(True)
        self.shades = ranked[:SHOWN]
        for b, s in zip(self.shade_buttons, self.shades):
            b.setText(f"{s.name}\n{match_words(s, level)}")
            dark = int(s.swatch_hex[1:3], 16) + int(s.swatch_hex[3:5], 16) + int(s.swatch_hex[5:7], 16) < 384
            b.setStyleSheet(f"QToolButton {{ background: {s.swatch_hex}; color: {'#f4efe9' if dark else '#1d1b1c'};"
                            " border-radius: 14px; padding: 6px; font-size: 18px; }")
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
        """Forget the shades shown and any reading still running (a new shopper)."""
        self._round += 1
        self.shades = []
        self.note = ""
        self.busy = False
        self.find_button.setEnabled(True)
        for b in self.shade_buttons:
            b.setIcon(QIcon())
            b.setText("")
            b.setStyleSheet("")
            b.hide()
        self.message.setText("")

    def set_preview(self, index: int, image: QImage) -> None:
        """Show shade ``index`` on her face: ``image`` as its tile's picture, :data:`THUMB_PX` pixels tall."""
        b = self.shade_buttons[index]
        pix = QPixmap.fromImage(image).scaledToHeight(THUMB_PX, Qt.TransformationMode.SmoothTransformation)
        room = max(THUMB_PX, b.width() - 16)
        if pix.width() > room:  # a wide crop keeps its height: its middle is shown
            pix = pix.copy((pix.width() - room) // 2, 0, room, THUMB_PX)
        b.setIcon(QIcon(pix))
        b.setIconSize(QSize(pix.width(), THUMB_PX))

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
