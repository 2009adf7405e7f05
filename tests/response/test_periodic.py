"""Periodic steady state by shooting (ced.response.periodic): Floquet flags on systems with
known stability."""
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from ced.response.integrators import newmark as average_acceleration
from ced.response.marching import Marcher
from ced.response.period_terms import PeriodTerms
from ced.response.periodic import (COND_LIMIT, INSTABILITY_MARGIN, RESONANCE_GAP,
                                   RESONANCE_SHARE, Monodromy, _near_share, _near_share_by_eig,
                                   _regular, floquet, monodromy, periodic_state, resonant, shoot)


def one_dof_period(stiffness, force, h, steps):
    """PeriodTerms of q̈ + k(t) q = f(t) at the steps of one period."""
    t = np.arange(steps) * h
    k = np.array([stiffness(x) for x in t], float)
    f = np.array([force(x) for x in t], float)
    return PeriodTerms(mass=np.ones((1, steps, 1, 1)), damping=None,
                       stiffness=k[None, :, None, None], force=f[None, :, None],
                       projection=np.zeros((1, steps, 1, 1)), samples=steps,
                       interpolation_error=np.zeros(1))


def _periodic_1dof(stiffness, force, period=2 * np.pi, steps=256, scheme=None, compiled=True):
    """Shoot a 1-DOF q̈ + k(t) q = f(t) with the solver's own shooting code."""
    h = np.array([period / steps])
    scheme = scheme or average_acceleration()
    terms = one_dof_period(stiffness, force, h[0], steps)
    return shoot(scheme, Marcher(scheme, terms, h, compiled), h, steps, 1, 1)


def test_mathieu_principal_tongue_is_parametrically_unstable():
    # q̈ + (δ + ε cos t) q = 0 with δ = 1/4, ε = 0.2 lies inside the principal instability
    # tongue |δ − 1/4| < ε/2 (Mathieu; Nayfeh & Mook 1979 §5.2): a Floquet multiplier > 1.
    state, mu, _ = _periodic_1dof(lambda t: 0.25 + 0.2 * np.cos(t), lambda t: 0.0)
    assert np.abs(mu).max() > 1.0 + INSTABILITY_MARGIN
    assert all(np.all(np.isfinite(s)) for s in state)
    # Outside the tongue (δ = 0.5) the multipliers stay on the unit circle.
    _, mu, _ = _periodic_1dof(lambda t: 0.5 + 0.2 * np.cos(t), lambda t: 0.0)
    assert np.abs(mu).max() < 1.0 + 1e-9


def test_exact_resonance_without_damping_is_flagged_and_finite():
    # q̈ + q = cos t: forcing at the natural frequency, no damping. The discrete multiplier of
    # the mode is within (ωh)²/12 of the forcing period, |1 − μ| ≪ RESONANCE_GAP, and that
    # mode carries the periodic response: resonant, with a finite periodic state.
    state, mu, resonant = _periodic_1dof(lambda t: 1.0, np.cos)
    assert resonant[0]
    assert np.abs(1 - mu).min() < RESONANCE_GAP
    assert all(np.all(np.isfinite(s)) for s in state)
    # Detuned (natural frequency 1.7): not resonant.
    _, _, resonant = _periodic_1dof(lambda t: 1.7**2, np.cos)
    assert not resonant[0]


def test_periodic_state_of_some_cases_is_theirs_alone_and_the_multipliers_are_phis():
    # Three detuned oscillators q̈ + k q = cos t in one batch: the state solved for cases 0
    # and 2 only is theirs when all are solved (to the bit), zero for case 1; the multipliers
    # (eigvals) are the eigenvalues of the monodromy: the undamped average-acceleration map
    # keeps the pair e^{±iωT} on the unit circle (the third, of the acceleration the scheme
    # determines, is 0).
    steps = 128
    h = np.full(3, 2 * np.pi / steps)
    scheme = average_acceleration()
    k = np.array([1.7**2, 2.3**2, 0.6**2])
    t = np.arange(steps) * h[0]
    terms = PeriodTerms(mass=np.ones((3, steps, 1, 1)), damping=None,
                        stiffness=np.broadcast_to(k[:, None, None, None],
                                                  (3, steps, 1, 1)).copy(),
                        force=np.broadcast_to(np.cos(t)[None, :, None], (3, steps, 1)).copy(),
                        projection=np.zeros((3, steps, 1, 1)), samples=steps,
                        interpolation_error=np.zeros(3))
    one_period = monodromy(scheme, Marcher(scheme, terms, h, True), h, steps, 1, 3)
    every = periodic_state(one_period, 1)
    some = periodic_state(one_period, 1, np.array([True, False, True]))
    for full, part in zip(every, some):
        assert np.array_equal(part[[0, 2]], full[[0, 2]]) and not part[1].any()
    # q(0) of the periodic response cos t / (k − 1), to the scheme's phase error
    assert np.allclose(every[0][:, 0, 0], 1.0 / (k - 1.0), rtol=2e-3)
    mu, resonant = floquet(one_period, 1)
    for c in range(3):
        assert np.allclose(np.sort_complex(mu[c]),
                           np.sort_complex(np.linalg.eigvals(one_period.Phi[c])))
    size = np.sort(np.abs(mu), axis=1)
    assert np.allclose(size[:, 1:], 1.0, atol=1e-9) and np.allclose(size[:, 0], 0.0, atol=1e-12)
    turn = np.exp(2j * np.pi * np.sqrt(k))  # e^{iωT}, T = 2π, to the phase error (ωh)²/12
    assert np.allclose(np.abs(mu - turn[:, None]).min(axis=1), 0.0, atol=0.02)
    assert not resonant.any()


