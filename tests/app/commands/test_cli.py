"""The ``sheer`` command line: help, and errors without a traceback."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pytest


def test_cli_help_and_errors_without_traceback(capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main

    assert main(["--help"]) == 0
    assert main(["no-such-command"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
