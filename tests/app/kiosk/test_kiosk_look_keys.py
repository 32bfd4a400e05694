"""Her face gets the look on screen: a built-in look is replayed on her head, every project's look (the
first, ``project``, and the others, ``project-2`` …) is carried over from the document on screen."""

from __future__ import annotations

from pathlib import Path

from app.kiosk.capture import look_to_replay
from app.kiosk.config import KioskLook, builtin_look


def test_every_projects_look_is_carried_over_and_built_in_looks_are_replayed() -> None:
    looks = [KioskLook("project", "Brand Glow", "--project", path=Path("/brand.sheer")),
             builtin_look("red-lip"),
             KioskLook("project-2", "Night Out", "kiosk.json: looks[2]", path=Path("/night.sheer"))]
    assert look_to_replay(looks, "project") == ""
    assert look_to_replay(looks, "project-2") == ""  # not a built-in look to replay (and warn about)
    assert look_to_replay(looks, "red-lip") == "red-lip"
    assert look_to_replay(looks, "natural") == "natural"  # none of the kiosk's: as it is
