"""A power cut at any moment of a save leaves the complete old or the complete new project.

The kill tests (``test_safety.py``) end a process: the kernel's page cache survives it, so they would
still pass with every ``fsync`` deleted. Here :class:`PowerCutModel` watches the file-system calls of a
real :func:`project.io.save_project` in the project's folder (``os.open``, ``os.fsync``,
``os.replace``, ``os.rename``, ``os.link``, ``os.unlink``, ``os.chmod``, ``shutil.copy2``) and works out,
after each of them, every state the folder could be in if the power were cut right then:

- a file holds what it held at its last ``fsync`` (a file never fsynced holds nothing; the files there
  before the save are taken as durable);
- the folder holds its entries as of its last ``fsync``, plus any prefix of the name changes made
  since (creations, renames, links, removals: a journal commits them in order, at a moment nobody
  chooses).

Every such state must hold a complete project at the path (the old or the new one) and, when a
``.bak`` exists, a complete earlier version there. Once ``save_project`` has returned, every state must
hold the new project, and the old one as ``.bak``. So deleting or reordering the ``fsync`` of the file
or of its folder in ``core/atomicio.py`` fails these tests; the last test drops each ``fsync`` of a
save in turn and checks that the model notices every one.
"""

from __future__ import annotations

import os
import shutil
import stat
from itertools import count
from typing import TYPE_CHECKING, Any

import pytest

from bench.fuzz import sample_project
from project.io import save_project

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

#: One crash state: name -> the bytes a file would hold after the power cut.
State = dict[str, bytes]


