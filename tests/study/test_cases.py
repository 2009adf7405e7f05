"""The case table of a study (docs/reference/config.md): grids, families, chunks, the config schema."""
import copy
import json
import math
from pathlib import Path

import pytest
import yaml
from snakemake.utils import validate

from ced.problem.errors import SceneError
from ced.problem.mechanism import FAMILIES, assembly_error, classify
from ced.study.config import validate_config
from ced.study.cases import (CASE_KEYS, case_config, case_table, chunk_rows, chunk_scenes, chunks,
                             family_sizes, grid_values, study_size)

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = str(ROOT / "workflow" / "schemas" / "config.schema.yaml")
CONFIGS = [ROOT / "config" / "config.yaml", *sorted((ROOT / "config" / "studies").glob("*.yaml"))]


def load(path) -> dict:
    config = yaml.safe_load(Path(path).read_text())
    validate(config, SCHEMA)  # also fills the schema defaults, as the Snakefile does
    return config


@pytest.fixture(scope="module")
def default():
    return load(ROOT / "config" / "config.yaml")


@pytest.fixture
def small():
    return load(ROOT / "config" / "studies" / "test.yaml")


# ------------------------------------------------------------------------------ grid values
@pytest.mark.parametrize("spec, expected", [
    ([0.3, 0.1, 0.2], [0.3, 0.1, 0.2]),                    # explicit, order kept
    ({"start": 0.1, "stop": 0.5, "num": 5}, [0.1, 0.2, 0.3, 0.4, 0.5]),   # inclusive range
    ({"start": 2.0, "stop": 9.0, "num": 1}, [2.0]),
    (0.25, [0.25]),                                         # a single value
    (3, [3.0]),
    ([1, 2.5], [1.0, 2.5]),
])
def test_grid_values_forms(spec, expected):
    values = grid_values(spec, "grids.x")
    assert values == expected
    assert all(type(v) is float for v in values)


def test_grid_range_values_are_exact_decimals():
    # linspace noise would make 0.1 + 0.5 != 0.2 + 0.4 fail exact comparisons downstream
    assert grid_values({"start": 0.05, "stop": 0.45, "num": 9}) == [
        0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45]


@pytest.mark.parametrize("spec, path", [
    ([], "grids.x"),
    ({"start": 0.1, "stop": 0.2}, "grids.x"),
    ({"start": 0.1, "stop": 0.2, "num": 0}, "grids.x.num"),
    ({"start": 0.1, "stop": 0.2, "num": 2.5}, "grids.x.num"),
    ({"start": 0.1, "stop": 0.2, "num": 2, "step": 1}, "grids.x"),
    ([0.1, "a"], "grids.x[1]"),
    ([0.1, float("nan")], "grids.x[1]"),
    (True, "grids.x"),
])
def test_grid_values_rejects_bad_forms(spec, path):
    with pytest.raises(SceneError) as err:
        grid_values(spec, "grids.x")
    assert err.value.path == path


# ------------------------------------------------------------------------------ case table
def test_case_table_is_deterministic(small):
    first = case_table(small)
    again = case_table(copy.deepcopy(small))
    reordered = json.loads(json.dumps(small, sort_keys=True))  # same config, other key order
    assert json.dumps(first, sort_keys=True) == json.dumps(again, sort_keys=True)
    assert json.dumps(first, sort_keys=True) == json.dumps(case_table(reordered),
                                                            sort_keys=True)
    assert chunks(small) == chunks(reordered)


def test_case_table_does_not_look_at_results(small, tmp_path, monkeypatch):
    before = json.dumps(case_table(small), sort_keys=True)
    monkeypatch.chdir(tmp_path)  # no results/, no config/ here
    assert json.dumps(case_table(small), sort_keys=True) == before


def test_rows_are_classified_into_their_family(default):
    rows = case_table(default, scenes=False)
    ground = default["grids"]["four_bar"]["ground"]
    for row in rows:
        if row["mechanism"] == "four_bar":
            assert row["ground"] == ground
            lengths = (row["ground"], row["crank"], row["coupler"], row["rocker"])
            assert row["family"] == classify(*lengths)
            assert assembly_error({"type": "four_bar", "ground": ground, "crank": row["crank"],
                                   "coupler": row["coupler"], "rocker": row["rocker"]}) is None
        else:
            assert row["family"] == "slider_crank"
            assert row["crank"] + abs(row["offset"]) < row["rod"]


def test_change_points_are_exact(default):
    rows = [r for r in case_table(default, scenes=False) if r["family"] == "change_point"]
    assert rows
    for r in rows:
        s, p, q, longest = sorted((r["ground"], r["crank"], r["coupler"], r["rocker"]))
        assert s + longest == pytest.approx(p + q, rel=1e-12)


