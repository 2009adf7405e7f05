"""Compiled LU for many small dense systems (numba): the rigid Newton–Euler systems and the
elastic step matrices.

numpy's batched ``np.linalg.solve`` pays its per-call and per-matrix overhead on systems of
10 unknowns (~5 µs each, measured); an LU in a compiled loop costs ~0.2 µs. :func:`lu_factor`
and :func:`lu_solve` work on one system, in place, allocating nothing (the elastic march,
:mod:`ced.response.kernels`, calls them at every step); :func:`solve_batch` solves a batch
of systems and returns, with the solutions, each matrix's Hadamard ratio
|det A| / Π‖rowᵢ‖ from the same LU (the singularity measure of
:mod:`ced.rigid.inverse_dynamics`). Given the :func:`block_order` of the systems' common
sparsity pattern, it solves them block by block (a linkage's Newton–Euler system falls into
one block per dyad, solved from the last dyad back to the input); a block marked as a dyad's
(:func:`solve_blocks`' ``dyads``) is solved in closed form instead of by LU.
"""
from __future__ import annotations

import functools

import numba as nb
import numpy as np

__all__ = ["lu_factor", "lu_solve", "solve_blocks", "solve_batch", "block_order",
           "lu_only"]

_JIT = dict(cache=True, nogil=True, fastmath={"reassoc", "contract"})


