"""The thesis's own link model: II.5 thin-link Lamé equations, III.2 quintic Hermite elements.

Physics (thesis II.5, eqs. 1–2, 10–11, 19–20, restated at the head of III.2)
-----------------------------------------------------------------------------
Dropping every derivative across the link (∂/∂b = 0) leaves, for the global components
u = (u_x, u_y) of a link of direction e = ((x2 − x1)/l, (y2 − y1)/l) = (cos θ, sin θ)::

    [a  b ]            ρ                  a  = cos²θ (1 − 2ν)⁻¹ + 1
    [b  a'] u_aa + … = ─ u_tt,            a' = sin²θ (1 − 2ν)⁻¹ + 1
                       μ                  b  = sin θ cos θ (1 − 2ν)⁻¹,

i.e. μ [I + (1 − 2ν)⁻¹ e eᵀ] u_aa + (body force) = ρ u_tt. Since μ(1 − 2ν)⁻¹ = λ + μ, rotating
to the link frame (u = R w, Rᵀ e = e_x) gives two uncoupled wave equations::

    axial       (λ + 2μ) u'' = ρ ü         (speed c1 = √((λ + 2μ)/ρ), thesis III.3.1.a)
    transverse        μ v''  = ρ v̈         (speed c2 = √(μ/ρ)).

The link-frame form is rotation invariant, so it is the same model as the thesis's global
form ([a, b; b, a'] = R diag(λ + 2μ, μ) Rᵀ / μ with R = [e, e⊥]). Multiplied by the section
area A (forces per length): axial stiffness (λ + 2μ)A, transverse μA, mass ρA. The transverse
strain is the shear strain γ = 2ε_ab = v' (II.5 eq. 14 in the link frame) and the transverse
stiffness is μA — not bending. This is the weakness named in the seed README: for a slender
link the II.5 model is far too stiff (first pinned–pinned frequency πc2/L instead of
(π/L)²√(EI/ρA), about L/h times higher; see tests). A second, smaller departure kept
faithfully: λ + 2μ is the plane-strain (constrained) modulus, E(1 − ν)/((1 + ν)(1 − 2ν)) =
1.35 E for ν = 0.3, not a bar's E. A third: dropping ∂u_x/∂b removes the rotation from the
shear strain, so a small rigid rotation v = φs of the link costs strain energy ½μAφ²L — a free
link has two zero modes (u, v constant), not three, and the end slope v' is a
translation-gradient DOF, not a section rotation (do not clamp it; see tests).

Discretization (thesis III.1–III.2)
-----------------------------------
Galerkin weighted residuals (III.1.1.a) with 2-node quintic Hermite elements, (f, f', f'') per
node and component (III.2.2), C² across nodes, on the reference element ε ∈ [−1, 1] with
s = s_e + (1 + ε)h/2. Reference DOFs (f, ∂_ε f, ∂²_ε f) relate to physical ones through the
thesis's T matrix, ∂_ε = (h/2) ∂_s, so N(s) = Φ(ε) T⁻¹ with T⁻¹ = diag(1, h/2, (h/2)²) per node.
Element matrices (exact 6-point Gauss: the highest integrand, s² v'ᵀv' or NᵀN, has degree 10)::

    K = ∫ (λ + 2μ)A u'ᵀu' + μA v'ᵀv' ds,   M = M_w = ∫ ρA NᵀN ds,   G = ∫ ρA NᵀJN ds,
    Kg_k = ∫ s^k v'ᵀv' ds,   L0 = ∫ Nᵀ ds,   L1 = ∫ s Nᵀ ds,

assembled by expansion (III.2.1). Interpolation error O(h⁶) (III.2.3), eigenvalue error
O(h^{2(p+1−m)}) = O(h¹⁰) (p = 5, m = 1; measured 9.7–10.3).

OCR and typesetting errors of the thesis corrected here (physics wins)
----------------------------------------------------------------------
- II.4 eq. 10 (text line ~1592): "(1 + 2ν)⁻¹" in the ∂²/∂b² coefficient is (1 − 2ν)⁻¹.
- II.5 eqs. 10–11: the right-hand side "μ⁻¹ρ ∂²u/∂a²" is μ⁻¹ρ ∂²u/∂t² (as in eqs. 1, 2, 19, 20).
- III.2.2: the shape functions are (1/16)(1 − ε)³(8 + 9ε + 3ε²), …, not 16(…) — only 1/16 gives
  Φ_i^{(k)}(node) = δ; the geometric maps are (1 ∓ ε)/2, not 2(1 ∓ ε).
- III.2.2: the stiffness entries "−(2/l) ∫ a(.) μ⁻¹ρ Φ'_iΦ'_j dε" carry a stray μ⁻¹ρ (mass only).
- III.2.2: "[A]^e = [A]_e [T]" is read as the congruence T⁻ᵀ A_ε T⁻¹ — the thesis itself states
  the element matrices are symmetric, which the one-sided product would not be.
- III.3.1.a eq. 1: "u + (1 − 2ν)⁻¹ div grad u" is Navier's Δu + (1 − 2ν)⁻¹ grad div u.

The thesis's joint conditions (II.5 strains D1..D4 entering as the boundary terms C1..C4 of
III.2.5) are not used: pins share translations (seed README), so the natural boundary terms
vanish and joint forces enter through the end translation DOFs.

Examples
--------
>>> lm = link_matrices(1.0, 4, E=2.1e11, G_shear=8.0e10, rho=7850.0, area=1e-4)
>>> lm.mass.shape, lm.geometric_stiffness.shape, lm.end_dofs, lm.end_rotations
((30, 30), (3, 30, 30), ((0, 3), (24, 27)), (4, 28))
>>> round(float(lm.load_constant[3::6, 1].sum()), 12)  # ∫ Σ N_v ds = L (partition of unity)
1.0
"""
from __future__ import annotations

