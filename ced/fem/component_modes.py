"""Component-mode synthesis of flexible links (Craig & Bampton 1968, with load vectors).

A link's local DOFs split into boundary rows (the end translations tied to the joints, and a
clamped rotation) and interior rows (:meth:`ced.fem.coupling.Layout.row_split`). The interior is
described by

* ``m`` fixed-interface normal modes Φ (boundary held), mass-normalised;
* static load vectors K_ii⁻¹ L_i of every load shape of the rigid motion (uniform and linear
  distributed loads along x and y, the distributed couple), M-orthogonalised against Φ — so
  the quasi-static response to the inertial loads is reproduced exactly (modal truncation
  augmentation, Dickens, Nakagawa & Wittbrodt 1997);
* the static constraint modes Ψ = −K_ii⁻¹ K_ib of the boundary rows (Craig–Bampton).

With q = B (η, q_b), B = [[Φ X Ψ], [0 0 I]], every local matrix becomes Bᵀ A B. The interior of
the reduced link is η (unit rows of the projection, as before), so the assembly of
:mod:`ced.fem.effect_terms` applies unchanged to far fewer DOFs.
"""
from __future__ import annotations

import hashlib

import numpy as np

from .effect_terms import LinkData
from .eigenproblem import natural_frequencies

__all__ = ["craig_bampton"]


def _m_orthonormalize(X: np.ndarray, M: np.ndarray, against: np.ndarray) -> np.ndarray:
    """Columns of X made M-orthonormal and M-orthogonal to ``against`` (Gram–Schmidt twice);
    columns that vanish (linearly dependent load shapes) are dropped for all cases alike."""
    cols = []
    basis = [against[..., :, j] for j in range(against.shape[-1])]
    for j in range(X.shape[-1]):
        x = X[..., :, j].copy()
        norm0 = np.sqrt(np.einsum("ci,cij,cj->c", x, M, x))
        for _ in range(2):
            for b in basis:
                x -= np.einsum("ci,cij,cj->c", b, M, x)[:, None] * b
        norm = np.sqrt(np.einsum("ci,cij,cj->c", x, M, x))
        if np.all(norm > 1e-8 * np.maximum(norm0, 1e-300)):
            x /= norm[:, None]
            basis.append(x)
            cols.append(x)
    if not cols:
        return np.zeros(X.shape[:-1] + (0,))
    return np.stack(cols, axis=-1)


def _distinct(*arrays: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Indices of the first case of each distinct set of values (along axis 0 of every array)
    and, per case, the position of its set among them (keyed by the values' bytes; a sort of
    whole rows, numpy.unique's axis=0, is far slower on rows of 10⁵–10⁶ entries)."""
    seen: dict[bytes, int] = {}
    first, inverse = [], np.empty(arrays[0].shape[0], np.int64)
    for c in range(arrays[0].shape[0]):
        digest = hashlib.blake2b(b"".join(np.ascontiguousarray(x[c]).tobytes()
                                          for x in arrays), digest_size=16).digest()
        if digest not in seen:
            seen[digest] = len(first)
            first.append(c)
        inverse[c] = seen[digest]
    return np.array(first, np.int64), inverse


def _basis(K: np.ndarray, M: np.ndarray, loads: np.ndarray, ni: int, modes: int) -> np.ndarray:
    """B = [[Φ X Ψ], [0 0 I]] (case, n, n_reduced) of links K, M (case, n, n), interior rows
    first, with load shapes ``loads`` (case, ni, shapes)."""
    Kii, Kib = K[:, :ni, :ni], K[:, :ni, ni:]
    Mii = M[:, :ni, :ni]
    _, phi = natural_frequencies(Kii, Mii, min(modes, ni), shapes=True)
    static = np.linalg.solve(Kii, loads)
    X = _m_orthonormalize(static, Mii, phi)
    interior = np.concatenate([phi, X], axis=-1)[:, :, :ni]  # never more than the FE DOFs
    psi = -np.linalg.solve(Kii, Kib)
    nb = K.shape[-1] - ni
    nr = interior.shape[-1]
    B = np.zeros((K.shape[0], ni + nb, nr + nb))
    B[:, :ni, :nr] = interior
    B[:, :ni, nr:] = psi
    B[:, ni:, nr:] = np.eye(nb)
    return B


def craig_bampton(data: LinkData, n_interior: int, modes: int) -> tuple[LinkData, np.ndarray]:
    """Reduce one link (matrices in split order: interior rows first).

    Parameters
    ----------
    data : local matrices, (case, n, n), interior rows first
    n_interior : number of interior rows
    modes : fixed-interface normal modes to keep

    Returns
    -------
    (reduced LinkData with the reduced interior first, basis B (case, n, n_reduced))
    """
    ni = n_interior
    K, M = data.stiffness, data.mass
    loads = np.concatenate([data.load_constant[:, :ni], data.load_linear[:, :ni],
                            data.moment_load[:, :ni, None]], axis=-1)
    # The basis depends on the link alone (its K, M and load shapes), not on the case's speed:
    # cases whose link is the same (a speed sweep; the convergence study's batches) share one.
    first, inverse = _distinct(K, M, loads)
    B = _basis(K[first], M[first], loads[first], ni, modes)[inverse]
    Bt = np.swapaxes(B, -1, -2)

    def sandwich(A):
        return Bt @ A @ B

    reduced = LinkData(
        mass=sandwich(M), translational_mass=sandwich(data.translational_mass),
        stiffness=sandwich(K), gyroscopic=sandwich(data.gyroscopic),
        geometric_stiffness=Bt[:, None] @ data.geometric_stiffness @ B[:, None],
        load_constant=Bt @ data.load_constant, load_linear=Bt @ data.load_linear,
        moment_load=(Bt @ data.moment_load[..., None])[..., 0],
        mass_per_length=data.mass_per_length,
        rotary_inertia_per_length=data.rotary_inertia_per_length)
    return reduced, B
