"""Rigid link as an "element": three small-motion DOFs (u0, v0, φ).

Field w(s) = (u0, v0 + sφ) in the link frame, section rotation θ = φ, no strain. The same
virtual work as the beams (see :mod:`ced.fem.elements.link`) gives, exactly,

    M   = ρA [[L, 0, 0], [0, L, L²/2], [0, L²/2, L³/3]] + ρIL on φ   (section rotary inertia)
    G   = ρA [[0, −L, −L²/2], [L, 0, 0], [L²/2, 0, 0]],   K = 0,
    Kg_k = L^{k+1}/(k + 1) on φ   (v' = φ, so δW_g = ∫P ds φ δφ — not zero),

which equal the beam matrices projected on their rigid-body modes.

Examples
--------
>>> lm = link_matrices(2.0, rho=1.0, area=1.0, second_moment=0.0)
>>> np.round(lm.mass, 12).tolist()
[[2.0, 0.0, 0.0], [0.0, 2.0, 2.0], [0.0, 2.0, 2.666666666667]]
"""
from __future__ import annotations

import numpy as np

from .link import (LinkMatrices, broadcast_parameters, element_integrals, gauss_legendre,
                   scatter_rows)

__all__ = ["shape_functions", "link_matrices", "recovery_matrices"]

FORMULATION = "rigid"


def shape_functions(xi, length, phi=None) -> dict:
    """Rigid-field "shape functions" at normalized points ξ (g,) of a link of length L.

    Returns dict of (..., g, 3) arrays with the keys of the beam elements; strains are zero.

    Parameters
    ----------
    xi : array_like
        Normalized points ξ ∈ [0, 1], shape (g,).
    length : array_like
        Link length L, m (per case; broadcasts).
    phi : optional
        Unused: the signature matches the beam elements'.
    """
    L = np.asarray(length, float)[..., None]
    x = np.broadcast_to(np.asarray(xi, float), L.shape[:-1] + np.shape(xi))
    z, one = np.zeros_like(x), np.ones_like(x)
    stack = lambda *c: np.stack(c, axis=-1)  # noqa: E731
    zero = stack(z, z, z)
    rotation = stack(z, z, one)
    return {"u": stack(one, z, z), "v": stack(z, one, L * x), "theta": rotation,
            "du": zero, "dv": rotation, "kappa": zero, "gamma": None}


def link_matrices(length, n_elements=None, *, rho, area, second_moment, E=None, G_shear=None,
                  height=None, shear_coefficient=None, rotary_inertia: bool = True
                  ) -> LinkMatrices:
    """Matrices of a rigid link (3 DOFs: u0, v0 at s = 0 and the small rotation φ).

    Parameters
    ----------
    length : (...) link length L, m
    rho : (...) density, kg/m³
    area : (...) cross-section area A, m²
    second_moment : (...) in-plane second moment of area I, m⁴ (rotary inertia ρIL on φ)
    n_elements, E, G_shear, shear_coefficient : ignored (uniform signature)
    height : (...) stored only
    rotary_inertia : include ρIL on φ (default; the link's full moment of inertia about its
        first end is then ρA L³/3 + ρI L)
    """
    p = broadcast_parameters(length=length, rho=rho, area=area, I=second_moment, height=height)
    L = p["length"]
    if np.any(~(L > 0)):
        raise ValueError("link length must be positive")
    xi, w = gauss_legendre(2)  # products of degree ≤ 3 in ξ
    rhoI = p["rho"] * p["I"] * (1.0 if rotary_inertia else 0.0)
    zero = np.zeros_like(L)
    # One "element" spanning the link: h = L, n_elements = 1, no assembly needed.
    el = element_integrals(shape_functions(xi, L), L, 1, rhoA=p["rho"] * p["area"], rhoI=rhoI,
                           EA=zero, EI=zero, xi=xi, weights=w)
    return LinkMatrices(
        mass=el["mass"], translational_mass=el["translational_mass"],
        stiffness=el["stiffness"], gyroscopic=el["gyroscopic"],
        geometric_stiffness=el["geometric_stiffness"][..., 0, :, :],
        load_constant=el["load_constant"], load_linear=el["load_linear"][..., 0, :, :],
        moment_load=el["moment_load"], node_positions=zero[..., None],
        end_dofs=((0, 1), None), end_rotations=(2, 2), length=L, n_elements=1,
        shear_parameter=zero, height=p["height"], formulation=FORMULATION)


def recovery_matrices(matrices: LinkMatrices, stations) -> dict:
    """Operators (..., st, 3) at normalized stations: ``u`` = u0, ``v`` = v0 + ξLφ,
    ``rotation`` = φ, and zero ``curvature`` and ``axial_strain``.

    Parameters
    ----------
    matrices : LinkMatrices
        The rigid link's matrices (its ``length``, m).
    stations : array_like
        Normalized stations ξ ∈ [0, 1] along the link, shape (st,).

    Returns
    -------
    dict
        Operators (…, st, 3) by field name.
    """
    sh = shape_functions(np.asarray(stations, float), matrices.length)
    elements = np.zeros(np.shape(stations), int)
    return {name: scatter_rows(sh[key], elements, 3) for name, key in
            (("u", "u"), ("v", "v"), ("rotation", "theta"), ("curvature", "kappa"),
             ("axial_strain", "du"))}
