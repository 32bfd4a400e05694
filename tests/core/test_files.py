"""core.files.read_bounded: the one bounded reader of user files, and its refusals."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import pytest

from core.errors import SheerError
from core.files import read_bounded

if TYPE_CHECKING:
    from pathlib import Path


class _Refused(SheerError):
    pass


def test_reads_a_file_up_to_the_limit(tmp_path: Path) -> None:
    path = tmp_path / "a.bin"
    path.write_bytes(b"x" * 100)
    assert read_bounded(path, 100, "thing", _Refused) == b"x" * 100


@pytest.mark.parametrize("case", ["missing", "folder", "fifo", "too large"])
def test_refusals_name_the_file_and_the_problem(case: str, tmp_path: Path) -> None:
    path = tmp_path / "f.dat"
    expected = {"missing": "no such library file (not found)", "folder": "is a folder, not a library file",
                "fifo": "not a regular file", "too large": "library file too large (101 bytes, over the limit of 100)"}
    if case == "folder":
        path.mkdir()
    elif case == "fifo":
        os.mkfifo(path)
    elif case == "too large":
        path.write_bytes(b"x" * 101)
    with pytest.raises(_Refused) as info:
        read_bounded(path, 100, "library file", _Refused)
    assert str(info.value) == f"{path}: {expected[case]}"
