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
    """Reduced matrices over a range of steps: M, C, K (case, step, ny, ny), F (case, step, ny);
    ``elastic_stiffness`` and ``elastic_mass`` without motion-induced terms (for damping)."""

    mass: np.ndarray | None
    damping: np.ndarray | None
    stiffness: np.ndarray
    force: np.ndarray
    elastic_stiffness: np.ndarray
    elastic_mass: np.ndarray


def _sandwich(P: np.ndarray, A: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Pᵀ A Q over leading (case, step) axes; A is (case, n, n) or (case, step, n, n)."""
    if A.ndim == 3:
        A = A[:, None]
    return np.swapaxes(P, -1, -2) @ (A @ Q)


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


def system_terms(
    layout: Layout,
    links: dict[str, LinkData],
    P: np.ndarray,
    omega: np.ndarray,
    alpha: np.ndarray,
    link_loads: dict[str, tuple[np.ndarray, np.ndarray]],
    axial: dict[str, np.ndarray] | None,
    joint_mass: np.ndarray,
    joint_load: np.ndarray,
    effects: set[str],
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
    """
    topo = layout.topology
    ncase, nstep = P.shape[1:3]
    ny = layout.ny
    M = np.zeros((ncase, nstep, ny, ny)) if "elastic_inertia" in effects else None
    C = np.zeros((ncase, nstep, ny, ny)) if "coriolis" in effects else None
    K = np.zeros((ncase, nstep, ny, ny))
    F = np.zeros((ncase, nstep, ny))
    K_el = np.zeros((ncase, nstep, ny, ny))
    M_el = np.zeros((ncase, nstep, ny, ny))
    offsets = layout.link_offsets
    for i, name in enumerate(topo.links):
        data = links[name]
        rows = slice(offsets[name], offsets[name] + layout.link_sizes[name])
        P0, P1, P2 = P[0, ..., rows, :], P[1, ..., rows, :], P[2, ..., rows, :]
        w = omega[..., i][..., None, None]
        a = alpha[..., i][..., None, None]
        G = data.gyroscopic[:, None]
        Mm = data.mass[:, None]
        M_el += _sandwich(P0, data.mass, P0)
        if layout.flexible[name]:
            K_el += _sandwich(P0, data.stiffness, P0)
        if M is not None:
            M += _sandwich(P0, data.mass, P0)
        if C is not None:
            C += np.swapaxes(P0, -1, -2) @ (2.0 * (Mm @ P1) + 2.0 * w * (G @ P0))
        if "centrifugal" in effects:
            Kc = a * G - (w * w) * data.translational_mass[:, None]
            K += np.swapaxes(P0, -1, -2) @ (Mm @ P2 + 2.0 * w * (G @ P1) + Kc @ P0)
        if axial is not None:
            N = axial[name]  # (3, case, step)
            Kg = np.einsum("kcs,cknm->csnm", N, data.geometric_stiffness)
            K += _sandwich(P0, Kg, P0)
        b0, b1, m0 = link_loads[name]
        f = data.load_constant[:, None] @ b0[..., None] + data.load_linear[:, None] @ b1[..., None]
        if m0 is not None:
            f = f + m0[..., None, None] * data.moment_load[:, None, :, None]
        F += (np.swapaxes(P0, -1, -2) @ f)[..., 0]
    K += K_el
    for k, joint in enumerate(topo.joints):
        m = joint_mass[:, k]
        if not np.any(m):
            continue
        off = layout.joint_offsets[joint]
        P0, P1, P2 = (P[d, ..., off : off + 2, :] for d in range(3))
        mm = m[:, None, None, None]
        M_el += mm * (np.swapaxes(P0, -1, -2) @ P0)
        if M is not None:
            M += mm * (np.swapaxes(P0, -1, -2) @ P0)
        if C is not None:
            C += 2.0 * mm * (np.swapaxes(P0, -1, -2) @ P1)
        if "centrifugal" in effects:
            K += mm * (np.swapaxes(P0, -1, -2) @ P2)
        F += (np.swapaxes(P0, -1, -2) @ joint_load[:, :, k, :, None])[..., 0]
    return SystemTerms(M, C, K, F, K_el, M_el)
