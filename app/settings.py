"""The studio's settings: all UI state in one plain object (after Open3D's GUI examples), and defaults.

Widgets set a field and call one ``apply`` function. Persisted with QSettings (brush, view options,
recent files; the window layout is saved by the window itself). No Qt is imported at run time here, so
the kiosk's configuration and the session use the defaults without loading Qt.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from PySide6.QtCore import QSettings

#: The version of the persisted settings' layout; settings of another version are ignored (defaults).
SETTINGS_SCHEMA_VERSION = 1
#: The QSettings organisation and application names.
ORGANISATION, APPLICATION = "Sheer", "Sheer Studio"

#: The thickness maps' resolution (texels per side) for a new document in the studio and the kiosk.
#:
#: 2048², the issue's own example. What the resolution costs a dab is its share of dab-to-frame: the
#: painting and the texture-space KM of the tiles it touches (``sheer bench studio`` reports it as
#: ``dab_update_ms``). Measured on the shared 2-core machine under load (load average 4–5, renderer at
#: 2d088a1, 8 mm brush): 10 ms at 1024², 20–50 ms at 2048² (27 ms median over runs), against a frame of
#: the renderer of 200–400 ms on that machine then. The frame, not the resolution, is what keeps
#: dab-to-frame above 100 ms today; with the renderer's target frame (≤ ~40 ms) 2048² leaves
#: dab-to-frame within 100 ms, so no smaller default is needed. Re-measure with
#: ``sheer bench studio --json --resolution N`` (``--resolution`` on ``sheer studio`` overrides this).
DEFAULT_RESOLUTION = 2048

LIGHT_PRESETS: dict[str, dict[str, Any]] = {
    "daylight": {"azimuth": 25.0, "elevation": 35.0, "colour": (1.0, 0.98, 0.95), "intensity": 2.4,
                 "ambient": (0.38, 0.40, 0.45)},
    "office": {"azimuth": 0.0, "elevation": 60.0, "colour": (0.95, 1.0, 1.0), "intensity": 2.0,
               "ambient": (0.42, 0.43, 0.44)},
    "evening": {"azimuth": -50.0, "elevation": 15.0, "colour": (1.0, 0.75, 0.55), "intensity": 2.0,
                "ambient": (0.18, 0.18, 0.28)},
    "warm indoor": {"azimuth": 40.0, "elevation": 20.0, "colour": (1.0, 0.82, 0.62), "intensity": 2.2,
                    "ambient": (0.30, 0.26, 0.22)},
}
ENVIRONMENTS: tuple[str, ...] = ("none", "studio", "city", "lobby", "night", "sunset", "warehouse")


@dataclass
class StudioSettings:
    """Everything the studio's controls show, in one place (:meth:`clamp` keeps it valid).

    Attributes:
        brush_radius_mm: brush radius in mm, [0.5, 100].
        brush_strength: how far a stroke goes towards its target (its opacity), [0.05, 1].
        brush_hardness: the fraction of the radius painted at full weight, [0, 0.95].
        brush_mode: "add", "erase" or "smooth".
        brush_mirror: paint the mirror image about the head's midplane too.
        render_mode: "fast", "reference" or "lightweight" (the last needs a captured face).
        debug_view: index into the renderer's debug views (0: the image).
        light_preset: a key of :data:`LIGHT_PRESETS`.
        light_azimuth: key light azimuth in degrees.
        light_elevation: key light elevation in degrees.
        environment: one of :data:`ENVIRONMENTS` ("none" for no HDR environment).
        split: the before/after divider's position, [0, 1] of the view's width (0: off).
        overlay: show the frame-time overlay.
        interactive_scale_cap: the largest internal scale of the frames drawn while the view moves
            (progressive refinement, render.progressive), one of 0.5, 0.75, 1.0 (1.0: full resolution).
        autosave_minutes: minutes between autosaves of unsaved work, [0.25, 120].
        recent_files: the projects opened or saved last, newest first.
        cache_max_mb: the cache folder's size cap in MiB, [0, 1048576]; 0: automatic (10 % of the free
            space, at most 2 GiB). ``SHEER_CACHE_MAX_MB`` overrides it (see :mod:`core.cache`).
    """

    brush_radius_mm: float = 8.0
    brush_strength: float = 0.6
    brush_hardness: float = 0.5
    brush_mode: str = "add"  # add | erase | smooth
    brush_mirror: bool = False
    render_mode: str = "fast"  # fast | reference | lightweight (the last needs a captured face)
    debug_view: int = 0
    light_preset: str = "daylight"
    light_azimuth: float = 25.0
    light_elevation: float = 35.0
    environment: str = "none"
    split: float = 0.0
    overlay: bool = False
    interactive_scale_cap: float = 0.75
    autosave_minutes: float = 3.0
    recent_files: list[str] = field(default_factory=list)
    cache_max_mb: float = 0.0

    def clamp(self) -> None:
        """Bring every field into its range (unknown names become their defaults)."""
        self.brush_radius_mm = min(max(self.brush_radius_mm, 0.5), 100.0)
        self.brush_strength = min(max(self.brush_strength, 0.05), 1.0)
        self.brush_hardness = min(max(self.brush_hardness, 0.0), 0.95)
        if self.brush_mode not in ("add", "erase", "smooth"):
            self.brush_mode = "add"
        if self.render_mode not in ("fast", "reference", "lightweight"):
            self.render_mode = "fast"
        if self.light_preset not in LIGHT_PRESETS:
            self.light_preset = "daylight"
        if self.environment not in ENVIRONMENTS:
            self.environment = "none"
        self.split = min(max(self.split, 0.0), 1.0)
        if self.interactive_scale_cap not in (0.5, 0.75, 1.0):
            self.interactive_scale_cap = 0.75
        self.autosave_minutes = min(max(self.autosave_minutes, 0.25), 120.0)
        if not math.isfinite(self.cache_max_mb) or self.cache_max_mb < 0:
            self.cache_max_mb = 0.0  # (automatic)
        self.cache_max_mb = min(self.cache_max_mb, 1024.0 * 1024.0)

    def add_recent(self, path: str, limit: int = 8) -> None:
        """Put ``path`` first in the recent files (once), keeping at most ``limit``."""
        self.recent_files = [path, *[p for p in self.recent_files if p != path]][:limit]


def apply_cache_cap(s: StudioSettings) -> None:
    """Give the cache policy the settings' cap (:func:`core.cache.set_configured_max_mb`)."""
    from core.cache import set_configured_max_mb

    set_configured_max_mb(s.cache_max_mb or None)


