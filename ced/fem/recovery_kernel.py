"""Compiled recovery (numba): the station fields and their peaks in one pass per case.

:func:`ced.fem.recovery.link_fields` and :func:`ced.fem.recovery.peaks` recover a link's
fields with one batched matmul and then reduce them with numpy: float64 temporaries of every
(case, step, station) value, a stacked copy for the stress, the float32 copies that are
stored, an ``argmax`` and three ``take_along_axis`` per peak — on the reference sweep about
half of a solve. :func:`recover` does the same arithmetic in one compiled pass per case over
(step, link, station): it forms the values of one step from the link DOFs, writes the float32
fields straight into their preallocated outputs and keeps, per station, the running largest
sample with its two neighbours, so that the peak (the parabola through them) is known at the
end of the pass without any history held in float64.

The arithmetic is that of the numpy path except for the order of the sums of the operator
products (BLAS's against a plain loop): the fields and peaks agree with it to round-off
(``tests/fem/test_recovery_kernel.py``); ``CED_KERNEL=numpy`` keeps the numpy path in
:mod:`ced.response.elastic`. Nothing here allocates per step.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numba as nb
import numpy as np

__all__ = ["recover", "OPERATORS", "FIELDS"]

#: The recovery operators a pass reads, in the order of their columns in the packed operator
#: array (the deflection's ``v`` first: a deflection-only pass reads the first block alone).
OPERATORS = ("v", "curvature", "axial_strain", "u")
#: The float32 station fields :func:`recover` returns besides ``stress``.
FIELDS = ("deflection", "axial_displacement", "bending_strain", "axial_strain")

# No fastmath: every operation after the operator sums rounds as numpy's does (no contracted
# multiply-adds, no reordering), so the peaks' parabola is numpy's to the last bit given the
# same samples.
_JIT = dict(cache=True, nogil=True)


@nb.njit(**_JIT)
def _finish(n_steps, best, step, before, after):
    """The peak of one station's history from its running state: the largest sample
    raised to the vertex of the parabola through it and its neighbours where it is interior
    and the parabola opens downward (:func:`ced.fem.recovery.peaks`, same operations).

    Parameters
    ----------
    n_steps : int
        Number of samples of the history.
    best, before, after : float
        The largest sample and its neighbours, in the field's unit.
    step : int
        The step of the largest sample.

    Returns
    -------
    float
        The peak, in the field's unit (NaN if any sample is NaN).
    """
    if n_steps >= 3 and 1 <= step <= n_steps - 2:
        curvature = 2.0 * best - before - after
        if curvature > 0.0:
            return best + (after - before) ** 2 / (8.0 * curvature)
    return best


@nb.njit(**_JIT)
def _recover(qz, first_row, size, first_col, flexible, ops, xi, half_height, E,
             deflection_only, store, deflection, axial_displacement, bending_strain,
             axial_strain, stress, peak, peak_stress):
    """One pass per case over (step, link, station): the fields, stored as float32, and the
    peaks of |deflection| and of the larger |stress| of the two fibres, in place.

    Parameters
    ----------
    qz : numpy.ndarray
        Joint and link displacements, m and rad, shape (case, step, nz), float64.
    first_row, size, first_col : numpy.ndarray
        Per link (link,) int64: the first row of its local DOFs in z, their number, and their
        first row in ``ops``.
    flexible : numpy.ndarray
        Per link (link,) bool; a rigid link's fields and peaks are zero.
    ops : numpy.ndarray
        Packed operators, shape (case, ncol, 4 station): row ``first_col[i] + m`` holds the
        column m of link i's operators :data:`OPERATORS`, one block of stations each
        (1/m for the curvature, 1 for the strain, m/m for the displacements).
    xi : numpy.ndarray
        Normalized stations (station,), the first 0 and the last 1.
    half_height : numpy.ndarray
        Half the in-plane section depth, m, shape (case, link).
    E : numpy.ndarray
        Young's modulus, Pa, shape (case, link).
    deflection_only : bool
        Form and peak the deflection alone (the quasi-static response's).
    store : bool
        Write the fields; without it the field arguments are not touched.
    deflection, axial_displacement, bending_strain, axial_strain : numpy.ndarray
        float32 outputs (case, step, link, station): m, m, 1, 1.
    stress : numpy.ndarray
        float32 output, Pa, shape (case, step, link, station, 2): at y = −h/2 and +h/2.
    peak, peak_stress : numpy.ndarray
        Outputs (case, link): peak |deflection|, m, and peak stress magnitude, Pa (the latter
        untouched with ``deflection_only``).
    """
    ncase, n_steps = qz.shape[0], qz.shape[1]
    nlink, nst = first_row.shape[0], xi.shape[0]
    ncol = nst if deflection_only else 4 * nst
    nfield = 1 if deflection_only else 2
    values = np.empty(4 * nst)
    best = np.empty((nfield, nlink, nst))
    step = np.zeros((nfield, nlink, nst), np.int64)
    before = np.zeros((nfield, nlink, nst))
    after = np.zeros((nfield, nlink, nst))
    previous = np.empty((nfield, nlink, nst))
    for c in range(ncase):
        for t in range(n_steps):
            z = qz[c, t]
            for i in range(nlink):
                if not flexible[i]:
                    if store:
                        for s in range(nst):
                            deflection[c, t, i, s] = 0.0
                            axial_displacement[c, t, i, s] = 0.0
                            bending_strain[c, t, i, s] = 0.0
                            axial_strain[c, t, i, s] = 0.0
                            stress[c, t, i, s, 0] = 0.0
                            stress[c, t, i, s, 1] = 0.0
                    continue
                for j in range(ncol):
                    values[j] = 0.0
                r0, c0 = first_row[i], first_col[i]
                for m in range(size[i]):
                    f = z[r0 + m]
                    op = ops[c, c0 + m]
                    for j in range(ncol):
                        values[j] += f * op[j]
                v_start, v_end = values[0], values[nst - 1]
                hh, e = half_height[c, i], E[c, i]
                for s in range(nst):
                    x = xi[s]
                    d = values[s] - ((1.0 - x) * v_start + x * v_end)
                    magnitude = abs(d)
                    if not deflection_only:
                        bending = values[nst + s] * hh
                        axial = values[2 * nst + s]
                        s0 = e * (axial + bending)
                        s1 = e * (axial - bending)
                        if store:
                            deflection[c, t, i, s] = d
                            axial_displacement[c, t, i, s] = values[3 * nst + s]
                            bending_strain[c, t, i, s] = bending
                            axial_strain[c, t, i, s] = axial
                            stress[c, t, i, s, 0] = s0
                            stress[c, t, i, s, 1] = s1
                    # The running peak of each field's magnitude: what peaks() reads of a
                    # history, the first largest sample (the first NaN, as numpy's argmax),
                    # its step and its two neighbours. Written out here: a call per sample
                    # would count the references of its arrays every time.
                    for f in range(nfield):
                        if f == 1:  # the larger magnitude of the two fibres, NaN if either
                            a0, a1 = abs(s0), abs(s1)
                            magnitude = a0 if a0 >= a1 else a1
                            if np.isnan(a0) or np.isnan(a1):
                                magnitude = np.nan
                        if t == 0:
                            best[f, i, s] = magnitude
                            step[f, i, s] = 0
                        else:
                            if step[f, i, s] == t - 1:
                                after[f, i, s] = magnitude
                            b = best[f, i, s]
                            if not np.isnan(b) and (magnitude > b or np.isnan(magnitude)):
                                best[f, i, s] = magnitude
                                step[f, i, s] = t
                                before[f, i, s] = previous[f, i, s]
                        previous[f, i, s] = magnitude
        for i in range(nlink):
            for f in range(nfield):
                out = 0.0
                if flexible[i]:
                    out = -np.inf
                    for s in range(nst):
                        p = _finish(n_steps, best[f, i, s], step[f, i, s], before[f, i, s],
                                    after[f, i, s])
                        if np.isnan(p) or np.isnan(out):
                            out = np.nan
                        elif p > out:
                            out = p
                if f == 0:
                    peak[c, i] = out
                else:
                    peak_stress[c, i] = out


def _pack(operators: Sequence[Mapping[str, np.ndarray] | None], ncase: int, nst: int):
    """(size, first_col, flexible, ops) of :func:`_recover` from per-link operator dicts."""
    sizes = np.array([0 if op is None else op["v"].shape[-1] for op in operators], np.int64)
    first_col = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
    ops = np.empty((ncase, int(sizes.sum()), len(OPERATORS) * nst))
    for op, c0, n in zip(operators, first_col, sizes):
        if op is None:
            continue
        for k, name in enumerate(OPERATORS):
            block = np.broadcast_to(op[name], (ncase, nst, n))
            ops[:, c0:c0 + n, k * nst:(k + 1) * nst] = np.swapaxes(block, -1, -2)
    return sizes, first_col, sizes > 0, ops


def _output(allocate, name: str, shape: tuple) -> np.ndarray:
    """A float32 output of ``shape`` from ``allocate`` (checked) or :func:`numpy.empty`."""
    if allocate is None or not all(shape):
        return np.empty(shape, np.float32)
    out = allocate(name, shape, np.float32)
    if out.shape != shape or out.dtype != np.float32 or not out.flags.c_contiguous:
        raise ValueError(f"allocate gave {name} {out.shape} {out.dtype}, not a C-contiguous "
                         f"float32 {shape}")
    return out


def recover(qz: np.ndarray, first_row: Sequence[int],
            operators: Sequence[Mapping[str, np.ndarray] | None], stations: np.ndarray,
            height: np.ndarray, youngs_modulus: np.ndarray, fields: bool = True,
            qz_static: np.ndarray | None = None,
            allocate: Callable[[str, tuple, type], np.ndarray] | None = None,
            ) -> dict[str, np.ndarray]:
    """Station fields of every link and their peaks, compiled: what
    :func:`ced.fem.recovery.link_fields` and :func:`ced.fem.recovery.peaks` give, link by
    link, to round-off.

    Parameters
    ----------
    qz : numpy.ndarray
        Joint and link displacements, m and rad, shape (case, step, nz), at equally spaced
        steps.
    first_row : sequence of int
        Per link, the first row of its local DOFs in z (they are contiguous).
    operators : sequence of dict or None
        Per link, its recovery operators (``"v"``, ``"curvature"``, ``"axial_strain"``,
        ``"u"`` → (case, station, n) or (station, n)), or None for a rigid link (zero fields
        and peaks).
    stations : numpy.ndarray
        Normalized positions ξ (station,); the first is 0 and the last 1.
    height : numpy.ndarray
        In-plane section depth, m, shape (case, link) (read for flexible links only).
    youngs_modulus : numpy.ndarray
        Pa, shape (case, link) (read for flexible links only).
    fields : bool, optional
        Return the station fields; without it the peaks alone.
    qz_static : numpy.ndarray, optional
        The quasi-static displacements, shaped as ``qz``: adds the peak of their deflection.
    allocate : callable, optional
        ``allocate(name, shape, dtype)`` gives the C-contiguous array a field is written into
        (a part of a larger batch's output, so that it is not copied there afterwards);
        :func:`numpy.empty` by default.

    Returns
    -------
    dict of str to numpy.ndarray
        With ``fields``: float32 (case, step, link, station) ``deflection`` (m, relative to the
        chord through the deformed end joints), ``axial_displacement`` (m),
        ``bending_strain`` and ``axial_strain`` (1), and ``stress`` (case, step, link,
        station, fibre), Pa, signed at y = −h/2 and +h/2. Always: ``peak_deflection`` (m) and
        ``peak_stress`` (Pa, the larger magnitude of the two fibres) (case, link), peaks
        between samples as :func:`ced.fem.recovery.peaks`; with ``qz_static`` also
        ``static_peak_deflection`` (case, link), m. Rigid links hold zeros.
    """
    qz = np.ascontiguousarray(qz, dtype=np.float64)
    ncase, n_steps = qz.shape[:2]
    nlink, nst = len(operators), len(stations)
    sizes, first_col, flexible, ops = _pack(operators, ncase, nst)
    rows = np.asarray(first_row, np.int64)
    xi = np.ascontiguousarray(stations, dtype=np.float64)
    half_height = np.ascontiguousarray(0.5 * np.asarray(height, np.float64))
    E = np.ascontiguousarray(youngs_modulus, dtype=np.float64)
    shape = (ncase, n_steps, nlink, nst)
    stored = {name: _output(allocate, name, shape if fields else (0,) * 4) for name in FIELDS}
    stored["stress"] = _output(allocate, "stress", shape + (2,) if fields else (0,) * 5)
    peak, peak_stress = np.empty((ncase, nlink)), np.empty((ncase, nlink))
    _recover(qz, rows, sizes, first_col, flexible, ops, xi, half_height, E, False, fields,
             *stored.values(), peak, peak_stress)
    out = {**(stored if fields else {}), "peak_deflection": peak, "peak_stress": peak_stress}
    if qz_static is not None:
        static = np.empty((ncase, nlink))
        _recover(np.ascontiguousarray(qz_static, dtype=np.float64), rows, sizes, first_col,
                 flexible, ops, xi, half_height, E, True, False, *stored.values(), static,
                 peak_stress)
        out["static_peak_deflection"] = static
    return out
