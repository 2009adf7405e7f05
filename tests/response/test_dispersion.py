"""Tests of ced.response.dispersion: the prewarped mass marches resolved modes at their period."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.problem.errors import SceneError
from ced.problem.scene import load_scene
from ced.response.dispersion import (RESOLVED, discrete_phase, mass_transform,
                                     modified_omega_h)
from ced.response.integrators import generalized_alpha, hht, integrate, newmark
from ced.simulation.simulate import simulate

SCHEMES = [newmark(), hht(-0.05), generalized_alpha(0.9), generalized_alpha(0.5)]
IDS = ["newmark", "hht-0.05", "genalpha0.9", "genalpha0.5"]


def test_trapezoidal_phase_is_its_closed_form():
    # λ = (1 + iΩ/2)/(1 − iΩ/2): phase 2 atan(Ω/2); the modified frequency is 2 tan(ωh/2)
    # (the prewarping of Tustin's bilinear transform).
    x = np.linspace(0.01, 2.0, 50)
    for scheme in (newmark(), generalized_alpha(1.0)):
        np.testing.assert_allclose(discrete_phase(scheme, x), 2 * np.arctan(x / 2), rtol=1e-10)
        np.testing.assert_allclose(modified_omega_h(scheme, x), 2 * np.tan(x / 2), rtol=1e-4)


@pytest.mark.parametrize("scheme", SCHEMES, ids=IDS)
@given(x=st.floats(1e-3, RESOLVED))
@settings(max_examples=25, deadline=None)
def test_modified_frequency_is_marched_at_the_physical_one(scheme, x):
    modified = float(modified_omega_h(scheme, x))
    assert modified >= x
    assert abs(float(discrete_phase(scheme, modified)) - x) < 1e-5 * x


def test_unresolved_modes_are_not_modified():
    assert np.isnan(modified_omega_h(newmark(), [RESOLVED * 1.01, 5.0, 0.0])).all()


def _chain(n: int = 3):
    """A fixed-free spring-mass chain: M, K (n × n), its frequencies and M-normalized modes."""
    M = np.diag(np.linspace(1.0, 2.0, n))
    K = 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    K[-1, -1] = 1.0
    K *= 400.0
    w2, phi = np.linalg.eigh(np.linalg.inv(np.linalg.cholesky(M)) @ K
                             @ np.linalg.inv(np.linalg.cholesky(M)).T)
    modes = np.linalg.inv(np.linalg.cholesky(M)).T @ phi
    return M, K, np.sqrt(w2), modes


@pytest.mark.parametrize("rho", [1.0, 0.9])
def test_free_vibration_keeps_every_resolved_modes_period(rho):
    # The chain's highest mode at ωh = 1.8 (3.5 steps a period), marched 400 steps from a
    # displacement in every mode: with the matched mass each modal coordinate is the exact
    # cos(ω_k t) times the scheme's amplitude decay (none for ρ∞ = 1); with the plain mass
    # the highest mode is over 100 periods behind by then.
    M, K, omega, modes = _chain()
    h = 1.8 / omega[-1]
    scheme = generalized_alpha(rho)
    q0 = modes.sum(axis=1)
    n = 400
    t = h * np.arange(n + 1)
    exact = np.cos(omega[None, :] * t[:, None])
    T = mass_transform(M[None], K[None], np.array([h]), scheme)[0]
    for M_marched, within in ((T.T @ M @ T, True), (M, False)):
        q = integrate(lambda k: (M_marched, None, K, None), h, n, q0, np.zeros(3), scheme)[0]
        modal = q @ M @ modes  # the coordinates in the physical modes (M-orthonormal)
        decay = np.abs(np.linalg.eigvals(
            _amplification(scheme, modified_omega_h(scheme, omega * h)))).max(axis=-1)
        envelope = decay[None, :] ** np.arange(n + 1)[:, None]
        phase_error = np.abs(modal / np.where(envelope > 0, envelope, 1) - exact)[:, -1].max()
        if within:
            assert phase_error < 2e-3
        else:
            assert phase_error > 0.5


def _amplification(scheme, x):
    from ced.response.integrators import amplification_matrix
    return amplification_matrix(scheme, x)


def test_the_correction_is_second_order_and_keeps_the_mass_definite():
    M, K, _, modes = _chain()
    scheme = generalized_alpha(0.9)
    h = 0.5 / np.sqrt(400.0 * 4)
    T = mass_transform(np.stack([M, M]), np.stack([K, K]), np.array([h, h / 2]), scheme)
    ratio = np.linalg.norm(T[0] - np.eye(3)) / np.linalg.norm(T[1] - np.eye(3))
    assert 3.8 < ratio < 4.2  # M′ − M = O(h²): the scheme's order on forced response stays 2
    # The modes stay the modes, each mass scaled by m′ = (ω/ω′)² < 1.
    modal = modes.T @ T[0].T @ M @ T[0] @ modes
    np.testing.assert_allclose(modal, np.diag(np.diag(modal)), atol=1e-12)
    assert np.all(np.diag(modal) < 1.0)
    # Statics untouched: the stiffness is not transformed, so K q = F is the same problem.


@given(scale=st.lists(st.floats(0.05, 3.0), min_size=3, max_size=3),
       x=st.floats(0.1, RESOLVED))
@settings(max_examples=40, deadline=None)
def test_the_transformed_mass_stays_definite(scale, x):
    # T is invertible, so Tᵀ M T is positive definite for any definite M.
    M, K, omega, _ = _chain()
    varied = np.diag(np.sqrt(scale)) @ M @ np.diag(np.sqrt(scale))
    T = mass_transform(varied[None], K[None], np.array([x / omega[-1]]),
                       generalized_alpha(0.9))[0]
    assert np.linalg.eigvalsh(T.T @ varied @ T).min() > 0


def test_a_mass_that_is_not_definite_is_left_alone():
    M, K, _, _ = _chain()
    h = np.array([0.01, 0.01])
    T = mass_transform(np.stack([np.zeros((3, 3)), M]), np.stack([K, K]), h, newmark())
    np.testing.assert_array_equal(T[0], np.eye(3))
    np.testing.assert_allclose(T[1], mass_transform(M[None], K[None], h[:1], newmark())[0],
                               rtol=1e-12)
    assert np.abs(T[1] - np.eye(3)).max() > 1e-6


FOUR_BAR = {
    "mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                  "rocker": 0.35},
    "drive": {"speed": 100.0},
    "links": {"default": {"material": "steel",
                          "section": {"shape": "rectangle", "height": 0.005, "width": 0.01}},
              "crank": {"flexible": False}, "rocker": {"flexible": False}},
    "discretization": {"elements_per_link": 8},
    "outputs": {"stations": 11, "error_estimate": False},
}


def _peak_strain(steps: int, dispersion: str) -> float:
    ds = simulate([{**FOUR_BAR, "time": {"revolutions": 2, "steps_per_revolution": steps,
                                         "dispersion": dispersion}}])
    return float(np.abs(ds.bending_strain.sel(link="coupler")).max())


def test_matched_start_transient_converges_to_the_plain_limit():
    # The reference four-bar's start transient rings in the coupler's modes up to 5 kHz: the
    # plain scheme needs many more steps for their phase than the matched one, and both
    # converge to the same peak (the correction vanishes as h → 0).
    limit = _peak_strain(16384, "plain")
    matched = _peak_strain(2048, "matched")
    plain = _peak_strain(2048, "plain")
    assert abs(matched / limit - 1) < 2e-3
    assert abs(plain / limit - 1) > 2 * abs(matched / limit - 1)


def test_every_link_flexible_converges_to_the_plain_limit():
    # Every link flexible: the mass varies by 21 % over the cycle and the modes with it. A
    # correction from the period's mean modes was 25 % off here at 1,024 steps; the
    # per-step one converges, and faster than the plain scheme (resonant and undamped, the
    # case is flagged, but both schemes must agree in the limit).
    scene = {**FOUR_BAR, "drive": {"speed": 60.0}, "links": {"default": FOUR_BAR["links"][
        "default"]}, "discretization": {"elements_per_link": 6}}

    def peak(steps, dispersion):
        ds = simulate([{**scene, "time": {"revolutions": 2, "steps_per_revolution": steps,
                                          "dispersion": dispersion}}])
        return float(ds.peak_stress.max())

    limit = peak(16384, "plain")
    matched, plain = peak(1024, "matched"), peak(1024, "plain")
    assert abs(matched / limit - 1) < 3e-3
    assert abs(plain / limit - 1) > 3 * abs(matched / limit - 1)


def test_a_periodic_start_marches_the_matched_terms():
    # Floquet multipliers of an undamped stable case stay on the unit circle with either mass.
    ds = simulate([{**FOUR_BAR, "time": {"revolutions": 1, "steps_per_revolution": 256,
                                         "start": "periodic", "dispersion": d}}
                   for d in ("plain", "matched")])
    mu = ds.floquet_multiplier_max.values
    assert np.all(np.abs(mu - 1.0) < 0.05)
    assert not np.array_equal(ds.bending_strain[0].values, ds.bending_strain[1].values)


def test_scene_refuses_matched_where_it_does_not_apply():
    with pytest.raises(SceneError, match="time.dispersion.*Newmark-family"):
        load_scene({**FOUR_BAR, "time": {"integrator": "houbolt", "dispersion": "matched"}})
    with pytest.raises(SceneError, match="time.dispersion.*elastic_axial_force"):
        load_scene({**FOUR_BAR, "effects": ["elastic_inertia", "axial_stiffening",
                                            "elastic_axial_force"],
                    "time": {"dispersion": "matched"}})
    with pytest.raises(SceneError, match="time.dispersion"):
        load_scene({**FOUR_BAR, "time": {"dispersion": "exact"}})


@pytest.mark.parametrize("modes", [0, 4])
def test_the_matched_terms_stay_within_the_memory_the_solver_plans(modes):
    # ced.simulation.size.solver_bytes plans 5n² a step more for a matched scene: the marched
    # mass and a block of transforms beside M, C and K read dense where they are held packed
    # (the full mesh).
    import tracemalloc

    from ced.response.batch import make_batch
    from ced.response.dispersion import matched_terms
    from ced.response.model_cache import model_for
    from ced.response.period_terms import period_terms
    from ced.simulation.size import elastic_dofs, solver_bytes

    scenes = [load_scene({**FOUR_BAR, "drive": {"speed": s},
                          "discretization": {"elements_per_link": 8, "modes_per_link": modes},
                          "time": {"steps_per_revolution": 128, "dispersion": d}})
              for s in (90.0, 100.0, 110.0) for d in ("matched",)]
    batch = make_batch(scenes)
    period = period_terms(model_for(batch), batch.step_size, batch.period_steps)
    n, steps = elastic_dofs(scenes[0]), 128
    planned = solver_bytes(scenes[0]) - solver_bytes({**scenes[0], "time": {
        **scenes[0]["time"], "dispersion": "plain"}})
    assert planned == 8 * steps * 5 * n * n
    tracemalloc.start()
    matched = matched_terms(period, batch.step_size, generalized_alpha(0.9))
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert matched.mass.shape == (3, steps, period.n, period.n)
    assert peak <= 3 * planned * 1.05  # three cases, and the small arrays of the modes
