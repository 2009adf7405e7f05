"""Fourier collocation of the periodic steady state (ced.response.spectral): the compiled
GMRES against the dense collocation solve, and both against exact solutions."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from ced.response.spectral import (diff_matrices, evaluate, solve_periodic,
                                   solve_periodic_dense)


def _system(P, n, seed, variation=0.3, damping=True):
    """A random stable linear periodic system: SPD mass and stiffness that vary smoothly over
    the period (first and second harmonics), light damping, a periodic force."""
    rng = np.random.default_rng(seed)
    theta = 2 * np.pi * np.arange(P) / P

    def spd(scale):
        A = rng.standard_normal((n, n))
        return scale * (A @ A.T / n + np.eye(n))

    def varying(base):
        B1, B2 = (rng.standard_normal((n, n)) for _ in range(2))
        B1, B2 = B1 + B1.T, B2 + B2.T
        out = base[None] + variation * np.linalg.norm(base, 2) / 4 * (
            np.cos(theta)[:, None, None] * B1 / np.linalg.norm(B1, 2)
            + np.sin(2 * theta)[:, None, None] * B2 / np.linalg.norm(B2, 2))
        return out[None]

    M = varying(spd(1.0))
    K = varying(spd(400.0))
    C = 0.02 * (M + K / 400.0) if damping else None
    F = (rng.standard_normal((1, 1, n)) * np.cos(theta)[None, :, None]
         + rng.standard_normal((1, 1, n)) * np.sin(3 * theta)[None, :, None]
         + rng.standard_normal((1, 1, n)))
    return M, C, K, F


def test_differentiation_matrices_differentiate_trigonometric_polynomials():
    P = 16
    theta = 2 * np.pi * np.arange(P) / P
    D1, D2 = diff_matrices(P)
    f = np.sin(3 * theta) + 0.5 * np.cos(7 * theta)
    np.testing.assert_allclose(D1 @ f, 3 * np.cos(3 * theta) - 3.5 * np.sin(7 * theta),
                               atol=1e-12)
    np.testing.assert_allclose(D2 @ f, -9 * np.sin(3 * theta) - 24.5 * np.cos(7 * theta),
                               atol=1e-11)
    # The Nyquist cosine: no first derivative at the points, −(P/2)² for the second.
    nyquist = np.cos(P // 2 * theta)
    np.testing.assert_allclose(D1 @ nyquist, 0.0, atol=1e-12)
    np.testing.assert_allclose(D2 @ nyquist, -(P // 2) ** 2 * nyquist, atol=1e-10)


@pytest.mark.parametrize("damped", [True, False])
def test_single_oscillator_with_constant_coefficients_is_exact(damped):
    # m x'' + c x' + k x = F0 cos(Ωt) + F1 sin(3Ωt): the steady state is known in closed form,
    # and with constant coefficients the preconditioner is the exact inverse.
    m, k, c, F0, F1, w = 2.0, 800.0, (3.0 if damped else 0.0), 5.0, -2.0, 7.0
    P = 16
    theta = 2 * np.pi * np.arange(P) / P
    M = np.full((1, P, 1, 1), m)
    K = np.full((1, P, 1, 1), k)
    C = np.full((1, P, 1, 1), c) if damped else None
    F = (F0 * np.cos(theta) + F1 * np.sin(3 * theta))[None, :, None]

    def response(amplitude, harmonic):  # complex amplitude of e^{i h Ω t}
        return amplitude / (k - m * (harmonic * w) ** 2 + 1j * c * harmonic * w)
    exact = (np.real(response(F0, 1) * np.exp(1j * theta))
             + np.real(response(F1, 3) * np.exp(1j * (3 * theta - np.pi / 2))))
    got = solve_periodic(K, F, [w], M, C, rtol=1e-12)
    assert got.converged[0]
    assert got.iterations[0] == 1
    np.testing.assert_allclose(got.displacement[0, :, 0], exact, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(solve_periodic_dense(K, F, [w], M, C)[0, :, 0], exact,
                               rtol=1e-10, atol=1e-14)


@settings(max_examples=12, deadline=None)
@given(st.sampled_from([8, 12, 16, 32]), st.integers(1, 5), st.integers(0, 10_000),
       st.booleans())
def test_compiled_gmres_equals_the_dense_solve(P, n, seed, damped):
    # Powers of two take the radix-2 FFT, the others the dense DFT.
    M, C, K, F = _system(P, n, seed, damping=damped)
    speed = np.array([3.0])
    dense = solve_periodic_dense(K, F, speed, M, C)
    got = solve_periodic(K, F, speed, M, C, rtol=1e-8)
    assert got.converged[0]
    # The residual it reports is that of the collocation equations, formed here independently.
    D1, D2 = diff_matrices(P)
    A = np.einsum("ij,iab->iajb", speed[0] ** 2 * D2, M[0])
    if C is not None:
        A += np.einsum("ij,iab->iajb", speed[0] * D1, C[0])
    A[np.arange(P), :, np.arange(P), :] += K[0]
    A = A.reshape(P * n, P * n)
    b = F[0].reshape(-1)
    residual = np.linalg.norm(A @ got.displacement[0].reshape(-1) - b) / np.linalg.norm(b)
    assert residual <= 1.01e-8
    # Equal where it is above round-off; at round-off (a one-iteration exact solve) the two
    # sums differ by a few ε (3.0e-15 against 2.0e-15 was found, P=12, n=1, seed=4832).
    assert residual == pytest.approx(got.residual[0], rel=1e-3, abs=1e-13)
    # and the solution is the dense one within what that residual allows (condition number).
    bound = 2 * np.linalg.cond(A) * residual * np.abs(dense).max() + 1e-14
    np.testing.assert_allclose(got.displacement, dense, rtol=0, atol=bound)


def test_a_batch_is_solved_case_by_case():
    systems = [_system(16, 3, seed) for seed in range(3)]
    M, C, K, F = (np.concatenate(parts) for parts in zip(*systems))
    speed = np.array([2.0, 3.0, 4.0])
    batch = solve_periodic(K, F, speed, M, C)
    for i in range(3):
        one = solve_periodic(K[i:i + 1], F[i:i + 1], speed[i:i + 1], M[i:i + 1], C[i:i + 1])
        np.testing.assert_array_equal(batch.displacement[i], one.displacement[0])
        assert batch.iterations[i] == one.iterations[0]


def test_a_warm_start_reaches_the_cold_solution_in_fewer_iterations():
    # A guess near the solution (as a coarser mesh's series is to a finer one's) starts
    # GMRES from its residual; the stopping test stays relative to the force.
    M, C, K, F = _system(32, 5, seed=3, variation=0.8)
    speed = np.array([3.0])
    cold = solve_periodic(K, F, speed, M, C)
    rng = np.random.default_rng(0)
    guess = cold.displacement * (1 + 1e-3 * rng.standard_normal(cold.displacement.shape))
    warm = solve_periodic(K, F, speed, M, C, initial=guess)
    assert cold.converged[0] and warm.converged[0]
    assert warm.iterations[0] < cold.iterations[0]
    assert warm.residual[0] <= 1e-6
    np.testing.assert_allclose(warm.displacement, cold.displacement, rtol=0,
                               atol=1e-5 * np.abs(cold.displacement).max())


def test_a_zero_or_poor_guess_is_a_cold_start():
    # A zero guess is the cold start bit for bit; a guess farther from the solution than
    # zero (or not finite) is dropped, so it costs no more than the cold start.
    M, C, K, F = _system(16, 3, seed=5)
    speed = np.array([2.0])
    cold = solve_periodic(K, F, speed, M, C)
    for guess in (np.zeros_like(F), -10 * cold.displacement, np.full_like(F, np.nan)):
        again = solve_periodic(K, F, speed, M, C, initial=guess)
        np.testing.assert_array_equal(again.displacement, cold.displacement)
        assert again.iterations[0] == cold.iterations[0]


def test_the_series_converges_exponentially_on_a_smooth_system():
    # A Mathieu-type oscillator, x'' + 0.05 x' + (4 + 1.5 cos θ) x = cos θ (Ω = 1), away from
    # its instability tongues: the collocation error falls by orders of magnitude with every
    # few points (spectral accuracy), judged against P = 128.
    def solve(P):
        theta = 2 * np.pi * np.arange(P) / P
        K = (4.0 + 1.5 * np.cos(theta))[None, :, None, None]
        ones = np.ones((1, P, 1, 1))
        return solve_periodic(K, np.cos(theta)[None, :, None], [1.0], ones, 0.05 * ones,
                              rtol=1e-13)
    fine = solve(128)
    check = 2 * np.pi * np.arange(64) / 64
    reference = evaluate(fine.displacement, check)
    errors = [np.abs(evaluate(solve(P).displacement, check) - reference).max()
              for P in (8, 16, 24, 32)]
    assert errors[0] > 1e-4
    for coarse, finer in zip(errors, errors[1:]):
        assert finer < 1e-2 * coarse or finer < 1e-12
    assert errors[-1] < 1e-12


def test_exact_undamped_resonance_ends_unconverged_but_finite():
    # k = m (hΩ)² for the forced harmonic h = 2: the collocation system is singular.
    P, w = 16, 5.0
    theta = 2 * np.pi * np.arange(P) / P
    M = np.ones((1, P, 1, 1))
    K = np.full((1, P, 1, 1), (2 * w) ** 2)
    got = solve_periodic(K, np.cos(2 * theta)[None, :, None], [w], M, None)
    assert not got.converged[0]
    assert np.isfinite(got.displacement).all()
    assert got.residual[0] > 1e-8


def test_zero_force_gives_zero_without_iterating():
    M, C, K, F = _system(8, 2, 0)
    got = solve_periodic(K, np.zeros_like(F), [2.0], M, C)
    assert got.converged[0] and got.iterations[0] == 0
    assert not got.displacement.any()


def test_bad_shapes_are_refused():
    M, C, K, F = _system(8, 2, 0)
    with pytest.raises(ValueError, match="even number of collocation points"):
        solve_periodic(K[:, :7], F[:, :7], [1.0], M[:, :7], C[:, :7])
    with pytest.raises(ValueError, match="stiffness .* and force"):
        solve_periodic(K, F[..., :1], [1.0], M, C)
    with pytest.raises(ValueError, match="mass has shape"):
        solve_periodic(K, F, [1.0], M[:, :4], C)


def _apply(M, C, K, speed, x):
    """A x of the collocation system of one case (x (P, n))."""
    D1, D2 = diff_matrices(x.shape[0])
    out = np.einsum("pij,pj->pi", K[0], x) + speed ** 2 * np.einsum("pij,pj->pi", M[0], D2 @ x)
    return out + speed * np.einsum("pij,pj->pi", C[0], D1 @ x)


def test_a_case_that_does_not_converge_from_its_guess_is_solved_again_from_zero():
    # Within too few iterations neither the guess (residual 0.9 ‖F‖) nor zero converges: the
    # case ends as the cold start does, bit for bit, and reports both attempts' iterations.
    M, C, K, F = _system(32, 5, seed=3, variation=0.8)
    speed = np.array([3.0])
    exact = solve_periodic(K, F, speed, M, C).displacement
    error = np.random.default_rng(2).standard_normal(F.shape[1:])
    error *= 0.9 * np.linalg.norm(F) / np.linalg.norm(_apply(M, C, K, speed[0], error))
    cold = solve_periodic(K, F, speed, M, C, maxiter=10)
    retried = solve_periodic(K, F, speed, M, C, maxiter=10, initial=exact + error[None])
    assert not cold.converged[0] and not retried.converged[0]
    assert retried.iterations[0] == 10 + cold.iterations[0]
    np.testing.assert_array_equal(retried.displacement, cold.displacement)
