"""The kiosk's configuration file, its looks and its administrator PIN (no Qt: ``sheer kiosk --set-pin`` uses it).

The configuration is JSON (default ``$XDG_CONFIG_HOME/sheer/kiosk.json``); anything missing or malformed
gets its default, numbers are clamped to sane ranges, and the PIN is stored only as a salted PBKDF2 hash.
There is no default PIN: :func:`require_pin` refuses to start a kiosk without one. The file holds the PIN's
hash, so it is written readable by its owner only (mode 0600, :func:`write_private`), as is the PIN lock
file beside it.

The looks (:class:`KioskLook`): built-in looks by name and ``.sheer`` projects (a brand's), from the
configuration's ``looks`` and ``sheer kiosk --project``; a project that cannot be used is refused in one
line before any window opens (:func:`kiosk_looks`, :func:`open_look_projects`, :func:`install_look_projects`).
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
from typing import TYPE_CHECKING, Any

from app.settings import DEFAULT_RESOLUTION
from core.errors import SheerError

if TYPE_CHECKING:
    from collections.abc import Callable

    import numpy as np

    from app.session import Session
    from capture.probe import ProbeAnalysis
    from painting import Document

log = logging.getLogger("sheer.kiosk")

#: The kiosk's renderers: see :attr:`KioskConfig.engine`.
ENGINES: tuple[str, ...] = ("auto", "physical", "lightweight")
#: PBKDF2-SHA256 iterations of a stored PIN hash.
_PBKDF2_ROUNDS = 200_000
#: The looks on the try-on screen when the configuration lists none.
DEFAULT_LOOKS: tuple[str, ...] = ("natural", "evening", "red-lip", "bare")
#: The built-in look the attract mode's cycle leaves out (a bare face invites no one).
BARE = "bare"
#: The mode of the files that hold secrets (the configuration with the PIN hash, the PIN lock file).
PRIVATE_MODE = 0o600


def write_private(path: Path, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically, readable and writable by its owner only (mode 0600).

    :func:`core.atomicio.atomic_writer` with ``file_mode``: the temporary file in the same folder is 0600
    from its creation, fsynced and renamed over ``path``, so at no moment is the file (old or new) readable
    by others, and an older file with a wider mode is replaced by a 0600 one. A new folder is made with
    mode 0700.

    Raises:
        OSError: the file could not be written (naming ``path``); the old file is unchanged then.
    """
    from core.atomicio import atomic_writer

    path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    with atomic_writer(path, "wb", file_mode=PRIVATE_MODE) as fh:
        fh.write(text.encode("utf-8"))


