"""The automatic capture's specular intensity i_s on a GPU-drawn flash photograph with a known i_s (issue 14).

The kiosk's path: the sample head drawn on the GPU (:func:`bench.capture_truth.draw_case`: per-pixel
normals, its albedo, the flash's cast shadows; i_s 0.18, s 16, the flash 6° above and 3° beside the lens,
the city sky's ambient; the validation's framing, so the automatic capture downscales the face to
:data:`capture.auto.MAX_FACE_PX`), its mirror-ball probe analysed, then :func:`capture.auto.capture_auto`
with the lens's focal length — MediaPipe's landmarks on the drawn photograph, the person's own head
built from them, its camera pinned to them.

Measured (11 GPU scenes of its own, none a bench's: the sample head (4 textured, 2
untextured) and MediaPipe's canonical face (5), s 10–50, the head turned −12° to +15°, six flash
placements, six skies): the automatic capture's i_s reads −83 to −100 % (0 on 8 of 11), s 1–6. The cause
is the person's head, not the pixel integration: its normals lie 9–10° (median; p90 23°) from the drawn
surface's, so at the lobe's 2 px high-pass (:data:`capture.lobe.LOBE_HIGH_PASS_PX`) its lobe does not
overlap the photograph's. The lobe integrated over each pixel (:mod:`capture.pixel_lobe`) moves i_s by
≤ 2 points of those −83…−100 %; the points path's registration on that head by 9–16 points; a high-pass
16 times broader with the true s leaves −40 to −72 %. The same photographs through the automatic capture
given the sample head itself (its standard landmarks, the registration and the pixel integration): i_s
−1.0 to −1.4 % textured. Hence a strict xfail: it turns green when the automatic capture reads i_s from
what its head can support. Until then the capture says so (a note in face.json and in the progress lines,
:data:`capture.auto.NO_SPECULAR`) rather than leaving i_s 0 to read as a matte skin.
"""

from __future__ import annotations

from typing import Any

import pytest

pytestmark = [pytest.mark.gl, pytest.mark.slow]


SPECULAR = 0.18


@pytest.fixture(scope="module")
def captured(_gl_session_ctx: Any, tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, list[str]]:
    """The scene drawn and captured automatically once: (the face folder read back, the progress lines)."""
    from bench.capture_truth import Case, draw_case
    from capture.auto import capture_auto
    from capture.exif import focal_35mm_from_px
    from capture.probe import analyse_probe

    case = Case(head="sample", exponent=16.0, specular=SPECULAR, environment="city", light_deg=(6.0, 3.0),
                shadows=True)
    scene = draw_case(_gl_session_ctx, case)
    assert _gl_session_ctx.error == "GL_NO_ERROR"
    lens = focal_35mm_from_px(float(scene.camera.K[0, 0]), scene.camera.width, scene.camera.height)
    lines: list[str] = []
    face = capture_auto(scene.photo.srgb8, tmp_path_factory.mktemp("auto") / "face",
                        probe=analyse_probe(scene.probe_linear), allow_closed_eyes=True, focal_mm=lens,
                        progress=lines.append)
    return face, lines


@pytest.mark.xfail(strict=True, raises=AssertionError,
                   reason="the person's head's normals are ~10° off the surface: its lobe does not overlap the "
                          "photograph's at the 2 px high-pass, i_s reads ~0 (see the module docstring)")
def test_the_automatic_capture_reads_a_drawn_specular_intensity(captured: tuple[Any, list[str]]) -> None:
    face, _ = captured
    assert abs(face.params.specular / SPECULAR - 1.0) < 0.10, face.params.specular


def test_a_lobe_not_found_is_said_not_left_as_a_matte_skin(captured: tuple[Any, list[str]]) -> None:
    from capture.auto import NO_SPECULAR

    face, lines = captured
    assert face.params.specular < NO_SPECULAR  # what the xfail above measures: no lobe on the person's head
    said = [n for n in face.data["notes"] if n.startswith("no specular lobe found")]
    assert len(said) == 1 and "too coarse at the lobe's scale" in said[0], face.data["notes"]
    assert f"note: {said[0]}" in lines
