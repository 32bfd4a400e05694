"""``sheer doctor``: in-process on this machine (exit 0, every line, ``--json``), headless without Qt or a
display (a real process), and its failures: a shader that does not compile (located as
``file.glsl:line: message``), no GL context at all, a missing sample head."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from app.cli import main

if TYPE_CHECKING:
    from collections.abc import Callable

pytestmark = pytest.mark.gl

REPO = Path(__file__).resolve().parents[3]
NAMES = ("GL", "max texture", "shaders", "assets", "cache", "dependencies", "Python", "OS")


@pytest.fixture
def run_doctor(capsys: pytest.CaptureFixture[str]) -> Callable[..., tuple[int, str]]:
    """``sheer doctor ARGS`` in this process: (exit status, stdout)."""

    def run(*args: str) -> tuple[int, str]:
        rc = main(["doctor", *args])
        return rc, capsys.readouterr().out

    return run


def test_doctor_on_this_machine(run_doctor: Callable[..., tuple[int, str]]) -> None:
    rc, out = run_doctor()
    assert rc == 0, out
    lines = out.splitlines()
    for name in NAMES:
        assert any(line.startswith("ok") and line[6:].startswith(f"{name}: ") for line in lines), (name, out)
    gl = next(line for line in lines if line[6:].startswith("GL: "))
    assert "llvmpipe" in gl and "4.5" in gl and gl.endswith(", EGL"), gl
    texture = next(line for line in lines if "max texture:" in line)
    assert "16384 texels" in texture and "needs 8192" in texture and "painting.atlas.MAX_RESOLUTION" in texture
    shaders = next(line for line in lines if line[6:].startswith("shaders: "))
    assert "quick" in shaders and "physical" in shaders and "lightweight" in shaders
    assert lines[-1] == "sheer doctor (quick): all is well"


def test_doctor_json(run_doctor: Callable[..., tuple[int, str]]) -> None:
    from render.programs import programs

    rc, out = run_doctor("--json")
    assert rc == 0
    report = json.loads(out)
    assert report["ok"] is True and report["level"] == "quick"
    checks = report["checks"]
    assert [c["name"] for c in checks.values()] == list(NAMES)
    assert all(c["status"] == "ok" for c in checks.values())
    assert checks["gl"]["api"] == "EGL" and "llvmpipe" in checks["gl"]["renderer"]
    assert checks["texture"]["max_texture_size"] >= checks["texture"]["required"] == 8192
    assert checks["shaders"]["programs"] == checks["shaders"]["built"] == len(programs("quick"))
    assert checks["shaders"]["failed"] == 0
    assert {"physical", "lightweight"} <= set(checks["shaders"]["engines"])
    assert set(checks["assets"]["present"]) == {"head", "photos", "environments", "spectra"}
    versions = checks["dependencies"]["versions"]
    assert set(versions) == {"numpy", "scipy", "colour-science", "moderngl", "PySide6", "trimesh", "mediapipe",
                             "dask", "distributed", "OpenEXR", "Pillow"}
    assert all(versions.values())
    assert checks["python"]["version"].startswith("3.")


def test_headless_without_display_never_loads_qt(tmp_path: Path) -> None:
    """A real process without DISPLAY: exit 0, and PySide6 is not imported after the in-process run."""
    code = ("import sys\n"
            "from app.cli import main\n"
            "rc = main(['doctor'])\n"
            "print('QT-LOADED' if 'PySide6' in sys.modules else 'QT-NOT-LOADED')\n"
            "sys.exit(rc)\n")
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM")}
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=300,
                          env={**env, "XDG_CACHE_HOME": str(tmp_path / "cache")})
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.splitlines()[-1] == "QT-NOT-LOADED"
    assert f"cache: {tmp_path / 'cache' / 'sheer'} (not made yet): 0.0 MiB in 0 entries" in proc.stdout


def test_a_shader_that_does_not_compile_fails_with_its_file_and_line(
        run_doctor: Callable[..., tuple[int, str]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import shutil

    import render.shaders

    folder = tmp_path / "shaders"
    shutil.copytree(render.shaders.default_shader_dir(), folder)
    frag = folder / "lightweight_eye.frag.glsl"
    lines = frag.read_text(encoding="utf-8").splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("void main"))
    lines.insert(at + 2, "    float broken = no_such_variable;")
    frag.write_text("\n".join(lines) + "\n", encoding="utf-8")
    monkeypatch.setattr(render.shaders, "default_shader_dir", lambda: folder)

    rc, out = run_doctor()
    assert rc == 1
    shaders = next(line for line in out.splitlines() if line[6:].startswith("shaders: "))
    assert shaders.startswith("FAIL  shaders: 1 failed: lightweight_eye.vert + lightweight_eye.frag;"), shaders
    assert f"lightweight_eye.frag.glsl:{at + 3}: " in out and "no_such_variable" in out, out
    assert "(lightweight, render/lightweight.py)" in out
    assert out.splitlines()[-1] == "sheer doctor (quick): 1 failed: shaders"

    rc, out = run_doctor("--json")
    report = json.loads(out)
    assert rc == 1 and report["ok"] is False
    failure, = report["checks"]["shaders"]["failures"]
    assert failure["program"] == "lightweight_eye.vert + lightweight_eye.frag"
    assert any(m.startswith(f"lightweight_eye.frag.glsl:{at + 3}: ") for m in failure["located"])


def test_no_gl_context_is_a_failed_line_not_a_traceback(
        run_doctor: Callable[..., tuple[int, str]], monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    import moderngl

    def no_egl(**kwargs: object) -> None:
        raise Exception("libEGL.so.1: cannot open shared object file: No such file or directory")

    monkeypatch.setattr(moderngl, "create_context", no_egl)
    rc, out = run_doctor()
    assert rc == 1
    lines = out.splitlines()
    assert lines[0] == ("FAIL  GL: no headless EGL context with GL 4.5 (Exception: libEGL.so.1: cannot open "
                        "shared object file: No such file or directory)")
    assert lines[1].startswith("skip  max texture: not checked")
    assert lines[2].startswith("skip  shaders: not checked")
    assert all(line.startswith("ok") for line in lines[3:-1])
    assert lines[-1] == "sheer doctor (quick): 1 failed: GL"
    assert "Traceback" not in capsys.readouterr().err


def test_missing_sample_head_fails_the_assets_line(
        run_doctor: Callable[..., tuple[int, str]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import app.diagnostics

    (tmp_path / "photos").mkdir()
    (tmp_path / "photos" / "astronaut.png").write_bytes(b"")
    monkeypatch.setattr("core.assets.assets_search_path", lambda: [tmp_path])
    line = app.diagnostics.assets_line()
    assert line.status == "FAIL" and line.text.startswith(f"{tmp_path}: photos; the sample head is missing")
    assert "heads/lee-perry-smith/head.glb" in line.details[0]


def test_sample_asset_paths_are_the_ones_sheer_reads() -> None:
    from app.diagnostics import ESSENTIAL_ASSET, SAMPLE_ASSETS
    from capture.person import CANONICAL_FACE
    from core.assets import ASSET_CREDITS
    from km.skin import HAEMOGLOBIN_ASSET
    from painting.head import SAMPLE_HEAD

    assert ESSENTIAL_ASSET == SAMPLE_HEAD
    assert SAMPLE_ASSETS["head"] == (SAMPLE_HEAD, CANONICAL_FACE)
    assert SAMPLE_ASSETS["spectra"] == (HAEMOGLOBIN_ASSET,)
    assert set(SAMPLE_ASSETS["photos"]) == {k for k in ASSET_CREDITS if k.startswith("photos/")}


def test_help_says_how_long_each_level_takes(run_doctor: Callable[..., tuple[int, str]]) -> None:
    rc, out = run_doctor("--help")
    assert rc == 0
    assert "--full" in out and "s here" in out
