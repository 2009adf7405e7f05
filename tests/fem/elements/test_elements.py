"""Verification of the link elements (ced.fem.elements) against closed-form beam results.

Beams are assembled here from the link matrices alone; boundary conditions delete DOFs.
References: Blevins, *Formulas for Natural Frequency and Mode Shape* (1979), table 8-1
(βL of uniform beams); Timoshenko (1921) / Han, Benaroya & Wei, J. Sound Vib. 225:935 (1999)
(simply supported Timoshenko beam); Wright, Smith, Thresher & Wang, J. Appl. Mech. 49:197
(1982) and Hodges & Rutkowski, AIAA J. 19:1459 (1981) (rotating cantilever).
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl
from hypothesis import given, settings, strategies as st
from scipy.optimize import brentq

from ced.fem import elements
from ced.fem.elements import euler_bernoulli as eb, rigid_body as rigid, timoshenko as tm

E, NU, RHO = 2.1e11, 0.3, 7850.0
G = E / (2 * (1 + NU))
WIDTH = 0.01


def section(h, b=WIDTH):
    return {"area": b * h, "second_moment": b * h**3 / 12, "height": h}


def build(module, L, ne, h=0.005, **kw):
    return module.link_matrices(L, ne, E=E, G_shear=G, rho=RHO, **section(h), **kw)


def dofs(lm, kinds=("u", "v", "t"), drop=()):
    """Kept DOF indices: node-wise kinds among u, v, t(heta), minus (node, kind) in drop."""
    nn = lm.n_elements + 1
    last = {-1: nn - 1}
    drop = {(last.get(n, n), k) for n, k in drop}
    return [3 * i + "uvt".index(k) for i in range(nn) for k in kinds if (i, k) not in drop]


def frequencies(K, M, keep, n=None):
    w2 = sl.eigh(K[np.ix_(keep, keep)], M[np.ix_(keep, keep)], eigvals_only=True)
    w = np.sqrt(np.clip(w2, 0, None))
    return w if n is None else w[:n]


def bending_scale(L, h):
    s = section(h)
    return np.sqrt(E * s["second_moment"] / (RHO * s["area"] * L**4))


# ---------------------------------------------------------------- Euler–Bernoulli, dynamics
L0_, H0_ = 0.5, 0.005
BETA_L = {  # Blevins table 8-1
    "pinned-pinned": np.pi * np.arange(1, 4),
    "clamped-free": np.array([1.87510407, 4.69409113, 7.85475744]),
    "free-free": np.array([4.73004074, 7.85320462, 10.9956078]),
}
BENDING_BCS = {"pinned-pinned": [(0, "v"), (-1, "v")], "clamped-free": [(0, "v"), (0, "t")],
               "free-free": []}


@pytest.mark.parametrize("bc", list(BETA_L))
def test_eb_bending_frequencies_8_elements(bc):
    lm = build(eb, L0_, 8)
    w = frequencies(lm.stiffness, lm.mass, dofs(lm, ("v", "t"), BENDING_BCS[bc]))
    if bc == "free-free":
        assert np.all(w[:2] < 1e-6 * w[2])  # rigid translation and rotation
        w = w[2:]
    err = w[:3] / (BETA_L[bc] ** 2 * bending_scale(L0_, H0_)) - 1
    # Measured with 8 elements: pinned 1.6e-5, 2.6e-4, 1.29e-3; clamped–free 2.1e-6, 8.0e-5,
    # 6.1e-4; free–free 8.1e-5, 5.8e-4, 2.11e-3. The third mode needs 10 elements for 0.1 %.
    assert np.all(np.abs(err[:2]) < 1e-3), err
    assert abs(err[2]) < 2.5e-3, err
    assert np.all(err > 0)  # consistent mass: Rayleigh–Ritz upper bounds
    lm = build(eb, L0_, 10)
    w = frequencies(lm.stiffness, lm.mass, dofs(lm, ("v", "t"), BENDING_BCS[bc]))
    w = w[2:] if bc == "free-free" else w
    assert np.all(np.abs(w[:3] / (BETA_L[bc] ** 2 * bending_scale(L0_, H0_)) - 1) < 1e-3)


def test_eb_convergence_rate_clamped_free():
    """First clamped–free frequency: error ∝ h^p with p = 2(p_poly + 1 − m) = 4."""
    exact = BETA_L["clamped-free"][0] ** 2 * bending_scale(L0_, H0_)
    ns = np.array([1, 2, 4, 8])
    err = []
    for ne in ns:
        lm = build(eb, L0_, ne)
        keep = dofs(lm, ("v", "t"), BENDING_BCS["clamped-free"])
        err.append(frequencies(lm.stiffness, lm.mass, keep, 1)[0] / exact - 1)
    p = -np.polyfit(np.log(ns), np.log(err), 1)[0]
    assert 3.5 < p < 4.5, (p, err)


def test_axial_bar_fixed_free():
    """Linear bar elements, consistent mass: the discrete spectrum is known in closed form,
    ω_n² = (6c²/h²)(1 − cos μ)/(2 + cos μ), μ = (2n − 1)π/(2 n_e) (the mesh dispersion
    relation with the free-end symmetry), an O(h²) overestimate of ω_n = (2n − 1)π c/(2L)."""
    c = np.sqrt(E / RHO)
    n = np.arange(1, 4)
    exact = (2 * n - 1) * np.pi / 2 * c / L0_
    for ne in (8, 64):
        lm = build(eb, L0_, ne)
        w = frequencies(lm.stiffness, lm.mass, dofs(lm, ("u",), [(0, "u")]), 3)
        mu, hh = (2 * n - 1) * np.pi / (2 * ne), L0_ / ne
        discrete = np.sqrt(6 * c**2 / hh**2 * (1 - np.cos(mu)) / (2 + np.cos(mu)))
        np.testing.assert_allclose(w, discrete, rtol=1e-10)
        if ne == 64:
            np.testing.assert_allclose(w, exact, rtol=1e-3)  # (kh)²/24 ≤ 6.3e-4 for n = 3


# ---------------------------------------------------------------- Euler–Bernoulli, statics
def static(lm, keep, f):
    q = np.zeros(lm.n_dofs)
    q[keep] = np.linalg.solve(lm.stiffness[np.ix_(keep, keep)], f[keep])
    return q


def test_simply_supported_uniform_load_midspan():
    q0, lm = 1000.0, build(eb, L0_, 8)
    EI = E * section(H0_)["second_moment"]
    q = static(lm, dofs(lm, ("v", "t"), BENDING_BCS["pinned-pinned"]), lm.load((0.0, q0)))
    mid = 3 * 4 + 1
    assert q[mid] == pytest.approx(5 * q0 * L0_**4 / (384 * EI), rel=1e-12)  # nodally exact


@pytest.mark.parametrize("peak, factor", [("root", 1 / 30), ("tip", 11 / 120)])
def test_cantilever_triangular_load_tip(peak, factor):
    """q(s) = q0(1 − s/L) (peak at the clamped root): δ = q0L⁴/(30EI); q(s) = q0 s/L (peak at
    the free tip): δ = 11q0L⁴/(120EI). Their sum is the uniform-load 15/120 = 1/8. Verified."""
    q0, lm = 1000.0, build(eb, L0_, 4)
    EI = E * section(H0_)["second_moment"]
    b0, b1 = ((0.0, q0), (0.0, -q0 / L0_)) if peak == "root" else ((0.0, 0.0), (0.0, q0 / L0_))
    q = static(lm, dofs(lm, ("v", "t"), BENDING_BCS["clamped-free"]), lm.load(b0, b1))
    assert q[lm.end_dofs[1][1]] == pytest.approx(factor * q0 * L0_**4 / EI, rel=1e-12)


def test_euler_buckling_load_from_geometric_stiffness():
    """det(K + P Kg0) = 0 at P = −π²EI/L² (compression), pinned–pinned."""
    lm = build(eb, L0_, 8)
    keep = dofs(lm, ("v", "t"), BENDING_BCS["pinned-pinned"])
    K, Kg = (a[np.ix_(keep, keep)] for a in (lm.stiffness, lm.geometric_stiffness[0]))
    p_cr = sl.eigh(K, Kg, eigvals_only=True)[0]  # K x = p Kg x, p = −P
    EI = E * section(H0_)["second_moment"]
    assert p_cr == pytest.approx(np.pi**2 * EI / L0_**2, rel=1e-4)


# ---------------------------------------------------------------- recovery
def test_recovery_exact_fields_eb_and_timoshenko():
    """Tip moment M0 → θ' = M0/EI everywhere; axial tip force N → u' = N/EA everywhere;
    tip shear force F on Timoshenko → γ = F/κGA everywhere (IIE reproduces these exactly)."""
    stations = np.linspace(0, 1, 11)
    for module in (eb, tm):
        lm = build(module, L0_, 5, h=0.05)
        s = section(0.05)
        EI, EA = E * s["second_moment"], E * s["area"]
        keep = dofs(lm, drop=[(0, "u"), (0, "v"), (0, "t")])
        f = np.zeros(lm.n_dofs)
        f[lm.end_rotations[1]], f[lm.end_dofs[1][0]] = 3.0, 5.0e4
        ops = module.recovery_matrices(lm, stations)
        q = static(lm, keep, f)
        np.testing.assert_allclose(ops["curvature"] @ q, 3.0 / EI, rtol=1e-9)
        np.testing.assert_allclose(ops["axial_strain"] @ q, 5.0e4 / EA, rtol=1e-9)
        np.testing.assert_allclose(ops["v"] @ q, 3.0 / EI * (stations * L0_) ** 2 / 2, rtol=1e-9)
    f = np.zeros(lm.n_dofs)
    f[lm.end_dofs[1][1]] = 100.0
    q = static(lm, keep, f)
    gamma = tm.recovery_matrices(lm, stations)["shear_strain"] @ q
    np.testing.assert_allclose(gamma, 100.0 / (tm.DEFAULT_SHEAR_COEFFICIENT * G * s["area"]),
                               rtol=1e-9)


def test_recovery_curvature_on_and_between_nodes():
    """Uniform load q on a simply supported beam: exact v(s) = q s (L³ − 2Ls² + s³)/(24EI),
    v'' = q s (s − L)/(2EI). The element curvature is the L2 projection of that parabola on
    linears, so it is exact at the Gauss–Legendre points ξ = 1/2 ± √3/6 and off by
    −qh²/(12EI) at both element ends (the projection of ξ² on {1, ξ} is ξ − 1/6). Recovery
    through the Gauss points (a quadratic through the nearest three) is therefore exact
    everywhere, nodes and link ends included, where reading the element field is not."""
    q0, ne, lm = 1000.0, 8, build(eb, L0_, 8)
    EI, h = E * section(H0_)["second_moment"], L0_ / 8
    q = static(lm, dofs(lm, ("v", "t"), BENDING_BCS["pinned-pinned"]), lm.load((0.0, q0)))
    kappa_exact = lambda s: q0 * s * (s - L0_) / (2 * EI)  # noqa: E731
    xi = np.linspace(0, 1, 11)
    s = xi * L0_
    ops = eb.recovery_matrices(lm, xi)
    v_exact = q0 * s * (L0_**3 - 2 * L0_ * s**2 + s**3) / (24 * EI)
    np.testing.assert_allclose(ops["v"] @ q, v_exact, rtol=0, atol=1e-4 * v_exact.max())
    scale = np.abs(kappa_exact(0.5 * L0_))
    nodes = np.arange(ne + 1) / ne
    for where in (xi, nodes, np.linspace(0, 1, 37)):
        np.testing.assert_allclose(eb.recovery_matrices(lm, where)["curvature"] @ q,
                                   kappa_exact(where * L0_), rtol=0, atol=1e-9 * scale)
    # The element field itself: exact at the Gauss points, −qh²/12EI at the nodes.
    from ced.fem.elements.link import recovery_operators
    raw = recovery_operators(eb.shape_functions, lm, nodes, {"curvature": "kappa"})
    np.testing.assert_allclose(raw["curvature"] @ q, kappa_exact(nodes * L0_)
                               - q0 * h**2 / (12 * EI), rtol=1e-9)
    gauss = ((np.arange(ne)[:, None] + 0.5 + np.array([-1, 1]) * np.sqrt(3) / 6) / ne).ravel()
    raw = recovery_operators(eb.shape_functions, lm, gauss, {"curvature": "kappa"})
    np.testing.assert_allclose(raw["curvature"] @ q, kappa_exact(gauss * L0_), rtol=1e-9)


def test_recovered_curvature_converges_at_third_order():
    """Cantilever under a linearly varying load (exact curvature cubic): the recovered
    curvature at fixed stations converges as O(h³), smoothly (each halving divides the error
    by about 8), where the element field alone converges erratically."""
    L, EI, q1 = L0_, E * section(H0_)["second_moment"], 1000.0
    xi = np.linspace(0, 1, 11)
    # q(s) = q1 s/L on a cantilever clamped at 0: M(s) = q1 (L − s)² (2L + s)/(6L).
    kappa_exact = q1 * (L - xi * L) ** 2 * (2 * L + xi * L) / (6 * L * EI)
    errors = []
    for ne in (4, 8, 16, 32):
        lm = build(eb, L, ne)
        f = lm.load((0.0, 0.0), (0.0, q1 / L))  # consistent load of q(s) = q1 s/L
        q = static(lm, dofs(lm, ("v", "t"), BENDING_BCS["clamped-free"]), f)
        kappa = eb.recovery_matrices(lm, xi)["curvature"] @ q
        errors.append(np.abs(kappa - kappa_exact).max() / np.abs(kappa_exact).max())
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert (rates > 2.7).all(), rates


def test_rigid_recovery_and_dispatch():
    lm = elements.link_matrices("rigid", 0.4, None, rho=RHO, **section(0.01))
    ops = elements.recovery_matrices(lm, [0.0, 0.5, 1.0])
    q = np.array([1e-3, 2e-3, 1e-2])
    np.testing.assert_allclose(ops["v"] @ q, 2e-3 + np.array([0, 0.2, 0.4]) * 1e-2)
    np.testing.assert_allclose(ops["u"] @ q, 1e-3)
    assert not ops["curvature"].any()
    with pytest.raises(ValueError, match="allowed"):
        elements.formulation("plate")


# ---------------------------------------------------------------- Timoshenko
def timoshenko_pinned_exact(L, h, n=1, kappa=5 / 6):
    """Lower root ω of the simply supported Timoshenko beam, w = W sin kx, ψ = Ψ cos kx,
    k = nπ/L: (κGAk² − ρAω²)(EIk² + κGA − ρIω²) = (κGAk)² (Timoshenko 1921; Han et al. 1999)."""
    s = section(h)
    A, I = s["area"], s["second_moment"]
    k, kGA = n * np.pi / L, kappa * G * s["area"]
    # Expanded in ω²: a ω⁴ + b ω² + c = 0.
    a = RHO * A * RHO * I
    b = -(RHO * A * (E * I * k**2 + kGA) + RHO * I * kGA * k**2)
    c = kGA * E * I * k**4
    return np.sqrt((-b - np.sqrt(b * b - 4 * a * c)) / (2 * a))


def test_timoshenko_slender_equals_euler_bernoulli():
    L, h = 0.5, 0.005  # L/h = 100
    w_t, w_e = (frequencies(m.stiffness, m.mass,
                            dofs(m, ("v", "t"), BENDING_BCS["pinned-pinned"]), 3)
                for m in (build(tm, L, 8, h), build(eb, L, 8, h)))
    # Measured: 1 − w_t/w_e = 1.7e-4, 6.5e-4, 1.4e-3 for modes 1-3 (≈ (nπr/L)²(1 + E/κG)/2).
    assert abs(w_t[0] / w_e[0] - 1) < 5e-4
    assert np.all(w_t < w_e)  # shear and rotary inertia both lower the frequencies


def test_timoshenko_stubby_pinned_frequency():
    L, h = 0.15, 0.05  # L/h = 3
    lm = build(tm, L, 8, h)
    w = frequencies(lm.stiffness, lm.mass, dofs(lm, ("v", "t"), BENDING_BCS["pinned-pinned"]), 1)[0]
    exact = timoshenko_pinned_exact(L, h)
    assert w == pytest.approx(exact, rel=1e-2)  # measured 1.3e-3
    assert w < 0.9 * np.pi**2 * bending_scale(L, h)  # measured 0.859 × Euler–Bernoulli


def test_timoshenko_stubby_convergence_rate():
    """With significant shear the IIE frequency error is O(h²), not O(h⁴): the shear strain
    is constant per element, so its energy-norm error is O(h) (eigenvalue error = its square)."""
    L, h = 0.15, 0.05
    ns, exact = np.array([4, 8, 16]), timoshenko_pinned_exact(L, h)
    err = []
    for ne in ns:
        lm = build(tm, L, ne, h)
        keep = dofs(lm, ("v", "t"), BENDING_BCS["pinned-pinned"])
        err.append(frequencies(lm.stiffness, lm.mass, keep, 1)[0] / exact - 1)
    p = -np.polyfit(np.log(ns), np.log(err), 1)[0]
    assert 1.8 < p < 2.2, (p, err)


@pytest.mark.parametrize("slenderness", [3.0, 1000.0])
def test_timoshenko_no_shear_locking(slenderness):
    """One element, tip load F: δ = FL³/(3EI) + FL/(κGA) exactly; a locking element would be
    orders of magnitude stiffer for L/h = 1000."""
    L, F = 0.5, 10.0
    h = L / slenderness
    s = section(h)
    EI, kGA = E * s["second_moment"], 5 / 6 * G * s["area"]
    tips = {}
    for module in (tm, eb):
        lm = build(module, L, 1, h)
        f = np.zeros(6)
        f[4] = F
        tips[module] = static(lm, [4, 5], f)[4]
    assert tips[tm] == pytest.approx(F * L**3 / (3 * EI) + F * L / kGA, rel=1e-10)
    assert tips[eb] == pytest.approx(F * L**3 / (3 * EI), rel=1e-12)
    if slenderness > 100:
        assert tips[tm] == pytest.approx(tips[eb], rel=1e-6)


def test_timoshenko_reduces_to_euler_bernoulli_with_rotary_inertia():
    lt = tm.link_matrices(0.3, 3, E=E, G_shear=G * 1e12, rho=RHO, **section(0.02))
    le = eb.link_matrices(0.3, 3, E=E, rho=RHO, **section(0.02), rotary_inertia=True)
    for name in ("mass", "translational_mass", "stiffness", "gyroscopic", "geometric_stiffness",
                 "load_constant", "load_linear", "moment_load"):
        a, b = getattr(lt, name), getattr(le, name)
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9 * np.abs(b).max(), err_msg=name)


# ---------------------------------------------------------------- rotating cantilever
def rotating_cantilever_flap(lam, n_terms=300):
    """First flapwise ω√(ρAL⁴/EI) of a cantilever rotating about its root, zero hub radius, by
    the Frobenius series of v'''' − (Pv')' = ω²v with P = λ²(1 − x²)/2, x = s/L (the method of
    Wright et al. 1982)."""
    l2 = lam * lam

    def det(w):
        ends = []
        for start in (2, 3):  # clamped root: v = v' = 0
            a = np.zeros(n_terms + 4)
            a[start] = 1.0
            for k in range(n_terms):
                rhs = (l2 / 2 * ((k + 2) * (k + 1) * a[k + 2] - k * (k - 1) * a[k])
                       - l2 * k * a[k] + w * w * a[k])  # x^k coefficient of (Pv')' + ω²v
                a[k + 4] = rhs / ((k + 4) * (k + 3) * (k + 2) * (k + 1))
            k = np.arange(a.size)
            ends.append(((k * (k - 1) * a).sum(), (k * (k - 1) * (k - 2) * a).sum()))
        return ends[0][0] * ends[1][1] - ends[0][1] * ends[1][0]  # free tip: v'' = v''' = 0

    grid = np.linspace(1.0, 4.0 + 1.2 * lam, 400)
    d = np.array([det(w) for w in grid])
    i = np.flatnonzero(np.sign(d[:-1]) != np.sign(d[1:]))[0]
    return brentq(det, grid[i], grid[i + 1], xtol=1e-13)