@nb.njit(**_JIT)
def lu_factor(A: np.ndarray, piv: np.ndarray) -> bool:
    """LU with partial pivoting of the square A (n, n) in place (L unit lower, U upper, as
    LAPACK getrf); ``piv[k]`` the row swapped with row k. Returns False if a pivot is zero or
    not finite (singular or corrupted matrix).

    Parameters
    ----------
    A : numpy.ndarray
        Square matrix (n, n), float64 or complex128 (the frequency blocks of
        :mod:`ced.response.spectral`), overwritten by its L and U factors.
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


# The same two functions inlined into solve_blocks (at numba's level, before LLVM): a call per
# block of a rigid system of ~10 unknowns costs about as much as its arithmetic (solve_blocks
# ~20 % faster on the four-bar's and the Watt II's systems, the same bits there, measured).
_factor = nb.njit(inline="always", **_JIT)(lu_factor.py_func)
_solve = nb.njit(inline="always", **_JIT)(lu_solve.py_func)


@nb.njit(inline="always", **_JIT)
def _gathered(A, b, x, c, r, cols, s0):
    """b[c, r] less row r's products with the unknowns of the blocks solved already (the
    columns ``cols[:s0]``)."""
    t = b[c, r]
    for j in range(s0):
        t -= A[c, r, cols[j]] * x[c, cols[j]]
    return t


@nb.njit(inline="always", **_JIT)
def _dyad(A, b, x, c, cols, s0, ra, rb, p, m, q) -> float:
    """Solve a dyad's block of case c in closed form, the classical way: |det| of the block
    (0 where it is singular or not finite, x then untouched).

    The block is two bodies' force and moment rows (``ra`` … ``ra + 2``, ``rb`` … ``rb + 2``:
    x force, y force, moment) in three forces (x columns ``p``, ``m``, ``q``, their y the
    next): F_p on body a alone, F_m on both, F_q on body b alone, each force row holding
    only its own component of two of them. The force rows give F_p and F_q in terms of F_m;
    put into the moment rows they leave a 2 × 2 system for F_m (its determinant is that of
    the two bodies' arms across the middle joint: zero at the dyad's toggle). Five
    divisions and ~40 products instead of an LU of 6 × 6 with partial pivoting (its pivots
    here are the force rows' unit entries: the same solution to round-off)."""
    Rax, Ray = _gathered(A, b, x, c, ra, cols, s0), _gathered(A, b, x, c, ra + 1, cols, s0)
    Ram = _gathered(A, b, x, c, ra + 2, cols, s0)
    Rbx, Rby = _gathered(A, b, x, c, rb, cols, s0), _gathered(A, b, x, c, rb + 1, cols, s0)
    Rbm = _gathered(A, b, x, c, rb + 2, cols, s0)
    ax, ay, bx, by = A[c, ra, p], A[c, ra + 1, p + 1], A[c, rb, q], A[c, rb + 1, q + 1]
    outer = abs(ax * ay * bx * by)
    if not (outer > 0.0 and outer < np.inf):
        return 0.0
    # Moment rows less (moment entry / force entry) times the force rows of F_p, F_q.
    ua, va = A[c, ra + 2, p] / ax, A[c, ra + 2, p + 1] / ay
    ub, vb = A[c, rb + 2, q] / bx, A[c, rb + 2, q + 1] / by
    cax = A[c, ra + 2, m] - ua * A[c, ra, m]
    cay = A[c, ra + 2, m + 1] - va * A[c, ra + 1, m + 1]
    cbx = A[c, rb + 2, m] - ub * A[c, rb, m]
    cby = A[c, rb + 2, m + 1] - vb * A[c, rb + 1, m + 1]
    da = Ram - ua * Rax - va * Ray
    db = Rbm - ub * Rbx - vb * Rby
    det = cax * cby - cay * cbx
    if not (abs(det) > 0.0 and abs(det) < np.inf):
        return 0.0
    fx = (da * cby - cay * db) / det
    fy = (cax * db - da * cbx) / det
    x[c, m], x[c, m + 1] = fx, fy
    x[c, p], x[c, p + 1] = (Rax - A[c, ra, m] * fx) / ax, (Ray - A[c, ra + 1, m + 1] * fy) / ay
    x[c, q], x[c, q + 1] = (Rbx - A[c, rb, m] * fx) / bx, (Rby - A[c, rb + 1, m + 1] * fy) / by
    return outer * abs(det)


@nb.njit(**_JIT)
def solve_blocks(A, b, x, ratio, rows, cols, starts, dyads):
    """Solve A x = b for a batch of systems, block by block, with each one's Hadamard ratio
    (the kernel of :func:`solve_batch`, callable from other kernels).

    Parameters
    ----------
    A : numpy.ndarray
        Matrices (batch, n, n), float64, C-contiguous; not modified.
    b : numpy.ndarray
        Right-hand sides (batch, n).
    x : numpy.ndarray
        Solutions (batch, n), filled; NaN where the LU fails.
    ratio : numpy.ndarray
        Hadamard ratios |det A| / Π‖rowᵢ‖ (batch,), filled; 0 where the LU fails.
    rows, cols, starts : numpy.ndarray
        A :func:`block_order` (one block ``0…n`` for the dense LU), int64.
    dyads : numpy.ndarray
        Per block (block, 5) int64: −1 first for a block solved by LU, else a dyad's block
        (:func:`_dyad`): the first rows of its two bodies' equations, the x columns of the
        force on the first body alone, of the shared one and of the one on the second alone.
    """
    n = A.shape[1]
    size = 0
    for k in range(starts.shape[0] - 1):
        size = max(size, starts[k + 1] - starts[k])
    piv = np.empty(size, np.int64)
    rhs = np.empty(size)
    work = np.empty(size * size)
    for c in range(A.shape[0]):
        norms = 1.0
        for i in range(n):
            t = 0.0
            for j in range(n):
                t += A[c, i, j] * A[c, i, j]
            norms *= np.sqrt(t)
        det = 1.0
        for k in range(starts.shape[0] - 1):
            s0, m = starts[k], starts[k + 1] - starts[k]
            if dyads[k, 0] >= 0:
                d = _dyad(A, b, x, c, cols, s0, dyads[k, 0], dyads[k, 1], dyads[k, 2],
                          dyads[k, 3], dyads[k, 4])
                det *= d
                if d == 0.0:  # as a failed LU
                    x[c] = np.nan
                    break
                continue
            LU = work[: m * m].reshape((m, m))
            for i in range(m):
                rhs[i] = _gathered(A, b, x, c, rows[s0 + i], cols, s0)
                r = rows[s0 + i]
                for j in range(m):
                    LU[i, j] = A[c, r, cols[s0 + j]]
            if m == 1:  # a single unknown (the input torque, a slider's moment): divide
                if not (abs(LU[0, 0]) > 0.0 and abs(LU[0, 0]) < np.inf):  # as lu_factor
                    det = 0.0
                    x[c] = np.nan
                    break
                det *= abs(LU[0, 0])
                x[c, cols[s0]] = rhs[0] / LU[0, 0]  # as lu_solve
                continue
            if not _factor(LU, piv[:m]):
                det = 0.0
                x[c] = np.nan
                break
            for i in range(m):
                det *= abs(LU[i, i])
            _solve(LU, piv[:m], rhs[:m])
            for i in range(m):
                x[c, cols[s0 + i]] = rhs[i]
        ratio[c] = det / norms if norms > 0.0 else 0.0


def block_order(pattern: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Row and column orders that make a square sparsity pattern block lower triangular,
    with the smallest blocks (Dulmage–Mendelsohn): a perfect matching of rows to columns,
    then the strongly connected components of "row r needs the column matched to row r′",
    dependencies first. None when the pattern has no perfect matching (structurally
    singular).

    Parameters
    ----------
    pattern : numpy.ndarray
        Which entries may be nonzero, bool (n, n).

    Returns
    -------
    rows, cols : numpy.ndarray
        Orders (n,) int: block k is rows[starts[k]:starts[k + 1]] by the same columns.
    starts : numpy.ndarray
        Block boundaries (blocks + 1,) int.
    """
    pattern = np.asarray(pattern, bool)
    return _block_order(pattern.shape[0], pattern.tobytes())


@functools.lru_cache(maxsize=32)
def _block_order(n: int, data: bytes):
    pattern = np.frombuffer(data, bool).reshape(n, n)
    needs = [list(np.flatnonzero(row)) for row in pattern]
    owner = [-1] * n  # column -> its matched row

    def augment(r, seen):  # Kuhn's augmenting path from row r
        for c in needs[r]:
            if not seen[c]:
                seen[c] = True
                if owner[c] < 0 or augment(owner[c], seen):
                    owner[c] = r
                    return True
        return False

    for r in range(n):
        if not augment(r, [False] * n):
            return None
    column = {r: c for c, r in enumerate(owner)}
    edges = [[owner[c] for c in needs[r] if owner[c] != r] for r in range(n)]
    blocks = _components(edges)  # dependencies first
    rows = [r for block in blocks for r in block]
    starts = np.cumsum([0] + [len(block) for block in blocks])
    return (np.array(rows, np.int64), np.array([column[r] for r in rows], np.int64),
            starts.astype(np.int64))


def _components(edges: list[list[int]]) -> list[list[int]]:
    """Strongly connected components of a directed graph (Tarjan), each after every
    component it has an edge to."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            block = []
            while True:
                w = stack.pop()
                on.discard(w)
                block.append(w)
                if w == v:
                    break
            out.append(sorted(block))

    for v in range(len(edges)):
        if v not in index:
            visit(v)
    return out


def lu_only(starts: np.ndarray) -> np.ndarray:
    """The ``dyads`` table of :func:`solve_blocks` that solves every block by LU.

    Parameters
    ----------
    starts : numpy.ndarray
        The block boundaries, shape (blocks + 1,), int.

    Returns
    -------
    numpy.ndarray
        Shape (blocks, 5), int64, every entry −1 (no block solved in closed form).
    """
    return np.full((len(starts) - 1, 5), -1, np.int64)


def solve_batch(A: np.ndarray, b: np.ndarray,
                blocks: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Solve A x = b for a batch of small systems by LU with partial pivoting.

    Parameters
    ----------
    A : numpy.ndarray
        Matrices, shape (..., n, n).
    b : numpy.ndarray
        Right-hand sides, shape (..., n).
    blocks : tuple of numpy.ndarray, optional
        The :func:`block_order` of a pattern that holds every nonzero of every A: the LU is
        then of the diagonal blocks only, in that order (the same solution and |det A|, to
        round-off); a fourth array, :func:`solve_blocks`' ``dyads``, solves the blocks it
        marks in closed form.

    Returns
    -------
    x : numpy.ndarray
        Solutions, shape (..., n); NaN where ``ratio`` is 0.
    ratio : numpy.ndarray
        Hadamard ratio |det A| / Π‖rowᵢ‖ of each matrix, shape (...): 1 for orthogonal rows,
        0 for a singular one (a zero or non-finite pivot).
    """
    n = A.shape[-1]
    flat_A = np.ascontiguousarray(A, dtype=float).reshape(-1, n, n)
    flat_b = np.ascontiguousarray(b, dtype=float).reshape(-1, n)
    x = np.empty_like(flat_b)
    ratio = np.empty(len(flat_A))
    if blocks is None:  # one block: the dense LU
        whole = np.arange(n, dtype=np.int64)
        blocks = (whole, whole, np.array([0, n], np.int64))
    if len(blocks) == 3:  # every block by LU
        blocks = (*blocks, lu_only(blocks[2]))
    solve_blocks(flat_A, flat_b, x, ratio, *blocks)
    return x.reshape(b.shape), ratio.reshape(A.shape[:-2])
