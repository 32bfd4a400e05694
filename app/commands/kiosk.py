"""``sheer kiosk [--project FILE] [--config FILE] [--set-pin] [--windowed]``: the in-store try-on kiosk."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import argparse


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``sheer kiosk`` and its options to the sub-command parsers ``sub``."""
    p = sub.add_parser("kiosk", help="start the full-screen customer kiosk", description=__doc__)
    p.add_argument("--project", help="project (.sheer) to show")
    p.add_argument("--config", help="kiosk configuration file (default: ~/.config/sheer/kiosk.json)")
    p.add_argument("--set-pin", action="store_true", help="ask for a new administrator PIN, store it hashed, exit")
    p.add_argument("--snapshot-dir", help="store this snapshot folder in the configuration and exit")
    p.add_argument("--windowed", action="store_true", help="run in a window (for setting up)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Store a PIN or a snapshot folder (``--set-pin``, ``--snapshot-dir``), or run the kiosk; returns the exit status."""
    from pathlib import Path

    from core.errors import SheerError

    if args.set_pin or args.snapshot_dir:
        import getpass

        from app.kiosk_config import KioskConfig, hash_pin

        path = Path(args.config) if args.config else None
        cfg = KioskConfig.load(path)
        if args.set_pin:
            pin = getpass.getpass("New administrator PIN (digits): ")
            if not pin.isdigit() or not 4 <= len(pin) <= 12:
                raise SheerError("the PIN must be 4 to 12 digits")
            if getpass.getpass("Again: ") != pin:
                raise SheerError("the two PINs differ; nothing was changed")
            cfg.pin_hash = hash_pin(pin)
        if args.snapshot_dir:
            cfg.snapshot_dir = str(Path(args.snapshot_dir).expanduser().resolve())
        print(f"kiosk configuration saved to {cfg.save(path)}")
        return 0
    from app.kiosk import run_kiosk

    return run_kiosk(project=args.project, config_path=args.config, windowed=args.windowed)
