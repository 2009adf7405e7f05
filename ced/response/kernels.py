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
:func:`newmark_march_packed` is the same scheme on sparse step matrices held packed, in a
fill-reducing order, factorized without pivoting (:mod:`ced.response.step_pattern`).

Every function takes and fills plain arrays; none allocates per step.
"""
from __future__ import annotations

import numba as nb
import numpy as np

# The LU of one small system lives with the rigid layer's batched solver (below this layer).
from ..rigid.small_systems import lu_factor, lu_solve
from .step_pattern import packed_factor, packed_solve

__all__ = ["lu_factor", "lu_solve", "lu_solve_columns", "newmark_march", "newmark_march_packed",
           "static_period", "static_period_packed", "expand"]

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


# The step's pieces shared by both marching kernels, inlined into them by numba (its IR, not
# LLVM's calls): as called functions, LLVM contracted their loops differently for many columns
# and the shot results moved by 3e-14; inlined, the kernels compile to the bits of the loops
# written out (checked on the default study's chunks).
_INLINE = dict(_JIT, inline="always")


@nb.njit(**_INLINE)
def _work_arrays(n, r):
    """The step's right-hand side (then solution), q̂, v̂ and a_k, each (n, r): with many
    columns (shooting) every inner loop runs along them."""
    return np.empty((n, r)), np.empty((n, r)), np.empty((n, r)), np.empty((n, r))


@nb.njit(**_INLINE)
def _start_case(h, alpha_m, alpha_f, beta, gamma, q, record_every, record):
    """The step matrix's coefficients (c_C, c_K, w) of a case with step h; q's column 0 is
    written to the first record (with ``record_every`` > 0)."""
    w = (1.0 - alpha_f) / (1.0 - alpha_m)
    if record_every > 0:
        for i in range(q.shape[0]):
            record[0, i] = q[i, 0]
    return w * gamma * h, w * beta * h * h, w


@nb.njit(**_INLINE)
def _predict(q, v, acc, a, h, alpha_m, alpha_f, beta, gamma, qh, vh, ak):
    """The step's predictors q̂, v̂ and the α-weighted acceleration a_k from the state (n, r)
    (Arnold & Brüls 2007, :func:`ced.response.integrators.alpha_step`)."""
    n, r = q.shape
    for i in range(n):
        for s in range(r):
            ak[i, s] = (alpha_f * acc[i, s] - alpha_m * a[i, s]) / (1.0 - alpha_m)
            qh[i, s] = q[i, s] + h * v[i, s] + h * h * ((0.5 - beta) * a[i, s] + beta * ak[i, s])
            vh[i, s] = v[i, s] + h * ((1.0 - gamma) * a[i, s] + gamma * ak[i, s])


@nb.njit(**_INLINE)
def _correct(x, qh, vh, ak, cC, cK, w, q, v, acc, a, k, record_every, record) -> bool:
    """The new state from step k's solution x (the acceleration) and the predictors, in
    place, q's column 0 recorded after every ``record_every``-th step; False where column 0
    of q is no longer finite."""
    n, r = q.shape
    finite = True
    for i in range(n):
        for s in range(r):
            y = x[i, s]
            acc[i, s] = y
            q[i, s] = qh[i, s] + cK * y
            v[i, s] = vh[i, s] + cC * y
            a[i, s] = ak[i, s] + w * y
        if not np.isfinite(q[i, 0]):
            finite = False
    if record_every > 0 and (k + 1) % record_every == 0:
        for i in range(n):
            record[(k + 1) // record_every, i] = q[i, 0]
    return finite


@nb.njit(**_JIT)
def newmark_march(M, C, K, F, has_damping, h, alpha_m, alpha_f, beta, gamma, n_steps,
                  q, v, acc, a, record_every, record, LU, piv, factored, ok):
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
    LU, piv, factored : (case, P, n, n), (case, P, n) int64, (case, P) bool
        Factorizations of the step matrices, kept across calls (``factored`` says which are
        done): a second march over the same terms reuses them.
    ok : (case,) bool
        Set False for a case whose step matrix is singular or whose state stops being finite
        (its march stops there).
    """
    ncase, P, n = K.shape[0], K.shape[1], K.shape[2]
    r = q.shape[2]
    rhs, qh, vh, ak = _work_arrays(n, r)
    for c in range(ncase):
        hc = h[c]
        cC, cK, w = _start_case(hc, alpha_m, alpha_f, beta, gamma, q[c], record_every,
                                record[c])
        for k in range(n_steps):
            if not ok[c]:
                break
            j = (k + 1) % P
            Kj = K[c, j]
            qc, vc, accc, ac = q[c], v[c], acc[c], a[c]
            _predict(qc, vc, accc, ac, hc, alpha_m, alpha_f, beta, gamma, qh, vh, ak)
            # rhs = F − K q̂ − C v̂
            if r == 1:
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
            if not factored[c, j]:
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
                factored[c, j] = True
            if r == 1:
                lu_solve(LUj, piv[c, j], rhs[:, 0])
            else:
                lu_solve_columns(LUj, piv[c, j], rhs)
            if not _correct(rhs, qh, vh, ak, cC, cK, w, qc, vc, accc, ac, k, record_every,
                            record[c]):
                ok[c] = False