def test_scene_of_a_row(small):
    row = case_table(small)[0]
    scene = row["scene"]
    assert scene["mechanism"] == {"type": "four_bar", "ground": 0.25, "crank": 0.05,
                                  "coupler": 0.2, "rocker": 0.15}
    assert scene["drive"]["speed"] == row["speed"] == 100.0
    assert scene["links"]["default"]["material"] == "steel"
    assert scene["links"]["default"]["section"] == small["sections"][0]
    assert scene["links"]["crank"] == {"flexible": False}
    assert scene["discretization"] == small["base_scene"]["discretization"]
    # building a row's scene must not alias the config
    scene["links"]["crank"]["flexible"] = True
    assert small["base_scene"]["links"]["crank"] == {"flexible": False}


@pytest.mark.parametrize("block", [{"links": None}, {"links": {"default": None}},
                                   {"drive": None}])
def test_null_base_scene_blocks_are_the_scene_defaults(small, block):
    # A scene reads a null block as its defaults; a row's scene fills it in as an absent one
    # (the fuzz test of tests/test_bad_input.py found links: null raising AttributeError).
    config = {**small, "base_scene": {**small["base_scene"], **block}}
    scene = case_table(config)[0]["scene"]
    assert scene["links"]["default"]["material"] == "steel"
    assert scene["drive"]["speed"] == 100.0


@pytest.mark.parametrize("key, value", [("links", True), ("drive", [1.0]),
                                        ("links", {"default": 3})])
def test_a_base_scene_block_that_is_no_mapping_is_refused_by_its_key(small, key, value):
    config = copy.deepcopy(small)
    config["base_scene"][key] = value
    with pytest.raises(SceneError, match=f"base_scene.{key}"):
        validate_config(config, memory=2**40)


def test_families_filter_and_case_ids(small):
    rows = case_table(small, scenes=False)
    assert {r["family"] for r in rows} == {"crank_rocker", "change_point", "slider_crank"}
    # the triple_rocker geometry of the grid is not kept
    assert study_size(small) == (2 * 1 * 2 + 1) * 2 * 2
    for family in {r["family"] for r in rows}:
        ids = [r["case"] for r in rows if r["family"] == family]
        assert ids == list(range(len(ids)))
    assert case_table(small, "change_point", scenes=False) == [
        r for r in rows if r["family"] == "change_point"]


def test_materials_are_resolved_names(small):
    config = copy.deepcopy(small)
    config["materials"] = ["aluminum", {"name": "soft", "E": 1e9, "rho": 1000.0, "nu": 0.3}]
    assert [r["material"] for r in case_table(config, "slider_crank", scenes=False)] == [
        "aluminium", "soft", "aluminium", "soft"]


# ------------------------------------------------------------------------------ chunks
@pytest.mark.parametrize("size", [1, 3, 4, 5, 1000])
def test_chunks_partition_each_family(small, size):
    config = dict(small, chunk_size=size)
    sizes = family_sizes(config)
    assert sizes == {"crank_rocker": 8, "change_point": 4, "slider_crank": 4}
    counts = chunks(config)
    assert counts == {f: math.ceil(n / size) for f, n in sizes.items()}
    table = case_table(config)
    for family, n in counts.items():
        rows = [r for i in range(n) for r in chunk_rows(config, family, i)]
        assert rows == [r for r in table if r["family"] == family]
        assert all(len(chunk_rows(config, family, i, scenes=False)) <= size for i in range(n))
        with pytest.raises(SceneError):
            chunk_rows(config, family, n)
    assert chunk_scenes(config, "slider_crank", 0)[0]["mechanism"]["type"] == "slider_crank"


def test_default_study_size(default):
    sizes = family_sizes(default)
    assert set(sizes) == set(FAMILIES)  # all seven families
    assert sum(sizes.values()) >= 2000
    assert all(n >= 100 for n in sizes.values())
    assert sum(chunks(default).values()) < 100  # one job per chunk, never per case


def test_case_config_holds_only_what_defines_cases(default):
    cases = case_config(default)
    assert set(cases) == set(CASE_KEYS) & set(default)
    assert "study" not in cases and "families" not in cases
    edited = dict(default, study="other", families=["crank_rocker"], stress_safety_factor=3.0)
    assert case_config(edited) == cases


# ------------------------------------------------------------------------------ config checks
# ------------------------------------------------------------------------------ validation


def test_estimate_and_modal_requested_follow_the_base_scene():
    from ced.study.cases import estimate_requested, modal_requested
    assert estimate_requested({"base_scene": {}})
    assert estimate_requested({"base_scene": {"discretization": "auto"}})
    assert not estimate_requested({"base_scene": {"outputs": {"error_estimate": False}}})
    assert not estimate_requested({"base_scene": {"discretization": {"formulation": "rigid"}}})
    assert modal_requested({"base_scene": {"discretization": "auto", "modal": {"modes": 2}}})
    assert not modal_requested({"base_scene": {"discretization": {"formulation": "rigid"},
                                               "modal": {"modes": 2}}})
