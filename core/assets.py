"""Where Sheer's files are: the shipped data, the sample assets' search path, and the assets' credits.

The shipped data is in the ``resources`` package (shaders, the default material library, looks, head
metadata, icons).

The sample assets (the scanned head, photographs, HDR environments, spectra) are never copied into the
repository. They are found, in this order, in

1. the folder named by the ``SHEER_ASSETS`` environment variable,
2. ``../shared/assets`` beside the checkout (the folder that holds this repository),
3. the user's data folder, ``$XDG_DATA_HOME/sheer/assets`` (default ``~/.local/share/sheer/assets``).
"""

from __future__ import annotations

import importlib.resources
import os
from pathlib import Path

from core.errors import AssetNotFoundError

#: the ``resources`` data package (a folder on disk: Sheer is installed from a checkout or a wheel, never a zip)
RESOURCES_DIR: Path = Path(str(importlib.resources.files("resources"))).resolve()
CHECKOUT_DIR: Path = RESOURCES_DIR.parent

#: Credits of the sample assets, shown in the About box, the README and exported files' metadata.
ASSET_CREDITS: dict[str, str] = {
    "heads/lee-perry-smith": (
        '"Infinite, 3D Head Scan by Lee Perry-Smith", CC BY 3.0, based on a work at www.triplegangers.com'
    ),
    "heads/canonical-face": "Canonical face model from the MediaPipe project, Apache-2.0",
    "photos/astronaut.png": "Eileen Collins, NASA, public domain",
    "photos/grace_hopper.jpg": "Grace Hopper, U.S. Navy, public domain",
    "environments": "HDR environments from Poly Haven, CC0 1.0",
    "spectra/hemoglobin_molar_extinction.csv": (
        "Haemoglobin molar extinction, S. Prahl's compilation, BSD-3-Clause, as shipped by MNE-Python"
    ),
}


def resource_path(*parts: str) -> Path:
    """Return the path of a file shipped in ``resources/`` (it is not checked for existence)."""
    return RESOURCES_DIR.joinpath(*parts)


def assets_search_path() -> list[Path]:
    """The folders searched for sample assets, in order (see the module docstring)."""
    paths: list[Path] = []
    env = os.environ.get("SHEER_ASSETS")
    if env:
        paths.append(Path(env).expanduser())
    paths.append(CHECKOUT_DIR.parent / "shared" / "assets")
    data_home = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    paths.append(Path(data_home) / "sheer" / "assets")
    return paths


def find_asset(relative: str) -> Path:
    """Locate a sample asset, e.g. ``find_asset("heads/lee-perry-smith/head.glb")``.

    Raises :class:`AssetNotFoundError` naming every folder that was searched.
    """
    looked: list[str] = []
    for folder in assets_search_path():
        candidate = folder / relative
        if candidate.exists():
            return candidate
        looked.append(str(folder))
    raise AssetNotFoundError(
        f"sample asset '{relative}' not found; looked in: {'; '.join(looked)}. "
        "Set SHEER_ASSETS to the folder that holds the sample assets."
    )


def credit_for(path: str | Path) -> str | None:
    """The credit line of the sample asset at ``path`` (any path inside the assets folder), or None."""
    text = str(path).replace(os.sep, "/")
    for key, credit in ASSET_CREDITS.items():
        if key in text:
            return credit
    return None
