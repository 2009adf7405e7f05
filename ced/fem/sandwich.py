"""Compiled Pᵀ A P products of one link block for every (case, step) (numba).

:class:`ced.fem.effect_terms._Split` forms Pᵀ A P from the few time-varying rows T of a link's
projection block and its constant unit rows: per (case, step) four small products (T is a few
rows by the joint coordinates). numpy's batched matmul pays its per-matrix overhead and a
temporary for each of them, ~1 µs per product and step on the default study's links — half of
forming the system's terms. :func:`sandwich_add` does the four in one compiled loop; the numpy
expressions stay the reference (``CED_KERNEL=numpy``, and ``tests/fem/test_sandwich.py``).

A link adds up to six such products to M, C and K (docs/theory.md), each a pass over every
(case, step) that re-reads T and read-modify-writes its (ny, ny) output, two of them on a
(case, step, n, n) temporary 2ω G. :func:`link_terms_add` makes the link's one pass: 2ω a
scalar per step times the constant G, T⁽⁰⁾, T⁽¹⁾, T⁽²⁾ read once, the products with the
mass matrix's varying columns shared by the three outputs, and K's combination Σ c_k(t) A_k
formed in a work matrix of the step rather than a batch temporary.
"""
from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["sandwich_add", "link_terms_add"]


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


@nb.njit(cache=True, nogil=True, fastmath={"reassoc", "contract"})
def _link_terms(M, C, K, mass, gyro, mats, coef, w2, T0, T1, T2, ns, c0, has_m, has_c,
                centrifugal):
    ncase, nstep, nv, nf = T0.shape
    n = ns + nv
    nk = coef.shape[2]
    flat = np.zeros(n * n)  # K's link matrix of the step, Σ c_k A_k (stays 0 without terms)
    A = flat.reshape((n, n))
    X = np.empty((3, nv, nf))  # (M_vv T0, C's and K's varying rows) before T0ᵀ
    for c in range(ncase):
        m, g = mass[c], gyro[c]
        for s in range(nstep):
            w = w2[c, s]
            t0, t1, t2 = T0[c, s], T1[c, s], T2[c, s]
            om, oc, ok = M[c, s], C[c, s], K[c, s]  # (0, 0) when absent
            for k in range(nk):  # flat loops: numba's array expressions would allocate
                x, a = coef[c, s, k], mats[c, k]
                if k == 0:
                    for i in range(n * n):
                        flat[i] = x * a[i]
                else:
                    for i in range(n * n):
                        flat[i] += x * a[i]
            # Rows r of A_{r,v} T for every link matrix and right order at once: the unit rows
            # (r < ns) are the out_cf blocks, the varying ones wait in X for T0ᵀ. Every term's
            # left projection is P itself (order 0).
            for r in range(n):
                for j in range(nf):
                    m0 = m1 = m2 = g0 = g1 = a0 = 0.0
                    for k in range(nv):
                        mk, gk = m[r, ns + k], g[r, ns + k]
                        m0 += mk * t0[k, j]
                        m1 += mk * t1[k, j]
                        m2 += mk * t2[k, j]
                        g0 += gk * t0[k, j]
                        g1 += gk * t1[k, j]
                        a0 += A[r, ns + k] * t0[k, j]
                    xc = w * g0 + 2.0 * m1  # Pᵀ 2ωG P + Pᵀ 2M Ṗ
                    xk = a0 + w * g1 + m2 if centrifugal else a0  # + Pᵀ 2ωG Ṗ + Pᵀ M P̈
                    if r < ns:
                        if has_m:
                            om[c0 + r, j] += m0
                        if has_c:
                            oc[c0 + r, j] += xc
                        ok[c0 + r, j] += xk
                    else:
                        X[0, r - ns, j] = m0
                        X[1, r - ns, j] = xc
                        X[2, r - ns, j] = xk
            # out_ff += T0ᵀ X
            for i in range(nf):
                for j in range(nf):
                    xm = xc = xk = 0.0
                    for k in range(nv):
                        t = t0[k, i]
                        xm += t * X[0, k, j]
                        xc += t * X[1, k, j]
                        xk += t * X[2, k, j]
                    if has_m:
                        om[i, j] += xm
                    if has_c:
                        oc[i, j] += xc
                    ok[i, j] += xk
            # The terms with P on the right: out_fc += T0ᵀ A_vs and out_cc += A_ss, one output
            # at a time so that the loops over the row's columns vectorize.
            if has_m:
                _unit_columns(om, m, t0, 1.0, ns, c0)
            if has_c:
                _unit_columns(oc, g, t0, w, ns, c0)
            _unit_columns(ok, A, t0, 1.0, ns, c0)


