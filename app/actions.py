"""Actions declared as data (after napari): id, title, shortcut, menu, and when they are enabled.

The studio builds its menus and shortcuts from :data:`STUDIO_ACTIONS`; the kiosk uses the reduced set
:data:`KIOSK_ACTIONS` (no menus, no file dialogs). ``enabled_when`` names a predicate of the window's
context (see :meth:`app.studio.main_window.StudioWindow.context`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Mapping


@dataclass(frozen=True)
class ActionSpec:
    """One action of the studio's menus or the kiosk's shortcuts.

    Attributes:
        id: a stable name ("file.save"), the key of its handler and of ``StudioWindow.actions_by_id``.
        title: the menu text (``&`` marks the mnemonic, "…" a dialog).
        menu: the menu it is listed in (one of :data:`MENU_ORDER`, or "Kiosk").
        shortcut: a ``QKeySequence`` string ("Ctrl+S", "[") or "" for none.
        enabled_when: "always" or the name of a predicate of the window's context (``has_layers``,
            ``can_undo``, ``can_redo``).
        checkable: the action toggles (shown with a check mark).
        tip: the status-bar tip ("" for none).
    """

    id: str
    title: str
    menu: str
    shortcut: str = ""
    enabled_when: str = "always"
    checkable: bool = False
    tip: str = ""


STUDIO_ACTIONS: tuple[ActionSpec, ...] = (
    ActionSpec("file.new", "&New Project", "File", "Ctrl+N"),
    ActionSpec("file.open", "&Open Project…", "File", "Ctrl+O"),
    ActionSpec("file.new_from_photo", "New from &Photo…", "File", "",
               tip="capture a face from a portrait and paint the current layers on it (app.studio.new_from_photo)"),
    ActionSpec("file.save", "&Save Project", "File", "Ctrl+S"),
    ActionSpec("file.save_as", "Save Project &As…", "File", "Ctrl+Shift+S"),
    ActionSpec("file.open_face", "Open Captured &Face…", "File", "",
               tip="a face folder written by 'sheer capture', drawn by the lightweight render mode"),
    ActionSpec("file.close_face", "Close Captured Face", "File", "", "has_face",
               tip="back to the physical renderer; the face's folder is left as it is"),
    ActionSpec("file.export_maps", "Export Layer &Maps (16-bit PNG)…", "File", "Ctrl+E", "has_layers"),
    ActionSpec("file.export_maps_exr", "Export Layer Maps (&EXR)…", "File", "", "has_layers"),
    ActionSpec("file.export_image", "Export Rendered &Image…", "File", "Ctrl+Shift+E"),
    ActionSpec("file.export_gltf", "Export &glTF/GLB…", "File", "Ctrl+Alt+E"),
    ActionSpec("file.export_ora", "Export &OpenRaster (GIMP, Krita)…", "File", "", "has_layers",
               tip="each cosmetic as its colour with its coverage as alpha, and the thickness maps as data layers"),
    ActionSpec("file.render_catalogue", "Render &Catalogue…", "File", "",
               tip="render a catalogue spec (shades × faces × lights × views) in the background"),
    ActionSpec("file.quit", "&Quit", "File", "Ctrl+Q"),
    ActionSpec("edit.undo", "&Undo", "Edit", "Ctrl+Z", "can_undo"),
    ActionSpec("edit.redo", "&Redo", "Edit", "Ctrl+Shift+Z", "can_redo"),
    ActionSpec("brush.smaller", "Brush Smaller", "Brush", "[", tip="radius ÷ 1.2"),
    ActionSpec("brush.larger", "Brush Larger", "Brush", "]", tip="radius × 1.2"),
    ActionSpec("brush.weaker", "Brush Weaker", "Brush", "Shift+[", tip="strength − 0.1"),
    ActionSpec("brush.stronger", "Brush Stronger", "Brush", "Shift+]", tip="strength + 0.1"),
    ActionSpec("brush.eraser", "&Eraser", "Brush", "E", checkable=True),
    ActionSpec("brush.smooth", "&Smooth", "Brush", "S", checkable=True),
    ActionSpec("brush.mirror", "Mirror (&X)", "Brush", "X", checkable=True),
    ActionSpec("view.frame", "&Frame Head", "View", "F"),
    ActionSpec("view.split", "Before/After &Split", "View", "B", checkable=True),
    ActionSpec("view.reference", "&Reference Render Mode", "View", "R", checkable=True),
    ActionSpec("view.mode_fast", "Render Mode: Fast", "View", checkable=True,
               tip="physical renderer, separable subsurface scattering (Jimenez 2015)"),
    ActionSpec("view.mode_reference", "Render Mode: Reference", "View", checkable=True,
               tip="physical renderer, sum-of-Gaussians subsurface scattering (Jimenez 2009)"),
    ActionSpec("view.mode_lightweight", "Render Mode: Lightweight (captured face)", "View", checkable=True,
               tip="Phong + detail texture of a captured face (Paris et al. 2003)"),
    ActionSpec("view.overlay", "Frame-Time &Overlay", "View", "O", checkable=True),
    ActionSpec("view.scale_50", "While Moving: Up to 50% Resolution", "View", checkable=True,
               tip="interactive frames at most half the view's resolution (a slow machine)"),
    ActionSpec("view.scale_75", "While Moving: Up to 75% Resolution", "View", checkable=True,
               tip="interactive frames at most three quarters of the resolution (the default)"),
    ActionSpec("view.scale_100", "While Moving: Full Resolution", "View", checkable=True,
               tip="interactive frames up to full resolution (a strong GPU)"),
    ActionSpec("looks.gallery", "Look &Gallery…", "Looks", "Ctrl+L",
               tip="pick a ready-made look from thumbnails: it is added to the head as new layers (one undo step)"),
    ActionSpec("help.shortcuts", "&Keyboard Shortcuts", "Help", "F1"),
    ActionSpec("help.about", "&About Sheer", "Help"),
)

#: The kiosk's reduced set: nothing that opens a dialog or leaves the application without the PIN.
KIOSK_ACTIONS: tuple[ActionSpec, ...] = (
    ActionSpec("kiosk.exit", "Exit (administrator)", "Kiosk", "Ctrl+Q"),
    ActionSpec("view.split", "Before/After", "Kiosk", "B", checkable=True),
)

MENU_ORDER: tuple[str, ...] = ("File", "Edit", "Brush", "Looks", "View", "Help")


def is_enabled(spec: ActionSpec, context: Mapping[str, bool]) -> bool:
    """Whether ``spec`` is enabled in ``context`` (predicate name → value; a missing predicate is False)."""
    return spec.enabled_when == "always" or bool(context.get(spec.enabled_when, False))


def shortcut_sheet(specs: tuple[ActionSpec, ...] = STUDIO_ACTIONS) -> list[tuple[str, str, str]]:
    """(menu, title without mnemonics, shortcut) for every action with a shortcut, plus mouse gestures."""
    rows = [(s.menu, s.title.replace("&", "").rstrip("…"), s.shortcut) for s in specs if s.shortcut]
    rows += [
        ("Viewport", "Paint on the face", "Left drag on the head"),
        ("Viewport", "Orbit", "Left drag off the head, or right drag"),
        ("Viewport", "Pan", "Middle drag, or Shift+right drag"),
        ("Viewport", "Zoom", "Wheel"),
        ("Viewport", "Move the light", "Ctrl+left drag"),
    ]
    return rows
