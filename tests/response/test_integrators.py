"""Tests of ced.response.integrators: accuracy, stability, batching and the driver's interface."""
from __future__ import annotations


import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from ced.response.integrators import (Houbolt, NewmarkFamily, alpha_step, amplification_matrix,
                                      effective_coefficients, generalized_alpha, hht, houbolt,
                                      houbolt_step, integrate, make_integrator, newmark,
                                      spectral_radius, stability_limit)

ALL = [newmark(), hht(-0.05), hht(-1 / 3), generalized_alpha(0.9), generalized_alpha(0.0),
       houbolt()]
IDS = ["newmark", "hht-0.05", "hht-1/3", "genalpha0.9", "genalpha0", "houbolt"]


def oscillator(omega: float, xi: float = 0.0, force=None):
    """system(k) of q̈ + 2ξω q̇ + ω² q = f(t) as 1×1 matrices (time step bound later)."""
    M, C, K = np.eye(1), np.array([[2 * xi * omega]]), np.array([[omega**2]])

    def make(h):
        return lambda k: (M, C if xi else None, K,
                          None if force is None else np.array([force(k * h)]))
    return make


# --- accuracy ------------------------------------------------------------------------------

def test_period_elongation_average_acceleration():
    # Trapezoidal rule: λ = (1 + iΩ/2)/(1 − iΩ/2), phase 2 atan(Ω/2), so the relative period
    # elongation is (ωh)²/12 + O((ωh)⁴) (Newmark 1959; Hughes, The Finite Element Method,
    # 2000, ch. 9).
    W = 0.1
    lam = np.linalg.eigvals(amplification_matrix(newmark(), W))
    phase = np.abs(np.angle(lam)).max()
    elongation = W / phase - 1.0
    assert abs(elongation - W**2 / 12) < 0.02 * W**2 / 12
    # The same from zero crossings of a long simulation by the driver (400 periods).
    h, n = W, int(400 * 2 * np.pi / W)
    q = integrate(oscillator(1.0)(h), h, n, np.array([1.0]), np.array([0.0]), newmark())[0][:, 0]
    i = np.flatnonzero(np.sign(q[:-1]) != np.sign(q[1:]))
    t0 = h * (i + q[i] / (q[i] - q[i + 1]))  # linear interpolation of each crossing
    period = 2 * np.mean(np.diff(t0))
    assert abs(period / (2 * np.pi) - 1 - W**2 / 12) < 0.02 * W**2 / 12


def _exact_damped(omega, xi, q0, v0, F, Omega_f, t):
    """Exact solution of q̈ + 2ξωq̇ + ω²q = F sin(Ω_f t)."""
    Z = F / (omega**2 - Omega_f**2 + 2j * xi * omega * Omega_f)   # particular: Im(Z e^{iΩt})
    qp0, vp0 = Z.imag, (1j * Omega_f * Z).imag
    wd = omega * np.sqrt(1 - xi**2)
    A, B = q0 - qp0, (v0 - vp0 + xi * omega * (q0 - qp0)) / wd
    return np.exp(-xi * omega * t) * (A * np.cos(wd * t) + B * np.sin(wd * t)) \
        + (Z * np.exp(1j * Omega_f * t)).imag


@pytest.mark.parametrize("integrator", ALL, ids=IDS)
@pytest.mark.parametrize("xi, F", [(0.0, 0.0), (0.1, 5.0)], ids=["undamped", "damped-forced"])
def test_second_order_convergence_1dof(integrator, xi, F):
    # All four schemes are second order in q (Newmark γ = ½; HHT 1977; Chung & Hulbert 1993
    # with γ = ½ − αm + αf; Houbolt 1950 with a second-order start): slope of log error.
    omega, Omega_f, T, q0, v0 = 2 * np.pi, 3.0, 2.0, 1.0, 0.5
    make = oscillator(omega, xi, lambda t: F * np.sin(Omega_f * t))
    hs, errs = [], []
    for n in (80, 160, 320, 640):
        h = T / n
        q = integrate(make(h), h, n, np.array([q0]), np.array([v0]), integrator)[0][:, 0]
        exact = _exact_damped(omega, xi, q0, v0, F, Omega_f, h * np.arange(n + 1))
        hs.append(h)
        errs.append(np.abs(q - exact).max())
    p = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert 1.9 < p < 2.2, (p, errs)


