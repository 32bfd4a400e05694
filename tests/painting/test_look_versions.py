"""Look files: version 2 carries regions and masks; version 1 (without them) is read as before; a version-1
file that names a region is refused with the key and the version it needs."""

from __future__ import annotations

import json

import pytest

from core.assets import resource_path
from painting.looks import LOOK_SCHEMA_VERSION, Look, LookError


def test_shipped_looks_with_regions_say_version_2() -> None:
    for path in sorted(resource_path("looks").glob("*.json")):
        data = json.loads(path.read_text())
        text = path.read_text()
        uses_regions = '"region' in text or '"fill_region"' in text or '"mask"' in text
        assert data["schema_version"] == (2 if uses_regions else data["schema_version"]), path.name
        Look.from_json(data, path.name)  # every shipped look loads
    assert LOOK_SCHEMA_VERSION == 2


def test_version_1_still_reads_and_refuses_version_2_keys() -> None:
    v1 = {"schema_version": 1, "name": "old", "layers": [
        {"material": "Lipstick Classic Red", "strokes": [{"points": ["lower_lip"], "radius_mm": 5}]}]}
    assert Look.from_json(v1, "old.json").layers[0].material == "Lipstick Classic Red"
    with_region = json.loads(json.dumps(v1))
    with_region["layers"][0]["strokes"][0]["region"] = "lips"
    with pytest.raises(LookError, match=r'old.json: layers\[0\].strokes\[0\].region needs "schema_version": 2'):
        Look.from_json(with_region, "old.json")
    with_mask = json.loads(json.dumps(v1))
    with_mask["layers"][0]["mask"] = {"regions": [["union", "lips"]]}
    with pytest.raises(LookError, match=r'layers\[0\].mask needs "schema_version": 2'):
        Look.from_json(with_mask, "old.json")
    with_region["schema_version"] = 2
    assert Look.from_json(with_region, "new.json").layers[0].strokes[0].region == "lips"
    for bad in (3, "2", True, None):
        with pytest.raises(LookError, match="is not supported"):
            Look.from_json({**v1, "schema_version": bad}, "odd.json")
