"""The periodic steady state of a batch by shooting, its Floquet multipliers and resonance.

The discretized system is linear and time-periodic, so one period of the marching loop maps
the discrete state linearly: s_N = Φ s_0 + p, Φ the monodromy matrix. The periodic state
solves (I − Φ) s_0 = p; the eigenvalues of Φ are the Floquet multipliers, which reveal
parametric instability (|μ| > 1) and resonance (a multiplier near 1).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .integrators import Integrator, NewmarkFamily, from_independent, independent
from .marching import Marcher

__all__ = ["Monodromy", "monodromy", "periodic_state", "floquet", "shoot", "resonant",
           "RESONANCE_GAP", "RESONANCE_SHARE", "INSTABILITY_MARGIN"]

#: A Floquet multiplier μ with |1 − μ| below this is near resonance: a crank harmonic k within
#: about 1 % of a natural frequency (|1 − μ| ≈ 2πk |ω/kΩ − 1|) ...
RESONANCE_GAP = 0.05
#: ... and the case is flagged resonant when such near-resonant modes carry more than this
#: share of the periodic displacement (a barely excited high mode near a harmonic is not).
RESONANCE_SHARE = 0.5
#: max |μ| above which the periodic system is parametrically unstable.
INSTABILITY_MARGIN = 1e-6


class Monodromy(NamedTuple):
    """One period of the discrete system in the scaled independent state: s_N = Φ s_0 + p.

    ``p`` (case, 3n) the forced part, ``Phi`` (case, 3n, 3n) Φ, ``scale`` (case, 3n) the
    state's scale ((q, h v, h² a) for the Newmark family; see :func:`monodromy`)."""

    p: np.ndarray
    Phi: np.ndarray
    scale: np.ndarray


def monodromy(scheme: Integrator, marcher: Marcher, h: np.ndarray, steps_per_period: int,
              ny: int, ncase: int) -> Monodromy:
    """Propagate the 3n unit states (homogeneous) and the zero state under the forcing
    (column 0) over one period with shared factorizations: s_N = Φ s_0 + p, s the independent
    state ((q, v, a) of the Newmark family, the history of Houbolt).

    Parameters
    ----------
    scheme : Integrator
        The time-integration scheme.
    marcher : Marcher
        Marches the period's terms with step ``h``.
    h : numpy.ndarray
        Step size per case, s, shape (case,).
    steps_per_period : int
        Steps in one input period.
    ny : int
        Number of elastic DOFs n.
    ncase : int
        Number of cases.

    Returns
    -------
    Monodromy
    """
    r = 3 * ny
    # Shoot in the scaled state (q, h v, h² a) (Houbolt: its history, all in m) so that the
    # columns of Φ are commensurate; unscaled, ω h ≫ 1 axial modes make I − Φ look singular.
    hh = np.asarray(h, float)[:, None]
    if isinstance(scheme, NewmarkFamily):
        scale = np.concatenate([np.ones((ncase, ny)), np.repeat(hh, ny, 1),
                                np.repeat(hh**2, ny, 1)], axis=1)  # (case, 3n)
    else:
        scale = np.ones((ncase, r))
    cols = np.concatenate([np.zeros((ncase, r, 1)),
                           np.broadcast_to(np.eye(r), (ncase, r, r)) / scale[:, :, None]], axis=2)
    parts = [cols[:, i * ny : (i + 1) * ny].copy() for i in range(3)]
    terms = marcher.columns(r + 1)
    end, _ = marcher.march(from_independent(terms, scheme, *parts), steps_per_period)
    final = independent(scheme, end) * scale[:, :, None]  # (case, 3n, r + 1), scaled
    return Monodromy(final[..., 0], final[..., 1:], scale)


def periodic_state(period: Monodromy, ny: int, cases: np.ndarray | None = None):
    """The periodic state, (I − Φ) s_0 = p — by least squares where I − Φ is singular, so
    exact resonance stays finite.

    Parameters
    ----------
    period : Monodromy
        The batch's monodromy.
    ny : int
        Number of elastic DOFs n.
    cases : numpy.ndarray, optional
        The cases whose state is wanted, shape (case,), bool (default: all); the others get
        zeros.

    Returns
    -------
    state : (q0, v0, a0)
        The periodic state's independent part, each (case, ny, 1)
        (:func:`ced.response.integrators.from_independent` makes the state to march from).
    """
    p, Phi, scale = period
    A = np.eye(Phi.shape[-1]) - Phi
    s0 = np.zeros_like(p)
    for c in np.flatnonzero(np.ones(len(p), bool) if cases is None else cases):
        # Equilibrate rows and columns first: for generalized-α the stiff modes' algorithmic
        # accelerations make Φ strongly non-normal (entries ~ (ωh)², e.g. 1e9 for the static
        # load vectors of a finely meshed reduced link) while I − Φ itself is harmless; only
        # a true resonance (a multiplier at 1) should reach the least-squares branch. Without
        # this, cond(I − Φ) crossed 1e13 on the double-rocker reference at 40 elements and the
        # least-squares state was wrong by 80 %.
        rows = 1.0 / np.maximum(np.abs(A[c]).max(axis=1), 1e-300)
        scaled = rows[:, None] * A[c]
        columns = 1.0 / np.maximum(np.abs(scaled).max(axis=0), 1e-300)
        scaled = scaled * columns[None, :]
        if np.linalg.cond(scaled) < 1e13:
            s0[c] = columns * np.linalg.solve(scaled, rows * p[c])
        else:  # exact resonance: the minimum-norm periodic state keeps results finite
            s0[c] = np.linalg.lstsq(A[c], p[c], rcond=1e-13)[0]
    s0 = s0 / scale
    return tuple(s0[:, i * ny : (i + 1) * ny, None] for i in range(3))


