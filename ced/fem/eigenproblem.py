"""Natural frequencies over the cycle (thesis III.3.1.b, docs/theory.md, "Modal analysis").

The generalized eigenproblem (K_eff − ω² M) φ = 0 at frozen configurations, where K_eff holds
the stiffness-type effects of the scene (elastic, centrifugal, axial stiffening). The
circulatory part of K_eff (the antisymmetric αG term of an accelerating link) has no place in
a symmetric frozen-time eigenproblem; its symmetric part is used.
"""
from __future__ import annotations

import numpy as np

__all__ = ["natural_frequencies"]


def natural_frequencies(
    stiffness: np.ndarray, mass: np.ndarray, modes: int, shapes: bool = False
):
    """Lowest natural frequencies, Hz, batched over leading axes.

    Parameters
    ----------
    stiffness, mass : (..., n, n); mass symmetric positive definite
    modes : number of frequencies (at most n)
    shapes : also return mass-normalised mode shapes (..., n, modes)

    Returns
    -------
    frequency : (..., modes) Hz, ascending; a negative eigenvalue (the frozen structure
        buckles under compression or softening) gives a negative frequency −√|λ|/2π so that
        it stays finite and visible.
    """
    K = 0.5 * (stiffness + np.swapaxes(stiffness, -1, -2))
    L = np.linalg.cholesky(0.5 * (mass + np.swapaxes(mass, -1, -2)))
    Linv = np.linalg.inv(L)
    A = Linv @ K @ np.swapaxes(Linv, -1, -2)
    A = 0.5 * (A + np.swapaxes(A, -1, -2))
    lam, vec = np.linalg.eigh(A)
    lam, vec = lam[..., :modes], vec[..., :modes]
    freq = np.sign(lam) * np.sqrt(np.abs(lam)) / (2.0 * np.pi)
    if not shapes:
        return freq
    return freq, np.swapaxes(Linv, -1, -2) @ vec
