"""The ``project`` package's public names: each resolves to its defining module, and importing the
package loads none of them until used.
"""

from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import project

CHECKOUT = Path(__file__).resolve().parents[2]


def test_every_public_name_resolves_to_its_module() -> None:
    assert project.__all__ == sorted(project._EXPORTS)
    for name, module in project._EXPORTS.items():
        assert getattr(project, name) is getattr(importlib.import_module(module), name), name


def test_importing_the_package_is_lazy() -> None:
    code = "import sys, project; print(sorted(m for m in sys.modules if m.startswith('project.')))"
    out = subprocess.run([sys.executable, "-c", code], cwd=CHECKOUT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
