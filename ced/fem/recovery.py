"""Recovery of deflections, strains and stresses from local link DOFs (docs/theory.md).

Stations are normalized positions ξ ∈ [0, 1] along each link, ξ = 0 and 1 included.
"""
from __future__ import annotations

import numpy as np

__all__ = ["link_fields", "deflection", "peaks", "FIBRES"]

#: Positions of the two outer fibres across the in-plane section depth, y/h: y along the link's
#: transverse (deflection) axis, so the curvature v'' > 0 stretches the fibre at y = −h/2
#: (bending strain κh/2 adds to the axial strain there).
FIBRES = (-0.5, 0.5)


def link_fields(
    q: np.ndarray,
    operators: dict[str, np.ndarray],
    stations: np.ndarray,
    height: np.ndarray,
    youngs_modulus: np.ndarray,
) -> dict[str, np.ndarray]:
    """Elastic fields of one link at the stations.

    Parameters
    ----------
    q : (case, step, n) local DOFs of the link, m and rad
    operators : "u", "v", "curvature", "axial_strain" -> (case, station, n) maps from q
    stations : (station,) normalized positions; the first is 0 and the last 1
    height : (case,) m, in-plane section depth (outer fibres at ±h/2)
    youngs_modulus : (case,) Pa

    Returns
    -------
    dict with (case, step, station) arrays:
    ``deflection`` transverse displacement relative to the chord through the two deformed end
    joints, m; ``axial_displacement`` u, m; ``bending_strain`` κh/2; ``axial_strain`` u';
    and ``stress`` (case, step, station, fibre): E × the strain at the two outer fibres,
    ``axial + bending`` at y = −h/2 and ``axial − bending`` at y = +h/2 (:data:`FIBRES`), Pa,
    signed (tension positive).
    """
    # One batched matmul per case over every operator: (t, n) @ (n, 4 st), BLAS-sized.
    names = ("v", "curvature", "axial_strain", "u")
    stacked = np.concatenate([operators[name] for name in names], axis=1)
    values = q @ np.swapaxes(stacked, -1, -2)
    nst = operators["v"].shape[1]

    def apply(name):
        i = names.index(name)
        return values[..., i * nst:(i + 1) * nst]

    v = apply("v")
    xi = np.asarray(stations)[None, None, :]
    chord = (1.0 - xi) * v[..., :1] + xi * v[..., -1:]
    bending = apply("curvature") * (0.5 * height)[:, None, None]
    axial = apply("axial_strain")
    # Both outer fibres, signed: the one of larger magnitude swaps between them within a cycle,
    # and a history that follows it jumps sign there, which no fatigue count may read.
    E = youngs_modulus[:, None, None, None]
    stress = E * np.stack([axial + bending, axial - bending], axis=-1)
    return {
        "deflection": v - chord,
        "axial_displacement": apply("u").copy(),
        "bending_strain": bending,
        "axial_strain": axial,
        "stress": stress,
    }


def deflection(q: np.ndarray, operator_v: np.ndarray, stations: np.ndarray) -> np.ndarray:
    """Transverse deflection relative to the chord through the deformed end joints, m
    (case, step, station): the ``deflection`` of :func:`link_fields` alone.

    Parameters
    ----------
    q : numpy.ndarray
        Local link DOFs, shape (case, step, n).
    operator_v : numpy.ndarray
        Recovery operator of the transverse displacement v, shape (case, station, n) (or
        (station, n)).
    stations : numpy.ndarray
        Normalized stations ξ ∈ [0, 1], shape (station,); the first and last are the link ends.

    Returns
    -------
    numpy.ndarray
        Deflection, m, shape (case, step, station).
    """
    v = q @ np.swapaxes(operator_v, -1, -2)
    xi = np.asarray(stations)[None, None, :]
    return v - ((1.0 - xi) * v[..., :1] + xi * v[..., -1:])


def peaks(field: np.ndarray, periodic: bool = False) -> np.ndarray:
    """Peak absolute value over time and stations: (case, step, link, station) → (case, link).

    The peak in time is taken between samples: a parabola through the largest sample and its
    two neighbours gives the maximum of the interpolated history. A sampled maximum alone is
    low by up to f''(Δt/2)²/2 with a constant that jumps with the peak's position on the grid,
    so its error would not converge smoothly under step refinement; the parabola's error is
    O(Δt³) and smooth, which the error estimate (``ced.auto.error_estimate``) relies on. Steps
    must be equally spaced (they are: one step size per case).

    Parameters
    ----------
    field : numpy.ndarray
        A recovered field (stress in Pa, deflection in m, …), shape (case, step, link, station),
        sampled at equally spaced steps.
    periodic : bool, optional
        The steps sample one period of a periodic history (the step after the last is the
        first): the parabola wraps around instead of stopping at the ends.

    Returns
    -------
    numpy.ndarray
        Peak of ``|field|``, in the field's unit, shape (case, link).
    """
    magnitude = np.abs(field)
    n = magnitude.shape[1]
    k = magnitude.argmax(axis=1)  # (case, link, station)
    peak = np.take_along_axis(magnitude, k[:, None], axis=1)[:, 0]
    if n >= 3:
        inner = k if periodic else np.clip(k, 1, n - 2)
        before = np.take_along_axis(magnitude, (inner[:, None] - 1) % n, axis=1)[:, 0]
        after = np.take_along_axis(magnitude, (inner[:, None] + 1) % n, axis=1)[:, 0]
        curvature = 2.0 * peak - before - after
        interior = (k == inner) & (curvature > 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            rise = np.where(interior, (after - before) ** 2 / (8.0 * curvature), 0.0)
        peak = peak + rise
    return peak.max(axis=-1)
