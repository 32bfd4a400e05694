"""The ``sheer`` sub-commands, one module each with ``register(subparsers)`` (see :mod:`app.cli`).

A command module imports only the standard library at import time (heavy imports go inside its run
function), so ``sheer --help`` is instant and headless commands never load Qt. May import what
:mod:`app` may (never ``bench``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    import argparse


class Subcommands(Protocol):
    """The sub-command parsers a command's ``register`` adds its parser to.

    What ``argparse.ArgumentParser.add_subparsers`` returns (argparse names its class only privately).
    """

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser:
        """A new sub-command ``name``'s parser (``kwargs`` as for ``argparse.ArgumentParser``)."""
        ...
