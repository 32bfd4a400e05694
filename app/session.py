"""What the studio and the kiosk work on: the material library and the painting document of one head.

:meth:`Session.open` reads the library (``km.default_library()``) and builds the ``painting.Document``
(mesh cleaning, UV check or xatlas unwrap, bake), then paints a built-in look (``painting.looks``). It
uses no Qt, so the studio runs it in a worker thread with a progress dialog
(:func:`app.studio.launch.open_session_with_progress`); the kiosk and ``sheer bench studio`` call it directly.
The windows then use the document as it is: layer ids in its change events, tiles as (row, col)
(:mod:`painting.tiles`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from app.settings import DEFAULT_RESOLUTION

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

    from km.library import Library
    from painting import Document

#: What implements each part of a session (shown in the About box, reported by ``sheer bench studio``).
BACKENDS: dict[str, str] = {"renderer": "render.Renderer", "library": "km", "document": "painting.Document"}


def load_library(user_file: str | Path | None = None) -> Library:
    """The material library shipped with Sheer, with the materials of ``user_file`` over it.

    A material of the user's file replaces the shipped one of its name, or is added; the shipped ones
    are always there (the built-in looks name them). The library's file is then ``user_file``, where
    the studio saves it (when ``user_file`` does not exist: the shipped library, with no file).

    Raises:
        km.library.LibraryError: a library file is malformed (the message names it).
    """
    from pathlib import Path

    from km.library import Library, default_library

    library = default_library()
    if user_file is not None and Path(user_file).is_file():
        for material in Library.load(user_file):
            library.add(material, replace=True)
        library.path = Path(user_file)
    return library


@dataclass
class Session:
    """The material library and the document a window paints on.

    Attributes:
        library: the materials layers refer to by name (the studio edits it in place).
        document: the painting document of the head (layers bottom first, thickness in µm).
        look: the built-in look last painted by :meth:`apply_look` ("" when none).
    """

    library: Library
    document: Document
    look: str = ""

    @classmethod
    def open(cls, head: str | Path | None = None, resolution: int = DEFAULT_RESOLUTION, look: str = "", *,
             library: Library | None = None,
             progress: Callable[[str, float], None] | None = None) -> Session:
        """Build the document of a head, then paint a built-in look on it (one undo history, cleared).

        Safe to call from a worker thread: nothing here touches Qt.

        Args:
            head: the head mesh (.glb, .gltf, .obj, .ply); None for the sample head.
            resolution: texels per side of the thickness maps (a multiple of 64 in [64, 8192]).
            look: a built-in look (``resources/looks/<name>.json``) to paint; "" for none.
            library: the material library; None reads the shipped one (:func:`load_library`).
            progress: called with (stage, fraction in [0, 1]) while the document is built and before the
                look is painted; it may raise (e.g. to cancel), which abandons the session. It is never
                called once this method has returned (later lazy bakes of the document report nothing).

        Raises:
            core.errors.SheerError: an unreadable head or library, a bad resolution or an unknown look.
        """
        from painting import Document

        library = load_library() if library is None else library
        opening = True

        def report(stage: str, fraction: float) -> None:
            # the document keeps its progress callback for later (lazy) bakes: report only while opening
            if opening and progress is not None:
                progress(stage, fraction)

        try:
            doc = Document.from_head(head, resolution=resolution, library=library, progress=report)
        finally:
            opening = False
        session = cls(library, doc)
        if look:
            if progress is not None:
                progress(f"painting the look '{look}'", 1.0)
            session.apply_look(look)
        return session

    def apply_look(self, name: str) -> None:
        """Replace the document's layers with the built-in look ``name`` and clear the undo history.

        Raises:
            painting.looks.LookError: an unknown or malformed look (the document is unchanged then).
        """
        from painting.looks import apply_look

        apply_look(self.document, name)
        self.document.clear_history()
        self.look = name
