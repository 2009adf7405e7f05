"""The generated reference pages (docs/reference/) are what the code defines: the committed
pages equal freshly generated ones, and every key, variable and flag has a meaning."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from ced import simulate
from ced.problem.materials import MATERIAL_FIELDS, SECTION_FIELDS
from ced.problem.reference import scene_rows
from ced.problem.scene import BLOCKS, MECHANISM_FIELDS, MEANINGS, load_scene
from ced.problem.status import STATUS_ADVICE, STATUS_FLAGS, STATUS_MEANINGS
from ced.simulation.dataset import (CASE_COORDINATES, DIMENSIONS, PRESENCE, VARIABLES,
                                    dataset_reference)
from ced.study.config import SCHEMA_PATH
from ced.cli import write_references
from ced.study.reference import REFERENCES, config_rows

DOCS = Path(__file__).resolve().parents[1] / "docs" / "reference"


@pytest.mark.parametrize("name", sorted(REFERENCES) + ["cli.md"])
def test_committed_page_is_up_to_date(name, tmp_path):
    write_references(tmp_path)
    fresh = (tmp_path / name).read_text(encoding="utf-8")
    committed = (DOCS / name).read_text(encoding="utf-8")
    assert committed == fresh, (
        f"docs/reference/{name} is out of date with the code: run `make reference` and "
        f"commit the result")


def test_every_scene_key_has_a_meaning():
    for kind, fields in MECHANISM_FIELDS.items():
        for key in fields:
            assert MEANINGS[f"mechanism.{kind}.{key}"]
    for block, fields in BLOCKS.items():
        for key in fields:
            assert MEANINGS[f"{block}.{key}"].strip(), f"{block}.{key}"
    assert all(meaning for *_, meaning in MATERIAL_FIELDS.values())
    assert all(meaning for *_, meaning in SECTION_FIELDS.values())
    rows = [row for section in scene_rows().values() for row in section]
    assert all(len(row) == 5 and row[4] for row in rows)


def test_every_dyad_key_has_a_meaning_and_the_rpr_example_loads():
    from ced.problem.linkage import DYAD_KEYS, DYAD_MEANINGS
    from ced.problem.reference import RPR_EXAMPLE

    assert set(DYAD_MEANINGS) == {f"{k}.{key}" for k, keys in DYAD_KEYS.items() for key in keys}
    scene = load_scene(yaml.safe_load(RPR_EXAMPLE))
    assert [d["kind"] for d in scene["mechanism"]["dyads"]] == ["RPR", "RRP"]
    assert scene["links"]["lever"]["flexible"] is False and scene["links"]["rod"]["flexible"]
    assert "```yaml\n" + RPR_EXAMPLE in (DOCS / "scene.md").read_text(encoding="utf-8")


def test_no_meaning_without_a_key():
    """A meaning left behind by a removed key fails too."""
    known = {"name", "mechanism.type", "effects", "gravity", "discretization", "modal",
             "tolerance", "links.default", "links.<link>.material", "links.<link>.section",
             "links.<link>.flexible", "point_masses.<joint>"}
    known |= {f"mechanism.{k}.{f}" for k, fields in MECHANISM_FIELDS.items() for f in fields}
    known |= {f"{b}.{f}" for b, fields in BLOCKS.items() for f in fields}
    assert set(MEANINGS) == known


def test_scene_defaults_in_the_reference_are_the_loaded_ones():
    """The defaults the page shows are the ones a minimal scene gets."""
    scene = load_scene({"mechanism": {"type": "single_link", "length": 0.5}})
    text = REFERENCES["scene.md"]()
    assert f"`{scene['time']['steps_per_revolution']}`" in text
    assert f"| `drive.speed` | a finite number > 0 | rad/s | `{scene['drive']['speed']:g}` |" \
        in text


def test_every_config_key_has_a_description():
    schema = yaml.safe_load(SCHEMA_PATH.read_text())
    rows = config_rows()
    keys = [row[0] for row in rows]
    assert set(schema["properties"]) <= set(keys)
    assert all(row[3].strip() for row in rows)
    assert "grids.four_bar.crank" in keys and "grids.slider_crank.offset" in keys


def test_every_variable_has_a_presence_and_documented_dims():
    assert set(PRESENCE) == set(VARIABLES)
    assert {d for dims, *_ in VARIABLES.values() for d in dims} <= set(DIMENSIONS)
    assert set(STATUS_MEANINGS) == set(STATUS_FLAGS) == set(STATUS_ADVICE)
    text = dataset_reference()
    for name in VARIABLES:
        assert f"| `{name}` |" in text


@pytest.mark.parametrize("mechanism", [
    {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35},
    {"type": "slider_crank", "crank": 0.1, "rod": 0.3}])
def test_case_coordinates_of_a_dataset_are_documented(mechanism):
    ds = simulate({"mechanism": mechanism, "discretization": {"formulation": "rigid"},
                   "time": {"revolutions": 1, "steps_per_revolution": 16}})
    for name, coord in ds.coords.items():
        if coord.dims == ("case",) and name != "case":
            assert name in CASE_COORDINATES, name
            assert coord.attrs.get("units", "") == CASE_COORDINATES[name][0], name
