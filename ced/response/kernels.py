"""Compiled time marching (numba): the Newmark family over a periodic step grid.

The one marching loop of :func:`ced.response.integrators.march` pays numpy's per-call cost
at every step: on a batch of 10×10 systems a batched ``np.linalg.solve`` costs ~5 µs per
system, while an LU in a compiled loop costs ~0.2 µs. :func:`newmark_march` runs the same
scheme (Arnold & Brüls 2007 form, :func:`ced.response.integrators.alpha_step`), step for
step and case by case, in compiled code, on terms given over **one period** of the step
grid: the KED system is periodic in the input period, so step k uses the terms at k mod P,
and the step matrix S = M + c_C C + c_K K of each step of the period is factorized once and
its LU reused in every later period (the second revolution costs only the solves).

The arithmetic is that of the numpy path; :func:`ced.response.integrators.march` stays the
reference it is tested against (``tests/response/test_kernels.py``: equal to round-off).

Every function takes and fills plain arrays; none allocates per step.
"""
from __future__ import annotations

import numba as nb
import numpy as np

# The LU of one small system lives with the rigid layer's batched solver (below this layer).
from ..rigid.small_systems import lu_factor, lu_solve
from .step_pattern import pattern_factor, pattern_solve

__all__ = ["lu_factor", "lu_solve", "lu_solve_columns", "newmark_march", "static_period",
           "expand"]

_JIT = dict(cache=True, nogil=True, fastmath={"reassoc", "contract"})


@nb.njit(**_JIT)
def lu_solve_columns(LU: np.ndarray, piv: np.ndarray, X: np.ndarray) -> None:
    """Solve A X = B in place for B (n, r), given A's :func:`lu_factor`; the loops run along
    the r columns (contiguous), so that many right-hand sides vectorize.

    Parameters
    ----------
    LU : numpy.ndarray
        The factors (n, n) from :func:`lu_factor`.
    piv : numpy.ndarray
        The pivot indices (n,) from :func:`lu_factor`.
    X : numpy.ndarray
        The right-hand sides B (n, r), C-contiguous, overwritten by the solutions.
    """
    n, r = X.shape
    for k in range(n):
        p = piv[k]
        if p != k:
            for s in range(r):
                t = X[k, s]
                X[k, s] = X[p, s]
                X[p, s] = t
    for i in range(n):
        for k in range(i):
            f = LU[i, k]
            for s in range(r):
                X[i, s] -= f * X[k, s]
    for i in range(n - 1, -1, -1):
        for k in range(i + 1, n):
            f = LU[i, k]
            for s in range(r):
                X[i, s] -= f * X[k, s]
        inv = 1.0 / LU[i, i]
        for s in range(r):
            X[i, s] *= inv