# Wright et al. (1982) table 1 / Hodges & Rutkowski (1981): first flapwise mode, zero hub.
FLAP_TABLE = {0.0: 3.5160, 2.0: 4.1373, 5.0: 6.4495, 10.0: 11.2023}


@pytest.mark.parametrize("lam", sorted(FLAP_TABLE))
def test_rotating_cantilever_in_plane(lam):
    """In-plane bending of a cantilever spinning at Ω about its clamped root: the floating
    frame gives (K + Kg[P] − Ω²M_w) q = ω² M q with P = ρAΩ²(L² − s²)/2. For the transverse
    field this is the flapwise operator shifted by −Ω², so ω̄²_in-plane = ω̄²_flap − λ²
    (λ = Ω√(ρAL⁴/EI)). Coriolis (2ΩG, axial–lag coupling) is not part of this eigenproblem.
    Measured (8 elements): 2e-6, 2.5e-6, 1.9e-5, 2.3e-4 for λ = 0, 2, 5, 10. The constant-K1
    formula ω̄² = ω̄0² + 0.193λ² is a low-speed law only: 1.8 % off at λ = 5, 11 % at λ = 10."""
    L, h = 0.5, 0.005
    s = section(h)
    rhoA = RHO * s["area"]
    scale = bending_scale(L, h)
    Om = lam * scale
    lm = build(eb, L, 8, h)
    Kg = lm.axial_force_stiffness(rhoA * Om**2 * L**2 / 2, 0.0, -rhoA * Om**2 / 2)
    keep = dofs(lm, drop=[(0, "u"), (0, "v"), (0, "t")])  # full: axial DOFs softened too
    w = frequencies(lm.stiffness + Kg - Om**2 * lm.translational_mass, lm.mass, keep, 1)[0] / scale
    flap = rotating_cantilever_flap(lam)
    assert flap == pytest.approx(FLAP_TABLE[lam], abs=1e-4)  # the series reproduces the table
    assert w == pytest.approx(np.sqrt(flap**2 - lam**2), rel=1e-3)


