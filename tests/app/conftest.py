"""Fixtures of the studio window tests: one real studio window per test module, reset before each test."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pytest

from tests.app.studio_support import DialogDriver, open_studio_window, reset_studio

if TYPE_CHECKING:
    from collections.abc import Iterator


@pytest.fixture(scope="module")
def studio(qapp: object, tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[object, DialogDriver]]:
    """An 800×600 studio window for the module and its dialog driver (a module may override this fixture to
    open the window differently)."""
    with open_studio_window(qapp, tmp_path_factory) as pair:
        yield pair


@pytest.fixture
def window(studio: tuple[object, DialogDriver]) -> object:
    """The module's window as it opened (see ``reset_studio``), whatever the tests before left in it."""
    reset_studio(studio[0])
    return studio[0]
