"""CF compliance of every kind of dataset ced writes, by the IOOS compliance-checker's newest
CF test (no high-priority failure: what the checker calls errors), and the labels of text
dimensions round-tripping through ced.io.open_dataset."""
import json

import numpy as np
import pytest

from ced.io import open_dataset, write_dataset
from ced.simulation.simulate import simulate
from tests.study.test_maps import study  # noqa: F401 (fixture: a reduced family on disk)
from tests.test_io import ELASTIC

checker = pytest.importorskip("compliance_checker.runner")

#: The newest CF test of the installed checker (compliance-checker 6.1: cf:1.11).
CF_TEST = "cf:1.11"

SLIDER = {"mechanism": {"type": "slider_crank", "crank": 0.05, "rod": 0.2, "offset": 0.01,
                        "slider_mass": 0.05},
          "links": {"crank": {"flexible": False}}, "discretization": {"elements_per_link": 2},
          "time": {"revolutions": 1, "steps_per_revolution": 16, "start": "periodic"}}


def cf_errors(path, tmp_path) -> list[str]:
    """Names of the checks the compliance-checker fails at high priority (its errors)."""
    checker.CheckSuite.load_all_available_checkers()
    report = tmp_path / f"{path.stem}.json"
    checker.ComplianceChecker.run_checker(str(path), [CF_TEST], 0, "lenient",
                                          output_filename=str(report), output_format="json")
    result = json.loads(report.read_text())[CF_TEST]
    assert result["possible_points"] > 100, result  # the checks ran
    return [f"{p['name']}: {p['msgs']}" for p in result["high_priorities"] if p["msgs"]]


@pytest.mark.parametrize("scene", [ELASTIC, SLIDER], ids=["four_bar", "slider_crank"])
def test_simulated_datasets_pass_the_cf_checker(scene, tmp_path):
    ds = simulate(scene)
    path = write_dataset(ds, tmp_path / "run.nc")
    assert cf_errors(path, tmp_path) == []
    # the control: the same dataset with its text dimension coordinates left as they are
    raw = tmp_path / "raw.nc"
    ds.to_netcdf(raw, engine="netcdf4")
    try:
        errors = cf_errors(raw, tmp_path)
    except Exception:  # noqa: BLE001 — older checkers crash on text coordinate variables
        errors = ["crashed"]
    assert errors


def test_study_files_pass_the_cf_checker(study, tmp_path):  # noqa: F811
    _, directory, paths = study
    for path in [paths[0], directory / "map.nc", directory / "grid.nc"]:
        assert cf_errors(path, tmp_path) == [], path


def test_labels_are_indexes_again_when_read_through_ced(study):  # noqa: F811
    _, directory, paths = study
    with open_dataset(paths[0]) as ds:
        assert ds.link.values.tolist() == ["crank", "coupler", "rocker"]
        assert ds.joint.values.tolist() == ["A", "B", "C", "D"]
        assert ds.stress.sel(link="coupler", fibre=0.5).dims == ("case", "step", "station")
        assert float(ds.joint_position.sel(joint="A", axis="x").isel(case=0, step=0)) == 0.0
        assert all(str(m) for m in ds.message.values)  # no empty text where a value belongs
        assert "scene_name" not in ds.coords  # study scenes have no name: no empty names
    with open_dataset(directory / "grid.nc") as grid:
        assert sorted(grid.material.values.tolist()) == ["aluminium", "steel"]
        assert np.isfinite(grid.peak_stress.sel(material="steel")).any()