def test_southwell_coefficient_small_speed():
    """ω̄² = ω̄0² + (K1 − 1)λ² for small λ, K1 = 1.193 flapwise (Southwell); in-plane K1 − 1."""
    L, h, lam = 0.5, 0.005, 0.5
    lm = build(eb, L, 8, h)
    scale, rhoA = bending_scale(L, h), RHO * section(h)["area"]
    keep = dofs(lm, drop=[(0, "u"), (0, "v"), (0, "t")])
    w = []
    for la in (0.0, lam):
        Om = la * scale
        Kg = lm.axial_force_stiffness(rhoA * Om**2 * L**2 / 2, 0.0, -rhoA * Om**2 / 2)
        K_eff = lm.stiffness + Kg - Om**2 * lm.translational_mass
        w.append(frequencies(K_eff, lm.mass, keep, 1)[0] / scale)
    k1 = (w[1] ** 2 - w[0] ** 2) / lam**2 + 1
    assert k1 == pytest.approx(1.193, abs=2e-3)


# ---------------------------------------------------------------- structure (hypothesis)
def rigid_modes(lm):
    """(n, 3) beam DOFs of the rigid field (u0, v0 + sφ), θ = φ."""
    s = lm.node_positions
    T = np.zeros((lm.n_dofs, 3))
    T[0::3, 0] = 1.0
    T[1::3, 1], T[1::3, 2] = 1.0, s
    T[2::3, 2] = 1.0
    return T


