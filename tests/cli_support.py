"""The ``sheer`` command line run in this process, for the tests that check its output and exit status
without the cost of a new process (what the process itself adds is tested through real ones)."""

from __future__ import annotations

import contextlib
import io
import subprocess
from pathlib import Path


def sheer(*args: str) -> subprocess.CompletedProcess[str]:
    """``sheer ARGS`` through the command line's entry function, in this process: its exit status and output."""
    from app.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args))
    return subprocess.CompletedProcess(["sheer", *args], code, out.getvalue(), err.getvalue())


#: This checkout's root: the folder a child Python process must import Sheer from.
CHECKOUT = Path(__file__).resolve().parents[1]


def checkout_env(**extra: str) -> dict[str, str]:
    """The environment of a child Python process of the tests.

    This process's, with Sheer imported from this checkout (``PYTHONPATH``) and ``extra`` variables set.
    """
    import os

    return {**os.environ, "PYTHONPATH": str(CHECKOUT), **extra}
