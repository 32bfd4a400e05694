"""Lazy public names for a package (PEP 562): ``import pkg`` stays cheap, each module loads on first use.

In a package's ``__init__.py``::

    __getattr__, __dir__, __all__ = install_lazy(__name__, {"Document": "painting.document"})
"""

from __future__ import annotations

import importlib
import sys
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping


def install_lazy(package: str, exports: Mapping[str, str],
                 eager: tuple[str, ...] = ()) -> tuple[Callable[[str], Any], Callable[[], list[str]], list[str]]:
    """The ``__getattr__``, ``__dir__`` and ``__all__`` of ``package`` for lazy ``exports``.

    Args:
        package: the package's ``__name__``.
        exports: public name -> the module that defines it.
        eager: names the package defines itself, listed in ``__all__`` too.

    Returns:
        ``(__getattr__, __dir__, __all__)``; a name is imported on first access and then kept in the
        package's namespace, so later accesses cost nothing.
    """
    table = dict(exports)

    def __getattr__(name: str) -> Any:
        module_name = table.get(name)
        if module_name is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module_name), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(table))

    return __getattr__, __dir__, [*eager, *sorted(table)]
