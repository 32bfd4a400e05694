"""Shared fixtures of the catalogue tests: spec files and one real 2-process Dask LocalCluster."""

from __future__ import annotations

import json
import logging
from typing import TYPE_CHECKING

import pytest

# a captured face folder, as a fixture
from tests.app.commands.test_lightweight_render_cli import face_dir  # noqa: F401

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator
    from pathlib import Path

#: A small catalogue: 2 lipsticks × 2 lights × 1 view of red-lip on the sample head, 48×48 pixels.
SMALL = """
name = "small"
size = [48, 48]
resolution = 256
{extra}
[[looks]]
look = "red-lip"
[products]
category = "lipstick"
materials = ["Lipstick Nude", "Lipstick Pink"]
[[lights]]
preset = "portrait"
[[lights]]
name = "flat"
preset = "flat"
{lights}
[[views]]
name = "front"
"""


@pytest.fixture
def write_spec(tmp_path: Path) -> Callable[..., Path]:
    """``write_spec(text=SMALL, name="spec.toml", extra="", lights="")`` writes a spec file in ``tmp_path``."""

    def write(text: str = SMALL, name: str = "spec.toml", extra: str = "", lights: str = "") -> Path:
        path = tmp_path / name
        path.write_text(text.replace("{extra}", extra).replace("{lights}", lights), encoding="utf-8")
        return path

    return write


@pytest.fixture
def library_copy(tmp_path: Path) -> Path:
    """Sheer's default material library, copied to ``tmp_path/materials.json`` (to be edited)."""
    from km.library import default_library_path

    path = tmp_path / "materials.json"
    path.write_text(default_library_path().read_text(encoding="utf-8"), encoding="utf-8")
    json.loads(path.read_text(encoding="utf-8"))
    return path


@pytest.fixture(scope="session")
def dask_client() -> Iterator[object]:
    """A real LocalCluster of 2 worker processes (one thread each, warmed by the catalogue's preload, as
    ``sheer catalogue``'s own cluster is), on 127.0.0.1, shared by the session.

    Its workers keep the renderer version of the code they loaded and refuse jobs named for another: an
    edit of the renderer's sources while these tests run fails them (correctly); run them on a tree at rest.
    """
    from distributed import Client, LocalCluster

    from catalogue.warmup import PRELOAD

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=":0", silence_logs=logging.CRITICAL, preload=[PRELOAD])
    client = Client(cluster)
    yield client
    client.close()
    cluster.close()
