"""A kiosk killed during a session leaves her private folder; the next start (or `sheer cache clear`) sweeps it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from core.cache import PRIVATE_PREFIX, PrivateCache, sweep_private_caches
from tests.cli_support import checkout_env

#: A kiosk's session in a child: the private folder opens (the real code), her photograph, mesh and albedo
#: are written into it, and it waits (to be killed, as a kiosk's power is cut mid-session).
SESSION = (
    "import time\n"
    "from core.cache import PrivateCache\n"
    "root = PrivateCache().open()\n"
    "face = root / 'face'\n"
    "face.mkdir()\n"
    "for name in ('photo.png', 'head.obj', 'albedo.png'):\n"
    "    (face / name).write_bytes(b'her ' + name.encode())\n"
    "print(root, flush=True)\n"
    "time.sleep(120)\n"
)


def _session(tmp: Path) -> tuple[subprocess.Popen[str], Path]:
    env = checkout_env(TMPDIR=str(tmp))
    proc = subprocess.Popen([sys.executable, "-c", SESSION], env=env, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    root = Path(proc.stdout.readline().strip())
    assert root.parent == tmp and (root / "face" / "photo.png").is_file()
    return proc, root


@pytest.fixture
def tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The temporary folder of this test's kiosks (``TMPDIR`` of the children, ``tempfile`` here)."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


def test_a_killed_kiosks_private_folder_is_swept_at_the_next_start(tmp: Path) -> None:
    killed, root = _session(tmp)
    live, live_root = _session(tmp)
    try:
        assert root.name.startswith(f"{PRIVATE_PREFIX}{killed.pid}-")  # the folder carries its process
        os.kill(killed.pid, signal.SIGKILL)
        killed.wait()
        assert (root / "face" / "albedo.png").is_file()  # kill -9: nothing of hers was removed
        PrivateCache()  # the next kiosk starts
        assert not root.exists()
        assert list(tmp.iterdir()) == [live_root]  # nothing of hers left; a live kiosk's session is kept
        assert (live_root / "face" / "photo.png").is_file()
    finally:
        live.kill()
        live.wait()


def test_sheer_cache_clear_sweeps_dead_kiosks_private_folders(tmp: Path, tmp_path: Path) -> None:
    killed, root = _session(tmp)
    os.kill(killed.pid, signal.SIGKILL)
    killed.wait()
    stranger = tmp / f"{PRIVATE_PREFIX}abcdefgh"  # no process in its name (not one of ours): kept
    stranger.mkdir()
    env = checkout_env(TMPDIR=str(tmp), SHEER_CACHE_DIR=str(tmp_path / "cache"), QT_QPA_PLATFORM="offscreen",
                       XDG_CONFIG_HOME=str(tmp_path / "config"))
    proc = subprocess.run([sys.executable, "-m", "app", "cache", "clear"], env=env, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "removed 1 private session folder" in proc.stdout
    assert not root.exists() and stranger.is_dir()
    assert sweep_private_caches(tmp) == []
