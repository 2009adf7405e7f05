"""Six-bar studies (config/studies/six_bar.yaml): grids over the presets' inputs, families by
the Grashof type of each loop, geometries that cannot be assembled dropped and counted."""
import copy
from pathlib import Path

import pytest

from ced.problem.errors import SceneError
from ced.problem.scene import load_scene
from ced.response.batch import case_family, loop_families
from ced.study.cases import (case_table, chunk_rows, chunks, family_sizes, geometry_counts,
                             grid_geometries, scene_for, six_bar_family)
from ced.study.config import load_config, study_estimate, validate_config

ROOT = Path(__file__).resolve().parents[2]
STUDY = ROOT / "config" / "studies" / "six_bar.yaml"


@pytest.fixture(scope="module")
def six_bar():
    return validate_config(load_config(STUDY))


def _scene(config, kind, lengths):
    return scene_for(config, kind, lengths, 60.0, "steel", config["sections"][0])


def test_assembly_check_is_the_scenes(six_bar):
    """A geometry is dropped exactly when its scene is refused as not assemblable, and the
    family is the type plus the Grashof type of each loop of the simulated scene."""
    refused, families = {}, {}
    for kind in ("watt_ii", "stephenson_iii"):
        for lengths, _ in grid_geometries(six_bar, kind):
            try:
                scene = load_scene(_scene(six_bar, kind, lengths))
            except SceneError as err:
                assert err.path == "mechanism" and "assemble" in err.message, str(err)
                refused[kind] = refused.get(kind, 0) + 1
                continue
            name = "-".join([kind, *loop_families(scene)])
            assert loop_families(scene)[0] == case_family(scene)
            assert six_bar_family(scene["mechanism"]) == name
            families[name] = families.get(name, 0) + 1
    counts = geometry_counts(six_bar)
    assert counts == {
        "watt_ii": {"grid": 24, "not_assemblable": refused["watt_ii"],
                    "kept": 24 - refused["watt_ii"]},
        "stephenson_iii": {"grid": 6, "not_assemblable": refused["stephenson_iii"],
                           "kept": 6 - refused["stephenson_iii"]}}
    # the shipped grid has geometries of both kinds that cannot follow the input's turn
    assert refused == {"watt_ii": 2, "stephenson_iii": 3}
    speeds = len(six_bar["speeds"])
    assert family_sizes(six_bar) == {f: n * speeds for f, n in families.items()}
    assert study_estimate(six_bar).not_assemblable == refused


def test_cases_and_chunks(six_bar):
    rows = case_table(six_bar, scenes=False)
    assert len(rows) == 50 == sum(family_sizes(six_bar).values())
    sizes = family_sizes(six_bar)
    for family, n in chunks(six_bar).items():
        ids = [r["case"] for i in range(n) for r in chunk_rows(six_bar, family, i, scenes=False)]
        assert ids == list(range(sizes[family]))
    row = rows[0]
    assert row["mechanism"] == "watt_ii" and row["ground"] == 0.5
    assert row["family"].startswith("watt_ii-crank_rocker-")
    scene = chunk_rows(six_bar, row["family"], 0)[0]["scene"]["mechanism"]
    assert scene["type"] == "watt_ii" and scene["rocker_arm_angle"] == 2.5


def test_families_filter(six_bar):
    only = validate_config({**six_bar, "families": ["watt_ii"]})
    assert all(f.startswith("watt_ii-") for f in family_sizes(only))
    one = validate_config({**six_bar, "families": ["stephenson_iii-crank_rocker"]})
    assert family_sizes(one) == {"stephenson_iii-crank_rocker": 6}


def test_rocker_input_six_bar_assembles_over_its_oscillation(six_bar):
    """A non-Grashof first loop (S + L > P + Q): the input oscillates over drive.amplitude of
    its range, over which the dyad must assemble; the family names the loop."""
    config = copy.deepcopy(six_bar)
    del config["grids"]["watt_ii"]
    config["grids"]["stephenson_iii"].update(crank=[0.32], coupler=[0.45], coupler2=[0.4],
                                             rocker2=[0.35])
    families = set(family_sizes(validate_config(config)))
    assert families == {"stephenson_iii-triple_rocker"}


@pytest.mark.parametrize("change, key, words", [
    ({"families": ["watt_ii-crank_rocker-crank_slider"]}, "families[0]", "unknown value"),
    ({"families": ["stephenson_iii-crank_rocker-crank_rocker"]}, "families[0]", "allowed"),
    ({"grids": {"watt_ii": {"ground": 0.5, "crank": [0.1]}}}, "grids.watt_ii.coupler",
     "missing"),
    ({"grids": {"stephenson_iii": {"ground": 0.5, "crank": [0.1], "coupler": [0.45],
                                   "rocker": [0.35], "coupler_arm": [0.3], "coupler2": [0.05],
                                   "rocker2": [0.05], "pivot2_x": [0.4], "pivot2_y": [0.55]}}},
     "grids.stephenson_iii", "no geometry of the grid can be assembled"),
    ({"grids": {"watt_ii": {"ground": 0.5, "crank": [0.1], "coupler": [0.45],
                            "rocker": [0.35], "rocker_arm": [-0.25], "coupler2": [0.4],
                            "rocker2": [0.3], "pivot2_x": [0.2], "pivot2_y": [-0.3]}}},
     "grids.watt_ii.rocker_arm[0]", "> 0"),
    ({"grids": {"watt_ii": {"ground": 0.5, "crank": [0.1], "coupler": [0.45],
                            "rocker": [0.35], "rocker_arm": [0.25], "coupler2": [0.4],
                            "rocker2": [0.3], "pivot2_x": [0.2], "pivot2_y": [-0.3],
                            "branch2": "sideways"}}},
     "grids.watt_ii.branch2", "allowed: open, crossed"),
])
def test_bad_six_bar_config_names_the_key(six_bar, change, key, words):
    with pytest.raises(SceneError) as err:
        validate_config({**copy.deepcopy(six_bar), **change})
    assert err.value.path == key, str(err.value)
    assert words in err.value.message, str(err.value)
