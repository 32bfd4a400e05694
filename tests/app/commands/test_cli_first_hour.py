"""A designer's and a pipeline engineer's first hour with ``sheer``: what the command line says outside the studio.

Through the real command: the installed ``sheer`` in a process where the process is the point (no display,
exit statuses, what reaches the terminal's descriptors, a closed pipe), ``app.cli.main`` in this process
where it adds nothing.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

from app.cli import main

if TYPE_CHECKING:
    from collections.abc import Sequence

SHEER = str(Path(sys.executable).with_name("sheer"))
DATA = Path(__file__).resolve().parents[2] / "data" / "materials"


def sheer(*args: str, env: dict[str, str] | None = None, cwd: str | Path | None = None,
          timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """The installed ``sheer`` with ``args``, its output captured."""
    return subprocess.run([SHEER, *args], capture_output=True, text=True, timeout=timeout, env=env, cwd=cwd)


def no_display_env(tmp_path: Path) -> dict[str, str]:
    """This process's environment without a display (and a home of its own: no kiosk configuration)."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM")}
    return {**env, "HOME": str(tmp_path), "XDG_CONFIG_HOME": str(tmp_path / "config")}


def run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("args", [[], ["studio"], ["kiosk"], ["--head", "x.obj"]])
def test_without_a_display_the_windows_say_so_in_one_line(tmp_path: Path, args: Sequence[str]) -> None:
    """Not Qt's "xcb-cursor0 is needed … reinstall" paragraph and status 134 (SIGABRT): make run's line, status 2."""
    env = no_display_env(tmp_path)
    if args == ["kiosk"]:  # a kiosk set up (its PIN: refused first without one), then started
        config = str(tmp_path / "kiosk.json")
        setup = subprocess.run([SHEER, "kiosk", "--config", config, "--set-pin"], input="482913\n", env=env,
                               capture_output=True, text=True, timeout=120)
        assert setup.returncode == 0, setup.stderr
        args = ["kiosk", "--config", config]
    done = sheer(*args, env=env)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    assert "DISPLAY" in lines[0] and "xvfb-run" in lines[0] and "sheer render" in lines[0]
    assert "qt." not in done.stderr and "Reinstalling" not in done.stderr and done.stdout == ""


