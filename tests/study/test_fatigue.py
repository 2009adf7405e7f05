"""Fatigue (ced.study.fatigue) against a case counted and corrected by hand."""
import json

import numpy as np
import pytest
import xarray as xr

from ced.problem.scene import load_scene
from ced.simulation.simulate import simulate
from ced.study.fatigue import (case_fatigue, fatigue_safety_factor, goodman_safety_factor,
                               periodic_cycles, whole_periods)

#: One period of a stress history, MPa. By hand (ASTM E1049 four-point rainflow) from its
#: largest value: 150 -50 50 0 100 -90 (150) closes the cycles 50-0 (range 50, mean 25),
#: -50-100 (range 150, mean 25) and, as two halves, 150/-90 (range 240, mean 30).
HISTORY = np.array([100.0, -90.0, 150.0, -50.0, 50.0, 0.0])
STEEL = dict(endurance_limit=180e6, ultimate_strength=360e6)


def test_rainflow_cycles_of_one_period_match_the_hand_count():
    amplitude, mean, count = periodic_cycles(HISTORY)
    cycles = sorted(zip(2 * amplitude, mean, count))
    assert cycles == [(50.0, 25.0, 1.0), (150.0, 25.0, 1.0), (240.0, 30.0, 0.5),
                      (240.0, 30.0, 0.5)]
    # a shifted start is the same periodic history: the same cycles
    again = sorted(zip(*periodic_cycles(np.roll(HISTORY, 2))))
    assert again == sorted(zip(amplitude, mean, count))


def test_goodman_factor_matches_the_hand_computation():
    # worst cycle: amplitude 120, mean 30 MPa -> 1/(120/180 + 30/360) = 1/0.75
    n = fatigue_safety_factor(HISTORY * 1e6, **STEEL)
    assert n == pytest.approx(4.0 / 3.0, rel=1e-12)
    # the other two: 1/(25/180 + 25/360) = 4.8 and 1/(75/180 + 25/360) = 2.0571...
    factors = goodman_safety_factor(np.array([25e6, 75e6]), np.array([25e6, 25e6]),
                                    180e6, 360e6)
    assert factors == pytest.approx([4.8, 1.0 / (75 / 180 + 25 / 360)])


def test_compressive_mean_earns_no_credit_and_no_cycle_is_static():
    assert goodman_safety_factor(90e6, -200e6, **STEEL) == pytest.approx(2.0)
    assert goodman_safety_factor(90e6, 0.0, **STEEL) == pytest.approx(2.0)
    assert fatigue_safety_factor(np.full(8, 120e6), **STEEL) == pytest.approx(3.0)  # S_u/σ
    assert fatigue_safety_factor(np.zeros(8), **STEEL) == np.inf


def chunk(stress: np.ndarray, materials: list[dict]) -> xr.Dataset:
    """A chunk-like dataset: stress (case, step, link, station, fibre), the scenes' materials."""
    ncase, nstep, nlink, nst, _ = stress.shape
    links = ["crank", "coupler"][:nlink]
    scenes = [{"links": {name: {"material": m} for name in links}} for m in materials]
    return xr.Dataset(
        {"stress": (("case", "step", "link", "station", "fibre"), stress)},
        coords={"case": np.arange(ncase), "link": links, "station": np.linspace(0, 1, nst),
                "fibre": [-0.5, 0.5]}, attrs={"scenes": json.dumps(scenes)})


def test_case_fatigue_reads_the_critical_station_and_both_fibres():
    steps = len(HISTORY)
    stress = np.zeros((2, steps, 2, 3, 2))
    # coupler: station 0.5 carries the hand case on the fibre -0.5 and a milder mirror image on
    # +0.5; station 1 a smaller fully reversed stress (not critical: lower peak)
    stress[:, :, 1, 1, 0] = HISTORY * 1e6
    stress[:, :, 1, 1, 1] = -0.5 * HISTORY * 1e6
    stress[:, :, 1, 2, :] = 100e6 * np.sin(np.linspace(0, 2 * np.pi, steps))[:, None]
    out = case_fatigue(chunk(stress, [{"endurance_limit": 180e6, "ultimate_strength": 360e6},
                                      {"endurance_limit": None, "ultimate_strength": None}]))
    n = out.fatigue_safety_factor
    assert n.sel(case=0, link="coupler") == pytest.approx(4.0 / 3.0)
    assert out.fatigue_critical_station.sel(case=0, link="coupler") == 0.5
    assert n.sel(case=0, link="crank") == np.inf        # rigid: no stress
    assert np.isnan(n.sel(case=1)).all()                # no endurance limit: no result
    assert n.attrs["mean_stress_correction"] == "goodman"


