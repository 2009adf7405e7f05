"""A periodic series carried from one discretization of a scene to another (GMRES warm start).

An error estimate's companion solves the scene again on a coarser mesh at the scene's own
collocation points (:func:`ced.auto.error_estimate.companions`). The two solutions differ by
the mesh's discretization error only, so the scene's series is a close initial guess for the
companion's GMRES (:func:`ced.response.spectral.solve_periodic`). Their reduced coordinates y
are not comparable, though: a link's interior coordinates are component modes of its own mesh
(:mod:`ced.fem.component_modes`), whose number, order and signs (``eigh``'s) depend on the
mesh. The series is therefore carried in terms that do not depend on the mesh — the joint
coordinates, the same physical quantities in both models, and each flexible link's local
displacements u and v at the output stations — and the companion fits its own interior
coordinates to those displacements by least squares.
"""
from __future__ import annotations

import numpy as np

from .kernels import expand
from .model import Model

__all__ = ["mesh_free_samples", "reduced_from_samples"]

#: Recovery operators read at the stations: the link's axial and transverse displacement, m.
_DISPLACEMENTS = ("u", "v")


def _link_displacement_operators(model: Model, name: str, cases: np.ndarray) -> np.ndarray:
    """(case, 2 station, n_local) operators of u and v at the stations of a flexible link."""
    ops = [model.recovery[name][key] for key in _DISPLACEMENTS]
    ops = [op[cases] if op.ndim == 3 else np.broadcast_to(op, (len(cases),) + op.shape)
           for op in ops]
    return np.concatenate(ops, axis=1)


def _joint_part(model: Model, projection: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """z (case, P, nz) of the joint coordinates alone (link interiors zero): the link ends
    the joints move."""
    layout = model.layout
    y = np.zeros(joints.shape[:2] + (layout.ny,))
    y[..., :joints.shape[-1]] = joints
    z = np.empty(y.shape[:2] + (layout.nz,))
    expand(np.ascontiguousarray(projection), y, np.arange(y.shape[1], dtype=np.int64),
           layout.projection_rows, layout.interior_rows().astype(np.int64), z)
    return z


def mesh_free_samples(model: Model, cases: np.ndarray, projection: np.ndarray,
                      z: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A series in terms that do not depend on the mesh: the joint coordinates and each
    flexible link's u, v at the stations.

    Parameters
    ----------
    model : Model
        The model of the batch the series was solved on.
    cases : numpy.ndarray
        The batch's cases the series are of, shape (case,), int.
    projection : numpy.ndarray
        The joint-coordinate columns of z = P y at the collocation points, their rows
        :attr:`ced.fem.coupling.Layout.projection_rows`, shape (case, P, row, nfree).
    z : numpy.ndarray
        Joint and link displacements at the collocation points, shape (case, P, nz), m.
    y : numpy.ndarray
        The reduced coordinates there, shape (case, P, ny), m and rad.

    Returns
    -------
    numpy.ndarray
        Shape (case, P, nfree + 2 × station × flexible link), m and rad: the joint
        coordinates, then u and v at the stations link by link.
    """
    layout = model.layout
    parts = [y[..., :projection.shape[-1]]]
    for name in layout.topology.links:
        if name in model.recovery:
            offset, size = layout.link_offsets[name], layout.link_sizes[name]
            R = _link_displacement_operators(model, name, cases)
            parts.append(np.einsum("cps,cks->cpk", z[..., offset:offset + size], R))
    return np.concatenate(parts, axis=-1)


def reduced_from_samples(model: Model, cases: np.ndarray, projection: np.ndarray,
                         samples: np.ndarray) -> np.ndarray:
    """The reduced coordinates of this model nearest a series given by
    :func:`mesh_free_samples` (of another mesh of the same scenes).

    The joint coordinates are taken as they are; each flexible link's interior coordinates
    are fitted, by least squares, to the link's u and v at the stations less what the joints
    contribute there.

    Parameters
    ----------
    model : Model
        The model to map into (same scenes and stations, any mesh).
    cases : numpy.ndarray
        The batch's cases the samples are of, shape (case,), int.
    projection : numpy.ndarray
        This model's joint-coordinate columns of z = P y at the collocation points, their
        rows :attr:`ced.fem.coupling.Layout.projection_rows`, shape (case, P, row, nfree).
    samples : numpy.ndarray
        Shape (case, P, nfree + 2 × station × flexible link), m and rad.

    Returns
    -------
    numpy.ndarray
        y, shape (case, P, ny), m and rad.
    """
    layout = model.layout
    nfree = projection.shape[-1]
    z = _joint_part(model, projection, samples[..., :nfree])
    y = np.zeros(samples.shape[:2] + (layout.ny,))
    y[..., :nfree] = samples[..., :nfree]
    start = nfree
    for name in layout.topology.links:
        if name not in model.recovery:
            continue
        offset, size = layout.link_offsets[name], layout.link_sizes[name]
        R = _link_displacement_operators(model, name, cases)
        stop = start + R.shape[1]
        target = samples[..., start:stop] - np.einsum(
            "cps,cks->cpk", z[..., offset:offset + size], R)
        columns = [c for c, (link, _) in enumerate(layout.interior_dofs) if link == name]
        local = [i for link, i in layout.interior_dofs if link == name]
        fit = np.linalg.pinv(R[..., local])  # (case, interior, 2 station)
        y[..., nfree + np.array(columns, int)] = np.einsum("cik,cpk->cpi", fit, target)
        start = stop
    return y
