"""Study configs (ced.study.config): the schema, every check it cannot express, and the size
and memory estimates."""
import copy

import pytest
import yaml
from snakemake.utils import validate

from ced.problem.errors import SceneError
from ced.study.cases import chunks, family_sizes, grid_points, study_size
from ced.study.config import check_config, study_estimate, validate_config
from tests.study.test_cases import CONFIGS, SCHEMA, default, load, small  # noqa: F401 (fixtures)


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: p.name)
def test_every_config_is_valid(path):
    config = load(path)
    assert check_config(config) == chunks(config)


def test_schema_rejects_unknown_family(default):
    bad = copy.deepcopy(default)
    bad["families"] = ["crank_rocker", "crank_slider"]
    with pytest.raises(Exception, match=r"(?s)crank_slider.*families"):
        validate(bad, SCHEMA)


@pytest.mark.parametrize("change, key", [
    ({"chunk_size": 0}, "chunk_size"),
    ({"speeds": {"start": 0.0, "stop": 10.0, "num": 3}}, "speeds"),
    ({"unknown_key": 1}, "unknown_key"),
    ({"materials": [{"E": 1e9, "rho": 1000.0, "nu": 0.3}]}, "materials"),
])
def test_schema_names_the_bad_key(default, change, key):
    bad = {**copy.deepcopy(default), **change}
    with pytest.raises(Exception, match=key):
        validate(bad, SCHEMA)


def test_schema_fills_defaults():
    config = {"study": "x", "grids": {"slider_crank": {"crank": [0.1], "rod": [0.3]}},
              "speeds": [10.0], "materials": ["steel"], "sections": [{"shape": "circle",
                                                                       "diameter": 0.01}]}
    validate(config, SCHEMA)
    assert config["chunk_size"] == 250
    assert config["families"][-1] == "slider_crank"
    assert config["grids"]["slider_crank"]["offset"] == [0.0]


def test_check_config_rejects_duplicate_materials(small):
    bad = dict(small, materials=["aluminium", "aluminum"])
    with pytest.raises(SceneError, match="aluminium"):
        check_config(bad)


def test_check_config_names_the_bad_scene_key(small):
    bad = copy.deepcopy(small)
    bad["base_scene"]["time"]["start"] = "sideways"
    with pytest.raises(SceneError) as err:
        check_config(bad)
    assert "time.start" in str(err.value)


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: p.name)
def test_validate_config_accepts_every_config_and_fills_the_schema_defaults(path):
    raw = yaml.safe_load(path.read_text())
    assert validate_config(raw) == load(path)  # same defaults as snakemake's validate


def test_grid_points_counts_without_building_the_grid(small):
    huge = copy.deepcopy(small)
    huge["grids"]["four_bar"]["crank"] = {"start": 0.01, "stop": 0.5, "num": 10**12}
    # 10¹² × 1 × 2 crank-coupler-rocker points + 1 slider-crank, × 2 speeds × 2 materials
    assert grid_points(huge) == (2 * 10**12 + 1) * 2 * 2
    assert study_size(huge) == grid_points(huge)


def test_study_estimate_of_the_default_study(default):
    estimate = study_estimate(default)
    assert estimate.cases == sum(family_sizes(default).values()) == 11536
    assert estimate.chunks == chunks(default)
    assert estimate.largest_chunk == default["chunk_size"]
    assert 0.6e9 < estimate.output_bytes < 2e9  # 11536 cases × 129 steps × … ≈ 1.3 GB
    assert estimate.chunk_memory_bytes < 2000 * 2**20  # fits simulate_chunk's mem_mb
