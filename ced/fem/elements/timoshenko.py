"""Timoshenko beam element, locking-free: interdependent interpolation (IIE).

Element DOFs (u1, v1, θ1, u2, v2, θ2), θ the section rotation (counter-clockwise, = v' when
shear is neglected). The transverse shape functions are the exact static solutions of the
homogeneous Timoshenko equations EIθ'' + κGA(v' − θ) = 0, (v' − θ)' = 0, with
φ = 12EI/(κGA h²) and μ = 1/(1 + φ) (Friedman & Kosmatka 1993, Comput. Struct. 47:473;
Reddy 1997, Commun. Numer. Meth. Eng. 13:495)::

    v = μ[1 − 3ξ² + 2ξ³ + φ(1 − ξ)] v1 + μh[ξ − 2ξ² + ξ³ + φ(ξ − ξ²)/2] θ1
      + μ[3ξ² − 2ξ³ + φξ] v2 + μh[ξ³ − ξ² − φ(ξ − ξ²)/2] θ2
    θ = 6μ(ξ² − ξ)/h v1 + μ[1 − 4ξ + 3ξ² + φ(1 − ξ)] θ1 + 6μ(ξ − ξ²)/h v2 + μ[3ξ² − 2ξ + φξ] θ2

so the shear strain γ = v' − θ = μφ(v2 − v1)/h − μφ(θ1 + θ2)/2 is constant: no shear locking
(the stiffness matrix is the exact one, nodal static deflections are exact), and as φ → 0
every function tends to its Euler–Bernoulli (Hermite) counterpart. The consistent mass
includes rotary inertia ρI∫θᵀθ ds.

Examples
--------
>>> lm = link_matrices(0.3, 2, E=2.1e11, G_shear=8.1e10, rho=7850.0, area=1e-3,
...                    second_moment=8.3e-8, shear_coefficient=5 / 6)
>>> lm.mass.shape, float(lm.shear_parameter) > 0
((9, 9), True)
"""
from __future__ import annotations

import numpy as np

from .link import LinkMatrices, broadcast_parameters, build_link, recovery_operators

__all__ = ["shape_functions", "link_matrices", "recovery_matrices", "DEFAULT_SHEAR_COEFFICIENT"]

FORMULATION = "timoshenko"
# Timoshenko's κ for a rectangle; Cowper's 10(1+ν)/(12+11ν) (rectangle) or 6(1+ν)/(7+6ν)
# (circle) may be passed instead.
DEFAULT_SHEAR_COEFFICIENT = 5.0 / 6.0


def shape_functions(xi, h, phi) -> dict:
    """IIE shape functions and s-derivatives at local points ξ (g,), elements of length h.

    Parameters
    ----------
    xi : (g,) local coordinates in [0, 1]
    h : (...) element length, m
    phi : (...) shear parameter φ = 12EI/(κGA h²) (0 → Euler–Bernoulli)

    Returns
    -------
    dict of (..., g, 6) arrays: ``u``, ``v``, ``theta``, ``du`` = u', ``dv`` = v',
    ``kappa`` = θ' (bending strain), ``gamma`` = v' − θ (shear strain).
    """
    h = np.asarray(h, float)[..., None]
    f = np.broadcast_to(np.asarray(phi, float), h.shape[:-1])[..., None]
    x = np.broadcast_to(np.asarray(xi, float), h.shape[:-1] + np.shape(xi))
    mu = 1.0 / (1.0 + f)
    z, one = np.zeros_like(x), np.ones_like(x)
    x2, x3 = x * x, x * x * x
    stack = lambda *c: np.stack(c, axis=-1)  # noqa: E731
    u = stack(1 - x, z, z, x, z, z)
    du = stack(-one, z, z, one, z, z) / h[..., None]
    v = mu[..., None] * stack(
        z, 1 - 3 * x2 + 2 * x3 + f * (1 - x), h * (x - 2 * x2 + x3 + 0.5 * f * (x - x2)),
        z, 3 * x2 - 2 * x3 + f * x, h * (x3 - x2 - 0.5 * f * (x - x2)))
    dv = mu[..., None] * stack(
        z, (6 * x2 - 6 * x - f) / h, 1 - 4 * x + 3 * x2 + 0.5 * f * (1 - 2 * x),
        z, (6 * x - 6 * x2 + f) / h, 3 * x2 - 2 * x - 0.5 * f * (1 - 2 * x))
    theta = mu[..., None] * stack(
        z, 6 * (x2 - x) / h, 1 - 4 * x + 3 * x2 + f * (1 - x),
        z, 6 * (x - x2) / h, 3 * x2 - 2 * x + f * x)
    dtheta = mu[..., None] * stack(
        z, (12 * x - 6) / h**2, (6 * x - 4 - f) / h, z, (6 - 12 * x) / h**2, (6 * x - 2 + f) / h)
    return {"u": u, "v": v, "theta": theta, "du": du, "dv": dv, "kappa": dtheta,
            "gamma": dv - theta}


