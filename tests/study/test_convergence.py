"""Convergence studies (ced.study.convergence) on a small sweep of the slider-crank."""
import json

import numpy as np
import pytest
import xarray as xr
import yaml

from ced.study.convergence import (TARGETS, accuracy_table, auto_table, estimate_validation,
                                   load_sweep, run_family, settings)


@pytest.fixture(scope="module")
def sweep():
    full = load_sweep(yaml.safe_load(open("config/studies/convergence.yaml")))
    return {**full,
            "families": {"slider_crank": full["families"]["slider_crank"]},
            "settings": [{"formulation": "euler_bernoulli", "modes_per_link": [0, 4],
                          "integrator": "generalized_alpha", "elements_per_link": [2, 8],
                          "steps_per_revolution": [32, 128]}],
            "batch": 2,
            "reference": {"elements_per_link": 32, "steps_per_revolution": 512,
                          "modes_per_link": 4},
            "tolerances": [1e-2]}


@pytest.fixture(scope="module")
def result(sweep):
    return run_family(sweep, "slider_crank")


def test_config_file_has_every_family():
    sweep = load_sweep({"convergence": "config/studies/convergence.yaml"})
    assert set(sweep["families"]) == {"crank_rocker", "rocker_crank", "double_crank",
                                      "double_rocker", "change_point", "triple_rocker",
                                      "slider_crank"}
    assert len(settings(sweep)) > 50
    assert load_sweep({}) is None


def test_errors_are_relative_to_the_reference(result):
    assert result.sizes["setting"] == 8
    for q in ("peak_stress", "peak_deflection", "first_frequency"):
        ref = float(result[f"reference_{q}"])
        assert 0 <= result[f"reference_{q}"].attrs["uncertainty"] < 1e-2
        np.testing.assert_allclose(result[f"error_{q}"], abs(result[q] - ref) / ref)
    assert (result.solve_time > 0).all() and result.solve_time.attrs["units"] == "s"


def test_refinement_reduces_the_stress_error(result):
    fine = result.where((result.elements_per_link == 8) & (result.steps_per_revolution == 128),
                        drop=True)
    coarse = result.where((result.elements_per_link == 2) & (result.steps_per_revolution == 32),
                          drop=True)
    assert (fine.error_peak_stress.values < coarse.error_peak_stress.values).all()
    # Full and reduced models converge to the same stress (truncation below 1e-4 here).
    assert fine.peak_stress.values[0] == pytest.approx(fine.peak_stress.values[1], rel=1e-4)


def test_estimate_bounds_the_true_error(result):
    check = estimate_validation({"slider_crank": result})
    assert check["min_ratio"] >= 0.5
    assert check["within"] >= 0.75


def test_auto_meets_the_tolerance(result):
    assert (result.auto_error < result.tolerance).all()
    # Its error estimate is the ladders' prediction, within the target.
    assert (result.auto_error_estimate < result.tolerance).all()
    assert (result.auto_error_estimate == result.auto_predicted_error).all()
    table = auto_table({"slider_crank": result})
    assert list(table.tolerance) == [1e-2] and table.resolved.all()
    # The cheapest sweep setting and the choice are re-timed side by side.
    np.testing.assert_allclose(table.cost_ratio, result.auto_solve_time
                               / result.cheapest_solve_time)
    assert (table.cheapest_error < 1e-2).all() and (result.cost_ratio > 0).all()


def test_table_picks_the_cheapest_setting_meeting_each_target(result):
    table = accuracy_table({"slider_crank": result})
    assert list(table.target) == list(TARGETS)
    for _, row in table.iterrows():
        meeting = result.where(result.error_peak_stress < row.target, drop=True)
        if meeting.sizes["setting"]:
            assert row.ms_per_case == pytest.approx(1e3 * float(meeting.solve_time.min()))
        else:
            assert np.isnan(row.ms_per_case) and row.setting == "none in the sweep"


def test_validation_ignores_settings_below_the_reference_uncertainty():
    ds = xr.Dataset({"error_peak_stress": ("setting", [1e-9, 1e-2, 1e-2]),
                     "error_estimate": ("setting", [1.0, 2e-2, 1e-3]),
                     "reference_peak_stress": ((), 1.0, {"uncertainty": 1e-6})})
    check = estimate_validation({"x": ds})
    assert check == {"upper_bound": 0.5, "within": 0.5, "min_ratio": pytest.approx(0.1),
                     "settings": 2}


def test_convergence_dataset_passes_the_cf_checker(result, tmp_path):
    from ced.io import write_dataset
    from tests.test_cf import cf_errors

    path = write_dataset(result, tmp_path / "slider_crank.nc")
    assert cf_errors(path, tmp_path) == []
    assert json.loads(result.attrs["reference_values"])  # the Richardson references, kept
    assert all(str(v) for v in result.cheapest_label.values)


def test_retime_interleaves_only_what_it_compares(monkeypatch):
    # Side by side, each batch is timed RETIME_REPEATS times, interleaved, and the fastest
    # kept; a batch with nothing to compare with (no sweep setting meets the tolerance) once.
    from ced.study import convergence
    calls = []
    times = iter([3.0, 5.0, 2.0, 6.0, 4.0, 1.0, 7.0])

    def measure(batch):
        calls.append(batch[0])
        return {"solve_time": [next(times)]}
    monkeypatch.setattr(convergence, "_measure", measure)
    both = convergence._retime({"auto": ["a"], "sweep": ["s"]})
    assert calls == ["a", "s"] * convergence.RETIME_REPEATS
    assert both == {"auto": 2.0, "sweep": 1.0}
    calls.clear()
    assert convergence._retime({"auto": ["a"]}) == {"auto": 7.0}
    assert calls == ["a"]