import numpy as np
from numpy.polynomial import Polynomial

from .link import (LinkMatrices, broadcast_parameters, element_integrals, gauss_legendre,
                   station_elements)

__all__ = ["shape_functions", "link_matrices", "recovery_matrices", "wave_speeds",
           "lame_moduli", "DOFS_PER_NODE"]

FORMULATION = "seed_lame"
DOFS_PER_NODE = 6  # (u, u', u'', v, v', v'')
N_GAUSS = 6  # exact to degree 11 ≥ 10
_U = np.array([0, 1, 2, 6, 7, 8])  # element columns of u's (f, f', f'') at nodes 1, 2
_V = _U + 3

# Thesis III.2.2 quintic Hermite basis on ε ∈ [−1, 1] (1/16 restored, see module docstring):
# Φ1..Φ3 carry (f, ∂_ε f, ∂²_ε f) at ε = −1, Φ4..Φ6 at ε = +1.
_E = Polynomial([0.0, 1.0])
_PHI = [p / 16.0 for p in (
    (1 - _E) ** 3 * (8 + 9 * _E + 3 * _E**2),
    (1 - _E) ** 3 * (1 + _E) * (5 + 3 * _E),
    (1 - _E) ** 3 * (1 + _E) ** 2,
    (1 + _E) ** 3 * (8 - 9 * _E + 3 * _E**2),
    (1 + _E) ** 3 * (_E - 1) * (5 - 3 * _E),
    (1 + _E) ** 3 * (1 - _E) ** 2,
)]


def reference_basis(eps, derivative: int = 0) -> np.ndarray:
    """Φ_i^{(derivative)}(ε) of the thesis basis (III.2.2) at ε (g,) → (g, 6)."""
    eps = np.asarray(eps, float)
    return np.stack([p.deriv(derivative)(eps) if derivative else p(eps) for p in _PHI], -1)


def shape_functions(xi, h, phi=None) -> dict:
    """Shape functions and s-derivatives at local points ξ ∈ [0, 1] (g,) of elements of length h.

    Parameters
    ----------
    xi : (g,) local coordinates, s = s_e + ξh (ε = 2ξ − 1 on the thesis's reference element)
    h : (...) element length, m
    phi : ignored (uniform signature)

    Returns
    -------
    dict of (..., g, 12) arrays over the element DOFs (u, u', u'', v, v', v'') × 2 nodes:
    ``u``, ``v`` (m per DOF unit), ``du`` = u', ``dv`` = v' (also ``gamma``, the II.5 shear
    strain), ``kappa`` = v'' (1/m per unit; no bending energy, reported as "curvature"),
    ``d2u`` = u'', ``theta`` zeros (no section rotation).
    """
    h = np.asarray(h, float)[..., None, None]
    eps = 2.0 * np.asarray(xi, float) - 1.0
    # N = Φ T⁻¹: T⁻¹ = diag(1, h/2, (h/2)²) per node (III.2.2), d/ds = (2/h) d/dε.
    scale = (h / 2) ** np.array([0, 1, 2, 0, 1, 2])
    scalar = [reference_basis(eps, d) * (2 / h) ** d * scale for d in range(3)]
    out = {}
    for comp, cols in (("u", _U), ("v", _V)):
        for d, name in enumerate((comp, "d" + comp, "d2" + comp)):
            a = np.zeros(scalar[d].shape[:-1] + (12,))
            a[..., cols] = scalar[d]
            out[name] = a
    out.update(kappa=out["d2v"], gamma=out["dv"], theta=np.zeros_like(out["u"]))
    return out