@settings(max_examples=40, deadline=None)
@given(L=st.floats(0.05, 2.0), ne=st.integers(1, 16), h_frac=st.floats(0.002, 0.3),
       module=st.sampled_from([eb, tm]))
def test_structure_and_rigid_body_consistency(L, ne, h_frac, module):
    kw = {"rotary_inertia": True}
    lm = build(module, L, ne, h=h_frac * L, **kw)
    for a in (lm.mass, lm.translational_mass, lm.stiffness, *lm.geometric_stiffness):
        np.testing.assert_allclose(a, a.T, rtol=0, atol=1e-12 * np.abs(a).max())
    np.testing.assert_allclose(lm.gyroscopic, -lm.gyroscopic.T, atol=1e-15)
    assert np.linalg.eigvalsh(lm.mass)[0] > 0
    # Exactly three rigid-body zero modes (scaled so axial and bending terms are comparable).
    d = 1 / np.sqrt(np.diag(lm.stiffness))
    ev = np.linalg.eigvalsh(d[:, None] * lm.stiffness * d)
    assert np.sum(ev < 1e-9 * ev[-1]) == 3 and ev[3] > 1e-7 * ev[-1]
    # The beam projected on its rigid field equals the rigid link, term by term.
    T = rigid_modes(lm)
    rl = rigid.link_matrices(L, rho=RHO, **section(h_frac * L))
    np.testing.assert_allclose(lm.stiffness @ T, 0, atol=1e-9 * np.abs(lm.stiffness).max())
    for name in ("mass", "translational_mass", "gyroscopic"):
        np.testing.assert_allclose(T.T @ getattr(lm, name) @ T, getattr(rl, name), rtol=1e-10,
                                   atol=1e-14, err_msg=name)
    np.testing.assert_allclose(T.T @ lm.geometric_stiffness @ T, rl.geometric_stiffness,
                               rtol=1e-10, atol=1e-12 * max(L, L**3))
    for name in ("load_constant", "load_linear", "moment_load"):
        np.testing.assert_allclose(T.T @ getattr(lm, name), getattr(rl, name), rtol=1e-10,
                                   atol=1e-14, err_msg=name)
    # Uniform load sums to the total force; the linear part to its first moment.
    np.testing.assert_allclose(lm.load_constant[0::3, 0].sum(), L, rtol=1e-12)
    np.testing.assert_allclose(lm.load_constant[1::3, 1].sum(), L, rtol=1e-12)
    np.testing.assert_allclose(lm.load_linear[1::3, 1].sum(), L**2 / 2, rtol=1e-12)


