"""Link "elements": local-frame matrices of one link, one formulation per module.

:mod:`~ced.fem.elements.link` holds :class:`LinkMatrices`, what every formulation returns, and
the quadrature, element integration, assembly along the link and recovery operators they
share; :mod:`~ced.fem.elements.rigid_body` is the rigid link (three small-motion DOFs).

Every formulation module exposes the same pure functions::

    link_matrices(length, n_elements, *, E, G_shear, rho, area, second_moment, height,
                  shear_coefficient, rotary_inertia) -> LinkMatrices
    recovery_matrices(matrices, stations) -> {"u", "v", "rotation", "curvature",
                                              "axial_strain", ...: (..., st, n)}
    shape_functions(xi, h, phi) -> dict of shape-function arrays

All parameters broadcast over leading batch (case) dimensions. Per link the equations are
(docs/theory.md)::

    M q̈ + 2ω G q̇ + (K + α G − ω² M_w + Σ_k P_k Kg_k) q = L0 b0 + L1 b1 (+ m0 moment_load)

``seed_lame`` is the thesis's II.5 thin-link model (quintic Hermite, III.2); ``plane_stress``
is the 2-D continuum of II.3 (quadratic quadrilaterals, pins tied to the end faces).
"""
from __future__ import annotations

from types import ModuleType

from . import euler_bernoulli, plane_stress, rigid_body, seed_lame, timoshenko
from .link import LinkMatrices

__all__ = ["LinkMatrices", "FORMULATIONS", "formulation", "link_matrices", "recovery_matrices",
           "euler_bernoulli", "timoshenko", "rigid_body", "seed_lame", "plane_stress"]

FORMULATIONS: dict[str, ModuleType] = {
    "euler_bernoulli": euler_bernoulli,
    "timoshenko": timoshenko,
    "rigid": rigid_body,
    "seed_lame": seed_lame,
    "plane_stress": plane_stress,
}


def formulation(name: str) -> ModuleType:
    """The module implementing formulation ``name`` (a clear error lists the allowed ones).

    Parameters
    ----------
    name : str
        Formulation name, a key of :data:`FORMULATIONS` (e.g. ``"euler_bernoulli"``).

    Returns
    -------
    module
        The formulation's module (``link_matrices``, ``recovery_matrices``, ``shape_functions``).
    """
    try:
        return FORMULATIONS[name]
    except KeyError:
        raise ValueError(f"unknown element formulation {name!r}; allowed: "
                         f"{sorted(FORMULATIONS)}") from None


def link_matrices(name: str, length, n_elements: int, **params) -> LinkMatrices:
    """``formulation(name).link_matrices(length, n_elements, **params)``.

    Parameters
    ----------
    name : str
        Formulation name, a key of :data:`FORMULATIONS`.
    length : array_like
        Link length L, m (per case; broadcasts).
    n_elements : int
        Number of elements along the link.
    **params
        Material and section parameters of the formulation (E, G_shear in Pa, rho in kg/m³, area
        in m², second_moment in m⁴, height in m, …).

    Returns
    -------
    LinkMatrices
        Mass, stiffness and load matrices of the link in its local DOFs.
    """
    return formulation(name).link_matrices(length, n_elements, **params)


def recovery_matrices(matrices: LinkMatrices, stations) -> dict:
    """Recovery operators of ``matrices`` with its own formulation's shape functions.

    Parameters
    ----------
    matrices : LinkMatrices
        The link's matrices (their ``formulation`` selects the module).
    stations : array_like
        Normalized stations ξ ∈ [0, 1] along the link, shape (st,).

    Returns
    -------
    dict
        Operators (…, st, n) by field name (see each formulation's ``recovery_matrices``).
    """
    return formulation(matrices.formulation).recovery_matrices(matrices, stations)
