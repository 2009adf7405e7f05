"""discretization: auto — the cheapest setting under the tolerance, and the achieved error."""
import json

import pytest
import yaml
from hypothesis import given, settings, strategies as st

from ced.discretize import _ELEMENTS, MODES, SAFETY, _cost, choose, predicted_error
from ced.simulation import simulate


@given(space=st.floats(1e-6, 1e-1), time=st.floats(1e-6, 1e-1),
       tol=st.sampled_from([1e-2, 1e-3, 1e-4]))
@settings(max_examples=25, deadline=None)
def test_choice_meets_the_tolerance_at_least_cost(space, time, tol):
    elements, steps, predicted = choose(space, time, 64, tol, 1.0, 16)
    assert predicted == pytest.approx(predicted_error(space, time, 64, elements, steps))
    if predicted <= tol / SAFETY:
        # Brute force over the same candidates: nothing that meets the target is cheaper.
        best = min(_cost(e, s, 1.0) for e in _ELEMENTS for s in range(16, 1 << 16, 8)
                   if predicted_error(space, time, 64, e, s) <= tol / SAFETY)
        assert _cost(elements, steps, 1.0) == pytest.approx(best)
    else:  # beyond the grid: the finest setting, its predicted error above the target
        assert elements == _ELEMENTS[-1]


@pytest.mark.parametrize("tolerance", [1e-2, 1e-3])
def test_reference_four_bar_meets_the_tolerance(reference_four_bar_peak, tolerance):
    raw = yaml.safe_load(open("config/scenes/reference_four_bar.yaml"))
    raw.pop("modal")
    raw["discretization"] = "auto"
    raw["tolerance"] = tolerance
    ds = simulate(raw)
    choice = json.loads(str(ds.discretization_auto.values[0]))
    assert choice["modes_per_link"] in (0, MODES) and choice["tolerance"] == tolerance
    true = abs(float(ds.peak_stress.max()) - reference_four_bar_peak) / reference_four_bar_peak
    assert true < tolerance
    assert choice["predicted_error"] <= tolerance / SAFETY
    # The per-case estimate (conservative by design) stays within a small factor of it.
    assert float(ds.error_estimate[0]) < 3.0 * tolerance
    assert ds.discretization_auto.attrs["long_name"].startswith("discretization chosen")


def test_prediction_is_safe_both_ways():
    # Order 3 towards coarser meshes, 2 towards finer ones: the larger of the two each way.
    assert predicted_error(1e-3, 0.0, 64, 4, 64) == pytest.approx(1e-3 * 2**3)
    assert predicted_error(1e-3, 0.0, 64, 16, 64) == pytest.approx(1e-3 / 2**2)
    assert predicted_error(0.0, 1e-3, 64, 8, 128) == pytest.approx(1e-3 / 4)


def test_scene_without_auto_reports_nothing():
    raw = yaml.safe_load(open("config/scenes/reference_four_bar.yaml"))
    raw.pop("modal")
    raw["discretization"] = {"elements_per_link": 2}
    raw["time"]["steps_per_revolution"] = 32
    assert "discretization_auto" not in simulate(raw)


def test_several_auto_scenes_share_the_most_demanding_discretization():
    raw = yaml.safe_load(open("config/scenes/reference_four_bar.yaml"))
    raw.pop("modal")
    raw["discretization"] = "auto"
    fast = {**raw, "drive": {"speed": 150.0}}
    ds = simulate([raw, fast])
    choices = [json.loads(str(v)) for v in ds.discretization_auto.values]
    own = [c["own_choice"] for c in choices]
    assert choices[0]["steps_per_revolution"] == choices[1]["steps_per_revolution"] == max(
        s for _, s in own)
    assert choices[0]["elements_per_link"] == max(e for e, _ in own)
