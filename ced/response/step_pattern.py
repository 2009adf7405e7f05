"""The common sparsity of a batch's step matrices: a fill-reducing order and its symbolic LU.

A flexible link's FE DOFs couple only with their element neighbours and, through the joint
coordinates, with the other links: the step matrices S = M + c_C C + c_K K of a full FE model
are 17–23 % nonzero (two or three flexible links of 4–8 elements; 60 % for two links reduced
to 4 modes each), and their pattern is the same at every step and in every case of a batch
(the terms vary in value, not in structure).
In the reverse Cuthill–McKee order of that pattern, an LU *without pivoting* fills in almost
nothing (298 nonzeros of 1,296 for the 36-DOF four-bar of ``benchmarks/six_bar_cost.py``,
where the dense LU with partial pivoting holds 408 and its solves touch all 1,296), so that
each solve and each product K q̂, C v̂ of the march costs the nonzeros instead of n².

Pivoting is given up because S is close to symmetric positive definite: M is, and c_K K is the
elastic stiffness plus small speed-dependent terms. An LU without pivoting is then stable;
every factorization checks it (each pivot positive against its diagonal entry,
:data:`MIN_PIVOT_RATIO`), and a step matrix that fails the check is factorized densely with
partial pivoting instead (:func:`ced.response.kernels.newmark_march`), so that an indefinite
S (a link buckling under its axial load) is solved as before.

Where the pattern fills more than :data:`MAX_FILL` of the matrix (one flexible link reduced
to a few dense modes) the dense kernels are as fast and are kept.
"""
from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import reverse_cuthill_mckee

__all__ = ["StepOrder", "nonzero_pattern", "step_order", "pattern_factor", "pattern_solve",
           "MAX_FILL", "MIN_PIVOT_RATIO"]

#: Largest fraction of nonzeros (factors' pattern over n²) for which the sparse path is taken:
#: above it the indexed loops gain little over the dense ones. Measured: the default study's
#: Craig–Bampton four-bars (two flexible links, 4 modes each, 20 unknowns) fill 0.595, and their
#: shooting march took 0.176 against 0.232 s per 100 cases.
MAX_FILL = 0.75
#: Smallest u_kk / s_kk (the pivot against the step matrix's own diagonal entry) accepted
#: without pivoting: positive and not vanishing, as for a symmetric positive definite S (for
#: which 0 < u_kk ≤ s_kk).
MIN_PIVOT_RATIO = 1e-10

_JIT = dict(cache=True, nogil=True, fastmath={"reassoc", "contract"})


class StepOrder(NamedTuple):
    """A fill-reducing order of the step matrices and the pattern of their LU factors.

    Index arrays come in CSR pairs (``*_ptr`` (n + 1,), ``*_idx``), all int64, sorted.

    Attributes
    ----------
    perm : (n,)
        Row ``perm[i]`` of S is row i of the ordered matrix (and the same for columns).
    lower_ptr, lower_idx
        Row i of L (strictly lower, ordered indices): the columns k < i.
    upper_ptr, upper_idx
        Row i of U (strictly upper, ordered indices): the columns j > i.
    column_ptr, column_idx
        Column k of L: the rows i > k (ordered indices).
    rows_ptr, rows_idx
        Row i of M, C, K in the original order: the columns of its nonzeros (for the products
        K q̂ and C v̂).
    fill : float
        Nonzeros of L + U (diagonal once) over n².
    """

    perm: np.ndarray
    lower_ptr: np.ndarray
    lower_idx: np.ndarray
    upper_ptr: np.ndarray
    upper_idx: np.ndarray
    column_ptr: np.ndarray
    column_idx: np.ndarray
    rows_ptr: np.ndarray
    rows_idx: np.ndarray
    fill: float


def nonzero_pattern(*terms: np.ndarray | None) -> np.ndarray:
    """(n, n) bool: where any of ``terms`` is nonzero in any case and phase, made symmetric
    and with the diagonal.

    Evaluated on the terms' samples, it covers their interpolation to every step as well: an
    interpolated entry is a weighted sum of the samples' entries, exactly 0 where they all are.

    Parameters
    ----------
    *terms : numpy.ndarray or None
        Matrices (case, phase, n, n) of the same n (None: absent, skipped).
    """
    pattern = None
    for x in terms:
        if x is None:
            continue
        nz = (x != 0).any(axis=(0, 1))
        pattern = nz if pattern is None else pattern | nz
    n = pattern.shape[0]
    return pattern | pattern.T | np.eye(n, dtype=bool)  # symmetric, with the diagonal


