"""Periodic steady state by shooting (ced.response.periodic): Floquet flags on systems with
known stability."""
import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from ced.response.integrators import newmark as average_acceleration
from ced.response.marching import Marcher
from ced.response.period_terms import PeriodTerms
from ced.response.integrators import generalized_alpha, hht, make_integrator
from ced.response.periodic import (COND_LIMIT, INSTABILITY_MARGIN, RESONANCE_GAP,
                                   RESONANCE_SHARE, Monodromy, _near_share, _near_share_by_eig,
                                   _regular, floquet, monodromy, periodic_state,
                                   range_reduction, resonant, shoot)


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


def _real_monodromy(rng, near: list[complex], others: int, zeros: int = 0):
    """A real Φ = V B V⁻¹ with the multipliers ``near`` (and their conjugates), ``others``
    random pairs inside the unit disc and ``zeros`` zero multipliers (Φ of rank r − zeros): B
    is block diagonal (2×2 rotations for the pairs), V well conditioned (cond ≤ e²). Returns Φ
    and the exact share of the ``near`` blocks in the displacement part (first 4 rows) of
    (I − Φ)⁻¹p for the returned p."""
    multipliers = (list(near) + [0.9 * rng.uniform(0.1, 1.0) * np.exp(1j * rng.uniform(0.2, 3.0))
                                 for _ in range(others)] + [complex(0.0, 0.0)] * zeros)
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


def _mathieu_chain_period(scheme, steps=256, n=3, cases=2):
    """The monodromy of n coupled Mathieu oscillators q̈ + K(t) q = f(t), K(t) = K₀ + ε cos t
    K₁ (case c detuned by c/10), over one period 2π in ``steps`` steps."""
    h = np.full(cases, 2 * np.pi / steps)
    t = np.arange(steps) * h[0]
    K0 = np.diag(np.arange(1.0, n + 1.0) ** 2 * 0.7) + 0.1 * (np.eye(n, k=1) + np.eye(n, k=-1))
    K1 = np.ones((n, n)) / n
    stiffness = np.stack([K0 * (1.0 + 0.1 * c) + 0.3 * np.cos(t)[:, None, None] * K1
                          for c in range(cases)])
    force = np.broadcast_to((np.cos(t)[:, None] * np.arange(1.0, n + 1.0))[None],
                            (cases, steps, n)).copy()
    terms = PeriodTerms(mass=np.broadcast_to(np.eye(n), (cases, steps, n, n)).copy(),
                        damping=None, stiffness=stiffness, force=force,
                        projection=np.zeros((cases, steps, n, n)), samples=steps,
                        interpolation_error=np.zeros(cases))
    return monodromy(scheme, Marcher(scheme, terms, h, True), h, steps, n, cases)


@pytest.mark.parametrize("scheme", [average_acceleration(), hht(-0.1), generalized_alpha(0.9)],
                         ids=["newmark", "hht", "generalized_alpha"])
def test_floquet_on_the_range_of_the_newmark_family_monodromy_is_the_full_eigenproblem(scheme):
    # One period of the Newmark family leaves the acceleration a function of (q, v): Φ has
    # rank 2n, spanned by its (q, h v) columns, and the multipliers found on that range are
    # Φ's nonzero ones (its other n are 0), to round-off; the resonance flag is the same.
    period = _mathieu_chain_period(scheme)
    n = 3
    assert period.spanning == 2 * n
    reduction = range_reduction(period.Phi, period.spanning)
    assert reduction.ok.all()
    mu, flagged = floquet(period, n)
    full_mu, full_flagged = floquet(period._replace(spanning=0), n)
    assert np.array_equal(flagged, full_flagged)
    assert np.array_equal(mu[:, 2 * n:], np.zeros((2, n)))
    for c in range(2):
        nonzero = np.sort_complex(full_mu[c][np.abs(full_mu[c]) > 1e-8])
        assert len(nonzero) == 2 * n
        assert np.allclose(np.sort_complex(mu[c, :2 * n]), nonzero, rtol=0, atol=1e-12)
    assert np.allclose(np.abs(mu).max(axis=1), np.abs(full_mu).max(axis=1), rtol=1e-13)


def test_a_monodromy_its_first_columns_do_not_span_keeps_the_full_eigenproblem():
    # Houbolt's history state has no such structure (spanning 0), and a full-rank Φ fails the
    # range check: its multipliers are LAPACK's on Φ itself, bit for bit.
    rng = np.random.default_rng(5)
    Phi = rng.standard_normal((3, 9, 9)) / 3.0
    p = rng.standard_normal((3, 9))
    assert not range_reduction(Phi, 6).ok.any()
    mu, _ = floquet(Monodromy(p, Phi, np.ones((3, 9)), 6), 3)
    assert np.array_equal(mu, np.linalg.eigvals(Phi))
    houbolt = _mathieu_chain_period(make_integrator("houbolt"))
    assert houbolt.spanning == 0
    # A diverged case (not finite) fails the check quietly; the full eigenproblem then
    # refuses it as it did.
    Phi[1, 2, 3] = np.inf
    with np.errstate(all="raise"):
        assert not range_reduction(Phi, 6).ok.any()
    with pytest.raises(np.linalg.LinAlgError):
        floquet(Monodromy(p, Phi, np.ones((3, 9)), 6), 3)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), detuning=st.floats(1e-3, 0.04),
       angle=st.floats(0.1, 2 * np.pi - 0.1))
def test_the_near_share_on_the_range_is_the_full_ones(seed, detuning, angle):
    # A real Φ of rank 8 (12 × 12, four multipliers 0) with a pair near 1: the share of the
    # pair in the periodic displacement found on Φ's range is the exact one, as the full
    # problem's is, and so is the flag.
    rng = np.random.default_rng(seed)
    Phi, p, exact = _real_monodromy(rng, [1.0 + detuning * np.exp(1j * angle)], 3, zeros=4)
    reduction = range_reduction(Phi[None], 8)
    # The range check measures ‖Φ_b − QQᵀΦ_b‖ against ‖Φ‖, and the round-off of a Φ_b in the
    # range grows with its coefficients in Φ's first columns: about 1 % of these random Φ have
    # first columns ill-conditioned enough (cond ~ 10³) to fail it and take the full problem,
    # which test_a_monodromy_its_first_columns_do_not_span_keeps_the_full_eigenproblem covers.
    assume(reduction.ok[0])
    mu_r = np.linalg.eigvals(reduction.reduced[0])
    share = _near_share(mu_r, reduction.reduced[0], reduction.image[0] @ p, 4, RESONANCE_GAP,
                        reduction.basis[0], p)
    assert share == pytest.approx(exact, rel=1e-9, abs=1e-12)
    mu = np.concatenate([mu_r, np.zeros(4)])[None]
    assert np.array_equal(resonant(mu, Phi[None], p[None], 4, reduction=reduction),
                          resonant(np.linalg.eigvals(Phi)[None], Phi[None], p[None], 4))
