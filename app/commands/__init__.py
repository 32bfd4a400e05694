"""The ``sheer`` sub-commands, one module each with ``register(subparsers)`` (see :mod:`app.cli`).

A command module imports only the standard library at import time (heavy imports go inside its run
function), so ``sheer --help`` is instant and headless commands never load Qt. May import what
:mod:`app` may (never ``bench``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    import argparse
    from collections.abc import Callable, Iterable


class Subcommands(Protocol):
    """The sub-command parsers a command's ``register`` adds its parser to.

    What ``argparse.ArgumentParser.add_subparsers`` returns (argparse names its class only privately).
    """

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser:
        """A new sub-command ``name``'s parser (``kwargs`` as for ``argparse.ArgumentParser``)."""
        ...


class LazyHelp(str):
    """A help string whose ``%(NAME)s`` fields come from the code's own data, read when the help is shown.

    A help that lists choices (the built-in looks, the light presets, the shade targets) names them from
    the tuple or dict the code uses, so the two cannot drift apart; the data's module is imported only
    when ``--help`` is asked for (``sheer --help`` stays instant: argparse fills a help string with
    ``help % params`` as it prints it).

    Example: ``LazyHelp("a built-in look (%(looks)s)", looks=lambda: painting.looks.BUILTIN_LOOKS)``.
    """

    fields: dict[str, Callable[[], Iterable[object]]]

    def __new__(cls, template: str, **fields: Callable[[], Iterable[object]]) -> LazyHelp:
        """``template`` with ``%(NAME)s`` for each of ``fields`` (NAME → a function returning the values)."""
        obj = super().__new__(cls, template)
        obj.fields = fields
        return obj

    def __mod__(self, params: Any) -> str:
        """The help filled: argparse's ``params`` and each field's values joined by commas."""
        values = {name: ", ".join(str(v) for v in get()) for name, get in self.fields.items()}
        return str.__mod__(str(self), {**params, **values})


#: The help of every ``--library`` option (the commands that read materials).
LIBRARY_HELP = "material library JSON file (default: Sheer's default library)"


def command_group(sub: Subcommands, name: str, help: str, description: str | None) -> Subcommands:
    """Add ``sheer NAME``, a command made of sub-commands, to ``sub``; returns the parsers its sub-commands join.

    ``description`` (the command module's docstring) is shown as written; the sub-command chosen is stored
    as ``NAME_command``; ``sheer NAME`` alone prints the command's help and exits with status 0.
    """
    import argparse

    parser = sub.add_parser(name, help=help, description=description,
                            formatter_class=argparse.RawDescriptionHelpFormatter)
    group = parser.add_subparsers(dest=f"{name}_command", metavar="SUBCOMMAND")

    def show_help(args: argparse.Namespace) -> int:
        parser.print_help()
        return 0

    parser.set_defaults(func=show_help)
    return group
