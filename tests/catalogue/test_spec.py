"""Spec checking and expansion: counts, naming, hashes, and every refusal before any work (exit 2, the key)."""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

import pytest

from app.cli import main
from catalogue import CatalogueError, expand, load_spec
from catalogue.spec import key_line

if TYPE_CHECKING:
    from pathlib import Path

BIG = """
name = "range"
size = [640, 640]
naming = "{product}/{head}_{look}_{light}_{view}_{hash}.png"
[[heads]]
name = "lps"
[[heads]]
name = "lps-file"
path = "HEADPATH"
[[looks]]
look = "red-lip"
[[looks]]
look = "natural"
[products]
category = "lipstick"
[[lights]]
preset = "portrait"
[[lights]]
name = "studio"
preset = "key"
environment = "studio"
[[views]]
name = "front"
[[views]]
name = "three-quarter"
yaw = 35
pitch = 5
"""


def _big(write_spec, **fmt) -> Path:
    from core.assets import find_asset

    return write_spec(BIG.replace("HEADPATH", str(find_asset("heads/lee-perry-smith/head.glb"))), **fmt)


def test_expansion_counts_and_names(write_spec) -> None:
    import km

    spec = load_spec(_big(write_spec))
    lipsticks = [m.name for m in km.default_library().by_category("lipstick")]
    assert spec.products == lipsticks and len(lipsticks) >= 5
    jobs = expand(spec)
    assert len(jobs) == 2 * 2 * len(lipsticks) * 2 * 2
    assert len({j.out for j in jobs}) == len(jobs)
    # the two heads are the same mesh: same content hash, so the same pixels under two labels
    assert len({j.head_hash for j in jobs}) == 1 and len({j.key for j in jobs}) == len(jobs) // 2
    for j in jobs:
        product = j.product.replace(" ", "_")
        pattern = rf"{product}/{j.head.name}_{j.look.name}_{j.light.name}_{j.view.name}_{j.key[:16]}\.png"
        assert re.fullmatch(pattern, j.out), j.out
    # consecutive jobs share a head, look and lighting (chunks keep a worker's caches)
    from catalogue.jobs import chunks

    for chunk in chunks(jobs, 2):
        assert len({j.group for j in chunk}) == 1


def test_hashes_are_stable_and_change_only_with_their_inputs(write_spec, tmp_path) -> None:
    a = expand(load_spec(write_spec()))
    b = expand(load_spec(write_spec()))
    assert [j.key for j in a] == [j.key for j in b]
    c = expand(load_spec(write_spec(extra="exposure = 1.0")))
    assert not {j.key for j in a} & {j.key for j in c}
    d = expand(load_spec(write_spec(lights='[[lights]]\nname = "third"\npreset = "key"')))
    assert {j.key for j in a} < {j.key for j in d} and len(d) == len(a) + 2


@pytest.mark.parametrize(("edit", "key", "words"), [
    (("look = \"red-lip\"", "look = \"no-such-look\""), "looks[0].look", "unknown look 'no-such-look'"),
    (("\"Lipstick Pink\"", "\"Lipstick Mauvre\""), "products.materials[1]", "unknown material 'Lipstick Mauvre'"),
    (("\"Lipstick Pink\"", "\"Blush Peach\""), "products.materials[1]", "not a lipstick"),
    (("category = \"lipstick\"\nmaterials = [\"Lipstick Nude\", \"Lipstick Pink\"]", "category = \"glitter\""),
     "products.category", "no product of category 'glitter'"),
    (("size = [48, 48]", "size = [-48, 48]"), "size[0]", "-48"),
    (("size = [48, 48]", "size = [48, 48]\nnaming = \"{product}.png\""), "naming", "{hash}"),
    (("size = [48, 48]", "size = [48, 48]\nnaming = \"{shade}-{hash}.png\""), "naming", "unknown field {shade}"),
    (("[[views]]", "[[views]]\nyaw = 400"), "views[0].yaw", "400"),
    (("preset = \"flat\"", "preset = \"flat\"\nenvironment = \"moon\""), "lights[1].environment", "moon"),
    (("[[looks]]", "[[looks]]\nname = \"a\"\n[[looks]]"), "looks[0]", ""),
    (("resolution = 256", "resolution = 256\ncolour = 3"), "(top level)", "colour"),
])
def test_spec_errors_name_the_key_and_exit_2(write_spec, capsys, edit, key, words) -> None:
    text = write_spec().read_text(encoding="utf-8")
    assert edit[0] in text
    path = write_spec(text.replace(edit[0], edit[1], 1))
    assert main(["catalogue", str(path), "--out", str(path.parent / "out")]) == 2
    err = capsys.readouterr().err.strip()
    line = f":{line_no}" if (line_no := key_line(path.read_text(), key)) else ""
    assert err.startswith(f"sheer: error: {path}{line}: {key}: "), err
    if key in ("looks[0].look", "products.materials[1]", "size[0]", "views[0].yaw"):
        assert line  # the key is written in the spec: its line is given
    assert words in err and "\n" not in err
    assert not (path.parent / "out").exists()  # refused before any work


def test_unknown_material_in_a_look_file_and_a_look_without_a_lipstick(write_spec, tmp_path, capsys) -> None:
    import json

    look = {"schema_version": 1, "name": "odd", "layers": [{"material": "Unobtainium", "strokes": []}]}
    (tmp_path / "odd.json").write_text(json.dumps(look), encoding="utf-8")
    path = write_spec(write_spec().read_text().replace("look = \"red-lip\"", "look = \"odd.json\""))
    assert main(["catalogue", str(path), "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert "looks[0].look" in err and "unknown material 'Unobtainium'" in err
    path = write_spec(write_spec().read_text().replace("look = \"red-lip\"", "look = \"bare\""))
    assert main(["catalogue", str(path), "--dry-run"]) == 2
    assert "looks[0]: 'bare' has no lipstick layer" in capsys.readouterr().err


def test_toml_syntax_error_names_the_line(write_spec, capsys) -> None:
    path = write_spec("name = \"x\"\nsize = [48, 48] 7\nmode = \"fast\"\n")
    assert main(["catalogue", str(path), "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert "invalid TOML" in err and "line 2" in err


def test_dry_run_prints_the_expansion_count_and_estimate(write_spec, tmp_path, capsys) -> None:
    path = _big(write_spec)
    assert main(["catalogue", str(path), "--dry-run", "--workers", "2", "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    n = len(expand(load_spec(path)))
    assert f"= {n} output(s) (640×640, fast); 0 already there, {n} to render; estimate ≈ " in out
    assert "on 2 local worker(s)" in out
    assert not (tmp_path / "out").exists()  # a dry run writes nothing


def test_missing_files_are_refused_before_work(write_spec, tmp_path) -> None:
    with pytest.raises(CatalogueError, match=r"heads\[0\]\.path: .*nope\.glb: head mesh not found"):
        load_spec(write_spec(extra="[[heads]]\npath = \"nope.glb\""))
    with pytest.raises(CatalogueError, match=r"library: "):
        load_spec(write_spec(extra="library = \"missing.json\""))