def test_a_closed_pipe_ends_the_command_quietly(tmp_path: Path) -> None:
    """``sheer … | head``: no "sheer: error: Broken pipe", and the status of a Unix tool killed by SIGPIPE."""
    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader is gone before the first line: every write fails (EPIPE)
    try:
        done = subprocess.run([SHEER, "cache", "info"], stdout=write_end, stderr=subprocess.PIPE, text=True,
                              timeout=120, env={**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache")})
    finally:
        os.close(write_end)
    assert done.stderr == ""
    assert done.returncode == 141


@pytest.mark.parametrize("args,where", [
    (["render", "--size", "abc", "--out", "x.png"], "sheer render"),
    (["shade", "match", "--rgb", "150,100,75", "--top", "many"], "sheer shade match"),
    (["capture", "--photo", "p.jpg"], "sheer capture"),
])
def test_a_bad_option_is_one_line_naming_the_help(capsys: pytest.CaptureFixture[str], args: list[str],
                                                   where: str) -> None:
    """Not the 9-line usage block before the line that matters."""
    code, out, err = run(capsys, *args)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"{where}: error: ") and "usage:" not in err
    assert err.rstrip().endswith(f"see '{where} --help'")


def test_a_write_that_fails_names_the_file_asked_for(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """Not the hidden temporary file of the atomic write (``…/.p.png.z13ce114.tmp``)."""
    blocker = tmp_path / "a-file"
    blocker.write_text("in the way")
    for args, name in ((["materials", "plot", "Foundation Beige", "--out", str(blocker / "p.png")], "p.png"),
                       (["materials", "export", "Foundation Beige", "--out", str(blocker / "p.csv")], "p.csv")):
        code, _, err = run(capsys, *args)
        assert code == 2 and err.count("\n") == 1, err
        assert str(blocker / name) in err and ".tmp" not in err, err


def test_a_truncated_exr_is_one_line(tmp_path: Path) -> None:
    """OpenEXR's own "Warning: Exception raised reading pixel data…" (stdout) and EXR_ERR line (stderr) never
    reach the terminal: only Sheer's one line naming the file."""
    import OpenEXR

    from capture.phong import PhongParams

    face = tmp_path / "face"
    face.mkdir()
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    rgb = np.random.default_rng(0).random((64, 64, 3)).astype(np.float32)
    OpenEXR.File(hdr, {"RGB": rgb}).write(str(tmp_path / "whole.exr"))
    data = (tmp_path / "whole.exr").read_bytes()
    (face / "detail.exr").write_bytes(data[: len(data) // 2])
    params = PhongParams(diffuse=np.array([0.3, 0.2, 0.1]), specular=0.1, exponent=20.0, ambient_scale=0.2)
    (face / "face.json").write_text(json.dumps({"schema_version": 1, "phong": params.to_json()}), "utf-8")
    done = sheer("shade", "match", "--face", str(face))
    assert done.returncode == 2 and done.stdout == ""
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith(f"sheer: error: {face / 'detail.exr'}: damaged or truncated EXR file")


def test_import_without_a_library_says_checked_not_imported(capsys: pytest.CaptureFixture[str]) -> None:
    """One meaning: "imported 1 material" then "(checked only…)" said two things."""
    code, out, _ = run(capsys, "materials", "import", str(DATA / "xrite_single.txt"), "--thickness-mm", "0.15",
                       "--name", "X1")
    assert code == 0
    assert "checked 1 material" in out and "nothing saved: pass --library PATH" in out
    assert "imported" not in out and "checked only" not in out


def test_project_info_names_the_painted_peak_and_the_max_thickness(capsys: pytest.CaptureFixture[str],
                                                                   tmp_path: Path) -> None:
    """The studio's "Max thickness" is the layer's cap; what is painted is its peak: two words for two things."""
    from bench.fuzz import sample_project
    from project.io import save_project

    project = sample_project(64, 2)
    path = tmp_path / "p.sheer"
    save_project(project, path, self_contained=True)
    code, out, _ = run(capsys, "project", "info", str(path))
    assert code == 0
    rows = [line for line in out.splitlines() if "opacity" in line]
    assert len(rows) == 2
    for row, layer in zip(rows, project.layers):
        assert f"max thickness {layer.max_thickness_um:g} µm" in row
        assert f"painted: peak {float(layer.thickness.max()):.2f} µm" in row
        assert " max " not in row.replace("max thickness", "")
    code, out, _ = run(capsys, "project", "info", "--json", str(path))
    js = json.loads(out)["layers"]
    assert [la["peak_um"] for la in js] == pytest.approx([float(la.thickness.max()) for la in project.layers])
    assert [la["max_thickness_um"] for la in js] == [la.max_thickness_um for la in project.layers]


def _help(capsys: pytest.CaptureFixture[str], *args: str) -> str:
    code, out, _ = run(capsys, *args, "--help")
    assert code == 0
    return " ".join(out.split())  # argparse wraps lines anywhere


def test_help_lists_what_the_code_knows(capsys: pytest.CaptureFixture[str]) -> None:
    """Every help that lists choices or a default says what the code uses: no "app.settings.DEFAULT_RESOLUTION",
    no 4 looks of 6."""
    from app.settings import DEFAULT_RESOLUTION, LIGHT_PRESETS
    from painting.looks import BUILTIN_LOOKS
    from shade.match import DEFAULT_STORE_LIGHT, TARGET_SHIFTS

    studio = _help(capsys, "studio")
    assert "app.settings" not in studio and f"{DEFAULT_RESOLUTION})" in studio
    assert f"look to start with: {', '.join(BUILTIN_LOOKS)} (default: natural)" in studio
    render = _help(capsys, "render")
    assert f"a built-in look ({', '.join(BUILTIN_LOOKS)}) or a look JSON" in render
    assert f"a kiosk light preset ({', '.join(LIGHT_PRESETS)})" in render
    match = _help(capsys, "shade", "match")
    assert f"{', '.join(TARGET_SHIFTS)} (default own" in match and f"(default {DEFAULT_STORE_LIGHT})" in match


def test_the_help_is_built_without_the_data_modules() -> None:
    """The lists are read when the help is shown: building the parser (every command's start) imports neither
    numpy nor the looks nor the shade finder."""
    code = ("import sys\nfrom app.cli import build_parser\nbuild_parser()\n"
            "print(sorted(m for m in ('numpy', 'painting.looks', 'shade.match') if m in sys.modules))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
