"""The common sparsity of a batch's step matrices: a fill-reducing order and its symbolic LU.

A flexible link's FE DOFs couple only with their element neighbours and, through the joint
coordinates, with the other links: the step matrices S = M + c_C C + c_K K of a full FE model
are 17–23 % nonzero (two or three flexible links of 4–8 elements; 60 % for two links reduced
to 4 modes each), and their pattern is the same at every step and in every case of a batch
(the terms vary in value, not in structure).
In the reverse Cuthill–McKee order of that pattern, an LU *without pivoting* fills in almost
nothing (298 nonzeros of 1,296 for the 36-DOF four-bar of ``benchmarks/six_bar_cost.py``,
where the dense LU with partial pivoting holds 408 and its solves touch all 1,296), so that
each solve and each product K q̂, C v̂ of the march costs the nonzeros instead of n². The
terms and the factors are then stored **packed**, their nonzeros only, row by row
(:func:`pack`): the march reads every step's matrices from memory once or twice per period,
and for a full FE model it is that traffic, not the arithmetic, that sets its speed (12 µs
per step for the 45 DOFs of a 15-element coupler, dense).

Pivoting is given up because S is close to symmetric positive definite: M is, and c_K K is the
elastic stiffness plus small speed-dependent terms. An LU without pivoting is then stable;
every factorization checks it (each pivot positive against its diagonal entry,
:data:`MIN_PIVOT_RATIO`), and where one fails the batch is marched densely with partial
pivoting instead (:class:`ced.response.marching.Marcher`), so that an indefinite S (a link
buckling under its axial load) is solved as before.

Where the pattern fills more than :data:`MAX_FILL` of the matrix (Craig–Bampton links, whose
modes are dense blocks) the dense kernels are kept.
"""
from __future__ import annotations

import functools
from typing import NamedTuple

import numba as nb
import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import reverse_cuthill_mckee

__all__ = ["StepOrder", "nonzero_pattern", "step_order", "pack", "unpack", "packed_factor",
           "packed_solve", "MAX_FILL", "MIN_PIVOT_RATIO"]

#: Largest fraction of nonzeros (factors' pattern over n²) for which the packed path is taken.
#: Measured on the default study's Craig–Bampton four-bars (two links of 4 modes, 20 unknowns,
#: 60 % nonzero): packed, a batch of crank-rockers took 8 % less, but a change-point chunk
#: (its terms packed at every step, many buckled cases marched again densely) 5 % more; full
#: FE models (17–23 %) gain 1.6–3× (docs/performance.md).
MAX_FILL = 0.5
#: Smallest u_kk / s_kk (the pivot against the step matrix's own diagonal entry) accepted
#: without pivoting: positive and not vanishing, as for a symmetric positive definite S (for
#: which 0 < u_kk ≤ s_kk).
MIN_PIVOT_RATIO = 1e-10

_JIT = dict(cache=True, nogil=True, fastmath={"reassoc", "contract"})


