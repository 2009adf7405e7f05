"""The periodic steady state of a batch by shooting, its Floquet multipliers and resonance.

The discretized system is linear and time-periodic, so one period of the marching loop maps
the discrete state linearly: s_N = Φ s_0 + p, Φ the monodromy matrix. The periodic state
solves (I − Φ) s_0 = p; the eigenvalues of Φ are the Floquet multipliers, which reveal
parametric instability (|μ| > 1) and resonance (a multiplier near 1). For the Newmark family
one period leaves the acceleration a function of (q, v) to round-off, so Φ has rank 2n and its
multipliers are found on its range, an eigenproblem of order 2n (:func:`range_reduction`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.linalg.lapack

from .integrators import Integrator, NewmarkFamily, from_independent, independent
from .marching import Marcher

__all__ = ["Monodromy", "monodromy", "periodic_state", "floquet", "shoot", "resonant",
           "RangeReduction", "range_reduction", "RESONANCE_GAP", "RESONANCE_SHARE",
           "INSTABILITY_MARGIN", "COND_LIMIT", "RANGE_TOLERANCE"]

#: A Floquet multiplier μ with |1 − μ| below this is near resonance: a crank harmonic k within
#: about 1 % of a natural frequency (|1 − μ| ≈ 2πk |ω/kΩ − 1|) ... (per input turn: for a
#: period of several turns the gap grows with them, :func:`floquet`'s ``turns``, so that it
#: stands for the same band of frequency, |1 − μ| ≈ |ωT − 2πk| growing with the period T) ...
RESONANCE_GAP = 0.05
#: ... and the case is flagged resonant when such near-resonant modes carry more than this
#: share of the periodic displacement (a barely excited high mode near a harmonic is not).
RESONANCE_SHARE = 0.5
#: max |μ| above which the periodic system is parametrically unstable.
INSTABILITY_MARGIN = 1e-6


class Monodromy(NamedTuple):
    """One period of the discrete system in the scaled independent state: s_N = Φ s_0 + p.

    ``p`` (case, 3n) the forced part, ``Phi`` (case, 3n, 3n) Φ, ``scale`` (case, 3n) the
    state's scale ((q, h v, h² a) for the Newmark family; see :func:`monodromy`),
    ``spanning`` the number of leading columns of Φ expected to span its range to round-off
    (2n for the Newmark family, whose acceleration one period determines from (q, v);
    0: none, the whole eigenproblem is solved; :func:`floquet`)."""

    p: np.ndarray
    Phi: np.ndarray
    scale: np.ndarray
    spanning: int = 0


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
    # The Newmark family's (algorithmic) acceleration after a period follows from (q, v) but
    # for the part its spurious root carries, decayed over the period's steps: Φ has rank 2n
    # to round-off (on the Watt II of benchmarks/six_bar_cost.py σ_2n+1 ≈ 1e-18 σ_1), spanned
    # by its (q, h v) columns; floquet() checks it case by case.
    spanning = 2 * ny if isinstance(scheme, NewmarkFamily) else 0
    return Monodromy(final[..., 0], final[..., 1:], scale, spanning)


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
    p, Phi, scale = period.p, period.Phi, period.scale
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
        if _regular(scaled):
            s0[c] = columns * np.linalg.solve(scaled, rows * p[c])
        else:  # exact resonance: the minimum-norm periodic state keeps results finite
            s0[c] = np.linalg.lstsq(A[c], p[c], rcond=1e-13)[0]
    s0 = s0 / scale
    return tuple(s0[:, i * ny : (i + 1) * ny, None] for i in range(3))


#: I − Φ (equilibrated) is solved directly below this 2-norm condition number, by least
#: squares above it.
COND_LIMIT = 1e13
#: LAPACK's 1-norm estimate can fall short of the 2-norm condition number (by at most n for the
#: norms, by a factor rarely above 3 for the estimate; measured on 2,092 monodromies of the
#: default study: 0.53–48× it), so it decides alone only this far below the limit.
_ESTIMATE_GUARD = 30.0


def _regular(A: np.ndarray) -> bool:
    """cond₂(A) < :data:`COND_LIMIT`, decided from LAPACK's condition estimate of an LU
    (0.04 ms at order 60) where that is far enough below the limit, else by the singular values
    (0.14 ms): the same decision as ``np.linalg.cond(A) < COND_LIMIT`` but for an estimate
    30 n times or more off."""
    lu, _, info = scipy.linalg.lapack.dgetrf(A)
    if info == 0 and np.all(np.isfinite(lu)):
        rcond, info = scipy.linalg.lapack.dgecon(lu, np.abs(A).sum(axis=0).max())
        if info == 0 and rcond * COND_LIMIT > _ESTIMATE_GUARD * len(A):
            return True
    return bool(np.linalg.cond(A) < COND_LIMIT)


def floquet(period: Monodromy, ny: int, turns: int = 1):
    """Floquet multipliers and the resonance flag.

    Only the eigenvalues are computed (LAPACK's problem costs half without the vectors: 0.27
    against 0.53 s per 500 monodromies of order 60); where a multiplier is near 1,
    :func:`resonant` finds the vectors of those few by inverse iteration. Where Φ's first
    ``period.spanning`` columns span its range to round-off (:func:`range_reduction`: the
    (q, h v) columns of the Newmark family, Φ of rank 2n), both are solved on the reduced
    Φ_r = QᵀΦQ of order 2n instead of Φ (its other n multipliers are 0 to round-off): the
    same nonzero multipliers to round-off at half the cost (order 72 against 108, 47 against
    98 ms per batch of ``benchmarks/six_bar_cost.py``, QR and products included).

    Parameters
    ----------
    period, ny
        As for :func:`periodic_state`.
    turns : int, optional
        Input turns of the period (two for a motion that passes a change point once a turn):
        the resonance gap is :data:`RESONANCE_GAP` per turn.

    Returns
    -------
    multipliers : (case, 3 ny) complex
        The eigenvalues of Φ (those of Φ_r, then zeros, for a reduced case).
    resonant : (case,) bool
        :func:`resonant`.
    """
    Phi = period.Phi
    reduction = range_reduction(Phi, period.spanning) if period.spanning else None
    multipliers = np.zeros(Phi.shape[:-1], complex)
    full = np.ones(len(Phi), bool) if reduction is None else ~reduction.ok
    if full.any():
        multipliers[full] = np.linalg.eigvals(Phi[full])
    if not full.all():
        multipliers[~full, :period.spanning] = np.linalg.eigvals(reduction.reduced[~full])
    return multipliers, resonant(multipliers, Phi, period.p, ny, RESONANCE_GAP * turns,
                                 reduction)


class RangeReduction(NamedTuple):
    """Φ on its range (:func:`range_reduction`): Φ = Q C to round-off where ``ok``.

    ``ok`` (case,) bool, ``basis`` Q (case, 3n, k) orthonormal, ``image`` C = QᵀΦ
    (case, k, 3n), ``reduced`` Φ_r = C Q (case, k, k)."""

    ok: np.ndarray
    basis: np.ndarray
    image: np.ndarray
    reduced: np.ndarray


#: Largest ‖Φ − QQᵀΦ‖_F / ‖Φ‖_F for which Φ is taken on the range of its first columns: a few
#: dozen round-offs (4–8e-16 measured on the monodromies of benchmarks/six_bar_cost.py), of
#: the order of the eigensolver's own backward error and far below any difference the flags
#: read.
RANGE_TOLERANCE = 1e-14


def range_reduction(Phi: np.ndarray, k: int) -> RangeReduction:
    """Φ on the range of its first ``k`` columns: Q from their QR, C = QᵀΦ, Φ_r = C Q.

    Where Φ = Q C to round-off (:data:`RANGE_TOLERANCE`) — its other columns lie in that
    range, as the acceleration columns of the Newmark family's monodromy do — the nonzero
    eigenvalues of Φ are those of Φ_r (Φ = QC and CQ share them), and with z an eigenvector of
    Φ_r for μ ≠ 0 and w its left one, Q z is Φ's right eigenvector and Cᵀw/μ̄ its left one.

    Parameters
    ----------
    Phi : numpy.ndarray
        Monodromy matrices, shape (case, m, m).
    k : int
        Leading columns taken for the range (k < m).

    Returns
    -------
    RangeReduction
    """
    # A case that is not finite (a diverged march) fails the check quietly: the full
    # eigenproblem then says so as before.
    with np.errstate(invalid="ignore", over="ignore"):
        Q = np.linalg.qr(Phi[..., :k])[0]
        C = np.swapaxes(Q, -1, -2) @ Phi
        # The first k columns are Q C's to the QR's round-off: only the others are checked (a
        # third of the product).
        residual = np.linalg.norm(Phi[..., k:] - Q @ C[..., k:], axis=(-2, -1))
        ok = residual <= RANGE_TOLERANCE * np.linalg.norm(Phi, axis=(-2, -1))
        return RangeReduction(ok, Q, C, C @ Q)


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


def resonant(mu: np.ndarray, Phi: np.ndarray, p: np.ndarray, ny: int,
             gap: float = RESONANCE_GAP, reduction: RangeReduction | None = None) -> np.ndarray:
    """(case,) bool: near-resonant Floquet modes dominate the periodic displacement.

    With Φ = V diag(μ) V⁻¹ the periodic state is Σ_i V_i c_i/(1 − μ_i), c = V⁻¹p; the share of
    the modes with |1 − μ_i| < ``gap`` in its displacement part is compared with
    RESONANCE_SHARE. Only the near modes' terms are needed: each is v_i (w_iᴴp)/(w_iᴴv_i)
    /(1 − μ_i) with v_i, w_i its right and left eigenvectors, found by inverse iteration at the
    known μ_i (one complex LU per conjugate pair: 0.65 against 2.6 ms per case for all the
    eigenvectors, monodromies of order 108 of ``benchmarks/six_bar_cost.py``), and the whole
    state is (I − Φ)⁻¹p. Where that is unreliable (another multiplier within
    :data:`_CLUSTER` of a near one, an eigenvalue too ill-conditioned, the iteration not
    settling) the case falls back to the eigenvectors of Φ, as do exact resonances. A case
    of ``reduction`` (:func:`range_reduction`, ``ok``) is solved on Φ_r instead, the same
    terms to round-off (:func:`_near_share`).

    Parameters
    ----------
    mu : numpy.ndarray
        Floquet multipliers, shape (case, 3 ny), complex: the cases with none near 1 are not
        resonant, and only the others are examined.
    Phi : numpy.ndarray
        The monodromy matrix Φ, shape (case, 3 ny, 3 ny).
    p : numpy.ndarray
        Forced part of the state after one period, shape (case, 3 ny).
    ny : int
        Number of elastic DOFs (the displacement part is the first ny rows).
    gap : float, optional
        |1 − μ| below which a multiplier is near resonance (:data:`RESONANCE_GAP` per input
        turn of the period).
    reduction : RangeReduction, optional
        Φ on its range (its multipliers the first k of ``mu``).

    Returns
    -------
    numpy.ndarray
        Shape (case,), bool.
    """
    flagged = np.zeros(mu.shape[0], bool)
    for c in np.flatnonzero((np.abs(1.0 - mu) < gap).any(axis=-1)):
        if reduction is not None and reduction.ok[c]:
            k = reduction.reduced.shape[-1]
            share = _near_share(mu[c, :k], reduction.reduced[c], reduction.image[c] @ p[c],
                                ny, gap, reduction.basis[c], p[c])
        else:
            share = _near_share(mu[c], Phi[c], p[c], ny, gap)
        if share is None:
            share = _near_share_by_eig(Phi[c], p[c], ny, gap)
        flagged[c] = share > RESONANCE_SHARE
    return flagged


#: A near multiplier closer than this to another one is left to the full eigenproblem: inverse
#: iteration would mix their vectors.
_CLUSTER = 1e-6
#: Relative change of the iterated vector at which inverse iteration has settled.
_SETTLED = 1e-11
#: The start vector of inverse iteration per order (fixed, so that results are reproducible).
_START: dict[int, np.ndarray] = {}


def _near_share(mu: np.ndarray, Phi: np.ndarray, p: np.ndarray, ny: int,
                gap: float, basis: np.ndarray | None = None,
                forced: np.ndarray | None = None) -> float | None:
    """The near-1 modes' share (within ``gap``) of the periodic displacement of one case by
    inverse iteration (:func:`resonant`), or None where it cannot be trusted.

    With ``basis`` Q (3n, k) the problem is Φ = QC on its range (:func:`range_reduction`):
    ``Phi`` is Φ_r = CQ, ``p`` is C p₀ and ``forced`` p₀ the forced part. Φ's eigenvectors are
    then Q z and Cᵀw/μ̄ (z, w Φ_r's), so that a near mode's term is Qz (wᴴCp₀)/μ/(wᴴz)/(1 − μ),
    and the periodic state (I − QC)⁻¹p₀ = p₀ + Q (I − Φ_r)⁻¹ C p₀."""
    near = np.flatnonzero(np.abs(1.0 - mu) < gap)
    if np.any(mu[near] == 1.0):
        return None  # exact resonance
    spacing = np.abs(mu[near, None] - mu[None, :])
    spacing[np.arange(len(near)), near] = np.inf
    if spacing.min() < _CLUSTER:
        return None
    r = Phi.shape[0]
    try:
        periodic = np.linalg.solve(np.eye(r) - Phi, p)
    except np.linalg.LinAlgError:
        return None
    if basis is not None:
        periodic = forced + basis @ periodic
    total = np.linalg.norm(periodic[:ny])
    start = _START[r] if r in _START else _START.setdefault(
        r, np.random.default_rng(0).standard_normal(r) + 0.0j)  # fixed: deterministic
    part = np.zeros(ny, complex)
    for i in near:
        # Φ is real, so μ̄ (also near) adds the conjugate of μ's term: one of each pair.
        weight = 1.0 if mu[i].imag == 0.0 else 2.0 if mu[i].imag > 0.0 else 0.0
        if weight == 2.0 and not np.any(mu[near] == mu[i].conjugate()):
            return None
        if weight == 0.0:
            continue
        lu = _shifted_lu(Phi, mu[i])
        if lu is None:
            return None
        v, w = _inverse_iteration(lu, start, 0), _inverse_iteration(lu, start, 2)
        if v is None or w is None:
            return None
        overlap = np.vdot(w, v)  # w unit, v unit: 1/|overlap| is μ_i's condition number
        if abs(overlap) < 1e-10:
            return None
        if basis is None:
            term = v[:ny] * (np.vdot(w, p) / overlap / (1.0 - mu[i]))
        else:
            term = (basis[:ny] @ v) * (np.vdot(w, p) / mu[i] / overlap / (1.0 - mu[i]))
        part += term if weight == 1.0 else 2.0 * term.real
    return float(np.linalg.norm(part) / max(total, 1e-300))


def _shifted_lu(Phi: np.ndarray, mu: complex):
    """LAPACK's LU (lu, piv) of Φ − σI, σ the multiplier μ or, where that is exactly singular
    in floating point (a pivot exactly 0), μ moved by 1e-13 of its size: inverse iteration
    still converges at once (the next multiplier is at least :data:`_CLUSTER` away). None if
    the matrix is not finite."""
    for shift in (mu, mu * (1.0 + 1e-13) + 1e-13):
        shifted = Phi.astype(complex)  # Φ − σI: the diagonal only (no σ·I of order 3n)
        shifted.flat[::len(Phi) + 1] -= shift
        lu, piv, info = scipy.linalg.lapack.zgetrf(shifted, overwrite_a=True)
        if info < 0 or not np.all(np.isfinite(lu)):
            return None
        if info == 0:
            return lu, piv
    return None


def _inverse_iteration(lu, start: np.ndarray, trans: int) -> np.ndarray | None:
    """Unit eigenvector of the nearly singular Φ − μI factored in ``lu`` (:func:`_shifted_lu`):
    right (``trans`` 0) or left (2, of its conjugate transpose); None if it does not settle in
    a few solves."""
    x = start / np.linalg.norm(start)
    for _ in range(6):
        y, info = scipy.linalg.lapack.zgetrs(*lu, x, trans=trans)
        if info != 0:
            return None
        size = np.linalg.norm(y)
        if not np.isfinite(size) or size == 0.0:
            return None
        y /= size
        y *= np.exp(-1j * np.angle(np.vdot(x, y)))  # the phase of the previous iterate
        if np.linalg.norm(y - x) < _SETTLED:
            return y
        x = y
    return None


def _near_share_by_eig(Phi: np.ndarray, p: np.ndarray, ny: int, gap: float) -> float:
    """The near-1 modes' share (within ``gap``) of the periodic displacement of one case from
    all the eigenvectors of Φ (:func:`resonant`); a defective Φ near 1 counts as resonant
    (inf)."""
    mu, V = np.linalg.eig(Phi)
    near = np.abs(1.0 - mu) < gap
    try:
        coeff = np.linalg.solve(V, p.astype(complex))
    except np.linalg.LinAlgError:
        return np.inf  # defective monodromy at a multiplier near 1: resonance
    with np.errstate(divide="ignore", invalid="ignore"):
        x = coeff / (1.0 - mu)
    x = np.where(np.isfinite(x), x, 1e300)
    total = np.linalg.norm(V[:ny] @ x)
    part = np.linalg.norm(V[:ny][:, near] @ x[near])
    return float(part / max(total, 1e-300))
