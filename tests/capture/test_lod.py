"""Level of detail: quadric decimation of the head, the detail texture re-baked, ``sheer head simplify``."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pytest

if TYPE_CHECKING:
    from pathlib import Path


@pytest.fixture(scope="module")
def heads() -> tuple[object, object]:
    from capture.lod import simplify_head
    from painting.head import load_head

    fine = load_head()
    return fine, simplify_head(fine, 1143)


def test_simplify_reaches_the_target_and_keeps_uvs_sane(heads: tuple) -> None:
    fine, coarse = heads
    assert abs(len(coarse.faces) - 1143) <= 5
    span = np.ptp(coarse.uv[coarse.faces], axis=1).max(axis=1)
    assert np.mean(span > 0.1) < 0.1  # a few triangles still straddle a UV seam (reported)
    assert coarse.mm_per_unit == fine.mm_per_unit and coarse.metadata.landmarks == fine.metadata.landmarks


def test_simplify_redoes_faulty_uvs_within_one_chart(heads: tuple) -> None:
    # Corner UVs from the closest fine point pick either side of a seam; the faulty triangles are redone
    # within one chart. Measured at 512²: texels claimed by two coarse triangles 1,346 → 714, UV folds
    # 46 → 39 (the rest straddle a seam for real: reported, not fixed).
    from capture.lod import uv_faults
    from painting.layout import coverage_count

    fine, coarse = heads
    count = coverage_count(coarse.uv[coarse.faces] * 512, 512, 512)
    assert int((count > 1).sum()) < 1000
    assert int(uv_faults(fine, coarse, tol=np.inf).sum()) <= 42


def test_rebake_keeps_a_constant_texture_constant(heads: tuple) -> None:
    from capture.lod import rebake_detail

    fine, coarse = heads
    detail = np.full((64, 64, 3), 1.25, np.float32)
    out = rebake_detail(fine, coarse, detail, size=64)
    assert out.shape == (64, 64, 3) and np.allclose(out, 1.25, atol=1e-5)


def test_head_simplify_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from app.cli import main
    from painting.head import load_head

    assert main(["head", "simplify", "--faces", "2000", "--out", str(tmp_path / "lod")]) == 0
    head = load_head(tmp_path / "lod" / "head.obj")
    assert abs(len(head.faces) - 2000) <= 5 and head.albedo is not None
    assert main(["head", "simplify", "--faces", "99999999", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "--faces must be between" in err and "Traceback" not in err
