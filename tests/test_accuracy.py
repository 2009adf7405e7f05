"""Error estimates: companions, the a-priori time term, and the estimate against true errors."""
import copy

import numpy as np
import pytest
import yaml

from ced.accuracy import combine, companions, time_resolution_error
from ced.scene import load_scene
from ced.simulation import simulate


def _scene(ne: int, spr: int, **time) -> dict:
    raw = yaml.safe_load(open("config/scenes/reference_four_bar.yaml"))
    raw.pop("modal")
    raw["discretization"] = {"elements_per_link": ne}
    raw["time"].update(steps_per_revolution=spr, **time)
    return raw


def test_one_companion_halves_both_directions():
    (companion,) = companions(load_scene(_scene(8, 64)))
    assert companion.scene["discretization"]["elements_per_link"] == 4
    assert companion.scene["time"]["steps_per_revolution"] == 32
    # r = 2, p = 2: Richardson's error is |Δ|/3, the estimate three times that.
    assert companion.factor == pytest.approx(1.0)


def test_direction_that_cannot_be_halved_is_refined_separately():
    space, time = companions(load_scene(_scene(2, 8)))
    assert space.scene["discretization"]["elements_per_link"] == 4
    assert space.scene["time"]["steps_per_revolution"] == 8
    assert space.factor == pytest.approx(3.0 * 4.0 / 3.0)
    assert time.scene["discretization"]["elements_per_link"] == 2
    assert time.scene["time"]["steps_per_revolution"] == 16


def test_companion_keeps_output_instants():
    raw = _scene(8, 64)
    raw["outputs"] = {"every": 4}
    (companion,) = companions(load_scene(raw))
    assert companion.scene["outputs"]["every"] == 2


def test_a_priori_time_term_is_second_order_and_vanishes_without_vibration():
    cfg = load_scene(_scene(8, 64, integrator="newmark"))["time"]
    w = np.array([0.05, 0.1])
    err = time_resolution_error(cfg, w, np.ones(2))
    # Trapezoidal rule: no algorithmic damping, period error (ωh)²/12 to leading order.
    assert err == pytest.approx(2.0 * w**2 / 12.0, rel=0.02)
    assert time_resolution_error(cfg, w, np.zeros(2)) == pytest.approx(0.0)
    assert time_resolution_error(cfg, np.array([4.0]), np.array([0.3]))[0] == pytest.approx(0.3)


def test_houbolt_is_less_accurate_than_generalized_alpha_at_the_same_step():
    ga = load_scene(_scene(8, 64))["time"]
    hb = load_scene(_scene(8, 64, integrator="houbolt"))["time"]
    w, share = np.array([0.3, 0.7]), np.array([0.2, 0.2])
    assert (time_resolution_error(hb, w, share) > 5 * time_resolution_error(ga, w, share)).all()


def test_combine_is_relative_and_takes_the_larger_term():
    est = combine(np.array([100.0, 0.0]), [np.array([90.0, 0.0])], [1.0], np.array([0.5, 0.0]))
    assert est == pytest.approx([0.5, 0.0])
    assert combine(np.array([100.0]), [np.array([90.0])], [1.0])[0] == pytest.approx(0.1)


@pytest.mark.parametrize("ne, spr, integrator", [
    (4, 64, "generalized_alpha"), (8, 128, "generalized_alpha"), (16, 256, "newmark"),
    (8, 128, "houbolt"), (8, 32, "houbolt"), (2, 32, "hht")])
def test_estimate_brackets_the_true_error(reference_four_bar_peak, ne, spr, integrator):
    ds = simulate(_scene(ne, spr, integrator=integrator))
    true = abs(float(ds.peak_stress.max()) - reference_four_bar_peak) / reference_four_bar_peak
    estimate = float(ds.error_estimate[0])
    assert estimate >= true / 2.0  # never smaller than the true error by more than 2
    assert estimate <= 10.0 * true or (ne, spr) == (8, 32)
    assert ds.error_estimate.attrs["units"] == "1"


def test_no_estimate_when_not_asked_or_rigid():
    raw = _scene(4, 32)
    raw["outputs"] = {"error_estimate": False}
    assert "error_estimate" not in simulate(raw)
    rigid = copy.deepcopy(_scene(4, 32))
    rigid["discretization"] = {"formulation": "rigid"}
    assert "error_estimate" not in simulate(rigid)