def _real_monodromy(rng, near: list[complex], others: int):
    """A real Φ = V B V⁻¹ with the multipliers ``near`` (and their conjugates) and ``others``
    random pairs inside the unit disc: B is block diagonal (2×2 rotations for the pairs), V
    well conditioned (cond ≤ e²). Returns Φ and the exact share of the ``near`` blocks in the
    displacement part (first 4 rows) of (I − Φ)⁻¹p for the returned p."""
    multipliers = list(near) + [0.9 * rng.uniform(0.1, 1.0) * np.exp(1j * rng.uniform(0.2, 3.0))
                                for _ in range(others)]
    sizes = [1 if m.imag == 0.0 else 2 for m in multipliers]
    r = sum(sizes)
    B = np.zeros((r, r))
    i = 0
    for m, size in zip(multipliers, sizes):
        B[i:i + size, i:i + size] = ([[m.real]] if size == 1
                                     else [[m.real, m.imag], [-m.imag, m.real]])
        i += size
    Q1, _ = np.linalg.qr(rng.standard_normal((r, r)))
    Q2, _ = np.linalg.qr(rng.standard_normal((r, r)))
    V = Q1 @ np.diag(np.exp(rng.uniform(-1.0, 1.0, r))) @ Q2
    p = rng.standard_normal(r)
    z = np.linalg.solve(np.eye(r) - B, np.linalg.solve(V, p))  # in the blocks' coordinates
    k = sum(sizes[:len(near)])
    share = np.linalg.norm((V[:, :k] @ z[:k])[:4]) / np.linalg.norm((V @ z)[:4])
    return V @ B @ np.linalg.inv(V), p, share


@settings(max_examples=40, deadline=None)
@example(seed=40835379, detuning=1e-4, angle=1e-4, real_one=True)  # Φ − μI exactly singular
@given(seed=st.integers(0, 2**32 - 1), detuning=st.floats(1e-4, 0.04),
       angle=st.floats(0.0, 2 * np.pi), real_one=st.booleans())
def test_near_share_by_inverse_iteration_is_the_eigenvector_share(seed, detuning, angle,
                                                                   real_one):
    # The resonance share from inverse iteration at the near multipliers is the exact one
    # (known from how Φ was made), as is the full eigenvector problem's, for a conjugate pair
    # near 1 (and a real multiplier near 1).
    rng = np.random.default_rng(seed)
    near = [1.0 + detuning * np.exp(1j * angle)]
    if abs(near[0].imag) < 1e-4:  # a pair this close to the real axis is a cluster (below)
        near[0] = complex(near[0].real, 1e-4)
    if real_one:
        near.append(complex(1.0 - 0.5 * detuning, 0.0))
    Phi, p, exact = _real_monodromy(rng, near, 8)
    share = _near_share(np.linalg.eigvals(Phi), Phi, p, 4, RESONANCE_GAP)
    assert share is not None
    assert share == pytest.approx(exact, rel=1e-9, abs=1e-12)
    assert (_near_share_by_eig(Phi, p, 4, RESONANCE_GAP)
            == pytest.approx(exact, rel=1e-9, abs=1e-12))


def test_clustered_or_exact_near_multipliers_fall_back_to_the_eigenvectors():
    # Two distinct pairs within 1e-9 of each other: inverse iteration would mix their vectors,
    # so the share is left to the eigenvector problem; so is an exact multiplier 1 (here
    # planted in the list).
    rng = np.random.default_rng(1)
    m = 0.99 + 0.01j
    Phi, p, _ = _real_monodromy(rng, [m, m + 1e-9], 4)
    assert _near_share(np.linalg.eigvals(Phi), Phi, p, 4, RESONANCE_GAP) is None
    one, q, _ = _real_monodromy(rng, [complex(0.999, 0.0)], 4)
    mu = np.linalg.eigvals(one)
    mu[np.argmin(np.abs(mu - 1.0))] = 1.0
    assert _near_share(mu, one, q, 4, RESONANCE_GAP) is None
    # ... and resonant() still decides them: the clustered pair carries the state or not.
    flagged = resonant(np.linalg.eigvals(Phi)[None], Phi[None], p[None], 4)
    assert flagged[0] == (_near_share_by_eig(Phi, p, 4, RESONANCE_GAP) > RESONANCE_SHARE)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), log_cond=st.floats(0.0, 17.0), n=st.integers(2, 60))
def test_the_direct_solve_is_taken_exactly_where_the_condition_number_allows_it(seed, log_cond,
                                                                                   n):
    # The quick decision from LAPACK's condition estimate is the singular values' one,
    # whatever the conditioning (near the limit the singular values decide).
    rng = np.random.default_rng(seed)
    U, _ = np.linalg.qr(rng.standard_normal((n, n)))
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    s = np.logspace(0.0, -log_cond, n)
    A = (U * s) @ V.T
    assert _regular(A) == (np.linalg.cond(A) < COND_LIMIT)


def test_the_resonance_gap_is_per_input_turn():
    # A pair at |1 − μ| = 0.07 carrying most of the state: past the gap of a one-turn period,
    # inside that of a two-turn one (the same band of frequency: |1 − μ| ≈ |ωT − 2πk|).
    rng = np.random.default_rng(3)
    for _ in range(20):
        Phi, p, share = _real_monodromy(rng, [1.0 + 0.07j], 4)
        if share > RESONANCE_SHARE:
            break
    period = Monodromy(p[None], Phi[None], np.ones((1, len(p))))
    assert not floquet(period, 4)[1][0]
    assert floquet(period, 4, turns=2)[1][0]
