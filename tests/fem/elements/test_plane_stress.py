"""Verification of the plane-stress continuum link (ced.fem.elements.plane_stress).

Links are assembled here from the link matrices alone; boundary conditions delete DOFs.
References: beam theory for slender links (Euler–Bernoulli tip deflection PL³/3EI, Blevins
(1979) table 8-1 βL = 1.87510 for the first clamped-free mode, Euler load π²EI/L²),
Timoshenko's tip deflection PL³/3EI + PL/(κGA) for stubby links (κ = 5/6, or Cowper's
10(1 + ν)/(12 + 11ν) for a rectangle, Cowper 1966 J. Appl. Mech. 33:335), and the
Euler–Bernoulli element of ced for the rotating cantilever (tested against Wright et al. in
test_elements.py).
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl

from ced.fem import elements
from ced.fem.elements import euler_bernoulli as eb
from ced.fem.elements import plane_stress as ps
from ced.fem.elements import timoshenko as tm

E, NU, RHO, WIDTH = 2.1e11, 0.3, 7850.0, 0.01
G = E / (2 * (1 + NU))
KAPPA_COWPER = 10 * (1 + NU) / (12 + 11 * NU)
H = 0.01  # in-plane height, m


def section(h=H, b=WIDTH):
    return {"area": b * h, "second_moment": b * h**3 / 12, "height": h}


def build(L, ne, na=2, npe=8, h=H, **kw):
    return ps.link_matrices(L, ne, E=E, G_shear=G, rho=RHO, elements_across=na,
                            nodes_per_element=npe, **section(h), **kw)


def clamped_keep(lm):
    """DOFs left when the face at s = 0 is clamped (pin 0 and the face deformation held)."""
    fixed = set(lm.end_dofs[0]) | set(lm.end_rotations[0])
    return [i for i in range(lm.n_dofs) if i not in fixed]


def tip_deflection(lm, P=1.0):
    keep = clamped_keep(lm)
    f = np.zeros(lm.n_dofs)
    f[lm.end_dofs[1][1]] = P  # transverse force on pin L: a uniform traction on the end face
    q = np.zeros(lm.n_dofs)
    q[keep] = np.linalg.solve(lm.stiffness[np.ix_(keep, keep)], f[keep])
    return q


def frequencies(K, M, keep, n=1):
    w2 = sl.eigh(K[np.ix_(keep, keep)], M[np.ix_(keep, keep)], eigvals_only=True,
                 subset_by_index=[0, n - 1])
    return np.sqrt(w2)


def beam_constants(L, h=H):
    s = section(h)
    EI, A = E * s["second_moment"], s["area"]
    return {"eb": L**3 / (3 * EI), "shear": L / (KAPPA_COWPER * G * A),
            "shear_56": L / (5 / 6 * G * A),
            "w1": 1.87510407**2 * np.sqrt(EI / (RHO * A * L**4))}


# ------------------------------------------------------------------------- registration
def test_registered_as_a_formulation():
    assert elements.formulation("plane_stress") is ps
    lm = elements.link_matrices("plane_stress", 0.2, 4, E=E, G_shear=G, rho=RHO, **section())
    assert lm.formulation == "plane_stress"
    ops = elements.recovery_matrices(lm, np.linspace(0, 1, 5))
    assert {"u", "v", "rotation", "curvature", "axial_strain"} <= set(ops)


# -------------------------------------------------------------------- static beam limits
@pytest.mark.parametrize("npe", [8, 9])
def test_slender_cantilever_tip_deflection_converges_to_beam_theory(npe):
    # L/h = 20: the shear part of the deflection is 3EI/(κGAL²) ≈ 0.2 %, so beam theory is
    # the reference; a 10 × 2 mesh is within 0.6 % and 20 × 2 within 0.3 % (measured 0.995,
    # 0.997 of Timoshenko for 8 nodes). The clamped root face (no Poisson contraction) keeps
    # the continuum ≈ 0.1 % stiffer than Timoshenko even on fine meshes.
    L = 20 * H
    c = beam_constants(L)
    tim = c["eb"] + c["shear"]
    errors = []
    for ne in (10, 20):
        lm = build(L, ne, 2, npe)
        tip = tip_deflection(lm)[lm.end_dofs[1][1]]
        errors.append(abs(tip / tim - 1))
        assert abs(tip / c["eb"] - 1) < 0.01
    assert errors[0] < 0.006 and errors[1] < 0.003
    assert errors[1] < errors[0]  # converging


def test_slender_cantilever_first_frequency_matches_euler_bernoulli():
    # 1.87510² √(EI/ρAL⁴) (Blevins 8-1); shear and rotary inertia lower it by ~0.2 % at
    # L/h = 20, the 10 × 2 mesh raises it by a similar amount: measured 1.0016 and 0.9998.
    L = 20 * H
    w1 = beam_constants(L)["w1"]
    for ne, tol in ((10, 0.01), (20, 0.003)):
        lm = build(L, ne)
        keep = clamped_keep(lm)
        assert abs(frequencies(lm.stiffness, lm.mass, keep)[0] / w1 - 1) < tol


def test_stubby_cantilever_follows_timoshenko_not_euler_bernoulli():
    # L/h = 3: Timoshenko's shear term PL/(κGA) is 8.7 % (κ = 5/6) of the bending term for
    # ν = 0.3 — not the > 10 % a coarser argument suggests; the continuum's clamped face is a
    # little stiffer than Timoshenko's root, so it lands 7.8–7.9 % above EB (measured 1.0779)
    # and within 1 % of Timoshenko (0.992 with κ = 5/6, 0.993 with Cowper's κ).
    L = 3 * H
    c = beam_constants(L)
    lm = build(L, 12, 4)
    tip = tip_deflection(lm)[lm.end_dofs[1][1]]
    assert abs(tip / (c["eb"] + c["shear_56"]) - 1) < 0.015
    assert abs(tip / (c["eb"] + c["shear"]) - 1) < 0.015
    assert tip / c["eb"] - 1 > 0.06
    # First frequency: the Timoshenko beam (Cowper κ, rotary inertia) within 1 % (1.0047).
    t = tm.link_matrices(L, 64, E=E, G_shear=G, rho=RHO, shear_coefficient=KAPPA_COWPER,
                         **section())
    w_t = frequencies(t.stiffness, t.mass, list(range(3, t.n_dofs)))[0]
    w_p = frequencies(lm.stiffness, lm.mass, clamped_keep(lm))[0]
    assert abs(w_p / w_t - 1) < 0.01
    assert w_p / c["w1"] < 0.95  # Euler–Bernoulli is 7 % too high


# ------------------------------------------------------------------ structure of the matrices
@pytest.mark.parametrize("npe,na", [(8, 1), (8, 2), (9, 2), (8, 3)])
def test_free_link_has_exactly_three_rigid_modes(npe, na):
    lm = build(0.2, 6, na, npe)
    K = lm.stiffness
    lam = np.linalg.eigvalsh(K)
    assert np.count_nonzero(np.abs(lam) < 1e-9 * lam.max()) == 3
    R = ps.rigid_modes(lm)
    assert np.abs(K @ R).max() < 1e-9 * np.abs(K).max() * np.abs(R).max()
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-12 * np.abs(K).max())


def test_mass_gyroscopic_and_rigid_body_integrals():
    L = 0.2
    lm = build(L, 6, 2, 9)
    M, G_ = lm.mass, lm.gyroscopic
    np.testing.assert_allclose(M, M.T, atol=1e-15 * np.abs(M).max())
    assert np.linalg.eigvalsh(M).min() > 0  # positive definite
    np.testing.assert_array_equal(lm.translational_mass, M)  # the continuum has no θ DOFs
    np.testing.assert_allclose(G_, -G_.T, atol=1e-15 * np.abs(G_).max())
    R = ps.rigid_modes(lm)
    s = section()
    rhoA, m = RHO * s["area"], RHO * s["area"] * L
    # Mass, first moment and inertia about pin 0 (ρA L³/3 + ρI L with I = t h³/12).
    np.testing.assert_allclose(R.T @ M @ R, [[m, 0, 0], [0, m, m * L / 2],
                                             [0, m * L / 2, rhoA * L**3 / 3
                                              + RHO * s["second_moment"] * L]], rtol=1e-12,
                               atol=1e-12 * m * L**2)
    # G_ij = ∫ρ N_i·J N_j: e_x·J e_y = −1.
    np.testing.assert_allclose(R[:, 0] @ G_ @ R[:, 1], -m, rtol=1e-12)


def test_loads_have_the_right_resultants():
    L = 0.3
    lm = build(L, 5, 3)
    R = ps.rigid_modes(lm)
    s = section()
    # Uniform unit load (N/m) along x and y: resultant L, moment about pin 0 L²/2 (y only).
    np.testing.assert_allclose(R.T @ lm.load_constant, [[L, 0], [0, L], [0, L**2 / 2]],
                               atol=1e-14)
    np.testing.assert_allclose(R.T @ lm.load_linear, [[L**2 / 2, 0], [0, L**2 / 2],
                                                      [0, L**3 / 3]], atol=1e-14)
    # The face DOFs are relative: the plain sum is not the resultant (see rigid_modes).
    # Distributed couple: m0 × moment_load has no resultant and the moment m0 L.
    np.testing.assert_allclose(R.T @ lm.moment_load, [0, 0, L], atol=1e-12)
    # m0 = −ρIα (what ked passes with rotary inertia) reproduces ρα∫N_uᵀ y t dA exactly.
    alpha = 3.7
    np.testing.assert_allclose(-RHO * s["second_moment"] * alpha * lm.moment_load,
                               RHO * alpha * lm.across_load[:, 0], rtol=1e-12, atol=1e-20)
    # The across stretch ∫N_vᵀ y t dA: no resultant, virtual work on d = (0, y) is I L.
    assert np.abs(R[:, :2].T @ lm.across_load).max() < 1e-18
    stretch = np.linalg.solve(lm.transform, np.stack(
        [np.zeros(len(lm.node_coordinates)), lm.node_coordinates[:, 1]], -1).ravel())
    np.testing.assert_allclose(stretch @ lm.across_load[:, 1], s["second_moment"] * L,
                               rtol=1e-12)


# ----------------------------------------------------------------------------- the pin tie
def test_pin_translation_moves_its_whole_face():
    lm = build(0.2, 4, 2)
    xy = lm.node_coordinates
    for end, x_face in ((0, 0.0), (1, 0.2)):
        for comp in range(2):
            q = np.zeros(lm.n_dofs)
            q[lm.end_dofs[end][comp]] = 1.0
            d = (lm.transform @ q).reshape(-1, 2)
            on_face = np.isclose(xy[:, 0], x_face)
            np.testing.assert_allclose(d[on_face, comp], 1.0)
            np.testing.assert_allclose(d[on_face, 1 - comp], 0.0)
            assert np.abs(d[~on_face]).max() == 0.0
    # ... and the pin is the consistent weighted mean of the face (the tie's definition),
    # weights ∫N_i dy/h = (1, 4, 1)/6 per quadratic edge, for any field.
    q = np.random.default_rng(0).normal(size=lm.n_dofs)
    d = (lm.transform @ q).reshape(-1, 2)
    face = np.isclose(xy[:, 0], 0.0)
    w = _face_weights(2)
    np.testing.assert_allclose(w @ d[face, 1], q[lm.end_dofs[0][1]], rtol=1e-12)


def _face_weights(na):
    w = np.zeros(2 * na + 1)
    for k in range(na):
        w[2 * k: 2 * k + 3] += np.array([1.0, 4.0, 1.0]) / (6.0 * na)
    return w


def test_pins_carry_no_moment():
    L = 0.2
    lm = build(L, 6, 2)
    K, n = lm.stiffness, lm.n_dofs
    rot = ps.rigid_modes(lm)[:, 2]  # unit rotation about pin 0
    # Pin 0 stays put, pin L moves (0, L), the face deformation DOFs take the rotation ...
    np.testing.assert_allclose(rot[list(lm.end_dofs[0])], 0.0, atol=1e-15)
    np.testing.assert_allclose(rot[list(lm.end_dofs[1])], [0.0, L], atol=1e-15)
    assert np.abs(rot[list(lm.end_rotations[0])]).max() > 0.1 * 0.5 * H
    # ... at no energy: holding pin 0 leaves exactly one mechanism (rotation about it).
    assert abs(rot @ K @ rot) < 1e-12 * np.abs(K).max()
    keep = [i for i in range(n) if i not in lm.end_dofs[0]]
    lam = np.linalg.eigvalsh(K[np.ix_(keep, keep)])
    assert np.count_nonzero(np.abs(lam) < 1e-9 * lam.max()) == 1
    # Pinned–pinned (pin 0 fixed, pin L on a roller) is stable; so is a clamped face.
    for fixed in ((0, 1, n - 1), tuple(lm.end_dofs[0]) + lm.end_rotations[0]):
        keep = [i for i in range(n) if i not in fixed]
        lam = np.linalg.eigvalsh(K[np.ix_(keep, keep)])
        assert lam.min() > 1e-9 * lam.max()


def test_end_rotations_are_the_face_deformation_dofs():
    na = 3
    lm = build(0.2, 4, na)
    m = 2 * na + 1  # nodes on a face; the centre one is replaced by the pin
    for face in lm.end_rotations:
        assert len(face) == 2 * (m - 1)
        assert not set(face) & {i for pair in lm.end_dofs for i in pair}
    assert lm.end_rotations[0][0] == 2 and lm.end_rotations[1][-1] == lm.n_dofs - 3


# --------------------------------------------------------------------- geometric stiffness
def test_pinned_pinned_buckling_load():
    # K + P Kg_0 singular at the Euler load π²EI/L², lowered by shear to P_E/(1 + P_E/κGA)
    # (0.6 % at L/h = 20): measured 0.9938 P_E and 1.0002 of the shear-corrected value.
    L = 20 * H
    s = section()
    PE = np.pi**2 * E * s["second_moment"] / L**2
    lm = build(L, 10, 2)
    n = lm.n_dofs
    keep = [i for i in range(n) if i not in (0, 1, n - 1)]
    mu = sl.eigh(lm.geometric_stiffness[0][np.ix_(keep, keep)],
                 lm.stiffness[np.ix_(keep, keep)], eigvals_only=True)
    P_cr = 1.0 / mu.max()
    assert abs(P_cr / (PE / (1 + PE / (5 / 6 * G * s["area"]))) - 1) < 0.005
    assert abs(P_cr / PE - 1) < 0.01


def test_rotating_cantilever_matches_euler_bernoulli():
    # K − Ω²M_w + Σ N_k Kg_k with the centrifugal axial force N(s) = ρAΩ²(L² − s²)/2
    # exercises the s⁰ and s² bases. At L/h = 20 the continuum and EB agree within 1 % up to Ω = 3ω₁
    # (measured 0.9996, 0.9956); beyond, the continuum's sectional spin softening −Ω²ρI∫ψ²
    # (absent from EB) grows: 0.98 at 6ω₁.
    L = 20 * H
    s = section()
    rhoA = RHO * s["area"]
    w1 = beam_constants(L)["w1"]
    lp = build(L, 20, 2)
    le = eb.link_matrices(L, 40, E=E, rho=RHO, **s)

    def first(lm, keep, Om):
        K = (lm.stiffness - Om**2 * lm.translational_mass
             + lm.axial_force_stiffness(rhoA * Om**2 * L**2 / 2, 0.0, -rhoA * Om**2 / 2))
        return frequencies(K, lm.mass, keep)[0]

    for Om in (w1, 3 * w1):
        wp = first(lp, clamped_keep(lp), Om)
        we = first(le, list(range(3, le.n_dofs)), Om)
        assert abs(wp / we - 1) < 0.01
        assert wp > 1.05 * w1  # stiffened


# ------------------------------------------------------------------------------- recovery
def test_recovery_of_a_tip_loaded_cantilever():
    # Beam values away from the ends (Saint-Venant): v'' = M/EI = P(L − x)/EI, fibre strain
    # ∓ v'' h/2 at y = ±h/2, no axial strain; centre-line v within 0.5 % (of the tip value)
    # of Timoshenko's
    # v(x) = P(Lx²/2 − x³/6)/EI + Px/(κGA).
    L = 20 * H
    s = section()
    EI = E * s["second_moment"]
    lm = build(L, 20, 2)
    q = tip_deflection(lm, P=100.0)
    st = np.array([0.25, 0.5, 0.75])
    ops = ps.recovery_matrices(lm, st)
    x = st * L
    kappa = 100.0 * (L - x) / EI
    np.testing.assert_allclose(ops["curvature"] @ q, kappa, rtol=0.01)
    np.testing.assert_allclose(ops["strain_top"] @ q, -kappa * H / 2, rtol=0.01)
    np.testing.assert_allclose(ops["strain_bottom"] @ q, kappa * H / 2, rtol=0.01)
    assert np.abs(ops["axial_strain"] @ q).max() < 1e-3 * kappa.max() * H / 2
    v = 100.0 * (L * x**2 / 2 - x**3 / 6) / EI + 100.0 * x / (KAPPA_COWPER * G * s["area"])
    # (The restrained root face keeps the shear part ~1 % smaller near the root: compare
    # against the tip deflection scale.)
    np.testing.assert_allclose(ops["v"] @ q, v, rtol=0, atol=0.005 * q[lm.end_dofs[1][1]])
    slope = 100.0 * (L * x - x**2 / 2) / EI
    np.testing.assert_allclose(ops["rotation"] @ q, slope, rtol=0.01)
    # σ_xx in plane stress ≈ E ε_xx where σ_yy ≈ 0.
    np.testing.assert_allclose(ops["stress_top"] @ q, E * (ops["strain_top"] @ q), rtol=0.01)
    # At the free end the centre-line v is the face centre's, within 0.1 % of the pin's.
    end = ps.recovery_matrices(lm, [1.0])["v"] @ q
    assert abs(end[0] / q[lm.end_dofs[1][1]] - 1) < 1e-3


def test_recovery_of_a_bar_in_tension():
    L, N = 0.2, 1.0e4
    s = section()
    lm = build(L, 6, 2)
    n = lm.n_dofs
    keep = [i for i in range(n) if i not in (0, 1) + lm.end_rotations[0]]
    f = np.zeros(n)
    f[lm.end_dofs[1][0]] = N
    q = np.zeros(n)
    q[keep] = np.linalg.solve(lm.stiffness[np.ix_(keep, keep)], f[keep])
    ops = ps.recovery_matrices(lm, np.linspace(0, 1, 5))
    # Clamped root face restrains the Poisson contraction locally; away from it ε = N/EA.
    np.testing.assert_allclose((ops["axial_strain"] @ q)[2:], N / (E * s["area"]), rtol=2e-3)
    np.testing.assert_allclose((ops["curvature"] @ q)[2:], 0.0, atol=1e-9)
    np.testing.assert_allclose(q[lm.end_dofs[1][0]], N * L / (E * s["area"]), rtol=5e-3)


# --------------------------------------------------------------------------------- batch
def test_batch_equals_single_builds():
    L = np.array([0.15, 0.2, 0.3])
    Es = np.array([2.1e11, 7.0e10, 1.1e11])
    h = np.array([0.01, 0.008, 0.012])
    area = WIDTH * h
    kw = dict(rho=RHO, area=area, second_moment=WIDTH * h**3 / 12, height=h, nu=0.3,
              elements_across=2)
    batch = ps.link_matrices(L, 4, E=Es, **kw)
    ops_b = ps.recovery_matrices(batch, [0.0, 0.3, 1.0])
    fields = ("mass", "translational_mass", "stiffness", "gyroscopic", "geometric_stiffness",
              "load_constant", "load_linear", "moment_load", "across_load", "node_positions",
              "node_coordinates")
    for c in range(3):
        one = ps.link_matrices(L[c], 4, E=Es[c], **{k: (v[c] if isinstance(v, np.ndarray)
                                                     else v) for k, v in kw.items()})
        for name in fields:
            np.testing.assert_allclose(getattr(batch, name)[c], getattr(one, name),
                                       rtol=1e-13, atol=0, err_msg=name)
        ops = ps.recovery_matrices(one, [0.0, 0.3, 1.0])
        for key in ops:
            np.testing.assert_allclose(ops_b[key][c], ops[key], rtol=1e-13, err_msg=key)
        assert batch.end_dofs == one.end_dofs and batch.end_rotations == one.end_rotations


def test_nu_from_shear_modulus_and_errors():
    a = ps.link_matrices(0.2, 2, E=E, G_shear=G, rho=RHO, **section())
    b = ps.link_matrices(0.2, 2, E=E, nu=NU, rho=RHO, **section())
    np.testing.assert_allclose(a.stiffness, b.stiffness, rtol=1e-12, atol=1e-3)
    with pytest.raises(ValueError, match="nu"):
        ps.link_matrices(0.2, 2, E=E, nu=0.5, rho=RHO, **section())
    with pytest.raises(ValueError, match="nu or the shear modulus"):
        ps.link_matrices(0.2, 2, E=E, rho=RHO, **section())
    with pytest.raises(ValueError, match="8 or 9"):
        ps.link_matrices(0.2, 2, E=E, nu=NU, rho=RHO, nodes_per_element=4, **section())
    with pytest.raises(ValueError, match="height"):
        ps.link_matrices(0.2, 2, E=E, nu=NU, rho=RHO, area=1e-4, second_moment=1e-9,
                         height=None)


# ----------------------------------------------------------------------- through the solver
def test_simeon_slider_crank_through_ked():
    # The flexible rod of Simeon's slider-crank (tests/conftest.py) with the continuum rod:
    # the periodic midpoint deflection stays in the published 1.4–2.0 mm band and within 2 % of
    # Euler–Bernoulli (measured 1.537 vs 1.547 mm), the first frequency within 1 % (212.9 vs
    # 212.3 Hz).
    from test_elastic import _solve, simeon

    out = {f: _solve(simeon(discretization={"formulation": f, "elements_per_link": 8}))
           for f in ("euler_bernoulli", "plane_stress")}
    mid = {f: o["deflection"][0, :, 1, 5] for f, o in out.items()}
    assert 1.4e-3 < mid["plane_stress"].max() < 2.0e-3
    assert abs(mid["plane_stress"].max() / mid["euler_bernoulli"].max() - 1) < 0.02
    f1 = {f: o["natural_frequency"][0, :, 0] for f, o in out.items()}
    np.testing.assert_allclose(f1["plane_stress"], f1["euler_bernoulli"], rtol=0.01)
    assert np.all(np.isfinite(out["plane_stress"]["stress"]))