@nb.njit(inline="always", fastmath={"reassoc", "contract"})
def _unit_columns(o, a, t0, scale, ns, c0):
    """o[:nf, c0:c0+ns] += scale T0ᵀ a_vs; o[c0:, c0:] += scale a_ss (one step)."""
    nv, nf = t0.shape
    for i in range(nf):
        for k in range(nv):
            t = scale * t0[k, i]
            for j in range(ns):
                o[i, c0 + j] += t * a[ns + k, j]
    for i in range(ns):
        for j in range(ns):
            o[c0 + i, c0 + j] += scale * a[i, j]


def link_terms_add(M: np.ndarray | None, C: np.ndarray | None, K: np.ndarray,
                   mass: np.ndarray, gyroscopic: np.ndarray, coefficients: list[np.ndarray],
                   matrices: list[np.ndarray], omega: np.ndarray, T: list[np.ndarray], ns: int,
                   c0: int, centrifugal: bool) -> None:
    """One link's terms of M q̈ + C q̇ + K q, added in place in one pass over (case, step).

    With the link block of P split as in :func:`sandwich_add` (``ns`` constant unit rows
    onto columns ``c0 …``, then the varying rows T⁽ᵈ⁾ onto the joint coordinates)::

        M += Pᵀ M_l P
        C += Pᵀ 2ωG P + Pᵀ 2M_l Ṗ
        K += Pᵀ (Σ_k c_k A_k) P [+ Pᵀ 2ωG Ṗ + Pᵀ M_l P̈ if centrifugal]

    Parameters
    ----------
    M, C : numpy.ndarray or None
        Reduced mass and damping targets (case, step, ny, ny) in the SI units of the DOF
        pairs (kg, kg/s for translations), C-contiguous float64, or None to leave out.
    K : numpy.ndarray
        Reduced stiffness (case, step, ny, ny) (N/m for translations), C-contiguous float64.
    mass, gyroscopic : numpy.ndarray
        The link's mass matrix M_l and gyroscopic matrix G in split order, (case, n, n).
    coefficients, matrices : list of numpy.ndarray
        K's link matrix Σ_k c_k(t) A_k: coefficients (case, step) in the matching units
        (1, rad/s², rad²/s², N, N/m, N/m²) and matrices (case, n, n); may be empty.
    omega : numpy.ndarray
        The link's angular velocity ω, rad/s, (case, step).
    T : list of numpy.ndarray
        The varying rows of P, Ṗ, P̈, each (case, step, nv, nf).
    ns, c0 : int
        Number of constant rows and their first column in the outputs.
    centrifugal : bool
        Add the terms with Ṗ and P̈ to K.
    """
    ncase, nstep, nv, nf = T[0].shape
    n = ns + nv
    if coefficients:
        coef, mats = np.stack(coefficients, axis=-1), np.stack(matrices, axis=1)
    else:
        coef, mats = np.zeros((ncase, nstep, 0)), np.zeros((ncase, 0, n, n))
    absent = np.empty((ncase, nstep, 0, 0))
    _link_terms(absent if M is None else M, absent if C is None else C, K,
                *(np.ascontiguousarray(a, dtype=float) for a in (
                    mass, gyroscopic, mats.reshape(ncase, -1, n * n), coef, 2.0 * omega, *T)),
                ns, c0, M is not None, C is not None, centrifugal)
