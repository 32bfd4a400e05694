"""The local cluster shares the machine's cores between its workers' llvmpipe threads."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from catalogue.driver import worker_environment

if TYPE_CHECKING:
    import pytest


def test_each_worker_gets_its_share_of_the_cores(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("LP_NUM_THREADS", raising=False)
    monkeypatch.setattr(os, "cpu_count", lambda: 8)
    assert worker_environment(1) == {"LP_NUM_THREADS": "8"}
    assert worker_environment(2) == {"LP_NUM_THREADS": "4"}
    assert worker_environment(3) == {"LP_NUM_THREADS": "2"}
    assert worker_environment(16) == {"LP_NUM_THREADS": "1"}  # never 0 (0 means "no threads" to llvmpipe)


def test_the_users_own_setting_is_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("LP_NUM_THREADS", "3")
    assert worker_environment(2) == {}
