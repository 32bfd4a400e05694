"""``sheer kiosk [--project FILE] [--config FILE] [--log FILE] [--set-pin [--pin-file FILE] [--allow-short-pin]] [--windowed]``.

The in-store kiosk. ``--project FILE`` makes a brand's project the kiosk's look: its button first (named
from the project), selected, and in the attract mode's cycle, before the configured looks.

Setting up (each stores into the configuration and exits; they combine). The configuration
(``~/.config/sheer/kiosk.json``, ``$XDG_CONFIG_HOME``) holds the PIN's hash: it is written mode 0600.

- ``--set-pin`` stores the administrator PIN's salted hash. At a terminal it asks twice; when standard
  input is not a terminal (a provisioning script: ``echo 482913 | sheer kiosk --set-pin``) it reads the
  PIN from its first line (a second line, if any, must repeat it); ``--pin-file FILE`` reads it from a
  file's first line instead. It refuses fewer than 6 digits unless ``--allow-short-pin``: after 5 wrong
  PINs the pad locks for 30 s, doubling up to 15 minutes, so a guesser gets about 96 tries a day; that
  finds a 4-digit PIN (10,000 values) within weeks, a 6-digit one (1,000,000) only after years.
- ``--snapshot-dir DIR``: where Save Photo writes.
- ``--calibrate-light PROBE``: the kiosk's own light from a photograph of a mirror ball cropped to the
  ball, taken with the kiosk's camera and light (``--probe-reflectance R`` for a chrome ball's
  reflectance, default 1); "Try it on me" then captures with it instead of a white flash on the axis.
  ``--without-flash PROBE0``: the same ball photographed without the light at the same exposure and crop;
  the light's colour is then read from the difference of the two (free of the room's texture under the
  light's reflection on the ball: 2–4 % per channel from one photograph, within 0.2 % from two).
- ``--camera auto|off|INDEX|PATH`` and ``--watch-dir DIR`` (``""`` for none): the camera "Try it on me"
  uses, or the folder a kiosk without one takes the photo from. A device must be there and give a
  picture, a file must be a video OpenCV reads a frame from (a still image is refused: use a watched
  folder); checked again when the kiosk starts.
- ``--looks LIST``: the try-on screen's looks, comma-separated built-in looks and ``.sheer`` projects
  (``--looks brand.sheer,natural,red-lip``; ``""`` for the default ones); each project is opened and
  checked.

Starting, the configuration is checked first (the PIN, every project, the camera): what is wrong is one
line and exit status 2, before any window. The kiosk logs to ``--log FILE``, else ``$SHEER_KIOSK_LOG``,
else the configuration's ``log``, else ``~/.local/state/sheer/kiosk.log`` (``$XDG_STATE_HOME``), and says
where as it starts.
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import argparse
    import logging
    from pathlib import Path

    from app.commands import Subcommands
    from app.kiosk.config import KioskConfig

#: The fewest digits ``--set-pin`` accepts, and with ``--allow-short-pin``; the most digits.
MIN_PIN, MIN_SHORT_PIN, MAX_PIN = 6, 4, 12
#: The most bytes read from a PIN file or a PIN's standard input.
_PIN_INPUT_BYTES = 4096


def register(sub: Subcommands) -> None:
    """Add ``sheer kiosk`` and its options to the sub-command parsers ``sub``."""
    import argparse

    p = sub.add_parser("kiosk", help="start the full-screen customer kiosk", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--project", help="a project (.sheer): the kiosk's first look, before the configured ones")
    p.add_argument("--config", help="kiosk configuration file (default: ~/.config/sheer/kiosk.json)")
    p.add_argument("--set-pin", action="store_true",
                   help="store a new administrator PIN (hashed) and exit: asked at a terminal, else read from "
                        "standard input's first line")
    p.add_argument("--pin-file", metavar="FILE", help="with --set-pin: read the PIN from this file's first line")
    p.add_argument("--allow-short-pin", action="store_true",
                   help=f"with --set-pin: accept {MIN_SHORT_PIN} or {MIN_SHORT_PIN + 1} digits (guessable within weeks)")
    p.add_argument("--snapshot-dir", help="store this snapshot folder in the configuration and exit")
    p.add_argument("--calibrate-light", metavar="PROBE",
                   help="store the kiosk's light measured from this mirror-ball photograph (cropped to the ball) and exit")
    p.add_argument("--probe-reflectance", type=float, default=1.0, metavar="R",
                   help="with --calibrate-light: the ball's reflectance, 0 < R <= 1 (default 1)")
    p.add_argument("--without-flash", metavar="PROBE0",
                   help="with --calibrate-light: the same ball photographed without the kiosk's light, same "
                        "exposure and crop (the light's colour is read from the difference)")
    p.add_argument("--camera", metavar="auto|off|INDEX|PATH",
                   help="store the camera 'Try it on me' uses and exit")
    p.add_argument("--watch-dir", metavar="DIR",
                   help="store the folder a kiosk without a camera takes the photo from and exit ('' for none)")
    p.add_argument("--looks", metavar="LIST",
                   help="store the try-on screen's looks and exit: comma-separated built-in looks and .sheer "
                        "projects, in order ('' for the default ones)")
    p.add_argument("--log", metavar="FILE",
                   help="the kiosk's log file (default: the configuration's 'log', else "
                        "~/.local/state/sheer/kiosk.log)")
    p.add_argument("--windowed", action="store_true", help="run in a window (for setting up)")
    p.set_defaults(func=run)


def _read_pin_text(args: argparse.Namespace) -> tuple[str, str | None]:
    """The PIN and its repetition (None when there is none) from ``--pin-file``, piped input or the terminal."""
    from pathlib import Path

    from core.errors import SheerError

    if args.pin_file:
        from core.files import read_bounded

        try:
            text = read_bounded(Path(args.pin_file), _PIN_INPUT_BYTES, "PIN file", SheerError).decode("utf-8")
        except UnicodeDecodeError:
            raise SheerError(f"{args.pin_file}: the PIN file is not text; nothing was changed") from None
        lines = text.splitlines()
        return (lines[0].strip() if lines else ""), None
    if sys.stdin is not None and not sys.stdin.isatty():
        lines = sys.stdin.read(_PIN_INPUT_BYTES).splitlines()
        if not lines:
            raise SheerError("--set-pin: standard input is empty; pipe the PIN in (e.g. `echo PIN | sheer kiosk "
                             "--set-pin`) or use --pin-file FILE; nothing was changed")
        again = lines[1].strip() if len(lines) > 1 and lines[1].strip() else None
        return lines[0].strip(), again
    import getpass

    pin = getpass.getpass("New administrator PIN (digits): ")
    return pin, getpass.getpass("Again: ")


def _new_pin_hash(args: argparse.Namespace) -> str:
    """Read, check and hash the new PIN (SheerError, naming what is wrong, when it is refused)."""
    from app.kiosk.config import hash_pin
    from core.errors import SheerError

    pin, again = _read_pin_text(args)
    shortest = MIN_SHORT_PIN if args.allow_short_pin else MIN_PIN
    if not pin.isdigit() or len(pin) > MAX_PIN:
        raise SheerError(f"the PIN must be {shortest} to {MAX_PIN} digits (0-9 only); nothing was changed")
    if len(pin) < shortest:
        raise SheerError(f"the PIN has {len(pin)} digits; use at least {shortest}"
                         + ("" if args.allow_short_pin else
                            f" (a shorter one can be guessed within weeks despite the lockout; "
                            f"--allow-short-pin accepts {MIN_SHORT_PIN})") + "; nothing was changed")
    if again is not None and again != pin:
        raise SheerError("the two PINs differ; nothing was changed")
    return hash_pin(pin)


def _calibrated_light(path: str, reflectance: float, without_flash: str | None = None) -> dict[str, object]:
    """The mirror-ball photograph's analysis as the configuration stores it.

    With ``without_flash`` (the same ball photographed without the light), the light's colour is read from
    the difference of the two.
    """
    from capture.pipeline import read_photo
    from capture.probe import ProbeError, analyse_probe

    if not 0.0 < reflectance <= 1.0:  # NaN fails too
        raise ProbeError(f"--probe-reflectance must be in (0, 1], got {reflectance}")
    without = None if without_flash is None else read_photo(without_flash)
    probe = analyse_probe(read_photo(path), source=path, reflectance=reflectance, without_flash=without,
                          without_flash_source=str(without_flash))
    light = probe.to_json()
    light["source"] = str(path)
    if without_flash is not None:
        light["source_without_flash"] = str(without_flash)
    return light


def _checked_looks(text: str) -> list[str]:
    """``--looks LIST`` checked: built-in looks by name, projects opened and stored as absolute paths."""
    from app.kiosk.config import KioskConfig, kiosk_looks, open_look_projects

    entries = [e.strip() for e in text.split(",") if e.strip()]
    if not entries:
        return []
    looks = kiosk_looks(KioskConfig(looks=entries), where="--looks")
    open_look_projects(looks)
    return [look.builtin or str(look.path) for look in looks]


def _checked_camera(text: str) -> str:
    """``--camera`` checked: a device that is there and gives a picture, or a video file that gives a frame."""
    from app.camera_source import check_camera_setting, is_device, probe_camera

    camera = check_camera_setting(text)
    if is_device(camera):
        probe_camera(camera)
    return camera


def _store(args: argparse.Namespace) -> int:
    """Check every set-up option given, then store them all in the configuration (a refused one changes nothing)."""
    from pathlib import Path

    from app.kiosk.config import KioskConfig

    path = Path(args.config) if args.config else None
    cfg = KioskConfig.load(path)
    if args.set_pin:
        cfg.pin_hash = _new_pin_hash(args)
    if args.calibrate_light:
        cfg.light = _calibrated_light(args.calibrate_light, args.probe_reflectance, args.without_flash)
    if args.snapshot_dir:
        cfg.snapshot_dir = str(Path(args.snapshot_dir).expanduser().resolve())
    if args.camera is not None:
        cfg.camera = _checked_camera(args.camera)
    if args.watch_dir is not None:
        cfg.watch_dir = str(Path(args.watch_dir).expanduser().resolve()) if args.watch_dir else ""
    if args.looks is not None:
        cfg.looks = _checked_looks(args.looks)
    print(f"kiosk configuration saved to {cfg.save(path)}")
    if args.calibrate_light:
        light = cfg.light
        print(f"kiosk light: θ={float(light['theta_deg']):.1f}° φ={float(light['phi_deg']):.1f}° from the camera's "  # type: ignore[arg-type]
              f"axis, flash colour {[round(float(v), 3) for v in light['flash_rgb']]}")  # type: ignore[attr-defined]
    return 0


def _open_log(cfg: KioskConfig, override: str | None) -> tuple[logging.Handler, Path]:
    """Start logging (INFO and up, every logger) to the kiosk's log file; the handler and the file.

    Raises:
        SheerError: the file cannot be written (naming it, and how to choose another).
    """
    import logging

    from core.errors import SheerError

    path = cfg.log_path(override)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handler = logging.FileHandler(path, encoding="utf-8")
    except OSError as exc:
        raise SheerError(f"{path}: the kiosk cannot write its log there ({exc.strerror or exc}); choose another "
                         f"with --log FILE or the configuration's 'log'") from None
    handler.setLevel(logging.INFO)
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    root = logging.getLogger()
    root.addHandler(handler)
    root.setLevel(min(root.getEffectiveLevel(), logging.INFO))
    return handler, path


def _start(args: argparse.Namespace) -> int:
    """Check the configuration (PIN, looks, camera) and run the kiosk; what is wrong is one line, exit 2."""
    import logging
    from pathlib import Path

    from app.application import require_display
    from app.camera_source import CameraError, check_camera_setting
    from app.kiosk.config import (
        KioskConfig,
        install_look_projects,
        kiosk_looks,
        open_look_projects,
        require_pin,
    )
    from core.errors import SheerError

    cfg = KioskConfig.load(Path(args.config) if args.config else None)
    require_pin(cfg)  # the first thing to set up
    looks = kiosk_looks(cfg, args.project)
    open_look_projects(looks)
    try:
        cfg.camera = check_camera_setting(cfg.camera)
    except CameraError as exc:
        raise SheerError(f"{cfg.source}: {exc}") from None
    require_display("kiosk")  # before Qt is imported: its abort is a paragraph and status 134
    from app.session import Session

    session = Session.open(resolution=cfg.resolution)
    install_look_projects(looks, session)  # a project painted on another head is refused here
    handler, log_path = _open_log(cfg, args.log)
    print(f"sheer kiosk: logging to {log_path}", flush=True)
    log = logging.getLogger("sheer.kiosk")
    log.info("kiosk: starting (configuration %s, log %s, looks %s)", cfg.source, log_path,
             ", ".join(look.label for look in looks))
    from app.kiosk.window import run_kiosk

    try:
        return run_kiosk(cfg, looks=looks, session=session, windowed=args.windowed)
    finally:
        logging.getLogger().removeHandler(handler)
        handler.close()


def run(args: argparse.Namespace) -> int:
    """Store the set-up options given (PIN, snapshot folder, light, camera, watched folder, looks), or run the kiosk."""
    from core.errors import SheerError

    if (args.allow_short_pin or args.pin_file) and not args.set_pin:
        raise SheerError("--allow-short-pin and --pin-file go with --set-pin")
    if args.probe_reflectance != 1.0 and not args.calibrate_light:
        raise SheerError("--probe-reflectance goes with --calibrate-light (the mirror ball it describes)")
    if args.without_flash and not args.calibrate_light:
        raise SheerError("--without-flash goes with --calibrate-light (the same ball photographed with the light)")
    setting_up = (args.set_pin, args.snapshot_dir, args.calibrate_light, args.camera is not None,
                  args.watch_dir is not None, args.looks is not None)
    if any(setting_up):
        if args.project or args.log:
            raise SheerError("--project and --log go with starting the kiosk, not with the set-up options")
        return _store(args)
    return _start(args)
