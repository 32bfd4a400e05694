"""Shared fixtures.

- ``gl_ctx``: the one standalone EGL context of the session (Mesa llvmpipe, GL 4.5 core). A test that
  leaves ``ctx.error`` other than ``GL_NO_ERROR`` fails.
- ``assert_image_close``: compare an image with a stored reference; a failure writes the actual image
  and the diff image under ``tests/_failures/``; ``SHEER_REGEN_REFERENCES=1`` rewrites the references.
- The RNG is seeded for every test.
"""

from __future__ import annotations

import os
import random
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator

TESTS_DIR = Path(__file__).resolve().parent
REFERENCE_DIR = TESTS_DIR / "references"
FAILURE_DIR = TESTS_DIR / "_failures"


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


def _to_float(img: np.ndarray) -> np.ndarray:
    a = np.asarray(img)
    if a.dtype == np.uint8:
        return a.astype(np.float64) / 255.0
    if a.dtype == np.uint16:
        return a.astype(np.float64) / 65535.0
    return a.astype(np.float64)


@pytest.fixture
def assert_image_close(request: pytest.FixtureRequest) -> Callable[..., None]:
    """``assert_image_close(image, "name.png", mean_tol=..., max_tol=..., frac_tol=...)``.

    ``image`` is uint8 (H, W, 3|4). Passes when the mean absolute difference (0..1 scale) is at most
    ``mean_tol`` and the fraction of pixels differing by more than ``max_tol`` is at most ``frac_tol``.
    """
    from PIL import Image

    def check(image: np.ndarray, name: str, mean_tol: float = 0.01, max_tol: float = 0.1,
              frac_tol: float = 0.005) -> None:
        ref_path = REFERENCE_DIR / name
        img = np.ascontiguousarray(image)
        if os.environ.get("SHEER_REGEN_REFERENCES") or not ref_path.exists():
            if not os.environ.get("SHEER_REGEN_REFERENCES"):
                pytest.fail(f"no reference image {ref_path}; run with SHEER_REGEN_REFERENCES=1 to make it")
            ref_path.parent.mkdir(parents=True, exist_ok=True)
            Image.fromarray(img).save(ref_path)
            return
        ref = np.asarray(Image.open(ref_path))
        if ref.shape != img.shape:
            pytest.fail(f"image shape {img.shape} differs from reference {ref.shape} ({ref_path})")
        diff = np.abs(_to_float(img) - _to_float(ref))
        per_px = diff.max(axis=-1) if diff.ndim == 3 else diff
        mean = float(diff.mean())
        frac = float((per_px > max_tol).mean())
        if mean > mean_tol or frac > frac_tol:
            FAILURE_DIR.mkdir(parents=True, exist_ok=True)
            stem = f"{request.node.name}-{Path(name).stem}"
            Image.fromarray(img).save(FAILURE_DIR / f"{stem}-actual.png")
            vis = np.clip(per_px * 4.0 * 255.0, 0, 255).astype(np.uint8)
            Image.fromarray(vis).save(FAILURE_DIR / f"{stem}-diff.png")
            pytest.fail(
                f"image differs from {ref_path}: mean |diff| {mean:.4f} (tol {mean_tol}), "
                f"{frac:.4%} of pixels over {max_tol} (tol {frac_tol:.4%}); "
                f"diff written to {FAILURE_DIR / (stem + '-diff.png')}"
            )

    return check


@pytest.fixture
def assert_de2000_close(request: pytest.FixtureRequest) -> Callable[..., float]:
    """``assert_de2000_close(a, b, mask, mean_tol, name)``: two uint8 sRGB frames agree on ``mask``.

    Passes when the mean ΔE2000 over the pixels of ``mask`` (bool (H, W)) is at most ``mean_tol``;
    otherwise writes both frames and the ΔE map (×25 grey levels per ΔE unit) to ``tests/_failures`` and
    fails. Returns the mean.
    """
    from PIL import Image

    from bench.stats import de2000_srgb8

    def check(a: np.ndarray, b: np.ndarray, mask: np.ndarray, mean_tol: float, name: str) -> float:
        assert a.shape == b.shape and mask.shape == a.shape[:2] and mask.any(), "frames and mask must match"
        de = de2000_srgb8(a, b, mask)
        mean = float(de.mean())
        if mean > mean_tol:
            FAILURE_DIR.mkdir(parents=True, exist_ok=True)
            stem = f"{request.node.name}-{name}"
            Image.fromarray(np.ascontiguousarray(a)).save(FAILURE_DIR / f"{stem}-a.png")
            Image.fromarray(np.ascontiguousarray(b)).save(FAILURE_DIR / f"{stem}-b.png")
            vis = np.zeros(mask.shape, np.float64)
            vis[mask] = de * 25.0
            Image.fromarray(np.clip(vis, 0, 255).astype(np.uint8)).save(FAILURE_DIR / f"{stem}-de2000.png")
            pytest.fail(f"{name}: mean ΔE2000 {mean:.3f} on {int(mask.sum())} pixels (tol {mean_tol}); "
                        f"diff written to {FAILURE_DIR / (stem + '-de2000.png')}")
        return mean

    return check


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
