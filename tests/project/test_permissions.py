"""Real permissions: ``sheer`` run as the unprivileged user ``nobody`` against a read-only folder.

The suite runs as root, for whom every folder is writable (other tests simulate a read-only folder). Here
one forked child of the test becomes ``nobody`` (:func:`tests.disk_support.run_as_nobody`; not a new
interpreter: the virtual environment's may be under root's own home, which ``nobody`` cannot read) and runs
the command line in-process against a folder of root's with mode 0555: ``project new`` (a new file, and
over an existing one), ``project export --out`` and ``render --out``, each exit status and stderr coming
back; then an autosave of the project there, which must go to the recovery folder instead.
"""

from __future__ import annotations

import os
import shutil
import stat
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from tests.cli_support import CHECKOUT, sheer
from tests.disk_support import NOBODY, can_drop_to_nobody, listing, run_as_nobody

if TYPE_CHECKING:
    from collections.abc import Iterator


def _reachable_by_nobody(path: Path) -> bool:
    """Whether anyone may read ``path`` (and search every folder above it)."""
    for p in [path, *path.parents]:
        if not os.stat(p).st_mode & (stat.S_IXOTH if p.is_dir() else stat.S_IROTH):
            return False
    return True


@pytest.fixture
def shared_folder() -> Iterator[Path]:
    """A fresh folder under the system's temporary folder, searchable by ``nobody`` (pytest's is root's only,
    and so is a test worker's own temporary folder: the nearest folder above it that ``nobody`` may search)."""
    why = can_drop_to_nobody()
    if why is not None:
        pytest.skip(f"cannot run sheer as an unprivileged user here: {why}")
    if not _reachable_by_nobody(CHECKOUT / "app" / "cli.py"):
        pytest.skip(f"{CHECKOUT} cannot be read by nobody")
    parent = Path(tempfile.gettempdir())
    while not _reachable_by_nobody(parent) and parent != parent.parent:
        parent = parent.parent
    base = Path(tempfile.mkdtemp(prefix="sheer-permissions-", dir=parent))
    try:
        base.chmod(0o755)
        yield base
    finally:
        shutil.rmtree(base)  # (root removes the read-only folder's files too)


def _checks(ro: Path, home: Path) -> dict[str, Any]:
    """What the child runs as nobody: each command line's exit status and stderr, then an autosave."""
    from project.io import new_project
    from project.recovery import autosave

    os.environ.update(HOME=str(home), SHEER_CACHE_DIR=str(home / "cache"), SHEER_RECOVERY_DIR=str(home / "rec"))
    out: dict[str, Any] = {"uid": os.getuid()}
    for name, args in {
        "new": ["project", "new", "--out", f"{ro}/new.sheer", "--resolution", "64"],
        "over": ["project", "new", "--out", f"{ro}/p.sheer", "--resolution", "64", "--force"],
        "export": ["project", "export", f"{ro}/p.sheer", "--out", f"{ro}/maps"],
        "render": ["render", "--out", f"{ro}/r.png"],
    }.items():
        done = sheer(*args)
        out[name] = [done.returncode, done.stderr]
    out["autosave"] = str(autosave(new_project("p", resolution=64), ro / "p.sheer"))
    return out


def test_a_read_only_folder_as_nobody(shared_folder: Path) -> None:
    from bench.fuzz import sample_project
    from project.io import save_project

    ro, home = shared_folder / "ro", shared_folder / "home"
    ro.mkdir()
    home.mkdir()
    os.chown(home, NOBODY, NOBODY)
    save_project(sample_project(64, 1, embedded=False), ro / "p.sheer")
    ro.chmod(0o555)  # root's, read-only to everyone else
    before = listing(ro)
    got = run_as_nobody(lambda: _checks(ro, home))
    assert got["uid"] == NOBODY
    for name, target in (("new", ro / "new.sheer"), ("over", ro / "p.sheer"), ("export", ro / "maps"),
                         ("render", ro / "r.png")):
        status, err = got[name]
        assert status == 2 and err.count("\n") == 1, (name, got[name])
        assert str(target) in err and ".tmp" not in err and "ermission denied" in err, (name, err)
    assert listing(ro) == before  # the project byte-identical, nothing new, no temporary file
    assert Path(got["autosave"]).parent == home / "rec"  # a folder it cannot write: the recovery folder
