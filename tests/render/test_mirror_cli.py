"""``sheer render --face DIR --view mirror|relight`` (issue 15), driven through the CLI in process, on a small
face folder written by hand (the sample head, a 320×240 camera looking at the face, a flash from the upper
left, a photograph of noise: the mirror view must give back whatever photograph it is given)."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import numpy as np
import pytest
from PIL import Image

if TYPE_CHECKING:
    from pathlib import Path

# the CLI in process: (exit code, image, stderr)
from tests.app.commands.test_render_camera_cli import _render

pytestmark = pytest.mark.gl
W, H = 320, 240


@pytest.fixture(scope="module")
def face_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    import OpenEXR

    from capture.camera import Camera
    from capture.face import FACE_SCHEMA_VERSION
    from capture.phong import PhongParams
    from painting.head import load_head

    head = load_head()
    lm = head.metadata.landmarks
    mouth = (np.asarray(lm["mouth_left"]) + np.asarray(lm["mouth_right"])) / 2
    d = tmp_path_factory.mktemp("face")
    p = PhongParams(diffuse=np.array([0.5, 0.35, 0.3]), specular=0.1, exponent=20.0, ambient_scale=1.0,
                    ambient_rgb=np.full(3, 0.02))
    eye = mouth + np.array([0.0, 0.0, 30.0])
    cam = Camera.looking_at(eye, mouth, np.array([0.0, 1.0, 0.0]), 20.0, W, H)
    light = np.array([0.3, 0.3, 1.0]) / np.linalg.norm([0.3, 0.3, 1.0])
    (d / "face.json").write_text(json.dumps({"schema_version": FACE_SCHEMA_VERSION, "phong": p.to_json(),
                                             "camera": cam.to_json(), "light_dir_world": light.tolist(),
                                             "photo": "photo.png"}))
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(hdr, {"RGB": np.ones((64, 64, 3), np.float32)}).write(str(d / "detail.exr"))
    rng = np.random.default_rng(7)
    Image.fromarray(rng.integers(0, 256, (H, W, 3), dtype=np.uint8)).save(d / "photo.png")
    Image.fromarray(rng.integers(0, 256, (H // 2, W // 2, 3), dtype=np.uint8)).save(d / "small.png")
    # the original the capture's 320×240 copy was "reduced from" (another aspect, 401×240, is not hers)
    Image.fromarray(rng.integers(0, 256, (3 * H, 3 * W, 3), dtype=np.uint8)).save(d / "original.png")
    Image.fromarray(rng.integers(0, 256, (H, W + 81, 3), dtype=np.uint8)).save(d / "wide.png")
    return d


def test_mirror_bare_is_the_photograph_and_lipstick_changes_the_mouth(face_dir: Path, tmp_path: Path) -> None:
    photo = np.asarray(Image.open(face_dir / "photo.png"))
    code, bare, err = _render("--face", str(face_dir), "--view", "mirror", "--out", str(tmp_path / "a.png"))
    assert code == 0, err
    # face.json's photo, its own size: its 8-bit texels copied to 8-bit pixels, exactly determined
    assert bare is not None and np.array_equal(bare, photo)
    code, lips, err = _render("--face", str(face_dir), "--view", "mirror", "--look", "red-lip",
                              "--photo", str(face_dir / "photo.png"), "--out", str(tmp_path / "b.png"))
    assert code == 0, err
    assert lips is not None and lips.shape == (H, W, 3)
    changed = np.abs(lips.astype(int) - photo.astype(int)).max(axis=2) > 2
    assert changed.sum() > 200
    rows, cols = np.nonzero(changed)
    # the camera looks at the mouth: the change is around the middle of the frame (lips, and the foundation)
    assert abs(np.median(rows) - H / 2) < H / 4 and abs(np.median(cols) - W / 2) < W / 4
    assert not changed[:, :10].any() and not changed[:10].any()  # the background is untouched


def test_mirror_of_the_original_photograph_is_drawn_at_its_own_resolution(face_dir: Path, tmp_path: Path) -> None:
    """``--photo ORIGINAL``: the photograph the capture's copy was reduced from (3× here) is drawn at its own
    size, its bytes back where there is no makeup, the makeup where it lies in the capture's copy."""
    original = np.asarray(Image.open(face_dir / "original.png"))
    code, bare, err = _render("--face", str(face_dir), "--view", "mirror", "--photo", str(face_dir / "original.png"),
                              "--out", str(tmp_path / "a.png"))
    assert code == 0, err
    assert bare is not None and np.array_equal(bare, original)
    small, big = ([*args, "--view", "mirror", "--look", "red-lip", "--out", str(tmp_path / f"{i}.png")]
                  for i, args in enumerate((["--face", str(face_dir)],
                                            ["--face", str(face_dir), "--photo", str(face_dir / "original.png")])))
    code, lips_small, err = _render(*small)
    assert code == 0 and lips_small is not None, err
    code, lips, err = _render(*big)
    assert code == 0 and lips is not None and lips.shape == (3 * H, 3 * W, 3), err
    changed = np.abs(lips.astype(int) - original.astype(int)).max(axis=2) > 2
    photo = np.asarray(Image.open(face_dir / "photo.png"))
    changed_small = np.abs(lips_small.astype(int) - photo.astype(int)).max(axis=2) > 2
    # the same makeup in the same place: 9 pixels for each of the copy's, its middle where the copy's is
    assert 0.8 < changed.sum() / (9 * changed_small.sum()) < 1.25
    rows, cols = np.nonzero(changed)
    rows_s, cols_s = np.nonzero(changed_small)
    assert abs(np.median(rows) / 3 - np.median(rows_s)) < 1.5 and abs(np.median(cols) / 3 - np.median(cols_s)) < 1.5
    assert not changed[:, :30].any() and not changed[:30].any()  # the background is untouched