def load_settings(qsettings: QSettings) -> StudioSettings:
    """Read the settings; anything missing, malformed or of another schema version gets its default.

    The cache cap they hold is applied to :mod:`core.cache` as they are read (:func:`apply_cache_cap`).
    """
    s = StudioSettings()
    if qsettings.value("schema_version") not in (SETTINGS_SCHEMA_VERSION, str(SETTINGS_SCHEMA_VERSION)):
        apply_cache_cap(s)
        return s
    for f in fields(s):
        raw = qsettings.value(f"studio/{f.name}")
        if raw is None:
            continue
        default = getattr(s, f.name)
        try:
            if isinstance(default, bool):
                value: Any = raw if isinstance(raw, bool) else str(raw).lower() == "true"
            elif isinstance(default, list):
                value = [str(x) for x in (raw if isinstance(raw, list) else [raw]) if x]
            else:
                value = type(default)(raw)
        except (TypeError, ValueError):
            continue
        setattr(s, f.name, value)
    s.clamp()
    apply_cache_cap(s)
    return s


def save_settings(qsettings: QSettings, s: StudioSettings) -> None:
    """Write the settings (with their schema version) to ``qsettings``."""
    qsettings.setValue("schema_version", SETTINGS_SCHEMA_VERSION)
    for k, v in asdict(s).items():
        qsettings.setValue(f"studio/{k}", v)
