"""Shared fixtures.

- ``gl_ctx``: the one standalone EGL context of the session (Mesa llvmpipe, GL 4.5 core). A test that
  leaves ``ctx.error`` other than ``GL_NO_ERROR`` fails.
- Comparing GPU frames and maps (ΔE2000 bounds, stored references, 8-bit levels): tests/imaging.py.
- The RNG is seeded for every test.
"""

from __future__ import annotations

import os
import random
import sys
from typing import TYPE_CHECKING

import numpy as np
import pytest

if TYPE_CHECKING:
    from collections.abc import Iterator


def pytest_configure(config: pytest.Config) -> None:
    """Qt's environment as the studio sets it, before pytest-qt makes the QApplication.

    Qt's GL windows then use EGL on X11, like the headless contexts of the render tests, so Qt window
    tests and headless GL tests may run in any order (with Qt's default GLX integration a Qt GL window
    shown after a headless EGL context never got its context: see ``app.application.configure_qt_environment``).
    """
    from app.application import configure_qt_environment

    configure_qt_environment()


@pytest.fixture(autouse=True)
def _seed_rng() -> None:
    random.seed(1234)
    np.random.seed(1234)


@pytest.fixture(scope="session")
def _gl_session_ctx() -> Iterator[object]:
    import moderngl  # a required dependency: missing, the GL tests fail rather than skip

    ctx = moderngl.create_context(standalone=True, backend="egl", require=450)
    yield ctx
    ctx.release()


@pytest.fixture
def gl_ctx(_gl_session_ctx: object) -> Iterator[object]:
    """The session's standalone GL context; fails the test if it leaves a GL error behind."""
    ctx = _gl_session_ctx
    assert ctx.error == "GL_NO_ERROR", "a GL error was pending before the test"  # type: ignore[attr-defined]
    yield ctx
    err = ctx.error  # type: ignore[attr-defined]
    assert err == "GL_NO_ERROR", f"the test left a GL error: {err}"


#: The session's exit status, kept for :func:`pytest_unconfigure`.
_EXIT_STATUS: list[int] = []


@pytest.hookimpl(trylast=True)
def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """Keep the session's exit status (pass, fail, no tests …) for :func:`pytest_unconfigure`."""
    _EXIT_STATUS.append(int(exitstatus))


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config: pytest.Config) -> None:
    """Leave with the session's exit status once pytest has reported, skipping the interpreter's teardown.

    Some full runs (2 of the 14 logged in sessions 7–8) ended "… passed" and then crashed while Python tore
    down the PySide6 wrappers ("QObject: shared QObject was deleted directly", a segmentation fault, exit
    139), after every test and fixture had finished — not anything a test checks, but it turned a green
    suite red. The root cause is not found (session 9, hygiene note): the suspect, ``Viewport.shutdown()``
    deleting the GL window under a live ``Viewport.surface`` wrapper, is ruled out (the wrapper is
    invalidated with the window, and every GLSurface is invalid at exit), and tests/app with the teardown
    kept, in order and with PySide's exit-time deletions shuffled, never crashed. The studio's and the
    kiosk's own exits are tested as real processes (tests/app/test_exit.py). ``SHEER_TEST_TEARDOWN=1``
    keeps the teardown, to study that crash, with the fault handler on so a crash prints the Python stack
    of every thread.
    """
    if os.environ.get("SHEER_TEST_TEARDOWN") == "1":
        import faulthandler

        faulthandler.enable(file=sys.__stderr__, all_threads=True)  # pytest's own was turned off before
        return
    if not _EXIT_STATUS:
        return
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(_EXIT_STATUS[-1])
