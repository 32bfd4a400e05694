"""``sheer materials …`` through ``app.cli.main``: exit codes, output, no tracebacks."""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import TYPE_CHECKING

from app.cli import main

if TYPE_CHECKING:
    import pytest

DATA = Path(__file__).resolve().parents[2] / "data" / "materials"


def run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(["materials", *args])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def test_list(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "list")
    assert code == 0 and "Foundation Porcelain" in out and "Eyeliner Black" in out
    code, out, _ = run(capsys, "list", "--category", "lipstick")
    assert code == 0 and "11 materials" in out and "Foundation" not in out
    code, _, err = run(capsys, "list", "--category", "glitter")
    assert code == 2 and err.count("\n") == 1 and "no materials in category 'glitter'" in err


def test_show(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "show", "blush rose")
    assert code == 0
    assert "Blush Rose" in out and "Modelled, not measured" in out and "D = 0.03 mm" in out  # its drawdown
    table = [line.split() for line in out.splitlines() if line.strip()[:3].isdigit()]
    assert [row[0] for row in table] == [str(w) for w in range(380, 781, 20)]
    code, _, err = run(capsys, "show", "Blush Rosy")
    assert code == 2 and err.count("\n") == 1 and "did you mean 'Blush Rose'" in err


def test_plot_writes_a_png(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out_png = tmp_path / "rose.png"
    code, out, _ = run(capsys, "plot", "Lipstick Classic Red", "--out", str(out_png))
    assert code == 0 and str(out_png) in out
    data = out_png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    width, height = struct.unpack(">II", data[16:24])
    assert (width, height) == (1000, 440)
    assert 20_000 < len(data) < 2_000_000
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rose.png"]  # no temporary file left
    code, _, err = run(capsys, "plot", "Lipstick Classic Red", "--out", str(tmp_path / "x.jpg"))
    assert code == 2 and ".png" in err
    code, _, err = run(capsys, "plot", "Lipstick Classic Red", "--out", str(tmp_path / "no" / "x.png"))
    assert code == 2 and "no such folder" in err


def test_import_into_a_new_library_then_use_it(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    lib = tmp_path / "mine.json"
    code, out, _ = run(capsys, "import", str(DATA / "rose_bad_rows.csv"), "--library", str(lib))
    assert code == 0
    assert "imported 1 material" in out and "line 12: R 'abc' is not a number" in out
    assert f"saved 1 material to {lib}" in out
    assert [m["name"] for m in json.loads(lib.read_text())["materials"]] == ["Test Rose"]
    code, out, _ = run(capsys, "list", "--library", str(lib))
    assert code == 0 and "Test Rose" in out and "measured" in out
    # a second import of the same name is refused and the library is untouched
    before = lib.read_bytes()
    code, _, err = run(capsys, "import", str(DATA / "rose_bad_rows.csv"), "--library", str(lib))
    assert code == 2 and "already exists" in err and lib.read_bytes() == before
    code, out, _ = run(capsys, "import", str(DATA / "two_shades_cgats.txt"), "--library", str(lib),
                       "--category", "lipstick")
    assert code == 0 and "saved 2 materials" in out and "missing the R and Rg samples" in out
    code, out, _ = run(capsys, "list", "--library", str(lib), "--category", "lipstick")
    assert "Coral Cream" in out and "Deep Plum" in out
    assert (tmp_path / "mine.json.bak").exists()


def test_import_checks_only_without_library(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "import", str(DATA / "xrite_single.txt"), "--thickness-mm", "0.15", "--name", "X1")
    assert code == 0 and "+ X1" in out and "checked 1 material" in out and "nothing saved" in out


def test_import_failures(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("# D_mm: 0.15\nwavelength,R_inf,R,Rg\n500,0.5,0.6,0.05\n")
    lib = tmp_path / "lib.json"
    code, out, err = run(capsys, "import", str(bad), "--library", str(lib))
    assert code == 1 and "nothing could be imported" in err and "rejected" in out and not lib.exists()
    code, _, err = run(capsys, "import", str(tmp_path / "missing.csv"))
    assert code == 2 and err.count("\n") == 1 and "no such measurement file" in err
    code, _, err = run(capsys, "import", str(DATA / "xrite_single.txt"))
    assert code == 2 and "--thickness-mm" in err
    broken = tmp_path / "broken.json"
    broken.write_text('{"format": "sheer.materials", "schema_version": 1, "materials": [')
    code, _, err = run(capsys, "import", str(DATA / "rose_bad_rows.csv"), "--library", str(broken))
    assert code == 2 and str(broken) in err and "not valid JSON" in err and err.count("\n") == 1
    code, _, err = run(capsys, "list", "--library", str(broken))
    assert code == 2 and str(broken) in err


def test_help_without_subcommand(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys)
    assert code == 0 and "import" in out and "plot" in out


def test_export_then_import(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    csv_path = tmp_path / "espresso.csv"
    code, out, _ = run(capsys, "export", "foundation espresso", "--out", str(csv_path))
    assert code == 0 and csv_path.read_text().startswith("# name: Foundation Espresso")
    lib = tmp_path / "lib.json"
    code, out, _ = run(capsys, "import", str(csv_path), "--library", str(lib), "--name", "Espresso again")
    assert code == 0 and "+ Espresso again (foundation" in out
    code, _, err = run(capsys, "export", "nothing", "--out", str(csv_path))
    assert code == 2 and "no material named" in err
