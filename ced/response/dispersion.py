"""Dispersion-matched mass: the Newmark family with each resolved mode's period exact.

An implicit Newmark-family scheme marches an undamped mode of frequency ω with step h at a
discrete frequency ω̃ < ω: its phase per step θ(ωh) = ω̃h falls behind ωh by (ωh)³/12 for
the trapezoidal rule (Hughes, *The Finite Element Method*, 2000, §9.3), more with numerical
dissipation. Over a start transient of many vibration periods the phase of the higher modes
drifts by radians: on the reference four-bar at 1,024 steps per revolution the coupler's
modes at 0.6–5 kHz (ωh ≈ 0.2–2) are what keeps the peak strain from converging (issue 14).

``time.dispersion: matched`` removes that drift for every mode resolved by the steps. The
scheme is applied to a modified system M′ẍ + Cẋ + Kq = F whose modal masses are lowered so
that the scheme's discrete frequency of each mode is its physical one: for a mode of
frequency ω with ωh ≤ :data:`RESOLVED`, the modified frequency ω′ solves θ(ω′h) = ωh, and the
mode's mass is scaled by m′ = (ω/ω′)². K, C and F are untouched, so the quasi-static response
(all that the stiff, unresolved modes carry) is unchanged, and M′ − M = O(h²), so the scheme
keeps its second order on the forced part of the response and converges to the same
solution. This is the classical prewarping of the bilinear transform (Tustin's method), done
per mode.

The modes are those of the frozen system at each step, M(t) and K(t), with M(t)-normalized
shapes φ_k: the mass of each step is transformed by a congruence, M′(t) = T(t)ᵀ M(t) T(t) with
T = I − Σ_k (1 − √m′_k) φ_k φ_kᵀ M(t), which scales each resolved mode's mass by m′_k and
leaves the others alone; T is invertible, so M′ is positive definite wherever M is, and the
scheme stays unconditionally stable. The modes are found at every step because they change
over the cycle: one T from the period's mean system (a sixth of the cost) was right where
only the coupler is flexible, but where every link is, the mass varies by 21 % over the cycle
and the mean system's modes mix; there it was 25 % off at 1,024 steps per revolution, where
the plain scheme is 2 % off and the per-step correction 0.15 %.

Measured on the reference sweep (100 speeds, two revolutions from the undeformed state):
16 elements at 8,192 steps per revolution are within 0.09 % of 32,768 steps with the plain
scheme at every one of 20 speeds checked, where the plain scheme at 8,192 steps is 0.52 % off
(``benchmarks/sweep.py``).
"""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from .integrators import NewmarkFamily, amplification_matrix
from .period_terms import PeriodTerms

__all__ = ["discrete_phase", "modified_omega_h", "mass_transform", "matched_terms",
           "RESOLVED"]

#: Modes with ωh above this (fewer than three steps per period) are left as they are: they
#: are not resolved by the steps whatever their phase.
RESOLVED = 2.0 * math.pi / 3.0
#: Steps whose modes are found at once, as a fraction of the period: the transforms and
#: their temporaries (about 12 matrices a step) stay below one term's worth of memory.
_BLOCKS = 16


def discrete_phase(scheme: NewmarkFamily, omega_h) -> np.ndarray:
    """The scheme's phase advance per step of an undamped mode, θ(ωh) = ω̃h.

    Parameters
    ----------
    scheme : NewmarkFamily
        The scheme.
    omega_h : array_like
        The mode's frequency times the step, ωh, rad per step.

    Returns
    -------
    numpy.ndarray
        θ, rad per step (the argument of the principal, complex pair of eigenvalues of
        :func:`ced.response.integrators.amplification_matrix`); π where the eigenvalues are
        real (the scheme no longer oscillates at that ωh).
    """
    x = np.atleast_1d(np.asarray(omega_h, float))
    lam = np.linalg.eigvals(amplification_matrix(scheme, x))
    oscillating = np.abs(lam.imag) > 1e-12 * np.abs(lam)
    # The principal roots are the complex pair (the spurious root of the α-schemes is real).
    phase = np.where(oscillating, np.abs(np.angle(lam)), -np.inf).max(axis=-1)
    return np.where(np.isfinite(phase), phase, np.pi).reshape(np.shape(omega_h))


@functools.lru_cache(maxsize=16)
def _phase_table(scheme: NewmarkFamily) -> tuple[np.ndarray, np.ndarray]:
    """(ω′h, θ(ω′h)) on a grid fine where θ bends, up to where θ has passed
    :data:`RESOLVED` or stopped growing; θ increases along it."""
    x = np.concatenate([np.linspace(1e-6, 3.0, 3001)[:-1], np.geomspace(3.0, 1e3, 2000)])
    theta = discrete_phase(scheme, x)
    rising = np.concatenate([[True], np.diff(theta) > 0.0])
    last = np.argmin(rising) if not rising.all() else len(x)
    return x[:last], theta[:last]


