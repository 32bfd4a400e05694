"""Labels of names in any script: readable, unique per axis, the same on every run and machine, never empty;
a spec whose names would still collide is refused in one line; a real run keeps every image and sheet."""

from __future__ import annotations

import json
import unicodedata
from typing import TYPE_CHECKING, Any

import pytest

from app.cli import main
from catalogue import CatalogueError, expand, load_spec, run_catalogue
from catalogue.labels import LabelCollision, label, unique_labels

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

#: A catalogue of looks and products named in other scripts (a look's name is its file's, a product's the
#: library's): 2 looks × 3 products × 1 light × 1 view.
NAMED = """
name = "Printemps"
size = [48, 48]
resolution = 256
library = "materials.json"
[[looks]]
look = "japan.json"
[[looks]]
look = "china.json"
[products]
category = "lipstick"
materials = ["Rouge Été", "Rouge Ôté", "Rouge Ete"]
[[lights]]
preset = "portrait"
[[views]]
name = "front"
"""
#: The library's lipsticks renamed for :data:`NAMED`.
RENAMED = {"Lipstick Nude": "Rouge Été", "Lipstick Pink": "Rouge Ôté", "Lipstick Coral": "Rouge Ete"}


def _named(write_spec: Callable[..., Path], library: Path, text: str = NAMED, renamed: dict[str, str] | None = None,
           looks: tuple[str, str] = ("日本 1", "中国 1")) -> Path:
    """Write ``text`` as a spec beside ``library`` (its materials renamed) and the look files it names."""
    from core.assets import resource_path

    data = json.loads(library.read_text(encoding="utf-8"))
    for m in data["materials"]:
        m["name"] = (RENAMED if renamed is None else renamed).get(m["name"], m["name"])
    library.write_text(json.dumps(data), encoding="utf-8")
    look = json.loads(resource_path("looks/red-lip.json").read_text(encoding="utf-8"))
    for file, name in zip(("japan.json", "china.json"), looks, strict=True):
        (library.parent / file).write_text(json.dumps({**look, "name": name}), encoding="utf-8")
    return write_spec(text)


def test_labels_are_readable_and_the_same_on_every_machine() -> None:
    # before: Rouge_t, Rouge_t, 1, 1 (accented and CJK letters dropped)
    assert [label(n) for n in ("Rouge Été", "Rouge Ôté", "日本 1", "中国 1")] == \
        ["Rouge_Ete", "Rouge_Ote", "RiBen_1", "ZhongGuo_1"]
    # precomposed or decomposed, one name: one label
    assert label(unicodedata.normalize("NFD", "Rouge Été")) == "Rouge_Ete"
    # nothing to transliterate, or too long: a hash of the name (SHA-256, fixed here: every machine's)
    assert label("") == "x-e3b0c4" and label("!!!") != label("???")
    assert label("Ω" * 100) == "O" * 57 + "-" + label("Ω" * 100)[-6:] and len(label("Ω" * 100)) == 64
    assert all(label(n) for n in ("", " ", "—", "\u200b", "..", "😀"))


def test_two_names_never_share_a_label() -> None:
    assert unique_labels(["Rouge Ete", "Rouge Été", "Rouge Ôté"]) == ["Rouge_Ete", "Rouge_Ete-28e925", "Rouge_Ote"]
    # the same labels in any order (a name's label does not depend on where it is listed)
    assert unique_labels(["Rouge Ôté", "Rouge Été", "Rouge Ete"]) == ["Rouge_Ote", "Rouge_Ete-28e925", "Rouge_Ete"]
    # names that differ only in case collide on macOS and Windows file systems: both get a suffix
    both = unique_labels(["Rouge", "rouge"])
    assert len({b.casefold() for b in both}) == 2 and all(b.lower().startswith("rouge-") for b in both)
    with pytest.raises(LabelCollision) as caught:
        unique_labels(["Rouge Ete", "Rouge Été", "Rouge_Ete-28e925"])
    assert {caught.value.first, caught.value.second} == {"Rouge Été", "Rouge_Ete-28e925"}