def mathieu(params: np.ndarray):
    """Batched 2-DOF Mathieu-like system; params (case, 3) = (ε, Ω_p, c).

    M(t), K(t) both vary with period 2π/Ω_p; damping c·I; force on DOF 0."""
    eps, Op, c = params.T

    def at(t):
        s, co = np.sin(Op * t), np.cos(Op * t)
        M = np.stack([np.stack([2 + 0.3 * eps * s, 0.2 + 0 * s], -1),
                      np.stack([0.2 + 0 * s, 1 + 0 * s], -1)], -2)
        K = np.stack([np.stack([30 + 10 * eps * co, -10 + 0 * co], -1),
                      np.stack([-10 + 0 * co, 20 - 5 * eps * co], -1)], -2)
        C = c[:, None, None] * np.eye(2)
        F = np.stack([np.sin(3 * t) + 0 * eps, 0 * eps], -1)
        return M, C, K, F
    return at


PARAMS = np.array([[0.0, 5.0, 0.0], [0.5, 7.0, 0.2], [0.9, 9.5, 0.05]])
Q0 = np.array([[0.1, -0.2], [0.0, 0.3], [0.2, 0.1]])
V0 = np.array([[0.0, 1.0], [-1.0, 0.5], [0.3, 0.0]])


def _reference(params, q0, v0, t_eval):
    """scipy solve_ivp (DOP853, rtol 1e-10) of each case, first-order form."""
    out = []
    for p, qq, vv in zip(params, q0, v0):
        at = mathieu(p[None])

        def rhs(t, y):
            M, C, K, F = (x[0] for x in at(t))
            return np.concatenate([y[2:], np.linalg.solve(M, F - C @ y[2:] - K @ y[:2])])
        sol = solve_ivp(rhs, (0, t_eval[-1]), np.concatenate([qq, vv]), method="DOP853",
                        t_eval=t_eval, rtol=1e-10, atol=1e-12)
        out.append(sol.y[:2].T)
    return np.stack(out, 1)  # (time, case, 2)


@pytest.mark.parametrize("integrator", ALL, ids=IDS)
def test_mathieu_batched_against_solve_ivp(integrator):
    # Time-varying M, C, K, F keep order 2 in the Arnold & Brüls (2007) form (Chung &
    # Hulbert's weighted residual drops to order 1 here when αm ≠ αf and M varies: rates
    # 1.3, 1.2, 1.1 under halving h); the reference error (rtol 1e-10) is far below the
    # finest error (~1e-5).
    T, n0 = 2.0, 100
    ref = _reference(PARAMS, Q0, V0, np.linspace(0, T, n0 + 1))
    hs, errs = [], []
    for m in (2, 4, 8):  # h = 0.01 … 0.0025: asymptotic for Houbolt too
        h = T / (n0 * m)
        at = mathieu(PARAMS)
        q = integrate(lambda k: at(k * h), h, n0 * m, Q0, V0, integrator)[0]
        hs.append(h)
        errs.append(np.abs(q[::m] - ref).max(axis=(0, 2)))   # per case
    errs = np.array(errs)
    p = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert np.all((1.9 < p) & (p < 2.2)), (p, errs)


@pytest.mark.parametrize("integrator", [newmark(), generalized_alpha(0.7), houbolt()],
                         ids=["newmark", "genalpha", "houbolt"])
def test_batched_equals_case_by_case(integrator):
    # No coupling between cases: batching is only vectorisation (same LAPACK calls per case).
    h, n = 0.01, 200
    at = mathieu(PARAMS)
    qb, vb, ab = integrate(lambda k: at(k * h), h, n, Q0, V0, integrator)
    for i in range(len(PARAMS)):
        ati = mathieu(PARAMS[i:i + 1])
        qi, vi, ai = integrate(lambda k: ati(k * h), h, n, Q0[i:i + 1], V0[i:i + 1], integrator)
        for b, s in ((qb, qi), (vb, vi), (ab, ai)):
            np.testing.assert_allclose(b[:, i], s[:, 0], rtol=1e-12, atol=1e-12 * np.abs(s).max())