def floquet(period: Monodromy, ny: int):
    """Floquet multipliers and the resonance flag.

    The eigenvectors are computed only where a multiplier is near 1 (:func:`resonant`):
    without them LAPACK's eigenvalue problem costs half (0.27 against 0.53 s per 500
    monodromies of order 60).

    Parameters
    ----------
    period, ny
        As for :func:`periodic_state`.

    Returns
    -------
    multipliers : (case, 3 ny) complex
        The eigenvalues of Φ.
    resonant : (case,) bool
        :func:`resonant`.
    """
    multipliers = np.linalg.eigvals(period.Phi)
    return multipliers, resonant(multipliers, period.Phi, period.p, ny)


def shoot(scheme: Integrator, marcher: Marcher, h: np.ndarray, steps_per_period: int, ny: int,
          ncase: int, floquet_analysis: bool = True):
    """Exact periodic state of the discretized system and its Floquet multipliers:
    :func:`monodromy`, :func:`periodic_state` of every case and :func:`floquet`.

    Parameters
    ----------
    scheme, marcher, h, steps_per_period, ny, ncase
        As for :func:`monodromy`.
    floquet_analysis : bool, optional
        Also compute the Floquet multipliers and the resonance flag.

    Returns
    -------
    state : (q0, v0, a0)
        Each (case, ny, 1).
    multipliers : (case, 3 ny) complex
        Floquet multipliers, the eigenvalues of Φ (None unless ``floquet_analysis``: the
        eigenvalue problem costs more than the periodic state).
    resonant : (case,) bool
        :func:`resonant` (None unless ``floquet_analysis``).
    """
    period = monodromy(scheme, marcher, h, steps_per_period, ny, ncase)
    state = periodic_state(period, ny)
    if not floquet_analysis:
        return state, None, None
    return (state, *floquet(period, ny))


def resonant(mu: np.ndarray, Phi: np.ndarray, p: np.ndarray, ny: int) -> np.ndarray:
    """(case,) bool: near-resonant Floquet modes dominate the periodic displacement.

    With Φ = V diag(μ) V⁻¹ the periodic state is Σ_i V_i c_i/(1 − μ_i), c = V⁻¹p; the share of
    the modes with |1 − μ_i| < RESONANCE_GAP in its displacement part is compared with
    RESONANCE_SHARE.

    Parameters
    ----------
    mu : numpy.ndarray
        Floquet multipliers, shape (case, 3 ny), complex: the cases with none near 1 are not
        resonant, and only the others' eigenvectors are computed.
    Phi : numpy.ndarray
        The monodromy matrix Φ, shape (case, 3 ny, 3 ny).
    p : numpy.ndarray
        Forced part of the state after one period, shape (case, 3 ny).
    ny : int
        Number of elastic DOFs (the displacement part is the first ny rows).

    Returns
    -------
    numpy.ndarray
        Shape (case,), bool.
    """
    flagged = np.zeros(mu.shape[0], bool)
    for c in np.flatnonzero((np.abs(1.0 - mu) < RESONANCE_GAP).any(axis=-1)):
        mu_c, V_c = np.linalg.eig(Phi[c])  # the same multipliers, with their vectors
        near = np.abs(1.0 - mu_c) < RESONANCE_GAP
        try:
            coeff = np.linalg.solve(V_c, p[c].astype(complex))
        except np.linalg.LinAlgError:
            flagged[c] = True  # defective monodromy at a multiplier near 1: resonance
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            x = coeff / (1.0 - mu_c)
        x = np.where(np.isfinite(x), x, 1e300)
        total = np.linalg.norm(V_c[:ny] @ x)
        part = np.linalg.norm(V_c[:ny][:, near] @ x[near])
        flagged[c] = part > RESONANCE_SHARE * max(total, 1e-300)
    return flagged
