"""The kiosk's configuration file and its administrator PIN (no Qt: ``sheer kiosk --set-pin`` uses it too).

The configuration is JSON (default ``$XDG_CONFIG_HOME/sheer/kiosk.json``); anything missing or malformed
gets its default, numbers are clamped to sane ranges, and the PIN is stored only as a salted PBKDF2 hash.
There is no default PIN: :func:`require_pin` refuses to start a kiosk without one.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import logging
import math
import os
import secrets
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from app.settings import DEFAULT_RESOLUTION

if TYPE_CHECKING:
    from capture.probe import ProbeAnalysis

log = logging.getLogger("sheer.kiosk")

#: The kiosk's renderers: see :attr:`KioskConfig.engine`.
ENGINES: tuple[str, ...] = ("auto", "physical", "lightweight")
#: PBKDF2-SHA256 iterations of a stored PIN hash.
_PBKDF2_ROUNDS = 200_000


def hash_pin(pin: str, salt: bytes | None = None) -> str:
    """``pbkdf2_sha256$rounds$salt_hex$hash_hex`` of a PIN."""
    salt = salt or secrets.token_bytes(16)
    digest = hashlib.pbkdf2_hmac("sha256", pin.encode("utf-8"), salt, _PBKDF2_ROUNDS)
    return f"pbkdf2_sha256${_PBKDF2_ROUNDS}${salt.hex()}${digest.hex()}"


def check_pin(pin: str, stored: str) -> bool:
    """Whether ``pin`` is the PIN whose :func:`hash_pin` is ``stored`` (False for a malformed hash)."""
    try:
        algo, rounds, salt_hex, hash_hex = stored.split("$")
        if algo != "pbkdf2_sha256":
            return False
        digest = hashlib.pbkdf2_hmac("sha256", pin.encode("utf-8"), bytes.fromhex(salt_hex), int(rounds))
    except (ValueError, TypeError):
        return False
    return hmac.compare_digest(digest.hex(), hash_hex)


@dataclass
class KioskConfig:
    """The kiosk's configuration file (JSON).

    Attributes:
        pin_hash: the administrator PIN as :func:`hash_pin` stores it (never the PIN itself).
        snapshot_dir: where Save Photo writes PNGs (default ``~/Pictures/sheer-kiosk``).
        idle_seconds: seconds without a touch before the attract mode starts, in [5, 3600].
        look_seconds: seconds each look shows in the attract mode, in [2, 120].
        fullscreen: cover the whole screen (``sheer kiosk --windowed`` overrides it).
        engine: "physical" (render.Renderer), "lightweight" (the captured face ``face_dir`` by the
            lightweight engine) or "auto": physical, falling back to lightweight when its frames take
            over ``max_frame_ms``.
        face_dir: a captured face folder written by ``sheer capture`` ("" for none).
        max_frame_ms: the slowest physical frame "auto" accepts, in ms, in [10, 10000].
        resolution: texels per side of the thickness maps (a multiple of 64 in [64, 8192]).
        camera: the "Try it on me" camera: "auto" (the first video device OpenCV opens), "off" (no
            camera and no "Try it on me" button unless ``watch_dir`` is set), a device index ("0") or a
            device or video-file path ("/dev/video2").
        watch_dir: a folder a kiosk without a camera takes the shopper's photo from (the newest image
            file written there after the countdown; "" for none).
        light: the kiosk's own light, measured from a mirror-ball photograph by ``sheer kiosk
            --calibrate-light`` (:meth:`capture.probe.ProbeAnalysis.to_json`); empty: the capture assumes
            a white flash on the camera's axis.
        source: the file this configuration was read from (None when made in memory); not saved. The
            PIN lockout's state is kept beside it (:mod:`app.kiosk.pin_lock`).
    """

    pin_hash: str = ""
    snapshot_dir: str = ""
    idle_seconds: float = 90.0
    look_seconds: float = 8.0
    fullscreen: bool = True
    engine: str = "auto"
    face_dir: str = ""
    max_frame_ms: float = 250.0
    resolution: int = DEFAULT_RESOLUTION
    camera: str = "auto"
    watch_dir: str = ""
    light: dict[str, object] = field(default_factory=dict)
    source: Path | None = field(default=None, repr=False, compare=False)

    @staticmethod
    def default_path() -> Path:
        """``$XDG_CONFIG_HOME/sheer/kiosk.json`` (``~/.config/sheer/kiosk.json`` without the variable)."""
        base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
        return Path(base) / "sheer" / "kiosk.json"

    @property
    def has_pin(self) -> bool:
        """An administrator PIN is configured (there is no default PIN: see :func:`require_pin`)."""
        return bool(self.pin_hash)

    @classmethod
    def load(cls, path: Path | None = None) -> KioskConfig:
        """Read the configuration (from :meth:`default_path` when ``path`` is None).

        A missing or broken file gives the defaults — with **no** PIN (the kiosk refuses to start until
        ``sheer kiosk --set-pin`` stores one); out-of-range numbers are clamped.
        """
        path = path or cls.default_path()
        cfg = cls(source=path)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            if isinstance(data, dict):
                for k in cfg._persisted():
                    value = data.get(k)
                    if isinstance(value, float) and not math.isfinite(value):
                        continue  # NaN/inf would defeat the clamping below
                    if k in data and isinstance(value, type(getattr(cfg, k))):
                        setattr(cfg, k, value)
        except (OSError, ValueError, RecursionError) as exc:
            if path.exists():
                log.warning("kiosk config %s unreadable (%s); using defaults", path, exc)
        if cfg.pin_hash and cfg.pin_hash.count("$") != 3:
            log.warning("kiosk config %s: the stored PIN is not a PIN hash; ignoring it", path)
            cfg.pin_hash = ""
        if not cfg.snapshot_dir:
            cfg.snapshot_dir = str(Path.home() / "Pictures" / "sheer-kiosk")
        cfg.idle_seconds = min(max(float(cfg.idle_seconds), 5.0), 3600.0)
        cfg.look_seconds = min(max(float(cfg.look_seconds), 2.0), 120.0)
        cfg.max_frame_ms = min(max(float(cfg.max_frame_ms), 10.0), 10_000.0)
        if cfg.engine not in ENGINES:
            log.warning("kiosk config: engine must be one of %s, got %r; using auto", ", ".join(ENGINES), cfg.engine)
            cfg.engine = "auto"
        if cfg.light and cfg.probe() is None:
            log.warning("kiosk config %s: the calibrated light is malformed; using the flash-on-axis default", path)
            cfg.light = {}
        from core.errors import SheerError
        from painting.atlas import check_resolution

        try:
            check_resolution(cfg.resolution)
        except SheerError as exc:
            log.warning("kiosk config: %s; using %d", exc, DEFAULT_RESOLUTION)
            cfg.resolution = DEFAULT_RESOLUTION
        return cfg

    @property
    def camera_enabled(self) -> bool:
        """Whether "Try it on me" may open a camera (``camera`` is not "off")."""
        return self.camera.strip().lower() != "off"

    @property
    def can_try_on(self) -> bool:
        """Whether the kiosk offers "Try it on me": a camera, or a watched folder to take the photo from."""
        return self.camera_enabled or bool(self.watch_dir)

    def probe(self) -> ProbeAnalysis | None:
        """The calibrated light as the capture takes it (None without one, or when it is malformed)."""
        if not self.light:
            return None
        import numpy as np

        from capture.probe import ProbeAnalysis

        try:
            d = self.light
            direction = np.asarray(d["light_dir_camera"], dtype=np.float64)
            flash = np.asarray(d["flash_rgb"], dtype=np.float64)
            ambient = np.asarray(d["ambient_rgb"], dtype=np.float64)
            if direction.shape != (3,) or flash.shape != (3,) or ambient.shape != (3,):
                return None
            if not (np.all(np.isfinite(direction)) and np.all(np.isfinite(flash)) and np.all(np.isfinite(ambient))
                    and abs(float(np.linalg.norm(direction)) - 1.0) < 1e-3 and np.all(flash >= 0)
                    and np.all(ambient >= 0)):
                return None
            hx, hy = (float(v) for v in d.get("highlight_px", (0.0, 0.0)))  # type: ignore[union-attr]
            return ProbeAnalysis(light_dir_camera=direction, theta_deg=float(d["theta_deg"]),  # type: ignore[arg-type]
                                 phi_deg=float(d["phi_deg"]), highlight_px=(hx, hy),  # type: ignore[arg-type]
                                 flash_rgb=flash, ambient_rgb=ambient, classes=np.zeros((0, 0), np.uint8),
                                 clipped_fraction=float(d.get("clipped_fraction", 0.0)),  # type: ignore[arg-type]
                                 flash_hue_spread=float(d.get("flash_hue_spread", 0.0)),  # type: ignore[arg-type]
                                 reflectance=float(d.get("reflectance", 1.0)))  # type: ignore[arg-type]
        except (KeyError, TypeError, ValueError):
            return None

    def save(self, path: Path | None = None) -> Path:
        """Write the configuration atomically (to :meth:`default_path` when ``path`` is None); returns the file."""
        from core.atomicio import atomic_write_text

        path = path or self.default_path()
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, json.dumps(self._persisted(), indent=2))
        return path

    def _persisted(self) -> dict[str, object]:
        """The fields written to the file (all but :attr:`source`)."""
        data = asdict(self)
        data.pop("source")
        return data


#: What a kiosk without a PIN says (one line, naming the command that sets one).
NO_PIN_MESSAGE = ("the kiosk has no administrator PIN yet; set one with `sheer kiosk --set-pin` "
                  "(add --config FILE if you use another configuration file)")


def require_pin(config: KioskConfig) -> None:
    """Refuse to run a kiosk nobody can leave, or that a shopper leaves with a PIN shipped by default."""
    if not config.has_pin:
        from core.errors import SheerError

        raise SheerError(NO_PIN_MESSAGE)
