"""The layering rules: the model and the renderer never import Qt; the optics never import GL.

Checked on the source (every ``import`` statement, at any depth), so it holds whatever is installed.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FORBIDDEN: dict[str, tuple[str, ...]] = {
    "km": ("PySide6", "pyqtgraph", "moderngl", "painting", "render", "capture", "app"),
    "painting": ("PySide6", "pyqtgraph", "moderngl", "render", "app"),
    "capture": ("PySide6", "pyqtgraph", "app"),
    "render": ("PySide6", "pyqtgraph", "app"),
}


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.lineno, node.module))
    return found


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_package_never_imports_forbidden_modules(package: str) -> None:
    offenders = []
    for path in sorted((ROOT / package).rglob("*.py")):
        for lineno, name in _imports(path):
            top = name.split(".")[0]
            if top in FORBIDDEN[package]:
                offenders.append(f"{path.relative_to(ROOT)}:{lineno} imports {name}")
    assert not offenders, "layering violated:\n" + "\n".join(offenders)


def test_resources_search_path_order(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    import core.assets as resources

    monkeypatch.setenv("SHEER_ASSETS", str(tmp_path))
    (tmp_path / "x.txt").write_text("here")
    assert resources.assets_search_path()[0] == tmp_path
    assert resources.find_asset("x.txt") == tmp_path / "x.txt"
    with pytest.raises(resources.AssetNotFoundError) as info:
        resources.find_asset("no/such/file.bin")
    assert str(tmp_path) in str(info.value) and "no/such/file.bin" in str(info.value)


def test_cli_help_and_errors_without_traceback(capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main

    assert main(["--help"]) == 0
    assert main(["no-such-command"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