@pytest.mark.parametrize("integrator", ALL, ids=IDS)
def test_multi_rhs_equals_separate_integrations(integrator):
    # Column layout (case, n, r): every column is an independent solution sharing the step
    # matrix, as needed for monodromy matrices.
    h, n, r = 0.02, 60, 3
    at = mathieu(PARAMS)
    rng = np.random.default_rng(1)
    q0, v0 = rng.normal(size=(3, 2, r)), rng.normal(size=(3, 2, r))
    load = rng.normal(size=r)  # column j carries load[j] × F

    def cols(k):
        M, C, K, F = at(k * h)
        return M, C, K, F[..., None] * load
    q, v, a = integrate(cols, h, n, q0, v0, integrator)
    assert q.shape == (n + 1, 3, 2, r)
    for j in range(r):
        def one(k, j=j):
            M, C, K, F = at(k * h)
            return M, C, K, F * load[j]
        qj, vj, aj = integrate(one, h, n, q0[..., j], v0[..., j], integrator)
        for b, s in ((q, qj), (v, vj), (a, aj)):
            np.testing.assert_allclose(b[..., j], s, rtol=1e-12, atol=1e-12 * np.abs(s).max())


@pytest.mark.parametrize("integrator", ALL, ids=IDS)
def test_driver_matches_amplification_matrix(integrator):
    # integrate on a damped 1-DOF system must reproduce x_n = A^n x_0 with x = (q, hv, h²a)
    # and a_0 = ẍ_0 (Houbolt: x_n = A^(n−2) x_2, its first two steps being the trapezoidal
    # starter). Only q and v are compared: the driver returns the true acceleration, A carries
    # the algorithmic one.
    omega, xi, h, n = 3.0, 0.05, 0.2, 30
    q, v, acc = integrate(oscillator(omega, xi)(h), h, n, np.array([1.0]), np.array([-0.4]),
                          integrator)
    # The returned acceleration satisfies the equation of motion at every step.
    np.testing.assert_allclose(acc, -2 * xi * omega * v - omega**2 * q, atol=1e-12)
    A = amplification_matrix(integrator, omega * h, xi)
    if isinstance(integrator, Houbolt):
        x = np.array([q[2, 0], q[1, 0], q[0, 0]])
        pred = [np.linalg.matrix_power(A, k - 2) @ x for k in range(2, n + 1)]
        np.testing.assert_allclose(q[2:, 0], [p[0] for p in pred], atol=1e-12)
    else:
        x = np.array([q[0, 0], h * v[0, 0], h * h * acc[0, 0]])
        pred = np.array([np.linalg.matrix_power(A, k) @ x for k in range(n + 1)])
        np.testing.assert_allclose(np.c_[q[:, 0], h * v[:, 0]], pred[:, :2], atol=1e-12)


def test_generalized_alpha_rho1_is_trapezoidal():
    # ρ∞ = 1: αm = αf = ½, β = ¼, γ = ½, so a_{n+1} = ẍ_{n+1} + ẍ_n − a_n = ẍ_{n+1} once
    # a_0 = ẍ_0: the same trajectory as average-acceleration Newmark, even with M(t).
    h, n = 0.01, 200
    at = mathieu(PARAMS)
    r1 = integrate(lambda k: at(k * h), h, n, Q0, V0, generalized_alpha(1.0))
    r0 = integrate(lambda k: at(k * h), h, n, Q0, V0, newmark())
    for x1, x0 in zip(r1, r0):
        np.testing.assert_allclose(x1, x0, rtol=0, atol=1e-12 * np.abs(x0).max())


