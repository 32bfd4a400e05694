"""``sheer cache info`` and ``sheer cache clear [--kind KIND]`` as a user runs them (a real process): the
location under XDG_CACHE_HOME, size and entries per kind, the cap and where it comes from (the studio's
settings, then SHEER_CACHE_MAX_MB), and clearing one kind or all."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pytest

REPO = Path(__file__).resolve().parents[3]


def _sheer(env: dict[str, str], *args: str) -> subprocess.CompletedProcess[str]:
    base = {k: v for k, v in os.environ.items() if k not in ("SHEER_CACHE_DIR", "SHEER_CACHE_MAX_MB")}
    return subprocess.run([sys.executable, "-m", "app", *args], cwd=REPO, capture_output=True, text=True,
                          timeout=120, env={**base, **env})


def test_info_and_clear(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from core.cache import cache_dir, save_array, save_arrays

    env = {"XDG_CACHE_HOME": str(tmp_path / "xdg-cache"), "XDG_CONFIG_HOME": str(tmp_path / "xdg-config")}
    monkeypatch.delenv("SHEER_CACHE_DIR", raising=False)
    monkeypatch.delenv("SHEER_CACHE_MAX_MB", raising=False)
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    root = tmp_path / "xdg-cache" / "sheer"
    save_arrays(cache_dir("atlas") / "a.cache", {"position": np.zeros((256, 256, 3), np.float32)})
    save_array(cache_dir("atlas") / "b.cache", np.zeros(1000))
    save_array(cache_dir("colour") / "m.cache", np.eye(3))

    out = _sheer(env, "cache", "info", "--json")
    assert out.returncode == 0, out.stderr
    info = json.loads(out.stdout)
    assert info["location"] == str(root) and info["entries"] == 3
    assert info["kinds"]["atlas"]["entries"] == 2 and info["kinds"]["atlas"]["bytes"] > 256 * 256 * 12
    assert info["kinds"]["colour"]["entries"] == 1 and info["kinds"]["mesh"] == {"entries": 0, "bytes": 0}
    assert info["bytes"] == sum(f.stat().st_size for f in root.rglob("*.cache"))
    assert info["cap_source"].startswith("automatic") and 0 < info["cap_bytes"] <= 2 * 1024**3

    settings = tmp_path / "xdg-config" / "Sheer" / "Sheer Studio.conf"  # what QSettings reads on Linux
    settings.parent.mkdir(parents=True)
    settings.write_text("[General]\nschema_version=1\n\n[studio]\ncache_max_mb=300\n", encoding="utf-8")
    info = json.loads(_sheer(env, "cache", "info", "--json").stdout)
    assert (info["cap_bytes"], info["cap_source"]) == (300 * 1024**2, "settings")
    info = json.loads(_sheer({**env, "SHEER_CACHE_MAX_MB": "50"}, "cache", "info", "--json").stdout)
    assert (info["cap_bytes"], info["cap_source"]) == (50 * 1024**2, "SHEER_CACHE_MAX_MB")

    table = _sheer(env, "cache", "info")
    assert table.returncode == 0 and f"location: {root}" in table.stdout and "300.0 MiB (settings)" in table.stdout
    assert any(line.split()[:2] == ["atlas", "2"] for line in table.stdout.splitlines())

    cleared = _sheer(env, "cache", "clear", "--kind", "atlas")
    assert cleared.returncode == 0 and "removed 2 atlas entries" in cleared.stdout
    assert sorted(p.name for p in root.rglob("*.cache")) == ["m.cache"]
    bad = _sheer(env, "cache", "clear", "--kind", "everything")
    assert bad.returncode == 2 and "invalid choice" in bad.stderr and "Traceback" not in bad.stderr
    assert "removed 1 entry" in _sheer(env, "cache", "clear").stdout
    assert list(root.rglob("*.cache")) == []
