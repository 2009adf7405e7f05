"""Compiled LU for many small dense systems (numba): the rigid Newton–Euler systems and the
elastic step matrices.

numpy's batched ``np.linalg.solve`` pays its per-call and per-matrix overhead on systems of
10 unknowns (~5 µs each, measured); an LU in a compiled loop costs ~0.2 µs. :func:`lu_factor`
and :func:`lu_solve` work on one system, in place, allocating nothing (the elastic march,
:mod:`ced.response.kernels`, calls them at every step); :func:`solve_batch` solves a batch
of systems and returns, with the solutions, each matrix's Hadamard ratio
|det A| / Π‖rowᵢ‖ from the same LU (the singularity measure of
:mod:`ced.rigid.inverse_dynamics`).
"""
from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["lu_factor", "lu_solve", "solve_batch"]

_JIT = dict(cache=True, nogil=True, fastmath={"reassoc", "contract"})


@nb.njit(**_JIT)
def lu_factor(A: np.ndarray, piv: np.ndarray) -> bool:
    """LU with partial pivoting of the square A (n, n) in place (L unit lower, U upper, as
    LAPACK getrf); ``piv[k]`` the row swapped with row k. Returns False if a pivot is zero or
    not finite (singular or corrupted matrix).

    Parameters
    ----------
    A : numpy.ndarray
        Square matrix (n, n), float64, overwritten by its L and U factors.
    piv : numpy.ndarray
        Pivot indices (n,), int64, filled.

    Returns
    -------
    bool
        True when the factorization succeeded.
    """
    n = A.shape[0]
    for k in range(n):
        p = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                p = i
        piv[k] = p
        if not (big > 0.0 and big < np.inf):
            return False
        if p != k:
            for j in range(n):
                t = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = t
        inv = 1.0 / A[k, k]
        pivot_row = A[k]
        for i in range(k + 1, n):
            f = A[i, k] * inv
            A[i, k] = f
            row = A[i]
            for j in range(k + 1, n):
                row[j] -= f * pivot_row[j]
    return True


@nb.njit(**_JIT)
def lu_solve(LU: np.ndarray, piv: np.ndarray, x: np.ndarray) -> None:
    """Solve A x = b in place for one right-hand side x (n,), given A's :func:`lu_factor`.

    Parameters
    ----------
    LU : numpy.ndarray
        The factors (n, n) from :func:`lu_factor`.
    piv : numpy.ndarray
        The pivot indices (n,) from :func:`lu_factor`.
    x : numpy.ndarray
        The right-hand side b (n,), overwritten by the solution.
    """
    # Kept apart from lu_solve_columns on purpose: that one's inner loops run along the columns
    # (4x faster than dot products for the shooting's 61 columns, measured), which with one
    # column are loops of length 1; here the inner loops are dot products along the row.
    n = x.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            t = x[k]
            x[k] = x[p]
            x[p] = t
    for i in range(n):
        t = x[i]
        for k in range(i):
            t -= LU[i, k] * x[k]
        x[i] = t
    for i in range(n - 1, -1, -1):
        t = x[i]
        for k in range(i + 1, n):
            t -= LU[i, k] * x[k]
        x[i] = t / LU[i, i]


@nb.njit(**_JIT)
def _solve_batch(A, b, x, ratio):
    LU = np.empty(A.shape[1:])
    piv = np.empty(A.shape[1], np.int64)
    n = A.shape[1]
    for c in range(A.shape[0]):
        norms = 1.0
        for i in range(n):
            t = 0.0
            for j in range(n):
                t += A[c, i, j] * A[c, i, j]
            norms *= np.sqrt(t)
        LU[:, :] = A[c]
        x[c] = b[c]
        if not lu_factor(LU, piv):
            ratio[c] = 0.0
            continue
        det = 1.0
        for i in range(n):
            det *= abs(LU[i, i])
        ratio[c] = det / norms if norms > 0.0 else 0.0
        lu_solve(LU, piv, x[c])


def solve_batch(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve A x = b for a batch of small systems by LU with partial pivoting.

    Parameters
    ----------
    A : numpy.ndarray
        Matrices, shape (..., n, n).
    b : numpy.ndarray
        Right-hand sides, shape (..., n).

    Returns
    -------
    x : numpy.ndarray
        Solutions, shape (..., n); meaningless where ``ratio`` is 0.
    ratio : numpy.ndarray
        Hadamard ratio |det A| / Π‖rowᵢ‖ of each matrix, shape (...): 1 for orthogonal rows,
        0 for a singular one (a zero or non-finite pivot).
    """
    n = A.shape[-1]
    flat_A = np.ascontiguousarray(A, dtype=float).reshape(-1, n, n)
    flat_b = np.ascontiguousarray(b, dtype=float).reshape(-1, n)
    x = np.empty_like(flat_b)
    ratio = np.empty(len(flat_A))
    _solve_batch(flat_A, flat_b, x, ratio)
    return x.reshape(b.shape), ratio.reshape(A.shape[:-2])