def _csr(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    rows, cols = np.nonzero(mask)  # row-major: sorted by row, then column
    ptr = np.zeros(mask.shape[0] + 1, np.int64)
    np.cumsum(np.bincount(rows, minlength=mask.shape[0]), out=ptr[1:])
    return ptr, cols.astype(np.int64)


def step_order(pattern: np.ndarray, max_fill: float = MAX_FILL) -> StepOrder | None:
    """The reverse Cuthill–McKee order of ``pattern`` and the symbolic LU (no pivoting) in it,
    or None when the factors would fill more than ``max_fill`` of the matrix.

    Parameters
    ----------
    pattern : numpy.ndarray
        Nonzeros of the step matrices, (n, n) bool, symmetric (:func:`nonzero_pattern`).
    max_fill : float, optional
        Largest fraction of nonzeros in the factors for which an order is returned.
    """
    n = pattern.shape[0]
    perm = reverse_cuthill_mckee(csr_matrix(pattern.astype(np.int8)), symmetric_mode=True)
    perm = np.asarray(perm, np.int64)
    filled = pattern[np.ix_(perm, perm)].copy()
    for k in range(n):  # symbolic elimination: row k's pattern spreads to the rows below it
        below = np.flatnonzero(filled[k + 1:, k]) + k + 1
        right = np.flatnonzero(filled[k, k + 1:]) + k + 1
        if len(below) and len(right):
            filled[np.ix_(below, right)] = True
    fill = filled.sum() / n**2
    if fill > max_fill:
        return None
    lower = np.tril(filled, -1)
    lower_ptr, lower_idx = _csr(lower)
    upper_ptr, upper_idx = _csr(np.triu(filled, 1))
    column_ptr, column_idx = _csr(lower.T)
    rows_ptr, rows_idx = _csr(pattern)
    return StepOrder(perm, lower_ptr, lower_idx, upper_ptr, upper_idx, column_ptr, column_idx,
                     rows_ptr, rows_idx, float(fill))


@nb.njit(**_JIT)
def pattern_factor(LU, diagonal, upper_ptr, upper_idx, column_ptr, column_idx) -> bool:
    """LU without pivoting, in place, of the ordered matrix (n, n) given on the factors'
    pattern (entries off it are never read). Returns False, leaving LU partly factorized,
    where a pivot is not finite or its ratio to ``diagonal`` (the matrix's own diagonal) is
    below :data:`MIN_PIVOT_RATIO`: the matrix is then to be factorized with pivoting.

    Parameters
    ----------
    LU : numpy.ndarray
        The ordered matrix (n, n) on the pattern; overwritten by L (unit, below the diagonal)
        and U.
    diagonal : numpy.ndarray
        The matrix's diagonal before factorization (n,).
    upper_ptr, upper_idx, column_ptr, column_idx : numpy.ndarray
        :class:`StepOrder`'s rows of U and columns of L.
    """
    n = LU.shape[0]
    for k in range(n):
        pivot = LU[k, k]
        if not (np.isfinite(pivot) and diagonal[k] > 0.0
                and pivot >= MIN_PIVOT_RATIO * diagonal[k]):
            return False
        inv = 1.0 / pivot
        for a in range(column_ptr[k], column_ptr[k + 1]):
            i = column_idx[a]
            f = LU[i, k] * inv
            LU[i, k] = f
            for b in range(upper_ptr[k], upper_ptr[k + 1]):
                j = upper_idx[b]
                LU[i, j] -= f * LU[k, j]
    return True


@nb.njit(**_JIT)
def pattern_solve(LU, perm, lower_ptr, lower_idx, upper_ptr, upper_idx, X, work) -> None:
    """Solve S X = B in place for B (n, r) in the original order, given the ordered S's
    :func:`pattern_factor`. The inner loops run along the r columns, as in
    :func:`ced.response.kernels.lu_solve_columns` (with one column: dot products along rows).

    Parameters
    ----------
    LU : numpy.ndarray
        The factors (n, n) from :func:`pattern_factor` (read on the pattern only).
    perm, lower_ptr, lower_idx, upper_ptr, upper_idx : numpy.ndarray
        :class:`StepOrder`'s order and rows of L and U.
    X : numpy.ndarray
        The right-hand sides B (n, r), C-contiguous, overwritten by the solutions.
    work : numpy.ndarray
        Scratch (n, r).
    """
    n, r = X.shape
    if r == 1:  # one column: dot products along the rows, no loops of length 1
        x, w = X[:, 0], work[:, 0]
        for i in range(n):
            t = x[perm[i]]
            for a in range(lower_ptr[i], lower_ptr[i + 1]):
                t -= LU[i, lower_idx[a]] * w[lower_idx[a]]
            w[i] = t
        for i in range(n - 1, -1, -1):
            t = w[i]
            for a in range(upper_ptr[i], upper_ptr[i + 1]):
                t -= LU[i, upper_idx[a]] * w[upper_idx[a]]
            w[i] = t / LU[i, i]
        for i in range(n):
            x[perm[i]] = w[i]
        return
    for i in range(n):
        src = perm[i]
        for s in range(r):
            work[i, s] = X[src, s]
    for i in range(n):
        for a in range(lower_ptr[i], lower_ptr[i + 1]):
            k = lower_idx[a]
            f = LU[i, k]
            for s in range(r):
                work[i, s] -= f * work[k, s]
    for i in range(n - 1, -1, -1):
        for a in range(upper_ptr[i], upper_ptr[i + 1]):
            k = upper_idx[a]
            f = LU[i, k]
            for s in range(r):
                work[i, s] -= f * work[k, s]
        inv = 1.0 / LU[i, i]
        for s in range(r):
            work[i, s] *= inv
    for i in range(n):
        dst = perm[i]
        for s in range(r):
            X[dst, s] = work[i, s]