class PowerCutModel:
    """The durable state of one folder, followed through the file-system calls made in it.

    Attributes:
        folder: the folder watched (calls elsewhere are passed through unrecorded).
        states: (the call just made, every crash state possible right after it), in call order.
        fsyncs: how many ``fsync`` calls were made (also those dropped).
        drop: the index of an ``fsync`` call to skip (as if deleted from the code), or None.
    """

    def __init__(self, folder: Path, drop: int | None = None) -> None:
        self.folder = folder
        self.drop = drop
        self.fsyncs = 0
        self._ids = count()
        self._id_of_inode: dict[int, int] = {}
        self._data: dict[int, bytes] = {}  # file id -> the bytes of its last fsync
        self.current: dict[str, int] = {}  # the folder's entries now: name -> file id
        for p in sorted(folder.iterdir()):
            file_id = self._new_file(p.stat().st_ino)
            self._data[file_id] = p.read_bytes()  # what was there before is durable
            self.current[p.name] = file_id
        self._durable = dict(self.current)  # the entries as of the folder's last fsync
        self._pending: list[tuple[str, str, str | int]] = []  # name changes since then, in order
        self.states: list[tuple[str, list[State]]] = [("start", self.crash_states())]

    def _new_file(self, inode: int) -> int:
        file_id = next(self._ids)
        self._id_of_inode[inode] = file_id
        self._data[file_id] = b""
        return file_id

    def _ours(self, path: Any) -> bool:
        return os.path.dirname(os.path.abspath(os.fspath(path))) == str(self.folder)

    def _change(self, op: str, a: str, b: str | int) -> None:
        self._pending.append((op, a, b))
        _apply(self.current, op, a, b)

    def crash_states(self) -> list[State]:
        """Every state a power cut now could leave: the durable entries plus each prefix of the pending changes."""
        out = []
        for k in range(len(self._pending) + 1):
            entries = dict(self._durable)
            for change in self._pending[:k]:
                _apply(entries, *change)
            out.append({name: self._data[file_id] for name, file_id in entries.items()})
        return out

    def _record(self, call: str) -> None:
        self.states.append((call, self.crash_states()))

    # ---- the instrumented calls (installed by :func:`watch`)

    def open(self, real: Callable[..., int], path: Any, flags: int, *args: Any, **kwargs: Any) -> int:
        existed = os.path.lexists(path)
        fd = real(path, flags, *args, **kwargs)
        if self._ours(path) and flags & os.O_CREAT and not existed:
            self._change("create", os.path.basename(path), self._new_file(os.fstat(fd).st_ino))
            self._record(f"create {os.path.basename(path)}")
        return fd

    def fsync(self, real: Callable[[int], None], fd: int) -> None:
        index = self.fsyncs
        self.fsyncs += 1
        info = os.fstat(fd)
        where = os.readlink(f"/proc/self/fd/{fd}")
        if index == self.drop:
            self._record(f"fsync {where} (dropped)")
            return
        real(fd)
        if stat.S_ISDIR(info.st_mode) and where == str(self.folder):
            self._durable = dict(self.current)
            self._pending = []
        elif stat.S_ISREG(info.st_mode) and info.st_ino in self._id_of_inode and self._ours(where):
            with open(f"/proc/self/fd/{fd}", "rb") as fh:
                self._data[self._id_of_inode[info.st_ino]] = fh.read()
        else:
            return
        self._record(f"fsync {os.path.basename(where) or where}")

    def move(self, real: Callable[..., None], src: Any, dst: Any, *args: Any, **kwargs: Any) -> None:
        real(src, dst, *args, **kwargs)
        if self._ours(dst):
            self._change("move", os.path.basename(src), os.path.basename(dst))
            self._record(f"rename {os.path.basename(src)} -> {os.path.basename(dst)}")

    def link(self, real: Callable[..., None], src: Any, dst: Any, *args: Any, **kwargs: Any) -> None:
        real(src, dst, *args, **kwargs)
        if self._ours(dst):
            self._change("link", os.path.basename(src), os.path.basename(dst))
            self._record(f"link {os.path.basename(src)} -> {os.path.basename(dst)}")

    def unlink(self, real: Callable[..., None], path: Any, *args: Any, **kwargs: Any) -> None:
        real(path, *args, **kwargs)
        if self._ours(path):
            self._change("unlink", os.path.basename(path), "")
            self._record(f"unlink {os.path.basename(path)}")

    def copy2(self, real: Callable[..., Any], src: Any, dst: Any, *args: Any, **kwargs: Any) -> Any:
        existed = os.path.lexists(dst)
        result = real(src, dst, *args, **kwargs)
        if self._ours(dst) and not existed:
            self._change("create", os.path.basename(dst), self._new_file(os.stat(dst).st_ino))
            self._record(f"copy {os.path.basename(src)} -> {os.path.basename(dst)}")
        return result

    def chmod(self, real: Callable[..., None], path: Any, *args: Any, **kwargs: Any) -> None:
        real(path, *args, **kwargs)
        if self._ours(path):
            self._record(f"chmod {os.path.basename(path)}")


def _apply(entries: dict[str, int], op: str, a: str, b: str | int) -> None:
    """Apply one name change to ``entries`` (name -> file id)."""
    if op == "create":
        assert isinstance(b, int)
        entries[a] = b
    elif op == "move" and a in entries:
        entries[str(b)] = entries.pop(a)
    elif op == "link" and a in entries:
        entries[str(b)] = entries[a]
    elif op == "unlink":
        entries.pop(a, None)


def watch(monkeypatch: pytest.MonkeyPatch, model: PowerCutModel, hard_links: bool = True) -> None:
    """Route the file-system calls through ``model``; ``hard_links=False`` makes ``os.link`` fail
    (as across file systems), so the backup is a copy.
    """

    def hook(module: Any, name: str, method: Callable[..., Any]) -> None:
        real = getattr(module, name)
        monkeypatch.setattr(module, name, lambda *a, **k: method(real, *a, **k))

    hook(os, "open", model.open)
    hook(os, "fsync", model.fsync)
    hook(os, "replace", model.move)
    hook(os, "rename", model.move)
    hook(os, "unlink", model.unlink)
    hook(os, "remove", model.unlink)
    hook(os, "chmod", model.chmod)
    hook(shutil, "copy2", model.copy2)
    if hard_links:
        hook(os, "link", model.link)
    else:
        def no_link(*args: Any, **kwargs: Any) -> None:
            raise OSError(18, "Invalid cross-device link")

        monkeypatch.setattr(os, "link", no_link)