def test_mirror_refuses_a_photograph_of_another_aspect_naming_it(face_dir: Path, tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _render("--face", str(face_dir), "--view", "mirror", "--photo", str(face_dir / "wide.png"),
                           "--out", str(tmp_path / "x.png"))
    err += capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"{face_dir / 'wide.png'}: the photograph is 401×240 but the face was captured from a 320×240 one " \
           "(of another aspect ratio" in err
    assert not (tmp_path / "x.png").exists()


def test_mirror_reads_the_photograph_upright(face_dir: Path, tmp_path: Path) -> None:
    """An original whose EXIF orientation turns it (a phone's portrait) is read upright, as the capture reads it."""
    original = Image.open(face_dir / "original.png")
    exif = Image.Exif()
    exif[0x0112] = 6  # rotate 90° clockwise to view
    original.transpose(Image.Transpose.ROTATE_90).save(tmp_path / "turned.jpg", exif=exif, quality=100)
    with Image.open(tmp_path / "turned.jpg") as im:
        from PIL import ImageOps

        upright = np.asarray(ImageOps.exif_transpose(im).convert("RGB"))
    code, bare, err = _render("--face", str(face_dir), "--view", "mirror", "--photo", str(tmp_path / "turned.jpg"),
                              "--out", str(tmp_path / "a.png"))
    assert code == 0, err
    assert bare is not None and np.array_equal(bare, upright)


def test_relight_turns_and_takes_presets_and_lights(face_dir: Path, tmp_path: Path) -> None:
    code, front, err = _render("--face", str(face_dir), "--view", "relight", "--out", str(tmp_path / "a.png"))
    assert code == 0, err
    assert front is not None and front.shape == (H, W, 3)
    code, turned, err = _render("--face", str(face_dir), "--view", "relight", "--yaw", "-20", "--pitch", "10",
                                "--light-preset", "evening", "--look", "red-lip", "--out", str(tmp_path / "b.png"))
    assert code == 0, err
    assert turned is not None and not np.array_equal(turned, front)
    code, big, err = _render("--face", str(face_dir), "--view", "relight", "--size", "640x480", "--light",
                             "-30,10,1.2,#ffddbb", "--out", str(tmp_path / "c.png"))
    assert code == 0 and big is not None and big.shape == (480, 640, 3), err


@pytest.mark.parametrize(("args", "message"), [
    (["--view", "relight", "--yaw", "30"], "at most ±25°"),
    (["--view", "mirror", "--size", "100x100"], "--size does not apply to --view mirror"),
    (["--view", "mirror", "--light", "10,10"], "--light does not apply"),
    (["--view", "mirror", "--photo", "SMALL"], "but the face was captured from a 320×240"),
    (["--view", "mirror", "--photo", "MISSING"], "photo not found"),
    (["--view", "relight", "--light-preset", "disco"], "--light-preset 'disco': one of daylight"),
    (["--view", "relight", "--light-preset", "office", "--light", "0,0"], "exclude each other"),
    (["--light-preset", "office"], "need --view"),
])
def test_bad_input_is_one_line(face_dir: Path, tmp_path: Path, args: list[str], message: str,
                               capsys: pytest.CaptureFixture[str]) -> None:
    args = [str(face_dir / "small.png") if a == "SMALL" else str(tmp_path / "nope.png") if a == "MISSING" else a
            for a in args]
    code, _, err = _render("--face", str(face_dir), *args, "--out", str(tmp_path / "x.png"))
    err += capsys.readouterr().err
    assert code == 2
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "x.png").exists()