def _timed(ds: xr.Dataset, turns, revolutions, speed=10.0) -> xr.Dataset:
    """``ds`` with the motion's turns, the speed and a time axis over ``revolutions``."""
    ncase, nstep = ds.sizes["case"], ds.sizes["step"]
    time = np.outer(revolutions, np.linspace(0.0, 2.0 * np.pi / speed, nstep))
    return ds.assign(motion_turns=("case", np.asarray(turns, np.int32)),
                     time=(("case", "step"), time)).assign_coords(speed=("case", [speed] * ncase))


def test_whole_periods_of_one_and_two_turn_motions():
    stress = np.zeros((5, 9, 1, 2, 2))
    # The last: one turn stored short of its end by less than a stored interval (outputs.every
    # not dividing the steps): a whole period still.
    ds = _timed(chunk(stress, [STEEL] * 5), [1, 2, 2, 1, 1], [1.0, 1.0, 2.0, 1.5, 24 / 25])
    assert whole_periods(ds).tolist() == [True, False, True, False, True]
    assert whole_periods(chunk(stress, [STEEL] * 5)).all()  # no motion_turns: as before


def test_a_history_short_of_its_period_gets_the_bound_of_its_peak():
    # One turn of a two-turn motion holds the hand case (peak 150 MPa); the other turn peaks
    # at 200 MPa (peak_stress): no cycle count, the bound S_e/200 MPa = 0.9.
    stress = np.zeros((2, len(HISTORY), 1, 2, 2))
    stress[:, :, 0, 1, 0] = HISTORY * 1e6
    ds = _timed(chunk(stress, [STEEL] * 2), [2, 1], [1.0, 1.0])
    ds["peak_stress"] = (("case", "link"), np.array([[200e6], [150e6]]))
    n = case_fatigue(ds).fatigue_safety_factor.sel(link="crank").values
    assert n[0] == pytest.approx(180.0 / 200.0)
    assert n[1] == pytest.approx(goodman_safety_factor(120e6, 30e6, **STEEL))  # counted


@pytest.mark.parametrize("revolutions, whole", [(1, False), (2, True)])
def test_a_change_point_stored_over_one_turn_is_not_a_period(revolutions, whole):
    ds = simulate([load_scene({
        "mechanism": {"type": "four_bar", "ground": 0.4, "crank": 0.1, "coupler": 0.35,
                      "rocker": 0.15},
        "drive": {"speed": 20.0}, "discretization": {"elements_per_link": 2},
        "time": {"revolutions": revolutions, "steps_per_revolution": 64}})])
    assert ds.motion_turns.values.tolist() == [2]
    assert whole_periods(ds).tolist() == [whole]


@pytest.mark.parametrize("every", [1, 4])
def test_a_thinned_history_is_scaled_to_the_peak_of_every_step(every):
    # The hand case as stored (largest 150 MPa) where the solver's peak over every step is
    # 165 MPa: stored every 4th step, the extremes between them were missed, and the counted
    # factor is scaled by 150/165; stored every step, the count stands (the peak's
    # interpolation between steps is within the discretization).
    stress = np.zeros((1, len(HISTORY), 1, 2, 2))
    stress[0, :, 0, 1, 0] = HISTORY * 1e6
    ds = chunk(stress, [STEEL])
    scenes = json.loads(ds.attrs["scenes"])
    ds.attrs["scenes"] = json.dumps([{**s, "outputs": {"every": every}} for s in scenes])
    ds["peak_stress"] = (("case", "link"), np.array([[165e6]]))
    n = case_fatigue(ds).fatigue_safety_factor.values[0, 0]
    counted = goodman_safety_factor(120e6, 30e6, **STEEL)
    assert n == pytest.approx(counted * (150.0 / 165.0 if every > 1 else 1.0))


def test_a_solve_stored_every_fifth_step_keeps_its_fatigue_factor():
    # The same periodic steady state stored every step and every 5th: the stored steps
    # alone count 2.7 % above the dense factor (unconservative); scaled to the peak of every
    # step, the thinned count is within 1 % of the dense one.
    def solve(every):
        return simulate([load_scene({
            "mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                          "rocker": 0.35},
            "drive": {"speed": 150.0}, "discretization": {"elements_per_link": 4},
            "outputs": {"every": every},
            "time": {"steps_per_revolution": 640, "start": "periodic"}})])
    dense, thin = solve(1), solve(5)
    n_dense, n_thin = (case_fatigue(ds).fatigue_safety_factor.sel(link="coupler").values[0]
                       for ds in (dense, thin))
    assert np.isfinite(n_dense) and n_thin == pytest.approx(n_dense, rel=0.01)
    uncorrected = thin.copy()
    uncorrected.attrs["scenes"] = dense.attrs["scenes"]  # as if nothing had been missed
    n_stored = case_fatigue(uncorrected).fatigue_safety_factor.sel(link="coupler").values[0]
    assert n_stored > 1.01 * n_dense and n_thin < n_stored
