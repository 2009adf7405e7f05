"""Compiled Pᵀ A P products of one link block for every (case, step) (numba).

:class:`ced.fem.effect_terms._Split` forms Pᵀ A P from the few time-varying rows T of a link's
projection block and its constant unit rows: per (case, step) four small products (T is a few
rows by the joint coordinates). numpy's batched matmul pays its per-matrix overhead and a
temporary for each of them, ~1 µs per product and step on the default study's links — half of
forming the system's terms. :func:`sandwich_add` does the four in one compiled loop; the numpy
expressions stay the reference (``CED_KERNEL=numpy``, and ``tests/fem/test_sandwich.py``).
"""
from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["sandwich_add"]


@nb.njit(cache=True, nogil=True, fastmath={"reassoc", "contract"})
def _sandwich(out, A, TL, TR, ns, c0, left_zero, right_zero):
    ncase, nstep, nv, nf = TR.shape
    per_step = A.shape[1] > 1
    W = np.empty((nv, nf))
    for c in range(ncase):
        for s in range(nstep):
            a = A[c, s if per_step else 0]
            tl, tr, o = TL[c, s], TR[c, s], out[c, s]
            if nf:
                # W = A_vv T_R; out_ff += T_Lᵀ W
                for i in range(nv):
                    for j in range(nf):
                        x = 0.0
                        for k in range(nv):
                            x += a[ns + i, ns + k] * tr[k, j]
                        W[i, j] = x
                for i in range(nf):
                    for j in range(nf):
                        x = 0.0
                        for k in range(nv):
                            x += tl[k, i] * W[k, j]
                        o[i, j] += x
                if ns and left_zero:  # out_cf += A_sv T_R
                    for i in range(ns):
                        for j in range(nf):
                            x = 0.0
                            for k in range(nv):
                                x += a[i, ns + k] * tr[k, j]
                            o[c0 + i, j] += x
                if ns and right_zero:  # out_fc += T_Lᵀ A_vs
                    for i in range(nf):
                        for j in range(ns):
                            x = 0.0
                            for k in range(nv):
                                x += tl[k, i] * a[ns + k, j]
                            o[i, c0 + j] += x
            if ns and left_zero and right_zero:  # out_cc += A_ss
                for i in range(ns):
                    for j in range(ns):
                        o[c0 + i, c0 + j] += a[i, j]


def sandwich_add(out: np.ndarray, A: np.ndarray, TL: np.ndarray, TR: np.ndarray, ns: int,
                 c0: int, left: int, right: int) -> None:
    """out += P⁽ˡᵉᶠᵗ⁾ᵀ A P⁽ʳⁱᵍʰᵗ⁾ for one link block, in place.

    The block's rows are permuted: ``ns`` constant unit rows first (mapping onto columns
    ``c0 … c0 + ns`` of ``out``), then the varying rows T, which map onto the first ``nf``
    columns (the joint coordinates).

    Parameters
    ----------
    out : numpy.ndarray
        The reduced matrix (case, step, ny, ny), C-contiguous, float64; added to.
    A : numpy.ndarray
        The link matrix in split order, (case, n, n) or (case, step, n, n).
    TL, TR : numpy.ndarray
        The varying rows of the left and right projection derivatives, (case, step, nv, nf).
    ns, c0 : int
        Number of constant rows and their first column in ``out``.
    left, right : int
        Time-derivative orders of the two projections (the constant rows' derivatives vanish).
    """
    if A.ndim == 3:
        A = A[:, None]
    _sandwich(out, np.ascontiguousarray(A, dtype=float), np.ascontiguousarray(TL, dtype=float),
              np.ascontiguousarray(TR, dtype=float), ns, c0, left == 0, right == 0)