def test_steps_accept_per_case_time_steps():
    # A per-case step h of shape (case, 1, 1) (column layout) is the same as stepping each
    # case with its own scalar h: nothing in a step mixes cases.
    hs = np.array([0.01, 0.02, 0.005])
    at = mathieu(PARAMS)
    terms = at(0.0)  # matrices at one instant suffice to exercise one step
    q, v = Q0[..., None], V0[..., None]
    acc, a = 0.3 * q, -0.2 * q
    cols = tuple(x if x is None else (x[..., None] if x.ndim == 2 else x) for x in terms)
    for s in (generalized_alpha(0.7), houbolt()):
        if isinstance(s, Houbolt):
            out = houbolt_step(hs[:, None, None], q, v, acc, cols, columns=True)
        else:
            out = alpha_step(s, hs[:, None, None], q, v, acc, a, cols, columns=True)
        for i, h in enumerate(hs):
            one = tuple(x[i:i + 1] for x in cols)
            if isinstance(s, Houbolt):
                ref = houbolt_step(h, q[i:i + 1], v[i:i + 1], acc[i:i + 1], one, columns=True)
            else:
                ref = alpha_step(s, h, q[i:i + 1], v[i:i + 1], acc[i:i + 1], a[i:i + 1], one,
                                 columns=True)
            for x, r in zip(out, ref):
                np.testing.assert_allclose(x[i:i + 1], r, rtol=1e-13, atol=1e-15)


def test_step_matrix_is_the_effective_coefficients():
    # The injected solve sees exactly S = c_M M + c_C C + c_K K (the documented contract the
    # compiled KED loop relies on), with a (..., n, k) right-hand side.
    h = 0.01
    at = mathieu(PARAMS)
    for integrator in (generalized_alpha(0.6), houbolt()):
        seen = []

        def spy(S, B):
            assert B.ndim == S.ndim
            seen.append(S)
            return np.linalg.solve(S, B)
        integrate(lambda k: at(k * h), h, 4, Q0, V0, integrator, solve=spy)
        c = effective_coefficients(integrator, h)
        M, C, K, _ = at(4 * h)
        np.testing.assert_allclose(seen[-1], c.c_M * M + c.c_C * C + c.c_K * K, rtol=1e-14)
    # Unknown ẍ_{n+1}: c = (1, ∂v/∂ẍ, ∂q/∂ẍ) = (1, γh w, βh² w), w = (1 − αf)/(1 − αm)
    # (Arnold & Brüls 2007 form), and (1, 11h/12, h²/2) for Houbolt's differences.
    s = generalized_alpha(0.6)
    w = (1 - s.alpha_f) / (1 - s.alpha_m)
    assert effective_coefficients(s, h) == pytest.approx((1, s.gamma * h * w, s.beta * h**2 * w))
    assert effective_coefficients(houbolt(), h) == pytest.approx((1, 11 * h / 12, h**2 / 2))


# --- stability -----------------------------------------------------------------------------

@pytest.mark.parametrize("rho", [0.0, 0.5, 0.9, 1.0])
def test_generalized_alpha_high_frequency_limit(rho):
    # Chung & Hulbert 1993: ρ(ωh → ∞) = ρ∞ (triple root −ρ∞; at ωh = 1e6 the approach is
    # O((ωh)^(-2/3)) ≈ 1e-4 for the triple root, hence the 1e-3 tolerance).
    assert abs(spectral_radius(generalized_alpha(rho), 1e6) - rho) < 1e-3


@pytest.mark.parametrize("alpha", [-1 / 3, -0.1, -0.05, 0.0])
def test_hht_high_frequency_limit(alpha):
    # Hilber, Hughes & Taylor 1977 (β = (1−α)²/4, γ = ½−α): ρ∞ = (1 + α)/(1 − α), i.e. ½ at
    # α = −1/3; HHT with α = −1/3 is also generalized-α with ρ∞ = ½ (αm = 0, αf = 1/3).
    assert abs(spectral_radius(hht(alpha), 1e6) - (1 + alpha) / (1 - alpha)) < 1e-3
    if alpha == -1 / 3:
        assert hht(alpha) == NewmarkFamily(**{**generalized_alpha(0.5).__dict__, "name": "hht"})


def test_houbolt_and_newmark_high_frequency_limits():
    # Houbolt annihilates infinite frequencies: the first row of its companion matrix is
    # O((ωh)⁻²), so all roots → 0 (its strong dissipation, as compared in HHT 1977);
    # the trapezoidal rule is non-dissipative: |λ| = 1 for every ωh.
    assert spectral_radius(houbolt(), 1e6) < 1e-3
    assert abs(spectral_radius(newmark(), 1e6) - 1.0) < 1e-12
    assert np.allclose(spectral_radius(newmark(), np.logspace(-3, 6, 50)), 1.0, atol=1e-12)


