"""Euler–Bernoulli beam element: linear axial u, cubic Hermite transverse v, θ = v'.

Element DOFs (u1, v1, θ1, u2, v2, θ2) on s ∈ [0, h], ξ = s/h. Hermite cubics reproduce
the nodal values of the exact static solution for any load with the consistent load vector
(Tong 1969), and eigenvalues converge as O(h⁴) (Strang & Fix, ch. 6: O(h^{2(p+1−m)}), p = 3,
m = 2). The axial part is the linear bar: eigenvalues converge as O(h²).

Examples
--------
>>> lm = link_matrices(1.0, 4, E=2.1e11, rho=7850.0, area=1e-4, second_moment=1e-9)
>>> lm.mass.shape, lm.geometric_stiffness.shape, lm.end_dofs
((15, 15), (3, 15, 15), ((0, 1), (12, 13)))
>>> round(float(lm.load_constant[1::3, 1].sum()), 12)  # ∫ Σ N_v ds = L
1.0
"""
from __future__ import annotations

import numpy as np

from .link import LinkMatrices, broadcast_parameters, build_link, recovery_operators

__all__ = ["shape_functions", "link_matrices", "recovery_matrices"]

FORMULATION = "euler_bernoulli"


def shape_functions(xi, h, phi=None) -> dict:
    """Shape functions and their s-derivatives at local points ξ (g,) of elements of length h.

    Parameters
    ----------
    xi : (g,) local coordinates in [0, 1]
    h : (...) element length, m
    phi : ignored (the Timoshenko shear parameter; Euler–Bernoulli is φ = 0)

    Returns
    -------
    dict of (..., g, 6) arrays: ``u``, ``v`` (m per DOF unit), ``theta`` = ``dv`` = v',
    ``du`` = u' (1/m), ``kappa`` = v'' (1/m per unit), ``gamma`` None.
    """
    h = np.asarray(h, float)[..., None]
    x = np.broadcast_to(np.asarray(xi, float), h.shape[:-1] + np.shape(xi))
    z, one = np.zeros_like(x), np.ones_like(x)
    x2, x3 = x * x, x * x * x
    stack = lambda *c: np.stack(c, axis=-1)  # noqa: E731
    u = stack(1 - x, z, z, x, z, z)
    du = stack(-one, z, z, one, z, z) / h[..., None]
    # Hermite cubics H1..H4 (v1, θ1, v2, θ2); rotations scale with h.
    v = stack(z, 1 - 3 * x2 + 2 * x3, h * (x - 2 * x2 + x3), z, 3 * x2 - 2 * x3, h * (x3 - x2))
    dv = stack(z, (6 * x2 - 6 * x) / h, 1 - 4 * x + 3 * x2, z, (6 * x - 6 * x2) / h,
               3 * x2 - 2 * x)
    d2v = stack(z, (12 * x - 6) / h**2, (6 * x - 4) / h, z, (6 - 12 * x) / h**2, (6 * x - 2) / h)
    return {"u": u, "v": v, "theta": dv, "du": du, "dv": dv, "kappa": d2v, "gamma": None}


def link_matrices(length, n_elements: int, *, E, rho, area, second_moment, G_shear=None,
                  height=None, shear_coefficient=None, rotary_inertia: bool = False
                  ) -> LinkMatrices:
    """Matrices of a link meshed with ``n_elements`` equal Euler–Bernoulli elements.

    Parameters
    ----------
    length : (...) link length L, m
    n_elements : number of equal elements (shared by the batch)
    E : (...) Young's modulus, Pa
    rho : (...) density, kg/m³
    area : (...) cross-section area A, m²
    second_moment : (...) in-plane second moment of area I, m⁴
    G_shear, shear_coefficient : ignored (accepted for a uniform signature across formulations)
    height : (...) in-plane section depth, m (stored for recovery only)
    rotary_inertia : add ρI ∫ v'ᵀv' ds to the mass (Rayleigh beam)

    Returns
    -------
    LinkMatrices with 3 (n_elements + 1) DOFs, node by node (u, v, θ).
    """
    p = broadcast_parameters(length=length, E=E, rho=rho, area=area, I=second_moment,
                             height=height)
    rhoI = p["rho"] * p["I"] * (1.0 if rotary_inertia else 0.0)
    return build_link(shape_functions, FORMULATION, p["length"], n_elements,
                      rhoA=p["rho"] * p["area"], rhoI=rhoI, EA=p["E"] * p["area"],
                      EI=p["E"] * p["I"], height=p["height"])


def recovery_matrices(matrices: LinkMatrices, stations) -> dict:
    """Operators mapping the link DOFs q to fields at normalized stations ξ ∈ [0, 1].

    Parameters
    ----------
    matrices : LinkMatrices
        The link's Euler–Bernoulli matrices (length, n_elements).
    stations : array_like
        Normalized stations ξ ∈ [0, 1] along the link, shape (st,).

    Returns
    -------
    dict of (..., st, n) arrays: ``u`` and ``v`` (m), ``rotation`` v' (rad), ``curvature`` v''
    (1/m), ``axial_strain`` u'. The curvature and axial strain (piecewise linear / constant,
    discontinuous at nodes) are recovered from their superconvergent Gauss points (quadratic /
    linear through the nearest ones, :func:`ced.fem.elements.link.superconvergent_rows`).
    """
    return recovery_operators(shape_functions, matrices, stations,
                              {"u": "u", "v": "v", "rotation": "dv", "curvature": "kappa",
                               "axial_strain": "du"},
                              superconvergent={"curvature": (2, 2), "axial_strain": (1, 1)})
