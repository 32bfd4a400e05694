"""Fixtures the render tests share: the sample head's document and a renderer on the session's GL context.

Module-scoped, so each test module gets its own; a module that needs another resolution, look, camera or
lights defines its own ``doc`` or ``renderer``, which takes precedence.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from collections.abc import Iterator

    from render.renderer import Renderer


@pytest.fixture(scope="module")
def doc() -> Any:
    """The sample head's document with 512² maps, no layers painted."""
    from painting import Document

    return Document.from_head(resolution=512)


@pytest.fixture(scope="module")
def renderer(_gl_session_ctx: Any, doc: Any) -> Iterator[Renderer]:
    """A renderer of ``doc``'s head with the default camera and lights; released without a GL error."""
    from render.renderer import Renderer

    r = Renderer(_gl_session_ctx, doc.head, layout=doc.layout)
    yield r
    r.release()
    assert _gl_session_ctx.error == "GL_NO_ERROR"