class StepOrder(NamedTuple):
    """A fill-reducing order of the step matrices, their packed storage and the pattern of
    their LU factors. Index arrays are int64.

    Attributes
    ----------
    perm : (n,)
        Row ``perm[i]`` of S is row i of the ordered matrix (and the same for columns).
    rows_ptr, rows_idx : (n + 1,), (nnz,)
        The terms' pattern in the original order, row by row (CSR): packed entry b of row i
        is column ``rows_idx[b]``. ``entries`` (nnz,) are the same entries' flat indices
        i n + j into an (n, n) matrix, ascending.
    lu_ptr, lu_idx : (n + 1,), (nnz_lu,)
        The factors' pattern in the ordered matrix, row by row (L's columns, the diagonal,
        U's columns, ascending).
    diagonal : (n,)
        Where row i's diagonal entry is in the packed factors.
    lu_source : (nnz_lu,)
        The packed terms' entry each packed factor entry starts from (-1: a fill-in, 0).
    fill : float
        Nonzeros of the factors over n².
    """

    perm: np.ndarray
    rows_ptr: np.ndarray
    rows_idx: np.ndarray
    entries: np.ndarray
    lu_ptr: np.ndarray
    lu_idx: np.ndarray
    diagonal: np.ndarray
    lu_source: np.ndarray
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

    Every batch of a mesh has the same pattern: the orders of the last few patterns are kept
    (their arrays read-only), since finding one costs half a millisecond, an eighth of a
    small batch's solve (the ``auto`` pilots solve dozens).

    Parameters
    ----------
    pattern : numpy.ndarray
        Nonzeros of the step matrices, (n, n) bool, symmetric (:func:`nonzero_pattern`).
    max_fill : float, optional
        Largest fraction of nonzeros in the factors for which an order is returned.
    """
    pattern = np.ascontiguousarray(pattern, dtype=bool)
    return _kept_order(pattern.shape[0], pattern.tobytes(), float(max_fill))


@functools.lru_cache(maxsize=32)
def _kept_order(n: int, pattern: bytes, max_fill: float) -> StepOrder | None:
    """:func:`step_order` of the pattern given as the bytes of an (n, n) bool array."""
    order = _order(np.frombuffer(pattern, dtype=bool).reshape(n, n), max_fill)
    if order is not None:
        for x in order:
            if isinstance(x, np.ndarray):
                x.flags.writeable = False
    return order


def _order(pattern: np.ndarray, max_fill: float) -> StepOrder | None:
    """:func:`step_order`, found afresh."""
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
    rows_ptr, rows_idx = _csr(pattern)
    entries = np.flatnonzero(pattern).astype(np.int64)
    lu_ptr, lu_idx = _csr(filled)
    lu_rows = np.repeat(np.arange(n), np.diff(lu_ptr))
    diagonal = np.flatnonzero(lu_rows == lu_idx).astype(np.int64)
    # Packed terms' index of each factor entry (perm[i], perm[j]) in the original order.
    where = np.full(n * n, -1, np.int64)
    where[entries] = np.arange(len(entries))
    lu_source = where[perm[lu_rows] * n + perm[lu_idx]]
    return StepOrder(perm, rows_ptr, rows_idx, entries, lu_ptr, lu_idx, diagonal, lu_source,
                     float(fill))


def pack(matrices: np.ndarray, order: StepOrder) -> np.ndarray:
    """The nonzeros (…, nnz) of matrices (…, n, n) on ``order``'s pattern, row by row.

    Parameters
    ----------
    matrices : numpy.ndarray
        Shape (…, n, n); zero off the pattern.
    order : StepOrder
        The pattern (:func:`step_order`).
    """
    n = matrices.shape[-1]
    # np.take along the last axis: 10× numpy's fancy indexing there (measured).
    return np.take(matrices.reshape(matrices.shape[:-2] + (n * n,)), order.entries, axis=-1)


def unpack(packed: np.ndarray, order: StepOrder, n: int) -> np.ndarray:
    """The matrices (…, n, n) of packed nonzeros (…, nnz) (:func:`pack`), zero elsewhere.

    Parameters
    ----------
    packed : numpy.ndarray
        Shape (…, nnz).
    order : StepOrder
        The pattern.
    n : int
        The matrices' order.
    """
    out = np.zeros(packed.shape[:-1] + (n * n,))
    _scatter(np.ascontiguousarray(packed).reshape(-1, packed.shape[-1]), order.entries,
             out.reshape(-1, n * n))
    return out.reshape(packed.shape[:-1] + (n, n))


@nb.njit(**_JIT)
def _scatter(packed, entries, out):
    """out[r, entries[k]] = packed[r, k]: numpy's fancy assignment along the last axis costs
    ten times this loop."""
    for r in range(packed.shape[0]):
        for k in range(entries.shape[0]):
            out[r, entries[k]] = packed[r, k]


@nb.njit(**_JIT)
def packed_factor(LU, lu_ptr, lu_idx, diagonal, work) -> bool:
    """LU without pivoting, in place, of the ordered matrix held packed (row by row, on the
    factors' pattern), row by row (Doolittle's IKJ form: row i gathers the updates of the
    rows k < i it has an L entry in). Returns False where a pivot is not finite or its ratio
    to the matrix's own diagonal entry is below :data:`MIN_PIVOT_RATIO`: the matrix is then
    to be factorized with pivoting.

    Parameters
    ----------
    LU : numpy.ndarray
        The ordered matrix packed (nnz_lu,) (fill-ins 0); overwritten by L (unit, below the
        diagonal) and U.
    lu_ptr, lu_idx, diagonal : numpy.ndarray
        :class:`StepOrder`'s pattern of the factors.
    work : numpy.ndarray
        Scratch (n,).
    """
    n = lu_ptr.shape[0] - 1
    for i in range(n):
        for a in range(lu_ptr[i], lu_ptr[i + 1]):
            work[lu_idx[a]] = LU[a]
        for a in range(lu_ptr[i], diagonal[i]):
            k = lu_idx[a]
            f = work[k] / LU[diagonal[k]]
            work[k] = f
            for b in range(diagonal[k] + 1, lu_ptr[k + 1]):
                work[lu_idx[b]] -= f * LU[b]
        pivot, own = work[i], LU[diagonal[i]]
        if not (np.isfinite(pivot) and own > 0.0 and pivot >= MIN_PIVOT_RATIO * own):
            return False
        for a in range(lu_ptr[i], lu_ptr[i + 1]):
            LU[a] = work[lu_idx[a]]
    return True


@nb.njit(**_JIT)
def packed_solve(LU, perm, lu_ptr, lu_idx, diagonal, X, work) -> None:
    """Solve S X = B in place for B (n, r) in the original order, given the ordered S's
    :func:`packed_factor`. The inner loops run along the r columns, as in
    :func:`ced.response.kernels.lu_solve_columns` (with one column: dot products along rows).

    Parameters
    ----------
    LU : numpy.ndarray
        The packed factors (nnz_lu,) from :func:`packed_factor`.
    perm, lu_ptr, lu_idx, diagonal : numpy.ndarray
        :class:`StepOrder`'s order and pattern of the factors.
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
            for a in range(lu_ptr[i], diagonal[i]):
                t -= LU[a] * w[lu_idx[a]]
            w[i] = t
        for i in range(n - 1, -1, -1):
            t = w[i]
            for a in range(diagonal[i] + 1, lu_ptr[i + 1]):
                t -= LU[a] * w[lu_idx[a]]
            w[i] = t / LU[diagonal[i]]
        for i in range(n):
            x[perm[i]] = w[i]
        return
    for i in range(n):
        src = perm[i]
        for s in range(r):
            work[i, s] = X[src, s]
    for i in range(n):
        for a in range(lu_ptr[i], diagonal[i]):
            k = lu_idx[a]
            f = LU[a]
            for s in range(r):
                work[i, s] -= f * work[k, s]
    for i in range(n - 1, -1, -1):
        for a in range(diagonal[i] + 1, lu_ptr[i + 1]):
            k = lu_idx[a]
            f = LU[a]
            for s in range(r):
                work[i, s] -= f * work[k, s]
        inv = 1.0 / LU[diagonal[i]]
        for s in range(r):
            work[i, s] *= inv
    for i in range(n):
        dst = perm[i]
        for s in range(r):
            X[dst, s] = work[i, s]
