"""Forced resonance (ced.response.resonance): flagged where a load-carrying crank harmonic
meets a mode's band over the cycle, whatever the start, and nowhere else."""
import numpy as np
import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from ced.problem.scene import load_scene
from ced.problem.status import STATUS_FLAGS
from ced.response.batch import make_batch
from ced.response.model import build_model
from ced.response.resonance import (ZETA_LEAST, cycle_modes, cycle_spectrum,
                                     resonance_weight)
from ced.simulation.simulate import simulate

REFERENCE = yaml.safe_load(open("config/scenes/reference_four_bar.yaml"))
SPEEDS = np.arange(60.0, 201.0, 10.0)  # rad/s; the coupler's first mode is 53–73 Hz here


def reference(start: str, **changes) -> dict:
    return {**REFERENCE, "outputs": {"error_estimate": False},
            "time": {"revolutions": 2, "steps_per_revolution": 512, "start": start},
            "modal": {"modes": 4, "angles": 72}, **changes}


def bands(ds) -> np.ndarray:
    """(case, mode, 2) Hz: each mode's band from the dataset's own modal analysis (72 angles,
    ced.response.frequencies: a separate computation from the criterion's 32 samples)."""
    f = ds.natural_frequency.values
    return np.stack([f.min(axis=1), f.max(axis=1)], axis=-1)


def resonant(ds) -> np.ndarray:
    return (ds.status.values & STATUS_FLAGS["resonant"]) > 0


@pytest.mark.parametrize("start", ["undeformed", "periodic"])
def test_flagged_where_a_low_harmonic_meets_the_first_mode_and_not_where_none_comes_near(start):
    ds = simulate([reference(start, drive={"speed": float(s)}) for s in SPEEDS])
    band = bands(ds)
    flagged = resonant(ds)
    met, clear = [], []
    for c, speed in enumerate(SPEEDS):
        harmonics = np.arange(1, 6) * speed / (2 * np.pi)  # Hz, k = 1 … 5
        low, high = band[c, 0]
        # k ≤ 3 inside the first mode's band by a 1 % margin (the bands are sampled)
        if any(low * 1.01 < h < high * 0.99 for h in harmonics[:3]):
            met.append(c)
        # no k ≤ 5 within 2 % of any mode's band
        if not any(lo * 0.98 < h < hi * 1.02 for lo, hi in band[c] for h in harmonics):
            clear.append(c)
    assert len(met) >= 5 and len(clear) >= 2, (met, clear)  # both kinds are in the sweep
    assert flagged[met].all(), SPEEDS[met][~flagged[met]]
    assert not flagged[clear].any(), SPEEDS[clear][flagged[clear]]


def test_the_first_modes_load_is_mostly_the_first_two_harmonics():
    # The share a_ik of harmonic k in the first mode's load at 100 rad/s (module docstring):
    # 62 % first harmonic, 25 % second, 6.4 % third, 1.9 % fourth, 0.47 % fifth, 0.12 % sixth.
    model = build_model(make_batch([load_scene(reference("undeformed"))]))
    omega, share = cycle_modes(model)
    np.testing.assert_allclose(share[0, 1:7, 0], [0.624, 0.254, 0.064, 0.019, 0.0047, 0.0012],
                               rtol=0.05)
    assert np.isclose(share[0, :, 0].sum(), 1.0)
    f1 = omega[0, :, 0] / (2 * np.pi)
    assert 54 < f1.min() < f1.max() < 64  # the band over the cycle, Hz


def test_damping_narrows_what_counts():
    # 5 % modal damping: a harmonic must carry 2ζ = 10 % of the mode's load. The third
    # harmonic (6.4 %) meets the band at 120 rad/s (3Ω/2π = 57 Hz) and no longer counts.
    undamped = simulate(reference("undeformed", drive={"speed": 120.0}))
    damped = simulate(reference("undeformed", drive={"speed": 120.0},
                                effects=["inertia", "elastic_inertia", "coriolis",
                                         "centrifugal", "axial_stiffening", "damping"],
                                damping={"model": "modal", "ratio": 0.05}))
    assert resonant(undamped)[0] and not resonant(damped)[0]