def link_matrices(length, n_elements: int, *, E, G_shear, rho, area, second_moment,
                  height=None, shear_coefficient=None, rotary_inertia: bool = True
                  ) -> LinkMatrices:
    """Matrices of a link meshed with ``n_elements`` equal Timoshenko (IIE) elements.

    Parameters
    ----------
    length : (...) link length L, m
    n_elements : number of equal elements (shared by the batch)
    E, G_shear : (...) Young's and shear moduli, Pa
    rho : (...) density, kg/m³
    area : (...) cross-section area A, m²
    second_moment : (...) in-plane second moment of area I, m⁴
    height : (...) in-plane section depth, m (stored for recovery only)
    shear_coefficient : (...) κ, default 5/6 (rectangle)
    rotary_inertia : include ρI∫θᵀθ ds in the mass (the Timoshenko beam; False gives the
        "shear beam", for comparisons only)

    Returns
    -------
    LinkMatrices with 3 (n_elements + 1) DOFs, node by node (u, v, θ).
    """
    kappa = DEFAULT_SHEAR_COEFFICIENT if shear_coefficient is None else shear_coefficient
    p = broadcast_parameters(length=length, E=E, G=G_shear, rho=rho, area=area,
                             I=second_moment, kappa=kappa, height=height)
    EI, kGA = p["E"] * p["I"], p["kappa"] * p["G"] * p["area"]
    h = p["length"] / int(n_elements)
    phi = 12.0 * EI / (kGA * h * h)
    rhoI = p["rho"] * p["I"] * (1.0 if rotary_inertia else 0.0)
    return build_link(shape_functions, FORMULATION, p["length"], n_elements,
                      rhoA=p["rho"] * p["area"], rhoI=rhoI, EA=p["E"] * p["area"], EI=EI,
                      kGA=kGA, phi=phi, height=p["height"])


def recovery_matrices(matrices: LinkMatrices, stations) -> dict:
    """Operators mapping the link DOFs q to fields at normalized stations ξ ∈ [0, 1].

    Parameters
    ----------
    matrices : LinkMatrices
        The link's Timoshenko matrices (length, n_elements).
    stations : array_like
        Normalized stations ξ ∈ [0, 1] along the link, shape (st,).

    Returns
    -------
    dict of (..., st, n) arrays: ``u``, ``v`` (m), ``rotation`` θ (rad), ``curvature`` θ'
    (the bending strain per unit distance from the neutral axis, 1/m), ``axial_strain`` u',
    ``shear_strain`` v' − θ. θ' (linear, discontinuous at nodes) and u' are recovered from their
    superconvergent points as for Euler–Bernoulli.
    """
    return recovery_operators(shape_functions, matrices, stations,
                              {"u": "u", "v": "v", "rotation": "theta", "curvature": "kappa",
                               "axial_strain": "du", "shear_strain": "gamma"},
                              superconvergent={"curvature": (2, 2), "axial_strain": (1, 1)})