@nb.njit(**_JIT)
def newmark_march_packed(M, C, K, F, has_damping, h, alpha_m, alpha_f, beta, gamma, n_steps,
                         q, v, acc, a, record_every, record, LU, factored, ok, refused, perm,
                         rows_ptr, rows_idx, lu_ptr, lu_idx, diagonal, lu_source):
    """:func:`newmark_march` on packed terms (:func:`ced.response.step_pattern.pack`).

    Parameters
    ----------
    M, C, K : (case, P, nnz)
        Mass, damping and stiffness over one period, packed on the pattern ``rows_ptr``,
        ``rows_idx`` (row by row, original order). C is ignored unless ``has_damping``.
    F, has_damping, h, alpha_m, alpha_f, beta, gamma, n_steps, q, v, acc, a, record_every, record
        As for :func:`newmark_march`.
    LU, factored : (case, P, nnz_lu), (case, P) bool
        The step matrices' packed factors in the order ``perm``, kept across calls.
    ok : (case,) bool
        As for :func:`newmark_march`.
    refused : (case,) bool
        Set True (and ``ok`` False) for a case with a step matrix the LU without pivoting
        refuses (:func:`ced.response.step_pattern.packed_factor`): to be marched densely.
    perm, rows_ptr, rows_idx, lu_ptr, lu_idx, diagonal, lu_source : int64 arrays
        :class:`ced.response.step_pattern.StepOrder`.
    """
    ncase, P = K.shape[0], K.shape[1]
    n, r = q.shape[1], q.shape[2]
    rhs, qh, vh, ak = _work_arrays(n, r)
    work, row = np.empty((n, r)), np.empty(n)
    for c in range(ncase):
        hc = h[c]
        cC, cK, w = _start_case(hc, alpha_m, alpha_f, beta, gamma, q[c], record_every,
                                record[c])
        for k in range(n_steps):
            if not ok[c]:
                break
            j = (k + 1) % P
            Kj, Cj = K[c, j], C[c, j] if has_damping else K[c, j]
            qc, vc, accc, ac = q[c], v[c], acc[c], a[c]
            _predict(qc, vc, accc, ac, hc, alpha_m, alpha_f, beta, gamma, qh, vh, ak)
            # rhs = F − K q̂ − C v̂ over the nonzeros, read in the order they are stored
            if r == 1:
                for i in range(n):
                    x = F[c, j, i]
                    for b in range(rows_ptr[i], rows_ptr[i + 1]):
                        x -= Kj[b] * qh[rows_idx[b], 0]
                    if has_damping:
                        for b in range(rows_ptr[i], rows_ptr[i + 1]):
                            x -= Cj[b] * vh[rows_idx[b], 0]
                    rhs[i, 0] = x
            else:
                for i in range(n):
                    for s in range(r):
                        rhs[i, s] = 0.0
                    rhs[i, 0] = F[c, j, i]
                    for b in range(rows_ptr[i], rows_ptr[i + 1]):
                        m, f = rows_idx[b], Kj[b]
                        for s in range(r):
                            rhs[i, s] -= f * qh[m, s]
                    if has_damping:
                        for b in range(rows_ptr[i], rows_ptr[i + 1]):
                            m, f = rows_idx[b], Cj[b]
                            for s in range(r):
                                rhs[i, s] -= f * vh[m, s]
            LUj = LU[c, j]
            if not factored[c, j]:
                Mj = M[c, j]
                for b in range(LUj.shape[0]):
                    src = lu_source[b]
                    if src < 0:
                        LUj[b] = 0.0
                    else:
                        x = Mj[src] + cK * Kj[src]
                        if has_damping:
                            x += cC * Cj[src]
                        LUj[b] = x
                if not packed_factor(LUj, lu_ptr, lu_idx, diagonal, row):
                    ok[c] = False
                    refused[c] = True
                    break
                factored[c, j] = True
            packed_solve(LUj, perm, lu_ptr, lu_idx, diagonal, rhs, work)
            if not _correct(rhs, qh, vh, ak, cC, cK, w, qc, vc, accc, ac, k, record_every,
                            record[c]):
                ok[c] = False


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
def static_period_packed(K, F, y, ok, perm, rows_ptr, rows_idx, lu_ptr, lu_idx, diagonal,
                         lu_source):
    """:func:`static_period` on packed stiffness matrices K (case, P, nnz)
    (:mod:`ced.response.step_pattern`), factorized without pivoting; a K the factorization
    refuses is solved densely with partial pivoting. ``ok[c]`` False where one is singular.

    Parameters
    ----------
    K : numpy.ndarray
        Packed stiffness matrices, shape (case, P, nnz).
    F, y, ok : numpy.ndarray
        As for :func:`static_period`.
    perm, rows_ptr, rows_idx, lu_ptr, lu_idx, diagonal, lu_source : numpy.ndarray
        :class:`ced.response.step_pattern.StepOrder`.
    """
    ncase, P, n = F.shape[0], F.shape[1], F.shape[2]
    LU = np.empty(lu_idx.shape[0])
    row = np.empty(n)
    work = np.empty((n, 1))
    A = np.empty((n, n))
    piv = np.empty(n, np.int64)
    for c in range(ncase):
        for j in range(P):
            Kj = K[c, j]
            for b in range(LU.shape[0]):
                LU[b] = Kj[lu_source[b]] if lu_source[b] >= 0 else 0.0
            x = y[c, j].reshape((n, 1))
            for r in range(n):
                x[r, 0] = F[c, j, r]
            if packed_factor(LU, lu_ptr, lu_idx, diagonal, row):
                packed_solve(LU, perm, lu_ptr, lu_idx, diagonal, x, work)
                continue
            for r in range(n):  # refused: the dense matrix, with pivoting
                for m in range(n):
                    A[r, m] = 0.0
                for b in range(rows_ptr[r], rows_ptr[r + 1]):
                    A[r, rows_idx[b]] = Kj[b]
            if not lu_factor(A, piv):
                ok[c] = False
                y[c, j] = np.nan
                continue
            lu_solve(A, piv, y[c, j])


