"""The elastic response's own axial force in the geometric stiffness (effect
``elastic_axial_force``).

``axial_stiffening`` builds each flexible link's geometric stiffness K_g[N] from the axial
force N(s, t) of the rigid motion: its d'Alembert load and its rigid joint forces. The elastic
response changes the joint forces as well. A vibrating link's end shear reaches the next link
through the joints as an axial load: the Watt II's coupler2, hanging from the ternary rocker,
pushes and pulls on the coupler. That part is of the same order as the rigid one, since both
balance the same inertia loads. A geometric stiffness without it keeps one part of a
second-order term and drops another of the same size. Against an independent, geometrically
exact code (``benchmarks/peer/linkages.py``), the Watt II's coupler peaks 1.4 % high at
50 rad/s with the rigid force alone, and within 0.2 % with both.

With the effect, the axial force of a flexible link is

    N(s, t) = N_rigid(s, t) + EA (ε(s, t) − ε_qs(s, t)),

with ε the axial strain of the response and ε_qs that of the quasi-static response, whose
EA ε_qs is N_rigid to the discretization. The added part is fitted in s by a quadratic (the
form :func:`ced.fem.effect_terms.axial_force_coefficients` gives K_g), by least squares over
the output stations. The model is then quadratic in the displacements. It is solved by
fixed-point iteration of the whole run (:func:`ced.response.elastic.elastic_response`).
Each iteration is a linear KED solve with the last iterate's N. The added force is not
periodic, so its terms are evaluated step by step, a chunk at a time, and marched by the
generic integrator. Memory stays bounded, but each iteration costs several times the
periodic march of the linear solve. From a periodic start the added force is periodic with the
response: each iteration is then a periodic solve (shooting) with it.

Rigid links keep the rigid motion's forces; the frozen modal analysis and the forced-resonance
check keep N_rigid.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["ElasticAxialForce", "axial_strain", "added_axial_force", "relative_change",
           "MAX_ITERATIONS", "TOLERANCE"]

#: Fixed-point iterations at most (the benchmark's linkages take 3).
MAX_ITERATIONS = 12
#: Largest change of the displacements between iterations, relative to their largest value,
#: at which a case has converged. An iteration contracts the error about twentyfold on the
#: benchmark's linkages (changes 5e-2, 3e-3, 2e-4, 6e-6 on the Watt II at 50 rad/s), so what
#: is left is some 1e-4, well inside the discretization's error.
TOLERANCE = 1e-3


class ElasticAxialForce(NamedTuple):
    """The axial force added to each flexible link's geometric stiffness, on the step grid.

    ``step`` (case,) s; ``coefficients`` link -> (3, case, step) the (N0, N1, N2) of
    N(s) = N0 + N1 s + N2 s², N (tension > 0), at steps 0, 1, … of ``step``. ``period``:
    0 for a force over the run; P for a force periodic in P steps, given at steps 0 … P
    (the last equal to the first).
    """

    step: np.ndarray
    coefficients: dict[str, np.ndarray]
    period: int = 0

    def at(self, link: str, times: np.ndarray) -> np.ndarray:
        """(3, case, k) coefficients of ``link`` at ``times`` (case, k), s: linear between
        steps; periodic, or held beyond the last step."""
        c = self.coefficients[link]
        x = np.asarray(times, float) / self.step[:, None]
        if self.period:
            x = np.mod(x, self.period)
        x = np.clip(x, 0.0, c.shape[-1] - 1)
        below = np.minimum(np.floor(x).astype(int), c.shape[-1] - 2)
        w = x - below
        rows = np.arange(c.shape[1])[:, None]
        return (1.0 - w) * c[:, rows, below] + w * c[:, rows, below + 1]


def axial_strain(recovery: dict[str, dict[str, np.ndarray]], offsets: dict[str, int],
                 sizes: dict[str, int], qz: np.ndarray) -> dict[str, np.ndarray]:
    """Axial strain (case, step, station) of each flexible link from the displacements.

    Parameters
    ----------
    recovery : dict
        Per flexible link its recovery operators; ``"axial_strain"`` (case, station, n).
    offsets, sizes : dict
        Per link its first row in z and its number of DOFs (:class:`ced.fem.coupling.Layout`).
    qz : numpy.ndarray
        Link displacements z at the steps, shape (case, step, nz), m and rad.

    Returns
    -------
    dict of str to numpy.ndarray
        Per flexible link, ε (case, step, station), dimensionless.
    """
    out = {}
    for name, operators in recovery.items():
        rows = slice(offsets[name], offsets[name] + sizes[name])
        out[name] = np.einsum("csn,ctn->cts", operators["axial_strain"], qz[..., rows])
    return out


def added_axial_force(strain: dict[str, np.ndarray], static_strain: dict[str, np.ndarray],
                      stiffness: dict[str, np.ndarray], length: dict[str, np.ndarray],
                      stations: np.ndarray) -> dict[str, np.ndarray]:
    """EA (ε − ε_qs) of each flexible link, as the coefficients of a quadratic in s.

    Parameters
    ----------
    strain, static_strain : dict
        Per flexible link the axial strain of the response and of the quasi-static response,
        (case, step, station).
    stiffness : dict
        Per flexible link its axial stiffness EA (case,), N.
    length : dict
        Per flexible link its length (case,), m.
    stations : numpy.ndarray
        Normalized stations ξ ∈ [0, 1] (station,).

    Returns
    -------
    dict of str to numpy.ndarray
        Per flexible link (N0, N1, N2), N, N/m, N/m², shape (3, case, step): the least-squares
        quadratic through the stations.
    """
    out = {}
    for name, eps in strain.items():
        s = length[name][:, None] * np.asarray(stations, float)[None, :]
        basis = np.stack([np.ones_like(s), s, s * s], axis=-1)  # (case, station, 3)
        fit = np.linalg.pinv(basis)  # (case, 3, station)
        force = stiffness[name][:, None, None] * (eps - static_strain[name])
        out[name] = np.moveaxis(np.einsum("cks,cts->ctk", fit, force), -1, 0)
    return out


def relative_change(new: np.ndarray, old: np.ndarray) -> np.ndarray:
    """Largest change of each case's displacements relative to their largest value.

    Parameters
    ----------
    new, old : numpy.ndarray
        Two iterates of the displacements, shape (case, step, n).

    Returns
    -------
    numpy.ndarray
        Shape (case,), dimensionless; 0 for a case at rest.
    """
    scale = np.abs(new).max(axis=(1, 2))
    change = np.abs(new - old).max(axis=(1, 2))
    return np.divide(change, scale, out=np.zeros_like(change), where=scale > 0)