def violations(model: PowerCutModel, name: str, old: bytes, new: bytes, older: bytes | None) -> list[str]:
    """What the crash states of a save of ``new`` over ``old`` (whose ``.bak`` held ``older``) get wrong.

    Before the save returned (every state but the last call's): the project is ``old`` or ``new``; the
    ``.bak`` is absent only if it was before, else ``older`` or ``old``. After (the last call's
    states): the project is ``new`` and the ``.bak`` is ``old``.
    """
    bak = name + ".bak"
    found = []
    *during, (last_call, after) = model.states
    for call, states in during:
        for state in states:
            if state.get(name) not in (old, new):
                found.append(f"cut after {call}: {name} holds {len(state.get(name, b''))} bytes, "
                             "neither the old nor the new project")
            if bak in state and state[bak] not in (older, old) or bak not in state and older is not None:
                found.append(f"cut after {call}: {bak} is not a complete earlier version")
    for state in after:
        if state.get(name) != new:
            found.append(f"cut after save_project returned ({last_call}): {name} is not the new project")
        if state.get(bak) != old:
            found.append(f"cut after save_project returned ({last_call}): {bak} is not the old project")
    return found


def _save_twice_under_watch(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, hard_links: bool,
                            drop: int | None = None) -> tuple[list[str], int]:
    """Save v1 over v0 (no ``.bak`` yet), then v2 over v1 (replacing the ``.bak``), each watched.

    Returns the violations of both saves and the number of ``fsync`` calls they made.
    """
    monkeypatch.setenv("SHEER_RECOVERY_DIR", str(tmp_path / "recovery"))
    folder = tmp_path / "projects"
    folder.mkdir(parents=True)
    path = folder / "p.sheer"
    save_project(sample_project(64, 2, name="v0"), path, self_contained=True)
    found: list[str] = []
    fsyncs = 0
    for version in ("v1", "v2"):
        bak = path.with_name(path.name + ".bak")
        older = bak.read_bytes() if bak.exists() else None
        old = path.read_bytes()
        project = sample_project(64, 2, name=version)
        with monkeypatch.context() as m:
            model = PowerCutModel(folder, None if drop is None else drop - fsyncs)
            watch(m, model, hard_links)
            save_project(project, path, self_contained=True)
            model.states.append(("return", model.crash_states()))
        fsyncs += model.fsyncs
        found += [f"{version}: {v}" for v in violations(model, path.name, old, path.read_bytes(), older)]
    return found, fsyncs


@pytest.mark.parametrize("hard_links", [True, False], ids=["backup-linked", "backup-copied"])
def test_a_power_cut_at_any_moment_of_a_save_loses_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                           hard_links: bool) -> None:
    found, fsyncs = _save_twice_under_watch(tmp_path, monkeypatch, hard_links)
    assert found == []
    assert fsyncs == (4 if hard_links else 6)  # per save: the file, [the copied backup,] the folder


@pytest.mark.parametrize("hard_links", [True, False], ids=["backup-linked", "backup-copied"])
def test_the_model_notices_each_missing_fsync(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                              hard_links: bool) -> None:
    """Skipping any one fsync of the two saves (as if its line were deleted) is a violation."""
    _, fsyncs = _save_twice_under_watch(tmp_path / "clean", monkeypatch, hard_links)
    for drop in range(fsyncs):
        found, _ = _save_twice_under_watch(tmp_path / f"drop{drop}", monkeypatch, hard_links, drop=drop)
        assert found, f"fsync call {drop} was dropped and no power cut lost anything"