@pytest.mark.parametrize("steps", [128, 1024])  # terms at every step, and sampled
def test_cycle_modes_from_the_period_terms_equal_a_fresh_evaluation(steps):
    # With damping, Coriolis and gravity: none of them changes the frozen M, K and F.
    from ced.response.period_terms import period_terms

    raw = {**REFERENCE, "effects": ["inertia", "elastic_inertia", "gravity", "coriolis",
                                    "centrifugal", "axial_stiffening", "damping"],
           "damping": {"model": "rayleigh", "alpha": 1.0, "beta": 1e-5},
           "time": {"steps_per_revolution": steps}}
    batch = make_batch([load_scene({**raw, "drive": {"speed": s}}) for s in (50.0, 150.0)])
    model = build_model(batch)
    period = period_terms(model, batch.step_size, steps)
    fresh, fresh_share = cycle_modes(model)
    reused, reused_share = cycle_modes(model, period=period)
    np.testing.assert_allclose(reused, fresh, rtol=1e-9)
    np.testing.assert_allclose(reused_share, fresh_share, atol=1e-9)


def test_cycle_modes_by_link_blocks_equal_the_dense_reduction(monkeypatch):
    # A Watt II with three flexible binary links: the frozen eigenproblem reduced link block
    # by link block (ced.fem.eigenproblem) gives the dense reduction's modes and load shares.
    from ced.response import resonance

    watt = {"type": "watt_ii", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35,
            "rocker_arm": 0.25, "rocker_arm_angle": 2.5, "coupler2": 0.4, "rocker2": 0.3,
            "pivot2_x": 0.2, "pivot2_y": -0.3}
    batch = make_batch([load_scene({"mechanism": watt, "drive": {"speed": s},
                                    "links": {"crank": {"flexible": False}},
                                    "discretization": {"formulation": "euler_bernoulli",
                                                       "elements_per_link": 4},
                                    "time": {"steps_per_revolution": 128}})
                        for s in (20.0, 70.0)])
    model = build_model(batch)
    assert model.layout.link_blocks == [(3, 14), (14, 25), (25, 36)]
    blocked, blocked_share = cycle_modes(model)
    dense = resonance.natural_frequencies
    monkeypatch.setattr(resonance, "natural_frequencies",
                        lambda K, M, modes, shapes, blocks: dense(K, M, modes, shapes))
    full, full_share = cycle_modes(model)
    np.testing.assert_allclose(blocked, full, rtol=1e-9)
    np.testing.assert_allclose(blocked_share, full_share, atol=1e-9)


@given(ratio=st.floats(0.3, 3.0), zeta=st.floats(0.0, 0.2), a=st.floats(0.0, 1.0),
       k=st.integers(1, 12))
def test_resonance_weight_of_one_harmonic_is_its_amplification_squared(ratio, zeta, a, k):
    # One mode whose load is all harmonic k: W = a / ((1 − r²)² + (2ζr)²), r = kΩ/ω̄, and the
    # other harmonics add nothing.
    share = np.zeros((1, 17, 1))
    share[0, k, 0] = a
    speed, omega = np.array([100.0]), np.array([[100.0 * k / ratio]])
    w = resonance_weight(speed, omega, share, np.array([[zeta]]))
    z = max(zeta, ZETA_LEAST)
    assert w[0] == pytest.approx(a / ((1 - ratio**2) ** 2 + (2 * z * ratio) ** 2), rel=1e-9)


def test_resonance_weight_peaks_where_the_periodic_states_error_does():
    # The reference four-bar's undamped steady state across its 4:1 resonance (ω̄₁/4 ≈ 90.9
    # rad/s), 0.2 rad/s apart: the error of a coarse mesh against a fine one (both Fourier
    # series) is largest at the speed where the weight is, and both fall away from it.
    speeds = np.arange(89.0, 93.01, 0.2)
    raw = [{**REFERENCE, "modal": None, "outputs": {"error_estimate": False},
            "drive": {"speed": float(s)},
            "time": {"revolutions": 1, "steps_per_revolution": 128, "start": "periodic",
                     "periodic_solver": "spectral"}} for s in speeds]

    def peaks(elements):
        ds = simulate([{**r, "discretization": {"elements_per_link": elements}} for r in raw])
        return ds.peak_stress.max("link").values

    error = np.abs(peaks(6) / peaks(24) - 1.0)
    model = build_model(make_batch([load_scene({**r, "discretization": {
        "elements_per_link": 8, "modes_per_link": 8}}) for r in raw]))
    frequency, share, zeta = cycle_spectrum(model)
    assert np.all(zeta == 0.0)
    assert 4 * speeds[0] < frequency[0, 0] < 4 * speeds[-1]
    weight = resonance_weight(speeds, frequency, share, zeta)
    assert np.argmax(weight) == np.argmax(error)
    assert error.max() > 20 * min(error[0], error[-1]) and weight.max() > 20 * min(
        weight[0], weight[-1])