def lame_moduli(E, G_shear=None, nu=None):
    """(λ + 2μ, μ, ν) from E and the shear modulus G = μ (or Poisson's ratio ν), Pa.

    Raises ValueError unless −1 < ν < 1/2 (λ + 2μ = 2μ(1 − ν)/(1 − 2ν) finite and positive).

    Parameters
    ----------
    E : array_like
        Young's modulus, Pa.
    G_shear : array_like, optional
        Shear modulus G = μ, Pa (takes precedence over ``nu``).
    nu : array_like, optional
        Poisson's ratio ν (dimensionless), used when ``G_shear`` is not given.

    Returns
    -------
    lam2mu, mu : numpy.ndarray
        λ + 2μ and μ, Pa.
    nu : numpy.ndarray
        Poisson's ratio ν.
    """
    E = np.asarray(E, float)
    if G_shear is not None:
        mu = np.asarray(G_shear, float)
        nu = E / (2.0 * mu) - 1.0
    elif nu is not None:
        nu = np.asarray(nu, float)
        mu = E / (2.0 * (1.0 + nu))
    else:
        raise ValueError("seed_lame needs the shear modulus G_shear (or Poisson's ratio nu)")
    if np.any(~((nu > -1.0) & (nu < 0.5))):
        raise ValueError(f"seed_lame needs -1 < nu < 0.5 (nu = E/(2 G_shear) - 1), got {nu}")
    return 2.0 * mu * (1.0 - nu) / (1.0 - 2.0 * nu), mu, nu


def wave_speeds(E, nu, rho):
    """Longitudinal and transverse wave speeds (c1, c2) = (√((λ + 2μ)/ρ), √(μ/ρ)), m/s
    (thesis III.3.1.a). E in Pa, ρ in kg/m³; broadcasts.

    Parameters
    ----------
    E : array_like
        Young's modulus, Pa.
    nu : array_like
        Poisson's ratio ν (dimensionless).
    rho : array_like
        Density ρ, kg/m³.

    Returns
    -------
    c1, c2 : numpy.ndarray
        Longitudinal and transverse wave speeds, m/s.
    """
    lam2mu, mu, _ = lame_moduli(E, nu=nu)
    rho = np.asarray(rho, float)
    return np.sqrt(lam2mu / rho), np.sqrt(mu / rho)


def _assemble(ae: np.ndarray, n_elements: int, *, matrix: bool, shared: bool) -> np.ndarray:
    """Assembly by expansion (III.2.1): element arrays (..., [e,] 12, c) → (..., n, n | c).

    Element e's 12 DOFs are the global DOFs 6e … 6e + 11 (nodes e and e + 1).
    """
    if shared:
        ae = ae[..., None, :, :]
    n = DOFS_PER_NODE * (n_elements + 1)
    out = np.zeros(ae.shape[:-3] + (n, n if matrix else ae.shape[-1]))
    for e in range(n_elements):
        a = ae[..., min(e, ae.shape[-3] - 1), :, :]
        rows = slice(DOFS_PER_NODE * e, DOFS_PER_NODE * e + 12)
        if matrix:
            out[..., rows, rows] += a
        else:
            out[..., rows, :] += a
    return out


def assemble_sparse(element_matrices: np.ndarray, n_elements: int):
    """Assembly by expansion into a sparse matrix (III.2.1–III.2.2, the thesis's storage).

    ``element_matrices`` (e, 12, 12) or (12, 12) for equal elements; returns a
    ``scipy.sparse.csr_array`` (n, n). Element e's DOFs are 6e … 6e + 11, so the matrix is
    banded (half-bandwidth 11) and its storage grows linearly with the number of elements.
    The batched KED solver uses dense stacks of small links instead (:func:`link_matrices`);
    this is the single-link path for long, finely meshed links.
    """
    from scipy import sparse

    ae = np.broadcast_to(element_matrices, (n_elements, 12, 12))
    local = np.arange(12)
    rows = (DOFS_PER_NODE * np.arange(n_elements))[:, None, None] + local[None, :, None]
    cols = (DOFS_PER_NODE * np.arange(n_elements))[:, None, None] + local[None, None, :]
    rows, cols = np.broadcast_to(rows, ae.shape), np.broadcast_to(cols, ae.shape)
    n = DOFS_PER_NODE * (n_elements + 1)
    return sparse.coo_array((ae.ravel(), (rows.ravel(), cols.ravel())), shape=(n, n)).tocsr()


