"""``sheer kiosk [--project FILE] [--config FILE] [--set-pin [--allow-short-pin]] [--windowed]``: the in-store kiosk.

``--set-pin`` asks for the administrator PIN (twice) and stores its salted hash. It refuses fewer than
6 digits unless ``--allow-short-pin``: after 5 wrong PINs the pad locks for 30 s, doubling up to 15
minutes, so a guesser gets about 96 tries a day; that finds a 4-digit PIN (10,000 values) within weeks,
a 6-digit one (1,000,000) only after years.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import argparse

#: The fewest digits ``--set-pin`` accepts, and with ``--allow-short-pin``; the most digits.
MIN_PIN, MIN_SHORT_PIN, MAX_PIN = 6, 4, 12


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``sheer kiosk`` and its options to the sub-command parsers ``sub``."""
    p = sub.add_parser("kiosk", help="start the full-screen customer kiosk", description=__doc__)
    p.add_argument("--project", help="project (.sheer) to show")
    p.add_argument("--config", help="kiosk configuration file (default: ~/.config/sheer/kiosk.json)")
    p.add_argument("--set-pin", action="store_true", help="ask for a new administrator PIN, store it hashed, exit")
    p.add_argument("--allow-short-pin", action="store_true",
                   help=f"with --set-pin: accept {MIN_SHORT_PIN} or {MIN_SHORT_PIN + 1} digits (guessable within weeks)")
    p.add_argument("--snapshot-dir", help="store this snapshot folder in the configuration and exit")
    p.add_argument("--windowed", action="store_true", help="run in a window (for setting up)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Store a PIN or a snapshot folder (``--set-pin``, ``--snapshot-dir``), or run the kiosk; returns the exit status."""
    from pathlib import Path

    from core.errors import SheerError

    if args.allow_short_pin and not args.set_pin:
        raise SheerError("--allow-short-pin goes with --set-pin")
    if args.set_pin or args.snapshot_dir:
        import getpass

        from app.kiosk_config import KioskConfig, hash_pin

        path = Path(args.config) if args.config else None
        cfg = KioskConfig.load(path)
        if args.set_pin:
            pin = getpass.getpass("New administrator PIN (digits): ")
            shortest = MIN_SHORT_PIN if args.allow_short_pin else MIN_PIN
            if not pin.isdigit() or len(pin) > MAX_PIN:
                raise SheerError(f"the PIN must be {shortest} to {MAX_PIN} digits (0-9 only); nothing was changed")
            if len(pin) < shortest:
                raise SheerError(f"the PIN has {len(pin)} digits; use at least {shortest}"
                                 + ("" if args.allow_short_pin else
                                    f" (a shorter one can be guessed within weeks despite the lockout; "
                                    f"--allow-short-pin accepts {MIN_SHORT_PIN})") + "; nothing was changed")
            if getpass.getpass("Again: ") != pin:
                raise SheerError("the two PINs differ; nothing was changed")
            cfg.pin_hash = hash_pin(pin)
        if args.snapshot_dir:
            cfg.snapshot_dir = str(Path(args.snapshot_dir).expanduser().resolve())
        print(f"kiosk configuration saved to {cfg.save(path)}")
        return 0
    from app.kiosk import run_kiosk

    return run_kiosk(project=args.project, config_path=args.config, windowed=args.windowed)