def modified_omega_h(scheme: NewmarkFamily, omega_h) -> np.ndarray:
    """ω′h with θ(ω′h) = ωh: the modified frequency the scheme marches at the physical one.

    Parameters
    ----------
    scheme : NewmarkFamily
    omega_h : array_like
        Physical ωh, rad per step.

    Returns
    -------
    numpy.ndarray
        ω′h, rad per step (≥ ωh); NaN where ωh exceeds :data:`RESOLVED` or any phase the
        scheme reaches.
    """
    x, theta = _phase_table(scheme)
    omega_h = np.asarray(omega_h, float)
    out = np.interp(omega_h, theta, x)
    return np.where((omega_h <= RESOLVED) & (omega_h <= theta[-1]) & (omega_h > 0.0),
                    np.maximum(out, omega_h), np.nan)


def mass_transform(mass: np.ndarray, stiffness: np.ndarray, h: np.ndarray,
                   scheme: NewmarkFamily) -> np.ndarray:
    """T with which Tᵀ M T marches every resolved mode of (M, K) at its own frequency.

    Parameters
    ----------
    mass, stiffness : numpy.ndarray
        A constant M and K per case, shape (case, n, n) (kg, N/m in the DOFs' units).
    h : numpy.ndarray
        Step per case, s, shape (case,).
    scheme : NewmarkFamily

    Returns
    -------
    numpy.ndarray
        T = I − Σ_k (1 − √m′_k) φ_k φ_kᵀ M over the resolved modes (module docstring), shape
        (case, n, n), invertible; the identity for a case whose M is not positive definite.
        Modes with ω² ≤ 0 are left alone.
    """
    mass = 0.5 * (mass + np.swapaxes(mass, -1, -2))
    stiffness = 0.5 * (stiffness + np.swapaxes(stiffness, -1, -2))
    ncase, n = mass.shape[0], mass.shape[-1]
    out = np.broadcast_to(np.eye(n), (ncase, n, n)).copy()
    definite = np.ones(ncase, bool)
    try:
        L = np.linalg.cholesky(mass)
    except np.linalg.LinAlgError:  # some case's M is not definite: those are left alone
        definite = np.array([_definite(m) for m in mass], bool)
        if not definite.any():
            return out
        L = np.linalg.cholesky(mass[definite])
    Linv = np.linalg.inv(L)
    w2, V = np.linalg.eigh(Linv @ stiffness[definite] @ np.swapaxes(Linv, -1, -2))
    omega_h = np.sqrt(np.clip(w2, 0.0, None)) * np.asarray(h, float)[definite, None]
    modified = modified_omega_h(scheme, omega_h)
    with np.errstate(invalid="ignore"):
        shrink = np.where(np.isfinite(modified), 1.0 - omega_h / modified, 0.0)
    # φ_k = L⁻ᵀ v_k (M-normalized) and φ_kᵀ M = v_kᵀ Lᵀ: T = I − L⁻ᵀ V diag(1 − √m′) Vᵀ Lᵀ.
    Phi = np.swapaxes(Linv, -1, -2) @ V
    out[definite] -= (Phi * shrink[:, None, :]) @ np.swapaxes(L @ V, -1, -2)
    return out


def _definite(matrix: np.ndarray) -> bool:
    try:
        np.linalg.cholesky(matrix)
    except np.linalg.LinAlgError:
        return False
    return True


def matched_terms(terms: PeriodTerms, h: np.ndarray, scheme: NewmarkFamily) -> PeriodTerms:
    """``terms`` with the dispersion-matched mass T(t)ᵀ M(t) T(t) at every step (module
    docstring).

    Parameters
    ----------
    terms : PeriodTerms
        The period's terms (with a mass).
    h : numpy.ndarray
        Step per case, s, shape (case,).
    scheme : NewmarkFamily

    Returns
    -------
    PeriodTerms
        The same terms with ``mass`` replaced, every matrix dense (Tᵀ M T is full).
    """
    M = terms.dense("mass")
    K = terms.dense("stiffness")
    ncase, period, n = M.shape[:3]
    h = np.asarray(h, float)
    matched = np.empty_like(M)
    block = max(1, period // _BLOCKS)
    for first in range(0, period, block):  # T is held for a block of steps only
        steps = slice(first, min(first + block, period))
        m, k = M[:, steps].reshape(-1, n, n), K[:, steps].reshape(-1, n, n)
        count = m.shape[0] // ncase
        T = mass_transform(m, k, np.repeat(h, count), scheme)  # rows: case-major
        transformed = np.swapaxes(T, -1, -2) @ m @ T
        matched[:, steps] = (0.5 * (transformed + np.swapaxes(transformed, -1, -2))).reshape(
            ncase, count, n, n)  # symmetric to the last bit
    # Tᵀ M T is full: the step matrices are marched dense (a full pattern has no sparse order).
    return dataclasses.replace(
        terms, mass=matched, damping=terms.dense("damping"), stiffness=K,
        pattern=np.ones((terms.n, terms.n), bool), order=None)
