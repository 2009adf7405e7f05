"""The named effects of docs/theory.md, each adding one group of terms to M q̈ + C q̇ + K q = F.

Per link, in its local frame (elastic field w, rigid angular velocity ω and acceleration α):

    M q̈ + 2ωG q̇ + (K + αG − ω² M_w + K_g[N]) q = f

and with q = P(t) y the frame-rotation terms Ṗ, P̈ of the projections join them. Grouping:

=================  ==========================================================================
inertia            f from the rigid-body acceleration field (−ρA Rᵀa_first, ρA(ω², −α) s)
                   and −m a_J on point masses
elastic_inertia    Pᵀ M P
gravity            f += ρA Rᵀ g on links, m g on point masses
coriolis           Pᵀ(2 M Ṗ + 2ω G P): every velocity-proportional motion-induced term
centrifugal        Pᵀ(M P̈ + 2ω G Ṗ + (αG − ω² M_w) P): every displacement-proportional one
axial_stiffening   Pᵀ K_g[N] P with the axial force N(s) of the rigid motion
=================  ==========================================================================

A term whose effect is absent is never formed.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from .coupling import Layout
from .sandwich import link_terms_add, sandwich_add

#: Form Pᵀ A P in the compiled loop (:mod:`ced.fem.sandwich`); ``CED_KERNEL=numpy`` keeps the
#: numpy products, the reference it is tested against.
COMPILED = os.environ.get("CED_KERNEL", "numba") != "numpy"

__all__ = ["LinkData", "SystemTerms", "system_terms", "axial_force_coefficients", "split_order",
           "permute"]


@dataclass(frozen=True)
class LinkData:
    """Local matrices of one link for every case of a batch, each with a leading case axis.

    ``mass``, ``translational_mass``, ``stiffness``, ``gyroscopic`` (case, n, n);
    ``geometric_stiffness`` (case, 3, n, n); ``load_constant``, ``load_linear`` (case, n, 2);
    ``moment_load`` (case, n) m; ``mass_per_length`` (case,) kg/m;
    ``rotary_inertia_per_length`` (case,) kg m, ρI where the mass matrix carries rotary
    inertia, else 0.
    """

    mass: np.ndarray
    translational_mass: np.ndarray
    stiffness: np.ndarray
    gyroscopic: np.ndarray
    geometric_stiffness: np.ndarray
    load_constant: np.ndarray
    load_linear: np.ndarray
    moment_load: np.ndarray
    mass_per_length: np.ndarray
    rotary_inertia_per_length: np.ndarray


@dataclass
class SystemTerms:
    """Reduced matrices over a range of steps: M, C, K (case, step, ny, ny), F (case, step, ny).

    ``elastic_mass`` (the mass without effects switched, for modal analysis and damping) and
    ``elastic_stiffness`` (K without motion-induced terms, for Rayleigh damping) are formed
    only when asked for.
    """

    mass: np.ndarray | None
    damping: np.ndarray | None
    stiffness: np.ndarray
    force: np.ndarray
    elastic_mass: np.ndarray | None = None
    elastic_stiffness: np.ndarray | None = None


def axial_force_coefficients(
    first_force_local_x: np.ndarray, load_constant_x: np.ndarray, load_linear_x: np.ndarray
) -> np.ndarray:
    """Coefficients (N0, N1, N2) of the axial force N(s) = N0 + N1 s + N2 s², N (tension > 0).

    Equilibrium of the piece [0, s] of the link under its first-end axial force X_f and the
    axial distributed load p(s) = p0 + p1 s (d'Alembert and weight, N/m):
    X_f + ∫₀ˢ p ds + N(s) = 0, so N0 = −X_f, N1 = −p0, N2 = −p1/2.
    Shape (3, case, step).

    Parameters
    ----------
    first_force_local_x : numpy.ndarray
        Axial (local x) force X_f on the link at its first end, N, shape (case, step).
    load_constant_x : numpy.ndarray
        Constant part p0 of the axial distributed load, N/m, shape (case, step).
    load_linear_x : numpy.ndarray
        Linear part p1 of the axial distributed load (p = p0 + p1 s), N/m², shape (case, step).

    Returns
    -------
    numpy.ndarray
        (N0, N1, N2) in N, N/m, N/m², shape (3, case, step).
    """
    return np.stack([-first_force_local_x, -load_constant_x, -0.5 * load_linear_x])


def split_order(layout: Layout, link: str) -> np.ndarray:
    """Local DOF order with the interior (constant unit) rows of P first, see
    :meth:`ced.fem.coupling.Layout.row_split`; link matrices are stored in this order.

    Parameters
    ----------
    layout : Layout
        The DOF layout.
    link : str
        Name of the link.

    Returns
    -------
    numpy.ndarray
        Permutation (n,) of the link's local DOF indices, int.
    """
    rows, _, varying = layout.row_split(link)
    return np.array(list(rows) + list(varying), int)


def permute(data: LinkData, order: np.ndarray) -> LinkData:
    """``data`` with its local DOFs in ``order`` (matrices, loads).

    Parameters
    ----------
    data : LinkData
        A link's matrices (…, n, n) and load vectors (…, n, c).
    order : numpy.ndarray
        Permutation (n,) of the local DOF indices, e.g. from :func:`split_order`.

    Returns
    -------
    LinkData
        The same data with rows (and columns) reordered; the per-length properties unchanged.
    """
    def both(a):
        return a[..., order, :][..., :, order]
    return LinkData(
        mass=both(data.mass), translational_mass=both(data.translational_mass),
        stiffness=both(data.stiffness), gyroscopic=both(data.gyroscopic),
        geometric_stiffness=both(data.geometric_stiffness),
        load_constant=data.load_constant[:, order], load_linear=data.load_linear[:, order],
        moment_load=data.moment_load[:, order], mass_per_length=data.mass_per_length,
        rotary_inertia_per_length=data.rotary_inertia_per_length)


class _Split:
    """One link block of P split into constant unit rows S and time-varying rows T, so that
    Pᵀ A P = SᵀAS + SᵀA T + TᵀA S + TᵀA T costs products with the few varying rows only.

    Link matrices are stored permuted (:func:`split_order`) with the unit rows first, so
    every block is a view; the unit rows' y columns of one link are contiguous. The varying
    rows depend on the joint coordinates only (the nfree columns that P carries).
    """

    def __init__(self, P: np.ndarray, rows, columns, varying):
        self.ns = len(rows)
        self.nf = P.shape[-1]
        self.cols = slice(columns[0], columns[-1] + 1) if rows else slice(0, 0)
        # (case, step, nv, nfree) each. P's own rows laid out as fancy indexing gives them
        # (varying rows outermost: the loads' products with their transpose are numpy's bits
        # for that layout); the derivatives', read by the compiled kernels only, C-contiguous
        # by np.take, without the copy the kernels made of the fancy ones, in half the time.
        varying = np.asarray(varying, np.int64)
        self.T = [P[0][..., varying, :]] + [np.take(P[d], varying, axis=-2) for d in (1, 2)]
        self.TT = [np.swapaxes(t, -1, -2) for t in self.T]

    def sandwich(self, out: np.ndarray, A: np.ndarray, left: int = 0, right: int = 0) -> None:
        """out += P⁽ˡᵉᶠᵗ⁾ᵀ A P⁽ʳⁱᵍʰᵗ⁾ for a permuted A, (case, n, n) or (case, step, n, n);
        left, right are the time-derivative orders of the projections (S is constant)."""
        if COMPILED and out.flags.c_contiguous and out.dtype == np.float64:
            sandwich_add(out, A, self.T[left], self.T[right], self.ns, self.cols.start,
                         left, right)
            return
        if A.ndim == 3:
            A = A[:, None]
        ns, c, f = self.ns, self.cols, slice(0, self.nf)
        if self.nf:
            out[..., f, f] += self.TT[left] @ (A[..., ns:, ns:] @ self.T[right])
            if ns and left == 0:
                out[..., c, f] += A[..., :ns, ns:] @ self.T[right]
            if ns and right == 0:
                out[..., f, c] += self.TT[left] @ A[..., ns:, :ns]
        if ns and left == 0 and right == 0:
            out[..., c, c] += A[..., :ns, :ns]

    def link_terms(self, M: np.ndarray | None, C: np.ndarray | None, K: np.ndarray,
                   data: LinkData, w: np.ndarray, coefficients: list[np.ndarray],
                   matrices: list[np.ndarray], centrifugal: bool) -> None:
        """The link's M += PᵀM_lP, C += Pᵀ(2ωG P + 2M_l Ṗ) and K += Pᵀ(Σ c_k A_k) P
        [+ Pᵀ(2ωG Ṗ + M_l P̈) if centrifugal]; M, C None to leave out, ω (case, step) rad/s.

        Compiled as one pass (:func:`ced.fem.sandwich.link_terms_add`), else one
        :meth:`sandwich` per product, the reference."""
        if COMPILED and all(o is None or (o.flags.c_contiguous and o.dtype == np.float64)
                            for o in (M, C, K)):
            link_terms_add(M, C, K, data.mass, data.gyroscopic, coefficients, matrices, w,
                           self.T, self.ns, self.cols.start, centrifugal)
            return
        if M is not None:
            self.sandwich(M, data.mass)
        if C is not None or centrifugal:
            gyroscopic = 2.0 * w[..., None, None] * data.gyroscopic[:, None]
        if C is not None:
            self.sandwich(C, gyroscopic)
            self.sandwich(C, 2.0 * data.mass, 0, 1)
        if centrifugal:
            self.sandwich(K, gyroscopic, 0, 1)
            self.sandwich(K, data.mass, 0, 2)
        if coefficients:
            self.sandwich(K, _combine(coefficients, matrices))

    def apply_transpose(self, out: np.ndarray, f: np.ndarray) -> None:
        """out += P⁽⁰⁾ᵀ f for a permuted local vector f (case, step, n)."""
        if self.nf:
            out[..., : self.nf] += (self.TT[0] @ f[..., self.ns:, None])[..., 0]
        if self.ns:
            out[..., self.cols] += f[..., : self.ns]


def _combine(coefficients: list[np.ndarray], matrices: list[np.ndarray]) -> np.ndarray:
    """Σ_k c_k(t) A_k as one batched matmul: (case, step, m) @ (case, m, n²) → (case, step, n, n)."""
    c = np.stack(coefficients, axis=-1)
    A = np.stack(matrices, axis=1)
    n = A.shape[-1]
    return (c @ A.reshape(A.shape[0], A.shape[1], n * n)).reshape(c.shape[:2] + (n, n))


def system_terms(
    layout: Layout,
    links: dict[str, LinkData],
    P: np.ndarray,
    omega: np.ndarray,
    alpha: np.ndarray,
    link_loads: dict[str, tuple],
    axial: dict[str, np.ndarray] | None,
    joint_mass: np.ndarray,
    joint_load: np.ndarray,
    effects: set[str],
    extras: frozenset[str] = frozenset(),
) -> SystemTerms:
    """Assemble the reduced system over a range of steps.

    Parameters
    ----------
    layout : DOF layout
    links : link -> local matrices
    P : (3, case, step, row, nfree) projection jet, compact (the ``compact`` of
        :func:`ced.fem.coupling.projection`: z row r is its row ``layout.projection_index[r]``)
    omega, alpha : (case, step, link) rad/s, rad/s²
    link_loads : link -> (b0, b1, m0): distributed load b0 + s b1 in the link frame, each
        (case, step, 2), N/m and N/m², and a distributed couple m0 (case, step) N m/m or None
        (already containing only the requested inertia/gravity parts)
    axial : link -> (3, case, step) coefficients of N(s), or None without axial_stiffening
    joint_mass : (case, joint) kg of point masses (and the slider at its joint)
    joint_load : (case, step, joint, 2) N on the point masses (global frame)
    effects : requested effect names
    extras : {"elastic_mass", "elastic_stiffness"} to form as well
    """
    topo = layout.topology
    ncase, nstep = P.shape[1:3]
    ny = layout.ny
    shape = (ncase, nstep, ny, ny)
    inertial = "elastic_inertia" in effects
    M = np.zeros(shape) if inertial else None
    C = np.zeros(shape) if "coriolis" in effects else None
    K = np.zeros(shape)
    F = np.zeros((ncase, nstep, ny))
    M_el = None
    if "elastic_mass" in extras:
        M_el = M if inertial else np.zeros(shape)
    K_el = np.zeros(shape) if "elastic_stiffness" in extras else None
    centrifugal = "centrifugal" in effects
    offsets, index = layout.link_offsets, layout.projection_index
    for i, name in enumerate(topo.links):
        data = links[name]  # stored in split order
        rows, columns, varying = layout.row_split(name)
        split = _Split(P, rows, columns, index[offsets[name] + np.array(varying, np.int64)])
        w = omega[..., i]
        a = alpha[..., i]
        coefficients, matrices = [], []
        if layout.flexible[name]:
            if K_el is not None:
                split.sandwich(K_el, data.stiffness)  # added to K once, at the end
            else:
                coefficients.append(np.ones_like(w))
                matrices.append(data.stiffness)
        if centrifugal:
            coefficients += [a, -w * w]
            matrices += [data.gyroscopic, data.translational_mass]
        if axial is not None:
            coefficients += list(axial[name])
            matrices += list(np.moveaxis(data.geometric_stiffness, 1, 0))
        split.link_terms(M_el if M_el is not None else M, C, K, data, w, coefficients,
                         matrices, centrifugal)
        b0, b1, m0 = link_loads[name]
        f = b0 @ np.swapaxes(data.load_constant, -1, -2) + b1 @ np.swapaxes(
            data.load_linear, -1, -2)
        if m0 is not None:
            f += m0[..., None] * data.moment_load[:, None, :]
        split.apply_transpose(F, f)
    nf = P.shape[-1]
    for k, joint in enumerate(topo.joints):
        m = joint_mass[:, k]
        if not np.any(m) or not nf:
            continue
        off = index[layout.joint_offsets[joint]]  # its two rows are consecutive
        P0, P1, P2 = (P[d, ..., off : off + 2, :] for d in range(3))
        mm = m[:, None, None, None]
        P0T = np.swapaxes(P0, -1, -2)
        target = M_el if M_el is not None else M
        if target is not None:
            target[..., :nf, :nf] += mm * (P0T @ P0)
        if C is not None:
            C[..., :nf, :nf] += 2.0 * mm * (P0T @ P1)
        if centrifugal:
            K[..., :nf, :nf] += mm * (P0T @ P2)
        F[..., :nf] += (P0T @ joint_load[:, :, k, :, None])[..., 0]
    if K_el is not None:
        K += K_el
    return SystemTerms(M, C, K, F, M_el, K_el)