def default_log_path() -> Path:
    """``$XDG_STATE_HOME/sheer/kiosk.log`` (``~/.local/state/sheer/kiosk.log`` without the variable)."""
    base = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(base) / "sheer" / "kiosk.log"


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
        looks: the try-on screen's looks, in order: built-in look names and ``.sheer`` project files
            (a relative path is from the configuration's folder); empty: :data:`DEFAULT_LOOKS`.
        log: the kiosk's log file ("": :func:`default_log_path`; a relative path is from the
            configuration's folder).
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
    looks: list[str] = field(default_factory=list)
    log: str = ""
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
        """Write the configuration atomically, mode 0600 (:func:`write_private`); returns the file.

        To :meth:`default_path` when ``path`` is None.
        """
        path = path or self.default_path()
        write_private(path, json.dumps(self._persisted(), indent=2))
        return path

    def folder(self) -> Path:
        """The folder relative paths in the configuration are read from (the file's; the current one without)."""
        return self.source.parent if self.source is not None else Path.cwd()

    def log_path(self, override: str | None = None) -> Path:
        """Where the kiosk logs: ``override`` (``--log``), else ``$SHEER_KIOSK_LOG``, else ``log``, else the default."""
        given = override or os.environ.get("SHEER_KIOSK_LOG")
        if given:
            return Path(given).expanduser().absolute()
        if self.log:
            path = Path(self.log).expanduser()
            return path if path.is_absolute() else self.folder() / path
        return default_log_path()

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
        raise SheerError(NO_PIN_MESSAGE)


# ---------------------------------------------------------------------------------------------- looks


@dataclass(frozen=True)
class LookLayer:
    """One layer of a look as the kiosk replays it onto a document.

    Attributes:
        material: the material's library name.
        name: the layer's name.
        max_thickness: the most the layer builds up to (µm).
        thickness: the map (float32 (H, W), µm).
        visible: shown.
        opacity: in [0, 1].
        mask: the layer's mask recipe (``painting.mask.LayerMask``) or None.
        mask_channel: the mask's paint channel (float32 (H, W) in [0, 2]) or None.
    """

    material: str
    name: str
    max_thickness: float
    thickness: np.ndarray
    visible: bool = True
    opacity: float = 1.0
    mask: Any = None
    mask_channel: np.ndarray | None = None


def snapshot_layers(doc: Document) -> list[LookLayer]:
    """``doc``'s layers, bottom first, their maps copied."""
    import numpy as np

    return [LookLayer(lay.material, lay.name, float(lay.max_thickness), np.array(lay.thickness),
                      bool(lay.visible), float(lay.opacity), lay.mask,
                      None if lay.mask_channel is None else np.array(lay.mask_channel))
            for lay in doc.layers]


def replay_layers(doc: Document, layers: list[LookLayer]) -> None:
    """Replace ``doc``'s layers with ``layers`` (from :func:`snapshot_layers` on the same head); no undo history."""
    for i in reversed(range(len(doc.layers))):
        doc.remove_layer(i)
    for saved in layers:
        lay = doc.add_layer(saved.material, resolution=int(saved.thickness.shape[0]), name=saved.name,
                            max_thickness=saved.max_thickness)
        doc.set_thickness(lay, saved.thickness)
        doc.set_layer(lay, visible=saved.visible, opacity=saved.opacity)
        if saved.mask is not None or saved.mask_channel is not None:
            doc.set_layer_mask(lay, saved.mask, saved.mask_channel)
    doc.clear_history()


@dataclass
class KioskLook:
    """One look of the kiosk: a button on the try-on screen, and a step of the attract mode's cycle.

    Attributes:
        key: the look's unique name: a built-in look's name, or ``project:`` and the label.
        label: the button's text (a project's stored name, else its file's stem).
        origin: where it was named (``--project``, ``kiosk.json: looks[2]``), for messages.
        builtin: the built-in look (``painting.looks``) it paints; "" for a project.
        path: the project file (None for a built-in look).
        project: the opened project (``project.model.Project``), once :func:`open_look_projects` read it.
        layers: the project's layers on the kiosk's head, once :func:`install_look_projects` put them there.
    """

    key: str
    label: str
    origin: str
    builtin: str = ""
    path: Path | None = None
    project: Any = None
    layers: list[LookLayer] | None = None

    @property
    def in_attract(self) -> bool:
        """Whether the attract mode shows it (every look but the bare face)."""
        return self.builtin != BARE


def builtin_look(name: str, origin: str = "") -> KioskLook:
    """The built-in look ``name`` as a kiosk look ("red-lip" → the button "Red Lip")."""
    return KioskLook(name, name.replace("-", " ").title(), origin, builtin=name)


def _parse_look(entry: object, origin: str, base: Path, builtins: list[str]) -> KioskLook:
    """A look entry (a built-in look's name, or a project file relative to ``base``); not opened yet."""
    if not isinstance(entry, str) or not entry.strip():
        raise SheerError(f"{origin}: {entry!r} is not a look: give a built-in look's name or a .sheer file")
    text = entry.strip()
    if text in builtins:
        return builtin_look(text, origin)
    path = Path(text).expanduser()
    path = path if path.is_absolute() else base / path
    if path.suffix.lower() != ".sheer" and not path.exists():
        raise SheerError(f"{origin}: {text!r} is neither a built-in look ({', '.join(builtins)}) nor a project "
                         f"file (.sheer)")
    return KioskLook("", "", origin, path=path.absolute())


def kiosk_looks(config: KioskConfig, project: str | None = None, where: str | None = None) -> list[KioskLook]:
    """The kiosk's looks, projects not opened yet: ``project`` first, then the configuration's ``looks``.

    The configuration's list defaults to :data:`DEFAULT_LOOKS`; a look named twice is kept once, where it
    comes first.

    Args:
        config: the configuration (its ``looks``; relative paths are from its folder).
        project: ``--project``: a project shown first.
        where: how messages name the configuration's list (default: its file and ``looks``).

    Raises:
        SheerError: an entry that is neither a built-in look nor a project file (one line naming the
            configuration file and the entry).
    """
    from painting.looks import available_looks

    builtins = available_looks()
    where = where or f"{config.source or 'the kiosk configuration'}: looks"
    entries: list[tuple[object, str, Path]] = [(project, "--project", Path.cwd())] if project else []
    if config.looks:
        entries += [(e, f"{where}[{i}]", config.folder()) for i, e in enumerate(config.looks)]
    else:
        entries += [(name, where, config.folder()) for name in DEFAULT_LOOKS]
    looks: list[KioskLook] = []
    for entry, origin, base in entries:
        look = _parse_look(entry, origin, base, builtins)
        if not any((look.builtin and k.builtin == look.builtin) or (look.path and k.path == look.path)
                   for k in looks):
            looks.append(look)
    return looks


def open_look_projects(looks: list[KioskLook], on_error: Callable[[KioskLook, str], None] | None = None) -> None:
    """Open (and check) each project of ``looks``, naming each look after its project.

    The button's label is the project's stored name (its file's stem when it has none). The first
    project's key is ``project`` (the kiosk's own look: a look the capture carries onto the shopper's
    face as it is), the others' ``project-2``, ``project-3``…

    Args:
        looks: the kiosk's looks (:func:`kiosk_looks`); a project that cannot be used is removed from it
            when ``on_error`` is given.
        on_error: called with the look and the one-line message instead of raising.

    Raises:
        SheerError: (without ``on_error``) a project that cannot be opened: one line naming where it was
            listed, the file and what is wrong.
    """
    from project.io import open_project

    for look in list(looks):
        if look.path is None or look.project is not None:
            continue
        try:
            try:
                look.project = open_project(look.path)
            except OSError as exc:
                raise SheerError(f"{look.path}: {exc.strerror or exc}") from None
        except SheerError as exc:
            _refuse(looks, look, f"{look.origin}: {exc}", on_error)
            continue
        name = str(look.project.name or "").strip()
        look.label = name if name and name != "Untitled" else look.path.stem
    for n, look in enumerate([k for k in looks if k.path is not None], start=1):
        look.key = "project" if n == 1 else f"project-{n}"


def _refuse(looks: list[KioskLook], look: KioskLook, message: str,
            on_error: Callable[[KioskLook, str], None] | None) -> None:
    """Refuse a look that cannot be used.

    :class:`SheerError` with ``message`` (one line), or, with ``on_error``, ``on_error(look, message)`` and
    the look removed from ``looks``.
    """
    if on_error is None:
        raise SheerError(message) from None
    on_error(look, message)
    looks.remove(look)


def install_look_projects(looks: list[KioskLook], session: Session,
                          on_error: Callable[[KioskLook, str], None] | None = None) -> None:
    """Put each opened project of ``looks`` on the kiosk's head (``session``) and keep its layers.

    A project painted at another resolution is resampled; the project's materials join the session's
    library. The session's document is left with no layers.

    Args:
        looks: the kiosk's looks, their projects opened (:func:`open_look_projects`); a project that
            cannot be used is removed from it when ``on_error`` is given.
        session: the kiosk's library and document (its head, its resolution).
        on_error: called with the look and the one-line message instead of raising.

    Raises:
        SheerError: (without ``on_error``) a project painted on another head, or whose maps cannot be
            used: one line naming where it was listed and the file.
    """
    from app.project_io import load_project_into

    doc = session.document
    for look in list(looks):
        if look.project is None or look.layers is not None:
            continue
        try:
            load_project_into(doc, session.library, look.project, resample=True)
        except SheerError as exc:
            _refuse(looks, look, f"{look.origin}: {look.path}: {exc}", on_error)
            continue
        look.layers = snapshot_layers(doc)
    replay_layers(doc, [])