def link_matrices(length, n_elements: int, *, E, rho, area, second_moment=None, G_shear=None,
                  height=None, shear_coefficient=None, rotary_inertia: bool = False,
                  nu=None) -> LinkMatrices:
    """Matrices of a link meshed with ``n_elements`` equal quintic Hermite II.5 elements.

    Parameters
    ----------
    length : (...) link length L, m
    n_elements : number of equal elements (shared by the batch)
    E : (...) Young's modulus, Pa
    rho : (...) density, kg/m³
    area : (...) cross-section area A, m²
    G_shear : (...) shear modulus μ, Pa (ν = E/(2μ) − 1); or give ``nu`` instead
    height : (...) in-plane section depth, m (stored for recovery only)
    second_moment, shear_coefficient, rotary_inertia : ignored — the II.5 model has no bending
        and no section rotation (accepted for a uniform signature across formulations)
    nu : Poisson's ratio, used only when ``G_shear`` is None

    Returns
    -------
    LinkMatrices with 6 (n_elements + 1) DOFs node by node (u, u', u'', v, v', v''): axial
    stiffness (λ + 2μ)A, transverse μA, mass = translational mass (ρA), zero moment load;
    ``end_rotations`` are the slope DOFs v' at s = 0 and s = L.
    """
    n_elements = int(n_elements)
    if n_elements < 1:
        raise ValueError(f"n_elements must be >= 1, got {n_elements}")
    p = broadcast_parameters(length=length, E=E, rho=rho, area=area, G=G_shear, nu=nu,
                             height=height)
    L = p["length"]
    if np.any(~(L > 0)):
        raise ValueError("link length must be positive")
    lam2mu, mu, _ = lame_moduli(p["E"], p["G"], p["nu"])
    h = L / n_elements
    xi, w = gauss_legendre(N_GAUSS)
    zero = np.zeros_like(L)
    # The shared beam integrals with EI = 0 and the shear slot γ = v' (θ ≡ 0): κGA → μA.
    el = element_integrals(shape_functions(xi, h), h, n_elements, rhoA=p["rho"] * p["area"],
                           rhoI=zero, EA=lam2mu * p["area"], EI=zero, kGA=mu * p["area"],
                           xi=xi, weights=w)
    mat = {k: _assemble(el[k], n_elements, matrix=True, shared=True)
           for k in ("mass", "translational_mass", "stiffness", "gyroscopic")}
    n = DOFS_PER_NODE * (n_elements + 1)
    return LinkMatrices(
        **mat,
        geometric_stiffness=_assemble(el["geometric_stiffness"], n_elements, matrix=True,
                                      shared=False),
        load_constant=_assemble(el["load_constant"], n_elements, matrix=False, shared=True),
        load_linear=_assemble(el["load_linear"], n_elements, matrix=False, shared=False),
        moment_load=np.zeros(L.shape + (n,)),
        node_positions=h[..., None] * np.arange(n_elements + 1),
        end_dofs=((0, 3), (n - 6, n - 3)),
        end_rotations=(4, n - 2),
        length=L,
        n_elements=n_elements,
        shear_parameter=zero,
        height=p["height"],
        formulation=FORMULATION,
    )


def recovery_matrices(matrices: LinkMatrices, stations) -> dict:
    """Operators mapping the link DOFs q to fields at normalized stations ξ ∈ [0, 1].

    Parameters
    ----------
    matrices : LinkMatrices
        The link's seed–Lamé matrices (length, n_elements, n_dofs).
    stations : array_like
        Normalized stations ξ ∈ [0, 1] along the link, shape (st,).

    Returns
    -------
    dict of (..., st, n) arrays: ``u``, ``v`` (m), ``rotation`` = v' (the slope; in this
    model also ``shear_strain`` γ = 2ε_ab), ``curvature`` = v'' (1/m), ``axial_strain`` = u'.
    All are continuous (C² elements); at an interior node the two adjacent elements agree.
    """
    ne, n = matrices.n_elements, matrices.n_dofs
    h = matrices.length / ne
    (left, right), (xl, xr) = station_elements(stations, ne)
    names = {"u": "u", "v": "v", "rotation": "dv", "curvature": "kappa", "axial_strain": "du",
             "shear_strain": "dv"}
    out = {name: 0.0 for name in names}
    for elems, x in ((left, xl), (right, xr)):
        sh = shape_functions(x, h)
        dof = DOFS_PER_NODE * elems[:, None] + np.arange(12)  # (st, 12)
        rows = np.arange(len(elems))[:, None]
        for name, key in names.items():
            op = np.zeros(sh[key].shape[:-1] + (n,))
            op[..., rows, dof] = sh[key]
            out[name] = out[name] + 0.5 * op
    return out
