"""What the renderer reads from a captured face: :class:`CapturedFace`.

render/ may not import capture/ (they are siblings), so the lightweight engine
(:class:`render.lightweight.LightweightRenderer`), the mirror and relight views (:mod:`render.mirror`) and
the interactive view (:meth:`render.view.ViewRenderer.set_face`) type a face by these protocols;
:class:`capture.face.Face` (read back by :func:`capture.face.load_face`) satisfies them, and it alone
parses face.json. The camera is a :class:`core.camera.Pinhole` (:class:`capture.camera.Camera` is one).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

if TYPE_CHECKING:
    import numpy as np

    from core.camera import Pinhole


class FittedSkin(Protocol):
    """The fitted Phong parameters (``capture.phong.PhongParams``): linear RGB, photograph units."""

    @property
    def diffuse(self) -> np.ndarray:
        """(3,) the diffuse reflectance D."""
        ...

    @property
    def specular(self) -> float:
        """The specular intensity i_s."""
        ...

    @property
    def exponent(self) -> float:
        """The Phong exponent s."""
        ...

    @property
    def ambient_scale(self) -> float:
        """k, the ambient's scale relative to ``ambient_rgb``."""
        ...

    @property
    def flash_rgb(self) -> np.ndarray:
        """(3,) the flash's colour F (luminance 1)."""
        ...

    @property
    def ambient_rgb(self) -> np.ndarray:
        """(3,) the ambient A as the probe measured it."""
        ...


@runtime_checkable
class CapturedFace(Protocol):
    """A captured face as the renderer reads it (``capture.face.Face``)."""

    @property
    def params(self) -> FittedSkin:
        """The fitted skin and light parameters."""
        ...

    @property
    def detail(self) -> np.ndarray:
        """float32 (H, W, 3): the detail texture in the head's UV space (top row first), [0, 8]."""
        ...

    def camera(self) -> Pinhole:
        """The photograph's camera (mesh units); raises a ``SheerError`` naming the face when it has none."""
        ...

    def light_dir(self) -> np.ndarray:
        """Unit (3,) towards the captured flash, mesh coordinates; a ``SheerError`` when there is none."""
        ...
