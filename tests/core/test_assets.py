"""The sample assets' search path: SHEER_ASSETS first, and a missing asset names every folder searched."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from pathlib import Path


def test_resources_search_path_order(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    from core import assets

    monkeypatch.setenv("SHEER_ASSETS", str(tmp_path))
    (tmp_path / "x.txt").write_text("here")
    assert assets.assets_search_path()[0] == tmp_path
    assert assets.find_asset("x.txt") == tmp_path / "x.txt"
    with pytest.raises(assets.AssetNotFoundError) as info:
        assets.find_asset("no/such/file.bin")
    assert str(tmp_path) in str(info.value) and "no/such/file.bin" in str(info.value)