def test_view_needs_a_face(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _render("--view", "mirror", "--out", str(tmp_path / "x.png"))
    assert code == 2 and "needs --face" in err + capsys.readouterr().err


def test_a_document_binding_drives_both_views_and_a_product_swap(face_dir: Path, gl_ctx: object) -> None:
    """The kiosk's use: one KM pass shared by the mirror and the relight view, kept in sync with a document
    by a DocumentBinding; a lipstick swapped for another shade changes both, as a fresh view would draw it."""
    from capture.face import load_face
    from km import default_library
    from painting import Document
    from painting.looks import apply_look, load_look
    from render.binding import layer_inputs
    from render.errors import RenderError
    from render.mirror import MirrorView, RelightView

    face = load_face(face_dir)
    head = face.load_head()
    photo = np.asarray(Image.open(face_dir / "photo.png"))
    lib = default_library()
    doc = Document(head, resolution=512, library=lib)
    mv = MirrorView(gl_ctx, head, face, photo)  # type: ignore[arg-type]
    rv = RelightView(gl_ctx, head, face, km=mv.km)  # type: ignore[arg-type]
    binding = mv.bind_document(doc)
    try:
        apply_look(doc, load_look("red-lip"))
        binding.flush()
        red, red_relit = mv.render_image(), rv.render_image()
        i = next(k for k, lay in enumerate(doc.layers) if "Lipstick" in lay.material)
        other = next(m.name for m in lib if m.category == "lipstick" and m.name != doc.layers[i].material)
        doc.set_layer(i, material=other)
        binding.flush()
        swapped, swapped_relit = mv.render_image(), rv.render_image()
        fresh = MirrorView(gl_ctx, head, face, photo)  # type: ignore[arg-type]
        try:
            fresh.set_layers(layer_inputs(doc))
            # exactly determined: the swap re-read every layer (DocumentBinding.flush's full evaluation), so
            # both views run the same programs on the same inputs (GL 4.5 appendix A, rule 4)
            assert np.array_equal(fresh.render_image(), swapped)
        finally:
            fresh.release()
    finally:
        binding.close()
        rv.release()
        mv.release()
    assert not np.array_equal(red, swapped) and not np.array_equal(red_relit, swapped_relit)

    class Unwrapped:  # a document painted in an xatlas unwrap: refused, the views use the mesh's UVs
        layout = type("Layout", (), {"source": "xatlas"})()

    with pytest.raises(RenderError, match="'xatlas' UV layout"):
        rv.bind_document(Unwrapped())  # type: ignore[arg-type]


def test_relight_adds_the_layers_own_lobes(face_dir: Path, gl_ctx: object) -> None:
    """The relight view's layers shine like the physical renderer's: their Kelemen lobes under each light
    (a gloss lipstick under the captured flash), and every specialisation with lobes compiles."""
    from capture.face import load_face
    from km import default_library
    from painting import Document
    from painting.looks import apply_look, load_look
    from render.binding import layer_inputs
    from render.mirror import RelightView

    face = load_face(face_dir)
    head = face.load_head()
    doc = Document(head, resolution=512, library=default_library())
    apply_look(doc, load_look("red-lip"))
    rv = RelightView(gl_ctx, head, face)  # type: ignore[arg-type]
    try:
        rv.set_layers(layer_inputs(doc))
        shiny = rv.render_image().astype(int)
        rv.engine.layer_spec_intensity = 0.0
        matte = rv.render_image().astype(int)
        for n_lights in (0, 1, 3):
            for shadows in (0, 1, 2):
                rv.engine.program_for(n_lights, shadows, False, True, 2)
    finally:
        rv.release()
    assert np.all(shiny >= matte - 1) and (shiny - matte).max() > 10


def test_mirror_draws_from_the_original_a_reduced_capture_was_made_from(face_dir: Path, tmp_path: Path) -> None:
    """Without ``--photo``, a face whose photo.png the capture reduced (face.json ``downscale``) draws from
    the original it recorded (``source_photo``, absolute) at the original's size; the copy when the original
    is gone."""
    import shutil

    folder = tmp_path / "face"
    shutil.copytree(face_dir, folder)
    original = tmp_path / "her-original.png"
    shutil.copy(face_dir / "original.png", original)
    data = json.loads((folder / "face.json").read_text())
    data.update(source_photo=str(original), downscale={"from": [3 * W, 3 * H], "to": [W, H], "why": "face taller"})
    (folder / "face.json").write_text(json.dumps(data))
    code, bare, err = _render("--face", str(folder), "--view", "mirror", "--out", str(tmp_path / "a.png"))
    assert code == 0 and bare is not None, err
    assert np.array_equal(bare, np.asarray(Image.open(original)))  # 3× the copy, her original's bytes
    original.unlink()
    code, bare, err = _render("--face", str(folder), "--view", "mirror", "--out", str(tmp_path / "b.png"))
    assert code == 0 and bare is not None and bare.shape == (H, W, 3), err

