"""Fatigue (ced.study.fatigue) against a case counted and corrected by hand."""
import json

import numpy as np
import pytest
import xarray as xr

from ced.study.fatigue import (case_fatigue, fatigue_safety_factor, goodman_safety_factor,
                               periodic_cycles)

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
