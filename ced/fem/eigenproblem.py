"""Natural frequencies over the cycle (thesis III.3.1.b, docs/theory.md, "Modal analysis").

The generalized eigenproblem (K_eff − ω² M) φ = 0 at frozen configurations, where K_eff holds
the stiffness-type effects of the scene (elastic, centrifugal, axial stiffening). The
circulatory part of K_eff (the antisymmetric αG term of an accelerating link) has no place in
a symmetric frozen-time eigenproblem; its symmetric part is used.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["natural_frequencies"]


def natural_frequencies(
    stiffness: np.ndarray, mass: np.ndarray, modes: int, shapes: bool = False,
    blocks: list[tuple[int, int]] | None = None,
):
    """Lowest natural frequencies, Hz, batched over leading axes.

    Parameters
    ----------
    stiffness, mass : (..., n, n); mass symmetric positive definite
    modes : number of frequencies (at most n)
    shapes : also return mass-normalised mode shapes (..., n, modes)
    blocks : optional (start, stop) index ranges of DOFs that couple only among themselves and
        with the DOFs outside every range (a linkage's links' interior DOFs, coupled through
        the joint coordinates): the reduction to a standard eigenproblem then runs block by
        block (:func:`_arrow_reduce`), the same problem to round-off; where the matrices
        couple two ranges after all, or the mass is not positive definite on them, the dense
        reduction is used.

    Returns
    -------
    frequency : (..., modes) Hz, ascending; a negative eigenvalue (the frozen structure
        buckles under compression or softening) gives a negative frequency −√|λ|/2π so that
        it stays finite and visible.
    """
    if blocks:
        arrow = _by_blocks(stiffness, mass, modes, shapes, blocks)
        if arrow is not None:
            return arrow
    K = 0.5 * (stiffness + np.swapaxes(stiffness, -1, -2))
    L = np.linalg.cholesky(0.5 * (mass + np.swapaxes(mass, -1, -2)))
    Linv = np.linalg.inv(L)
    A = Linv @ K @ np.swapaxes(Linv, -1, -2)
    A = 0.5 * (A + np.swapaxes(A, -1, -2))
    if not shapes:
        return _frequency(_eigenvalues(A)[..., :modes])
    lam, vec = np.linalg.eigh(A)
    return _frequency(lam[..., :modes]), np.swapaxes(Linv, -1, -2) @ vec[..., :modes]


def _eigenvalues(A: np.ndarray) -> np.ndarray:
    """Eigenvalues of symmetric A (..., n, n), ascending: without the eigenvectors, which
    cost two thirds of ``eigh`` at the orders of a linkage (20–36)."""
    return np.linalg.eigvalsh(A)


def _frequency(lam: np.ndarray) -> np.ndarray:
    """Hz from the eigenvalues λ (rad²/s²), −√|λ|/2π for a negative one."""
    return np.sign(lam) * np.sqrt(np.abs(lam)) / (2.0 * np.pi)


def _by_blocks(stiffness: np.ndarray, mass: np.ndarray, modes: int, shapes: bool,
               blocks: list[tuple[int, int]]):
    """:func:`natural_frequencies` through the block-arrow reduction, or None where it does
    not apply (an entry couples two blocks, or a block's mass is not positive definite).

    Ordered blocks first and the other DOFs (the separator J) last, M and K are block-arrow:
    diagonal blocks and the J rows and columns. So are the Cholesky factor L of M (no fill
    outside them) and A = L⁻¹ K L⁻ᵀ, which is formed block by block in a compiled pass: per
    matrix the cost of the blocks' cubes and of products with the few J columns, instead of
    the dense inverse and two products of order n (a six-bar's three links of 11 interior
    DOFs: 3 × 11³ against 36³). The eigenvalues of A are those of the pencil (K, M); the
    shapes are L⁻ᵀ times its eigenvectors, back in the given order."""
    n = stiffness.shape[-1]
    inner = [np.arange(a, b) for a, b in blocks if b > a]
    if not inner:
        return None
    inside = np.concatenate(inner)
    perm = np.concatenate([inside, np.setdiff1d(np.arange(n), inside)]).astype(np.int64)
    starts = np.cumsum([0] + [len(r) for r in inner]).astype(np.int64)
    lead = stiffness.shape[:-2]
    K = np.ascontiguousarray(stiffness, dtype=float).reshape(-1, n, n)
    M = np.ascontiguousarray(mass, dtype=float).reshape(-1, n, n)
    A, factor = np.empty_like(K), np.empty_like(K)
    ok = np.ones(len(K), np.bool_)
    _arrow_reduce(K, M, perm, starts, A, factor, ok)
    if not ok.all():
        return None
    if not shapes:
        return _frequency(_eigenvalues(A)[..., :modes]).reshape(lead + (modes,))
    lam, vec = np.linalg.eigh(A)
    freq = _frequency(lam[..., :modes]).reshape(lead + (modes,))
    X = np.empty((len(K), n, modes))
    _arrow_shapes(factor, perm, starts, np.ascontiguousarray(vec[..., :modes]), X)
    return freq, X.reshape(lead + (n, modes))


@nb.njit(cache=True, nogil=True)
def _cholesky_block(Mp, L, a, e):
    """L[a:e, a:e] = the lower Cholesky factor of Mp[a:e, a:e]; False if not positive."""
    for i in range(a, e):
        for j in range(a, i + 1):
            x = Mp[i, j]
            for k in range(a, j):
                x -= L[i, k] * L[j, k]
            if i == j:
                if not x > 0.0:
                    return False
                L[i, i] = math.sqrt(x)
            else:
                L[i, j] = x / L[j, j]
    return True


@nb.njit(cache=True, nogil=True)
def _arrow_reduce(K, M, perm, starts, A, F, ok):
    """A = L⁻¹ K L⁻ᵀ of every matrix pair (N, n, n) in the order ``perm`` (the blocks
    ``starts`` (B + 1,) first, the separator J last), M = L Lᵀ; both symmetrized first.

    F keeps what the shapes need (:func:`_arrow_shapes`): the blocks' factors L_b and J's
    L_S on the diagonal, and Z_b = −L_S⁻¹ W_b L_b⁻¹ (the J rows of L⁻¹, W_b = M_Jb L_b⁻ᵀ the
    J rows of L) in the J rows. ``ok[c]`` False: pair c couples two blocks, or its mass is not
    positive definite (its A and F are then not formed)."""
    N, n = K.shape[0], K.shape[1]
    nblock = len(starts) - 1
    s0 = starts[nblock]
    nj = n - s0
    Kp, Mp, T = np.empty((n, n)), np.empty((n, n)), np.empty((n, n))
    Y, V = np.empty((n, nj)), np.empty((n, nj))  # L_b⁻¹ M_bJ and L_b⁻ᵀ of it, per block rows
    YJ, H = np.empty((nj, n)), np.empty((nj, nj))  # the J rows of L⁻¹K
    for c in range(N):
        for i in range(n):
            for j in range(n):
                Kp[i, j] = 0.5 * (K[c, perm[i], perm[j]] + K[c, perm[j], perm[i]])
                Mp[i, j] = 0.5 * (M[c, perm[i], perm[j]] + M[c, perm[j], perm[i]])
        good = True
        for b in range(nblock):
            for i in range(starts[b], starts[b + 1]):
                for j in range(s0):
                    if ((j < starts[b] or j >= starts[b + 1])
                            and (Kp[i, j] != 0.0 or Mp[i, j] != 0.0)):
                        good = False
        L, Ac = F[c], A[c]
        L[:] = 0.0
        Ac[:] = 0.0
        for b in range(nblock):
            a, e = starts[b], starts[b + 1]
            if not (good and _cholesky_block(Mp, L, a, e)):
                good = False
                break
            for q in range(nj):  # Y_b = L_b⁻¹ M_bJ = W_bᵀ
                for i in range(a, e):
                    x = Mp[i, s0 + q]
                    for k in range(a, i):
                        x -= L[i, k] * Y[k, q]
                    Y[i, q] = x / L[i, i]
        if not good:
            ok[c] = False
            continue
        for p in range(nj):  # L_S: the Cholesky factor of S = M_JJ − Σ_b W_b W_bᵀ
            for q in range(p + 1):
                x = Mp[s0 + p, s0 + q]
                for k in range(s0):
                    x -= Y[k, p] * Y[k, q]
                for k in range(q):
                    x -= L[s0 + p, s0 + k] * L[s0 + q, s0 + k]
                if p == q:
                    if not x > 0.0:
                        good = False
                        x = 1.0
                    L[s0 + p, s0 + p] = math.sqrt(x)
                else:
                    L[s0 + p, s0 + q] = x / L[s0 + q, s0 + q]
        if not good:
            ok[c] = False
            continue
        for b in range(nblock):
            a, e = starts[b], starts[b + 1]
            for q in range(nj):  # V_b = L_b⁻ᵀ Y_b, so that W_b L_b⁻¹ = V_bᵀ
                for i in range(e - 1, a - 1, -1):
                    x = Y[i, q]
                    for k in range(i + 1, e):
                        x -= L[k, i] * V[k, q]
                    V[i, q] = x / L[i, i]
            for i in range(a, e):  # Z_b = −L_S⁻¹ V_bᵀ, in the J rows of F
                for p in range(nj):
                    x = -V[i, p]
                    for k in range(p):
                        x -= L[s0 + p, s0 + k] * L[s0 + k, i]
                    L[s0 + p, i] = x / L[s0 + p, s0 + p]
            for j in range(a, e):  # T = L_b⁻¹ K_bb
                for i in range(a, e):
                    x = Kp[i, j]
                    for k in range(a, i):
                        x -= L[i, k] * T[k, j]
                    T[i, j] = x / L[i, i]
            for j in range(a, e):  # A_bb = L_b⁻¹ Tᵀ (= T L_b⁻ᵀ: K_bb is symmetric)
                for i in range(a, e):
                    x = T[j, i]
                    for k in range(a, i):
                        x -= L[i, k] * Ac[k, j]
                    Ac[i, j] = x / L[i, i]
            for i in range(a, e):
                for j in range(a, i):
                    Ac[i, j] = Ac[j, i] = 0.5 * (Ac[i, j] + Ac[j, i])
            for j in range(a, e):  # YJ_b = L_S⁻¹ K_Jb + Z_b K_bb
                for p in range(nj):
                    x = Kp[s0 + p, j]
                    for k in range(p):
                        x -= L[s0 + p, s0 + k] * YJ[k, j]
                    YJ[p, j] = x / L[s0 + p, s0 + p]
            for p in range(nj):
                for j in range(a, e):
                    x = YJ[p, j]
                    for k in range(a, e):
                        x += L[s0 + p, k] * Kp[k, j]
                    T[0, j] = x
                for j in range(a, e):
                    YJ[p, j] = T[0, j]
            for p in range(nj):  # A_Jb = YJ_b L_b⁻ᵀ, and A_bJ its transpose
                for i in range(a, e):
                    x = YJ[p, i]
                    for k in range(a, i):
                        x -= L[i, k] * Ac[s0 + p, k]
                    Ac[s0 + p, i] = x / L[i, i]
                for i in range(a, e):
                    Ac[i, s0 + p] = Ac[s0 + p, i]
        for q in range(nj):  # H = L_S⁻¹ K_JJ + Σ_b Z_b K_bJ, the J block of L⁻¹K
            for p in range(nj):
                x = Kp[s0 + p, s0 + q]
                for k in range(p):
                    x -= L[s0 + p, s0 + k] * H[k, q]
                H[p, q] = x / L[s0 + p, s0 + p]
        for p in range(nj):
            for q in range(nj):
                x = H[p, q]
                for k in range(s0):
                    x += L[s0 + p, k] * Kp[k, s0 + q]
                T[0, q] = x
            for q in range(nj):
                H[p, q] = T[0, q]
        for p in range(nj):  # A_JJ = H L_S⁻ᵀ + Σ_b YJ_b Z_bᵀ
            for q in range(nj):
                x = H[p, q]
                for k in range(q):
                    x -= L[s0 + q, s0 + k] * Ac[s0 + p, s0 + k]
                Ac[s0 + p, s0 + q] = x / L[s0 + q, s0 + q]
            for q in range(nj):
                x = 0.0
                for k in range(s0):
                    x += YJ[p, k] * L[s0 + q, k]
                Ac[s0 + p, s0 + q] += x
        for p in range(nj):
            for q in range(p):
                Ac[s0 + p, s0 + q] = Ac[s0 + q, s0 + p] = 0.5 * (Ac[s0 + p, s0 + q]
                                                                + Ac[s0 + q, s0 + p])


@nb.njit(cache=True, nogil=True)
def _arrow_shapes(F, perm, starts, vec, X):
    """X = L⁻ᵀ vec of every pair, back in the given order: x_J = L_S⁻ᵀ v_J and
    x_b = L_b⁻ᵀ v_b + Z_bᵀ v_J (:func:`_arrow_reduce`'s F); vec (N, n, m), X (N, n, m)."""
    N, n, m = vec.shape
    nblock = len(starts) - 1
    s0 = starts[nblock]
    x = np.empty(n)
    for c in range(N):
        L = F[c]
        for mode in range(m):
            v = vec[c, :, mode]
            for p in range(n - 1, s0 - 1, -1):
                y = v[p]
                for k in range(p + 1, n):
                    y -= L[k, p] * x[k]
                x[p] = y / L[p, p]
            for b in range(nblock):
                a, e = starts[b], starts[b + 1]
                for i in range(e - 1, a - 1, -1):
                    y = v[i]
                    for k in range(i + 1, e):
                        y -= L[k, i] * x[k]
                    x[i] = y / L[i, i]
                for i in range(a, e):
                    y = 0.0
                    for p in range(s0, n):
                        y += L[p, i] * v[p]
                    x[i] += y
            for i in range(n):
                X[c, perm[i], mode] = x[i]