@nb.njit(**_JIT)
def expand(P0, y, steps, rows, interior_rows, z):
    """Joint and link displacements z = P(step mod P) y at the given steps.

    P0 (case, P, row, nfree): the rows ``rows`` of the joint-coordinate columns of the
    projection (the others are zero: :attr:`ced.fem.coupling.Layout.projection_rows`); the
    interior DOFs y[nfree:] map one to one onto the rows ``interior_rows`` of z
    (:meth:`ced.fem.coupling.Layout.expand`). y (case, nout, ny); steps (nout,) int;
    z (case, nout, nz) filled.

    Parameters
    ----------
    P0 : numpy.ndarray
        Rows ``rows`` of the joint-coordinate columns of the projection, shape
        (case, P, row, nfree).
    y : numpy.ndarray
        Independent DOFs, m, shape (case, nout, ny).
    steps : numpy.ndarray
        Step index of each output, shape (nout,), int.
    rows : numpy.ndarray
        The z row of each row of P0, shape (row,), int.
    interior_rows : numpy.ndarray
        Rows of z of the interior DOFs y[nfree:], shape (ny − nfree,), int.
    z : numpy.ndarray
        Output joint and link displacements, m, shape (case, nout, nz), overwritten.
    """
    ncase, P, nrow, nfree = P0.shape
    nz = z.shape[2]
    for c in range(ncase):
        for t in range(steps.shape[0]):
            j = steps[t] % P
            # A zero row of P gives 0.0 + Σ 0·y: +0.0, or NaN where y is not finite.
            zero = 0.0
            for m in range(nfree):
                zero += 0.0 * y[c, t, m]
            for i in range(nz):
                z[c, t, i] = zero
            for i in range(nrow):
                s = 0.0
                for m in range(nfree):
                    s += P0[c, j, i, m] * y[c, t, m]
                z[c, t, rows[i]] = s
            for i in range(interior_rows.shape[0]):
                z[c, t, interior_rows[i]] += y[c, t, nfree + i]