def test_a_spec_in_other_scripts_expands_to_distinct_images_and_sheets(write_spec: Callable[..., Path],
                                                                      library_copy: Path) -> None:
    spec = load_spec(_named(write_spec, library_copy))
    assert [look.name for look in spec.looks] == ["RiBen_1", "ZhongGuo_1"]  # before: 1 and 1
    assert spec.product_labels == {"Rouge Été": "Rouge_Ete-28e925", "Rouge Ôté": "Rouge_Ote", "Rouge Ete": "Rouge_Ete"}
    jobs = expand(spec)
    assert len(jobs) == len({j.out for j in jobs}) == 2 * 3
    assert {j.out.split("/")[0] for j in jobs} == {"Rouge_Ete", "Rouge_Ete-28e925", "Rouge_Ote"}
    from catalogue.sheets import sheet_groups

    groups = sheet_groups(library_copy.parent / "out", jobs)
    assert len(groups) == 3 and all(len(items) == 2 for items in groups.values())  # both looks on each
    # the same spec gives the same outputs on another run
    assert [j.out for j in expand(load_spec(_named(write_spec, library_copy)))] == [j.out for j in jobs]


def test_names_that_would_still_collide_are_refused_in_one_line(write_spec: Callable[..., Path],
                                                                library_copy: Path, capsys: Any) -> None:
    path = _named(write_spec, library_copy, NAMED.replace("Rouge Ôté", "Rouge_Ete-28e925"),
                  {**RENAMED, "Lipstick Pink": "Rouge_Ete-28e925"})
    assert main(["catalogue", str(path), "--dry-run"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"sheer: error: {path}:") and "\n" not in err, err
    assert "products: 'Rouge Été' and 'Rouge_Ete-28e925' would both be labelled 'Rouge_Ete-28e925'" in err
    # the two spellings of one name (precomposed, decomposed) are one name, twice
    path = _named(write_spec, library_copy, looks=("Rouge Été", unicodedata.normalize("NFD", "Rouge Été")))
    with pytest.raises(CatalogueError, match="looks: two entries are named 'Rouge Été'"):
        load_spec(path)


def test_two_products_and_views_on_one_contact_sheet_are_refused(write_spec: Callable[..., Path],
                                                                 library_copy: Path) -> None:
    text = (NAMED.replace('"Rouge Été", "Rouge Ôté", "Rouge Ete"', '"Lipstick Nude", "Lipstick Nude-matte"')
            .replace('name = "front"', 'name = "front"\n[[views]]\nname = "matte-front"'))
    path = _named(write_spec, library_copy, text, {"Lipstick Pink": "Lipstick Nude-matte"})
    with pytest.raises(CatalogueError, match=r"contact_sheets: product 'Lipstick Nude' in view 'matte-front' and "
                                             r"product 'Lipstick Nude-matte' in view 'front' would share "
                                             r"sheets/Lipstick_Nude-matte-front\.png"):
        expand(load_spec(path))
    assert expand(load_spec(write_spec(text.replace("resolution = 256", "resolution = 256\ncontact_sheets = false"))))


@pytest.mark.gl
@pytest.mark.xdist_group("dask-cluster")
def test_a_real_run_keeps_every_image_and_sheet(dask_client: Any, write_spec: Callable[..., Path],
                                                library_copy: Path, tmp_path: Path) -> None:
    from PIL import Image

    text = NAMED.replace('"Rouge Été", "Rouge Ôté", "Rouge Ete"', '"Rouge Été", "Rouge Ete"')
    spec = load_spec(_named(write_spec, library_copy, text))
    result = run_catalogue(spec, tmp_path / "out", client=dask_client)
    assert (result.rendered, result.failed) == (4, [])
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text(encoding="utf-8"))
    files = [e["file"] for e in manifest["images"]]
    assert len(set(files)) == 4 and all((tmp_path / "out" / f).is_file() for f in files)
    assert {(e["product"], e["look"]) for e in manifest["images"]} == \
        {(p, look) for p in ("Rouge Été", "Rouge Ete") for look in ("RiBen_1", "ZhongGuo_1")}
    sheets = sorted(p.name for p in (tmp_path / "out" / "sheets").iterdir())
    assert sheets == ["Rouge_Ete-28e925-front.png", "Rouge_Ete-front.png"]
    for name in sheets:  # each sheet: both looks (faces down) under the one light
        assert Image.open(tmp_path / "out" / "sheets" / name).size == (192, 2 * (192 + 16))
