"""Progressive refinement: how large an interactive frame may be to hold a frame budget.

While the user orbits, pans, zooms, moves a light or paints, the view draws *interactive* frames at a
reduced internal resolution, upscaled to the window; when input stops it *settles* to the
full-resolution frame (see :class:`render.view.ViewRenderer` and ``app.view.viewport``). This module holds
the part that needs no GPU: :class:`AdaptiveScale` chooses the internal scale from the frame times it is
told, as Blender's viewport and Substance Painter do on weak hardware.

The frame time of the physical renderer is close to ``fixed + per_pixel · scale²`` (the passes are
fragment-bound; shadow maps and the texture-space caches do not depend on the view), so the controller
predicts the scale that meets the budget from the last frames with that model instead of stepping blindly,
then quantises it to :data:`SCALE_STEP` so the renderer's targets are not made again for every frame.

Units: times in ms, scales as a fraction of the window's side (1.0 = full resolution).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from render.errors import RenderError

#: Scales are multiples of this (a new scale means new render targets: they are kept per size).
SCALE_STEP = 0.05
#: The smallest internal scale: below it the face is too coarse to judge a colour (≈ 0.3 of 720 px
#: is a 216 px tall frame, about 1.3 mm of face per pixel at the default framing).
MIN_SCALE = 0.3
#: The default cap of the interactive scale (a user on a strong GPU sets 1.0: full resolution always).
DEFAULT_MAX_SCALE = 0.75
#: The default interactive frame budget on this class of machine (ms): what the renderer may take so
#: that, with the window system's share (≈ 8–10 ms a frame here), 24 or more frames a second reach the
#: screen and a dab is on screen within about two frames (≤ 60 ms). Measured with ``sheer bench studio``
#: on llvmpipe, 2 cores: at 30 ms, 24.7–25.0 fps and 55–61 ms from a dab to its frame.
DEFAULT_BUDGET_MS = 26.0


@dataclass
class AdaptiveScale:
    """Chooses the interactive frames' internal scale to hold ``budget_ms``.

    Attributes:
        budget_ms: the renderer's time per interactive frame to aim for, ms (> 0).
        min_scale: the smallest scale, in [0.1, max_scale].
        max_scale: the cap (the studio's setting), in [min_scale, 1].
        scale: the scale of the next interactive frame (a multiple of :data:`SCALE_STEP`).
        over_budget: the last frame missed the budget even at ``min_scale`` (the overlay says so).
    """

    budget_ms: float = DEFAULT_BUDGET_MS
    min_scale: float = MIN_SCALE
    max_scale: float = DEFAULT_MAX_SCALE
    scale: float = field(default=0.5)
    over_budget: bool = False
    _fixed_ms: float = field(default=4.0, repr=False)  # the part of a frame that does not scale, ms

    def __post_init__(self) -> None:
        self.validate()
        self.scale = self._quantise(self.scale)

    def validate(self) -> None:
        """Check the limits.

        Raises:
            RenderError: a non-positive budget, or scales outside 0.1 ≤ min_scale ≤ max_scale ≤ 1.
        """
        if not (math.isfinite(self.budget_ms) and self.budget_ms > 0):
            raise RenderError(f"the interactive frame budget must be > 0 ms, got {self.budget_ms!r}")
        if not (0.1 <= self.min_scale <= self.max_scale <= 1.0):
            raise RenderError("interactive scales must satisfy 0.1 ≤ minimum ≤ cap ≤ 1, got "
                              f"minimum {self.min_scale!r}, cap {self.max_scale!r}")

    def set_cap(self, max_scale: float) -> None:
        """Set the cap (the studio's setting), in [min_scale, 1]; the current scale follows it down."""
        old = self.max_scale
        self.max_scale = float(max_scale)
        try:
            self.validate()
        except RenderError:
            self.max_scale = old
            raise
        self.scale = self._quantise(min(self.scale, self.max_scale))

    def _quantise(self, s: float) -> float:
        s = min(max(s, self.min_scale), self.max_scale)
        q = round(s / SCALE_STEP) * SCALE_STEP
        return round(min(max(q, self.min_scale), self.max_scale), 4)

    def update(self, frame_ms: float, scale: float) -> float:
        """Learn from one interactive frame that took ``frame_ms`` at ``scale``; returns the next scale.

        The frame's time is split into the fixed part (an estimate kept as the smallest time seen per
        unit of scale², so it never exceeds a real frame) and the part that grows with the pixels; the
        next scale is the one whose predicted time is the budget. A frame over the budget lowers the
        scale at once; a frame under it raises the scale by at most one step per frame (no oscillation).
        """
        if not (math.isfinite(frame_ms) and frame_ms > 0 and scale > 0):
            return self.scale
        self._fixed_ms = min(self._fixed_ms, 0.8 * frame_ms)
        per_px = max(frame_ms - self._fixed_ms, 1e-3) / (scale * scale)
        room = max(self.budget_ms - self._fixed_ms, 1e-3)
        target = math.sqrt(room / per_px)
        if target >= scale:
            target = min(target, scale + SCALE_STEP)
        else:
            target = min(target, scale - SCALE_STEP) if frame_ms > self.budget_ms * 1.1 else target
        self.scale = self._quantise(target)
        self.over_budget = frame_ms > self.budget_ms * 1.1 and scale <= self.min_scale + 1e-6
        return self.scale


def scaled_size(size: tuple[int, int], scale: float) -> tuple[int, int]:
    """The internal size for ``size`` (width, height in pixels) at ``scale``: each side ≥ 1 pixel."""
    w, h = size
    return max(int(round(w * scale)), 1), max(int(round(h * scale)), 1)