@pytest.mark.parametrize("integrator", ALL, ids=IDS)
@pytest.mark.parametrize("xi", [0.0, 0.1])
def test_unconditional_stability(integrator, xi):
    # All these parameter choices are unconditionally stable: ρ ≤ 1 for every ωh
    # (Newmark γ = ½, β = ¼; HHT 1977 α ∈ [−⅓, 0]; Chung & Hulbert 1993; Houbolt).
    rho = spectral_radius(integrator, np.logspace(-3, 6, 200), xi)
    assert np.all(rho <= 1 + 1e-12)


def test_energy_average_acceleration_conserved():
    # The trapezoidal rule conserves ½(v² + ω²q²) exactly for an undamped linear oscillator
    # (Newmark 1959; Hughes 2000, ch. 9); 10 000 steps at ωh = 1 leave round-off only.
    omega, h, n = 1.0, 1.0, 10_000
    q, v, _ = integrate(oscillator(omega)(h), h, n, np.array([1.0]), np.array([0.3]), newmark())
    E = 0.5 * (v[:, 0] ** 2 + omega**2 * q[:, 0] ** 2)
    assert np.abs(E / E[0] - 1).max() < 1e-10


@pytest.mark.parametrize("rho", [0.5, 0.9])
def test_energy_generalized_alpha_dissipates(rho):
    # Chung & Hulbert 1993, ρ∞ < 1: the energy never exceeds its initial value, and after N
    # steps it has decayed as ρ(ωh)^(2N) (the principal root sets the amplitude decay).
    # Note: ½(v² + ω²q²) is NOT monotone step by step (it oscillates within each period by
    # up to ~3e-4 relative at ρ∞ = 0.9); with ρ∞ = 0 it even overshoots at the first step.
    omega, h, n = 1.0, 1.0, 10_000
    s = generalized_alpha(rho)
    q, v, _ = integrate(oscillator(omega)(h), h, n, np.array([1.0]), np.array([0.0]), s)
    E = 0.5 * (v[:, 0] ** 2 + omega**2 * q[:, 0] ** 2)
    assert E.max() <= E[0] * (1 + 1e-12)
    predicted = 2 * n * np.log(spectral_radius(s, omega * h))
    assert abs(np.log(E[-1] / E[0]) / predicted - 1) < 0.02


# --- interface -----------------------------------------------------------------------------

def test_make_integrator_and_parameters():
    # Coefficients as defined by the papers (Chung & Hulbert 1993 eq. 25; HHT 1977).
    assert make_integrator("newmark") == NewmarkFamily(0.0, 0.0, 0.25, 0.5, "newmark")
    g = make_integrator("generalized_alpha", rho_inf=0.8)
    assert (g.alpha_m, g.alpha_f) == pytest.approx((0.6 / 1.8, 0.8 / 1.8))
    assert g.gamma == pytest.approx(0.5 - g.alpha_m + g.alpha_f)
    assert g.beta == pytest.approx(0.25 * (1 - g.alpha_m + g.alpha_f) ** 2)
    s = make_integrator("hht", alpha=-0.1)
    assert (s.alpha_m, s.alpha_f, s.gamma, s.beta) == pytest.approx((0, 0.1, 0.6, 0.3025))
    assert isinstance(make_integrator("houbolt"), Houbolt)


@pytest.mark.parametrize("call, words", [
    (lambda: make_integrator("rk4"), ["rk4", "generalized_alpha", "hht", "houbolt", "newmark"]),
    (lambda: make_integrator("hht", rho_inf=0.5), ["rho_inf", "alpha"]),
    (lambda: make_integrator("houbolt", alpha=0.1), ["alpha", "none"]),
    (lambda: newmark(beta=0.6), ["beta", "[0, 0.5]"]),
    (lambda: newmark(gamma=0.4), ["gamma", "[0.5, 1]"]),
    (lambda: hht(0.1), ["alpha", "[-1/3, 0]"]),
    (lambda: hht(-0.5), ["alpha", "[-1/3, 0]"]),
    (lambda: generalized_alpha(1.5), ["rho_inf", "[0, 1]"]),
    (lambda: generalized_alpha(float("nan")), ["rho_inf", "[0, 1]"]),
    (lambda: make_integrator("generalized_alpha", rho_inf=-0.1), ["rho_inf", "[0, 1]"]),
])
def test_bad_names_and_parameters(call, words):
    # Interface contract: scene errors name the parameter / the allowed names and range.
    with pytest.raises(ValueError) as err:
        call()
    for w in words:
        assert w in str(err.value)