@nb.njit(**_JIT)
def newmark_march(M, C, K, F, has_damping, h, alpha_m, alpha_f, beta, gamma, n_steps,
                  q, v, acc, a, record_every, record, LU, piv, factored, ok, order):
    """March the Newmark family from step 0 to ``n_steps``, every case, in place.

    Parameters
    ----------
    M, C, K : (case, P, n, n)
        Mass, damping and stiffness over one period of P steps; step k uses index k mod P.
        C is ignored unless ``has_damping``.
    F : (case, P, n)
        Load over the period; it drives column 0 of the state (the other columns are
        homogeneous solutions, as in the shooting method).
    has_damping : bool
    h : (case,) s
        Step size per case.
    alpha_m, alpha_f, beta, gamma : float
        The scheme (:class:`ced.response.integrators.NewmarkFamily`).
    n_steps : int
    q, v, acc, a : (case, n, r)
        State at step 0 (displacement, velocity, true and algorithmic acceleration),
        overwritten with the state at ``n_steps``.
    record_every : int
        Column 0 of q is written to ``record[:, k // record_every]`` at every step k that
        ``record_every`` divides (0 records nothing).
    record : (case, n_record, n)
    LU, piv, factored : (case, P, n, n), (case, P, n) int64, (case, P) int8
        Factorizations of the step matrices, kept across calls: a second march over the same
        terms reuses them. ``factored`` says which are done and how: 0 not yet, 1 in
        ``order`` without pivoting, 2 dense with partial pivoting.
    ok : (case,) bool
        Set False for a case whose step matrix is singular or whose state stops being finite
        (its march stops there).
    order : tuple of nine int64 arrays
        :class:`ced.response.step_pattern.StepOrder`'s index arrays (perm, then the CSR
        pairs of L's rows, U's rows, L's columns and the terms' rows), or nine empty arrays:
        the dense path. With an order, the products K q̂, C v̂ run over the terms' nonzeros
        and each step matrix is factorized in the order without pivoting, densely with
        pivoting where that fails (:func:`ced.response.step_pattern.pattern_factor`).
    """
    ncase, P, n = K.shape[0], K.shape[1], K.shape[2]
    r = q.shape[2]
    perm, lower_ptr, lower_idx, upper_ptr, upper_idx = order[0], order[1], order[2], order[3], order[4]
    column_ptr, column_idx, rows_ptr, rows_idx = order[5], order[6], order[7], order[8]
    sparse = perm.shape[0] == n
    # Work arrays (n, r): with many columns (shooting) every inner loop runs along them.
    rhs = np.empty((n, r))
    qh = np.empty((n, r))
    vh = np.empty((n, r))
    ak = np.empty((n, r))
    work = np.empty((n, r))
    diagonal = np.empty(n)
    w = (1.0 - alpha_f) / (1.0 - alpha_m)
    for c in range(ncase):
        hc = h[c]
        cC = w * gamma * hc
        cK = w * beta * hc * hc
        if record_every > 0:
            for i in range(n):
                record[c, 0, i] = q[c, i, 0]
        for k in range(n_steps):
            if not ok[c]:
                break
            j = (k + 1) % P
            Kj = K[c, j]
            qc, vc, accc, ac = q[c], v[c], acc[c], a[c]
            for i in range(n):
                for s in range(r):
                    ak[i, s] = (alpha_f * accc[i, s] - alpha_m * ac[i, s]) / (1.0 - alpha_m)
                    qh[i, s] = qc[i, s] + hc * vc[i, s] + hc * hc * (
                        (0.5 - beta) * ac[i, s] + beta * ak[i, s])
                    vh[i, s] = vc[i, s] + hc * ((1.0 - gamma) * ac[i, s] + gamma * ak[i, s])
            # rhs = F − K q̂ − C v̂
            # One column: the dense row products, which stream the step's matrices from
            # memory; the nonzeros alone, read scattered, were slower (7.6 against 4.4 µs per
            # step for the 36 DOFs of benchmarks/six_bar_cost.py). Many columns: the nonzeros.
            if sparse and r > 1:
                Cj = C[c, j] if has_damping else Kj
                for i in range(n):
                    for s in range(r):
                        rhs[i, s] = 0.0
                    rhs[i, 0] = F[c, j, i]
                    for b in range(rows_ptr[i], rows_ptr[i + 1]):
                        m = rows_idx[b]
                        f = Kj[i, m]
                        for s in range(r):
                            rhs[i, s] -= f * qh[m, s]
                    if has_damping:
                        for b in range(rows_ptr[i], rows_ptr[i + 1]):
                            m = rows_idx[b]
                            f = Cj[i, m]
                            for s in range(r):
                                rhs[i, s] -= f * vh[m, s]
            elif r == 1:
                for i in range(n):
                    x = F[c, j, i]
                    for m in range(n):
                        x -= Kj[i, m] * qh[m, 0]
                    rhs[i, 0] = x
                if has_damping:
                    Cj = C[c, j]
                    for i in range(n):
                        x = rhs[i, 0]
                        for m in range(n):
                            x -= Cj[i, m] * vh[m, 0]
                        rhs[i, 0] = x
            else:
                for i in range(n):
                    for s in range(r):
                        rhs[i, s] = 0.0
                    rhs[i, 0] = F[c, j, i]
                    for m in range(n):
                        f = Kj[i, m]
                        for s in range(r):
                            rhs[i, s] -= f * qh[m, s]
                if has_damping:
                    Cj = C[c, j]
                    for i in range(n):
                        for m in range(n):
                            f = Cj[i, m]
                            for s in range(r):
                                rhs[i, s] -= f * vh[m, s]
            LUj = LU[c, j]
            if factored[c, j] == 0 and sparse:
                _gather_ordered(M[c, j], C[c, j] if has_damping else Kj, Kj, has_damping, cC,
                                cK, perm, lower_ptr, lower_idx, upper_ptr, upper_idx, LUj,
                                diagonal)
                if pattern_factor(LUj, diagonal, upper_ptr, upper_idx, column_ptr,
                                  column_idx):
                    factored[c, j] = 1
            if factored[c, j] == 0:
                Mj = M[c, j]
                for i in range(n):
                    for m in range(n):
                        LUj[i, m] = Mj[i, m] + cK * Kj[i, m]
                if has_damping:
                    Cj = C[c, j]
                    for i in range(n):
                        for m in range(n):
                            LUj[i, m] += cC * Cj[i, m]
                if not lu_factor(LUj, piv[c, j]):
                    ok[c] = False
                    break
                factored[c, j] = 2
            if factored[c, j] == 1:
                pattern_solve(LUj, perm, lower_ptr, lower_idx, upper_ptr, upper_idx, rhs, work)
            elif r == 1:
                lu_solve(LUj, piv[c, j], rhs[:, 0])
            else:
                lu_solve_columns(LUj, piv[c, j], rhs)
            finite = True
            for i in range(n):
                for s in range(r):
                    x = rhs[i, s]
                    accc[i, s] = x
                    qc[i, s] = qh[i, s] + cK * x
                    vc[i, s] = vh[i, s] + cC * x
                    ac[i, s] = ak[i, s] + w * x
                if not np.isfinite(qc[i, 0]):
                    finite = False
            if not finite:
                ok[c] = False
            if record_every > 0 and (k + 1) % record_every == 0:
                for i in range(n):
                    record[c, (k + 1) // record_every, i] = qc[i, 0]


@nb.njit(**_JIT)
def _gather_ordered(Mj, Cj, Kj, has_damping, cC, cK, perm, lower_ptr, lower_idx, upper_ptr,
                    upper_idx, LU, diagonal):
    """The step matrix S = M + c_C C + c_K K in ``perm``'s order, on the factors' pattern
    only (row i: L's columns, the diagonal, U's columns), into LU; its diagonal into
    ``diagonal``."""
    n = perm.shape[0]
    for i in range(n):
        src = perm[i]
        for part in range(3):
            if part == 0:
                lo, hi = lower_ptr[i], lower_ptr[i + 1]
            elif part == 1:
                lo, hi = 0, 1
            else:
                lo, hi = upper_ptr[i], upper_ptr[i + 1]
            for b in range(lo, hi):
                if part == 0:
                    k = lower_idx[b]
                elif part == 1:
                    k = i
                else:
                    k = upper_idx[b]
                col = perm[k]
                x = Mj[src, col] + cK * Kj[src, col]
                if has_damping:
                    x += cC * Cj[src, col]
                LU[i, k] = x
        diagonal[i] = LU[i, i]


@nb.njit(**_JIT)
def static_period(K, F, y, ok):
    """Quasi-static response K y = F at every step of the period, in place.

    K (case, P, n, n), F (case, P, n), y (case, P, n); ``ok[c]`` False where a K is singular.

    Parameters
    ----------
    K : numpy.ndarray
        Stiffness matrices (SI units: N/m for translations), shape (case, P, n, n).
    F : numpy.ndarray
        Load vectors, N, shape (case, P, n).
    y : numpy.ndarray
        Output displacements, m, shape (case, P, n); NaN at singular steps.
    ok : numpy.ndarray
        Per-case success flags, shape (case,), bool; set False, never True.
    """
    ncase, P, n = K.shape[0], K.shape[1], K.shape[2]
    A = np.empty((n, n))
    piv = np.empty(n, np.int64)
    for c in range(ncase):
        for j in range(P):
            # Element by element: an array assignment compiles numba's broadcasting and its
            # formatted error messages (3 s of this kernel's 4 s compile time).
            for r in range(n):
                y[c, j, r] = F[c, j, r]
                for k in range(n):
                    A[r, k] = K[c, j, r, k]
            if not lu_factor(A, piv):
                ok[c] = False
                y[c, j] = np.nan
                continue
            lu_solve(A, piv, y[c, j])


@nb.njit(**_JIT)
def expand(P0, y, steps, interior_rows, z):
    """Joint and link displacements z = P(step mod P) y at the given steps.

    P0 (case, P, nz, nfree): the joint-coordinate columns of the projection; the interior
    DOFs y[nfree:] map one to one onto the rows ``interior_rows`` of z
    (:meth:`ced.fem.coupling.Layout.expand`). y (case, nout, ny); steps (nout,) int;
    z (case, nout, nz) filled.

    Parameters
    ----------
    P0 : numpy.ndarray
        Joint-coordinate columns of the projection, shape (case, P, nz, nfree).
    y : numpy.ndarray
        Independent DOFs, m, shape (case, nout, ny).
    steps : numpy.ndarray
        Step index of each output, shape (nout,), int.
    interior_rows : numpy.ndarray
        Rows of z of the interior DOFs y[nfree:], shape (ny − nfree,), int.
    z : numpy.ndarray
        Output joint and link displacements, m, shape (case, nout, nz), overwritten.
    """
    ncase, P, nz, nfree = P0.shape
    for c in range(ncase):
        for t in range(steps.shape[0]):
            j = steps[t] % P
            for i in range(nz):
                s = 0.0
                for m in range(nfree):
                    s += P0[c, j, i, m] * y[c, t, m]
                z[c, t, i] = s
            for i in range(interior_rows.shape[0]):
                z[c, t, interior_rows[i]] += y[c, t, nfree + i]
