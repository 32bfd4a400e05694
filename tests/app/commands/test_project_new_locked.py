"""``sheer project new --force`` over a project another Sheer has open is refused: one line naming the file
and its holder (host, pid), exit 2, the file and its folder untouched; once the holder lets go, it replaces
the file (the old one kept as ``.bak``)."""

from __future__ import annotations

import socket
import subprocess
import sys
import textwrap
from typing import TYPE_CHECKING

from tests.cli_support import checkout_env, sheer

if TYPE_CHECKING:
    from pathlib import Path

#: A process holding a project's lock as a studio with the project open does, until its stdin closes.
HOLDER = textwrap.dedent("""
    import sys
    from core.locks import FileLock

    lock = FileLock(sys.argv[1], "open")
    assert lock.try_acquire() is None
    print("held", flush=True)
    sys.stdin.read()
""")


def _listing(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if not p.name.endswith(".lock")}


def test_force_over_a_project_open_elsewhere_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "look.sheer"
    assert sheer("project", "new", "--out", str(out), "--resolution", "64", "--name", "old").returncode == 0
    before = _listing(tmp_path)
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(out)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True, env=checkout_env())
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        done = sheer("project", "new", "--force", "--out", str(out), "--resolution", "64", "--name", "new")
    finally:
        assert holder.stdin is not None
        holder.stdin.close()
        holder.wait(timeout=30)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    assert f"{out}: open in another Sheer ({socket.gethostname()}, pid {holder.pid})" in done.stderr
    assert _listing(tmp_path) == before

    again = sheer("project", "new", "--force", "--out", str(out), "--resolution", "64", "--name", "new")
    assert again.returncode == 0, again.stderr
    assert (tmp_path / "look.sheer.bak").read_bytes() == before["look.sheer"] != out.read_bytes()