def test_integrate_rejects_bad_input():
    sys1 = lambda k: (np.eye(2), None, np.eye(2), None)  # noqa: E731
    with pytest.raises(ValueError, match="ndim"):
        integrate(sys1, 0.1, 3, np.zeros((1, 1, 2, 1)), np.zeros(2), newmark())
    with pytest.raises(ValueError, match="h ="):
        integrate(sys1, 0.0, 3, np.zeros(2), np.zeros(2), newmark())
    with pytest.raises(ValueError, match="n_steps"):
        integrate(sys1, 0.1, -1, np.zeros(2), np.zeros(2), newmark())


@st.composite
def linear_systems(draw):
    """Random batched time-varying systems (SPD mass), loads, initial states, a scalar."""
    seed = draw(st.integers(0, 2**32 - 1))
    n, batch = draw(st.integers(1, 4)), draw(st.integers(1, 3))
    rng = np.random.default_rng(seed)
    B = rng.normal(size=(batch, n, n))
    M0 = B @ np.swapaxes(B, -1, -2) + n * np.eye(n)
    M1, C0, K0, K1 = (rng.normal(size=(batch, n, n)) for _ in range(4))
    f1, f2 = rng.normal(size=(2, batch, n))
    x = rng.normal(size=(4, batch, n))
    return M0, 0.1 * M1, C0, K0, K1, f1, f2, x, draw(st.floats(-3, 3))


@settings(max_examples=30, deadline=None)
@given(linear_systems(), st.sampled_from(ALL))
def test_superposition(data, integrator):
    # The schemes are linear in (q0, v0, F) for given matrices: response(F1 + c F2, x1 + c x2)
    # = response(F1, x1) + c response(F2, x2).
    M0, M1, C0, K0, K1, f1, f2, (q1, v1, q2, v2), c = data
    h, n = 0.05, 12

    def system(f):
        return lambda k: (M0 + np.sin(k * h) * M1, (1 + k * h) * C0, K0 + np.cos(3 * k * h) * K1,
                          f * np.cos(k * h))
    r1 = integrate(system(f1), h, n, q1, v1, integrator)
    r2 = integrate(system(f2), h, n, q2, v2, integrator)
    r = integrate(system(f1 + c * f2), h, n, q1 + c * q2, v1 + c * v2, integrator)
    for x, x1, x2 in zip(r, r1, r2):
        scale = np.abs(x1).max() + abs(c) * np.abs(x2).max()
        np.testing.assert_allclose(x, x1 + c * x2, rtol=0, atol=1e-9 * scale)


@pytest.mark.parametrize("beta, gamma", [(0.0, 0.5), (0.1, 0.6), (0.2, 0.5), (0.0, 0.8)])
def test_stability_limit_is_where_the_spectral_radius_crosses_one(beta, gamma):
    # Newmark with 2β < γ: the amplification matrix's spectral radius stays ≤ 1 up to the
    # limit 1/√(γ/2 − β) and exceeds 1 beyond it (Hughes 2000, §9.1.2).
    scheme = newmark(beta, gamma)
    limit = stability_limit(scheme)
    assert limit == pytest.approx(1.0 / np.sqrt(gamma / 2 - beta))
    assert spectral_radius(scheme, 0.999 * limit) <= 1.0 + 1e-12
    assert spectral_radius(scheme, 1.001 * limit) > 1.0 + 1e-6
    assert stability_limit(newmark(gamma / 2, gamma)) == np.inf
    assert stability_limit(generalized_alpha(0.0)) == stability_limit(houbolt()) == np.inf
