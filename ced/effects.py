"""The named effects of DESIGN §3, each adding one group of terms to M q̈ + C q̇ + K q = F.

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

from dataclasses import dataclass

import numpy as np

from .assembly import Layout

__all__ = ["LinkData", "SystemTerms", "system_terms", "axial_force_coefficients"]


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
    """
    return np.stack([-first_force_local_x, -load_constant_x, -0.5 * load_linear_x])


class _Split:
    """One block of P split into constant unit rows S and time-varying rows T (see
    :meth:`ced.assembly.Layout.row_split`), so that Pᵀ A P = SᵀAS + SᵀA T + TᵀA S + TᵀA T
    costs products with the few varying rows only.

    Local matrices are permuted once (:meth:`permute`) to put the unit rows first, so every
    block is a view; the unit rows' y columns of one link are contiguous. The varying rows
    depend on the joint coordinates only (the first ``nfree`` columns of y), never on interior
    DOFs, so T is kept to those columns.
    """

    def __init__(self, P: np.ndarray, rows, columns, varying, nfree: int):
        self.order = np.array(list(rows) + list(varying), int)
        self.ns = len(rows)
        self.cols = slice(columns[0], columns[-1] + 1) if rows else slice(0, 0)
        assert not rows or list(columns) == list(range(columns[0], columns[-1] + 1))
        self.nf = nfree
        self.T = [P[d][..., varying, :nfree] for d in range(3)]  # (case, step, nv, nfree)
        self.TT = [np.swapaxes(t, -1, -2) for t in self.T]

    def permute(self, A: np.ndarray) -> np.ndarray:
        """A local (…, n, n) matrix in the split order."""
        return A[..., self.order, :][..., :, self.order]

    def sandwich(self, out: np.ndarray, A: np.ndarray, left: int = 0, right: int = 0) -> None:
        """out += P⁽ˡᵉᶠᵗ⁾ᵀ A P⁽ʳⁱᵍʰᵗ⁾ for a permuted A, (case, n, n) or (case, step, n, n);
        left, right are the time-derivative orders of the projections (S is constant)."""
        if A.ndim == 3:
            A = A[:, None]
        ns, c, f = self.ns, self.cols, slice(0, self.nf)
        if self.nf:
            out[..., f, f] += self.TT[left] @ (A[..., ns:, ns:] @ self.T[right])
        if ns:
            if left == 0 and self.nf:
                out[..., c, f] += A[..., :ns, ns:] @ self.T[right]
            if right == 0 and self.nf:
                out[..., f, c] += self.TT[left] @ A[..., ns:, :ns]
            if left == 0 and right == 0:
                out[..., c, c] += A[..., :ns, :ns]

    def apply_transpose(self, out: np.ndarray, f: np.ndarray) -> None:
        """out += P⁽⁰⁾ᵀ f for a permuted local vector f (case, step, n)."""
        if self.nf:
            out[..., : self.nf] += (self.TT[0] @ f[..., self.ns:, None])[..., 0]
        if self.ns:
            out[..., self.cols] += f[..., : self.ns]


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
    P : (3, case, step, nz, ny) projection jet
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
    offsets = layout.link_offsets
    nfree = len(layout.free_coordinates)
    for i, name in enumerate(topo.links):
        data = links[name]
        block = slice(offsets[name], offsets[name] + layout.link_sizes[name])
        split = _Split(P[:, :, :, block], *layout.row_split(name), nfree)
        mass = split.permute(data.mass)
        G = split.permute(data.gyroscopic)[:, None]
        w = omega[..., i][..., None, None]
        a = alpha[..., i][..., None, None]
        if M_el is not None:
            split.sandwich(M_el, mass)
        elif M is not None:
            split.sandwich(M, mass)
        if C is not None:
            split.sandwich(C, 2.0 * w * G)
            split.sandwich(C, 2.0 * mass, 0, 1)
        stiffness = split.permute(data.stiffness)[:, None] if layout.flexible[name] else None
        if K_el is not None and stiffness is not None:
            split.sandwich(K_el, stiffness)  # added to K once, at the end
            stiffness = None
        if centrifugal:
            kc = a * G - (w * w) * split.permute(data.translational_mass)[:, None]
            stiffness = kc if stiffness is None else stiffness + kc
            split.sandwich(K, 2.0 * w * G, 0, 1)
            split.sandwich(K, mass, 0, 2)
        if axial is not None:
            kg = np.einsum("kcs,cknm->csnm", axial[name], split.permute(data.geometric_stiffness))
            stiffness = kg if stiffness is None else stiffness + kg
        if stiffness is not None:
            split.sandwich(K, stiffness)
        b0, b1, m0 = link_loads[name]
        order = split.order
        f = np.einsum("cnj,csj->csn", data.load_constant[:, order], b0)
        f += np.einsum("cnj,csj->csn", data.load_linear[:, order], b1)
        if m0 is not None:
            f += m0[..., None] * data.moment_load[:, None, order]
        split.apply_transpose(F, f)
    for k, joint in enumerate(topo.joints):
        m = joint_mass[:, k]
        if not np.any(m):
            continue
        off = layout.joint_offsets[joint]
        P0, P1, P2 = (P[d, ..., off : off + 2, :] for d in range(3))
        mm = m[:, None, None, None]
        P0T = np.swapaxes(P0, -1, -2)
        if M_el is not None:
            M_el += mm * (P0T @ P0)
        elif M is not None:
            M += mm * (P0T @ P0)
        if C is not None:
            C += 2.0 * mm * (P0T @ P1)
        if centrifugal:
            K += mm * (P0T @ P2)
        F += (P0T @ joint_load[:, :, k, :, None])[..., 0]
    if K_el is not None:
        K += K_el
    return SystemTerms(M, C, K, F, M_el, K_el)