def test_rigid_link_closed_form():
    L, s = 0.3, section(0.01)
    rl = rigid.link_matrices(L, rho=RHO, **s)
    m, J = RHO * s["area"], RHO * s["second_moment"]
    np.testing.assert_allclose(rl.mass, m * np.array([[L, 0, 0], [0, L, L**2 / 2],
                                                      [0, L**2 / 2, L**3 / 3]])
                               + np.diag([0, 0, J * L]))
    np.testing.assert_allclose(rl.gyroscopic, m * np.array([[0, -L, -L**2 / 2], [L, 0, 0],
                                                            [L**2 / 2, 0, 0]]))
    np.testing.assert_allclose(rl.geometric_stiffness[:, 2, 2], [L, L**2 / 2, L**3 / 3])
    assert not rl.stiffness.any()


def test_batch_broadcasting_matches_single_builds():
    lengths, heights = np.array([0.2, 0.35, 0.5]), np.array([0.004, 0.006, 0.01])
    for module in (eb, tm, rigid):
        batch = module.link_matrices(lengths, 4, E=E, G_shear=G, rho=RHO, area=WIDTH * heights,
                                     second_moment=WIDTH * heights**3 / 12)
        ops = module.recovery_matrices(batch, np.linspace(0, 1, 5))
        for i, (L, h) in enumerate(zip(lengths, heights)):
            one = build(module, L, 4, h)
            for name in ("mass", "stiffness", "gyroscopic", "geometric_stiffness", "load_linear"):
                np.testing.assert_allclose(getattr(batch, name)[i], getattr(one, name),
                                           rtol=1e-13, atol=1e-300)
            single = module.recovery_matrices(one, np.linspace(0, 1, 5))
            for key in single:
                np.testing.assert_allclose(ops[key][i], single[key], rtol=1e-13)
