"""The KED system over one period of the step grid, from a few samples of it.

The system M, C, K, F (and the projection P that maps it back to the links) depends on time
only through the rigid motion, which repeats every input period T: the terms of step k are
those of step k mod P, P the steps per period. Evaluating them
(:func:`ced.response.model.terms_at`: rigid motion, inverse dynamics, projection and the
effects' sandwich products) costs ~25 µs per step and case in numpy, more than the step's
solve; but they vary with the mechanism's motion, smoothly and slowly against the step
(the step resolves the links' vibration, the terms change on the scale of the crank
harmonics). So they are evaluated at ``samples`` equally spaced phases of the period and
interpolated to every step by a :data:`STENCIL`-point periodic Lagrange stencil (10 points:
degree 9, error O((2πk/samples)¹⁰) on the k-th crank harmonic).

The interpolation error is checked, not assumed. The samples' even half interpolates the odd
half; that error, divided by 2¹⁰ / 4 = 256 (the stencil's order, with a safety factor 4), is
the estimated error of the full set, relative to each term's largest entry in the case. The
samples double until it is below :data:`TOLERANCE` for every case, and the terms are evaluated
at every step (exact) once the samples would reach a quarter of the steps per period. The check only sees the
samples, so motions with features narrower than their spacing — near a toggle or a change
point, flagged ``near_singular`` — are evaluated exactly at every step (the caller says so).
"""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numba as nb
import numpy as np

from .model import Model, terms_at
from .model_cache import kept_terms
from .step_pattern import StepOrder, nonzero_pattern, pack, step_order, unpack

__all__ = ["PeriodTerms", "period_terms", "with_sparsity", "with_modal_damping",
           "evaluate_terms", "interpolate_periodic", "interpolation_weights", "SAMPLES",
           "TOLERANCE", "STENCIL"]

#: Samples per period to start from (doubled until the interpolation error is small enough).
SAMPLES = 64
#: Estimated interpolation error allowed, relative to each term's largest entry: far below any
#: discretization error ced reports, so that sampling never shows in a result (measured on the
#: reference four-bar: true error 4.5e-9 at 64 samples, estimate 1.1e-8).
TOLERANCE = 1e-7
#: Points of the Lagrange stencil (nodes −4 … 5 around the interval holding the step): more
#: points cost interpolation flops, fewer need more samples (6 points needed 256 samples).
STENCIL = 10
_NODES = np.arange(STENCIL) - (STENCIL // 2 - 1)
#: Estimated full-set error = half-set error / this: the stencil's 2⁶ with a safety factor 4.
_HALVING_GAIN = 2.0 ** STENCIL / 4.0


@dataclass
class PeriodTerms:
    """M, C, K, F and the projection at every step of one period (case, P, …).

    ``mass`` or ``damping`` is None where the effects do not form it. Step k uses index
    k mod P. ``samples`` is the number of terms evaluations per period (P when exact) and
    ``interpolation_error`` the estimate per case (0 when exact). ``sampled`` holds the
    terms at the samples (case, samples, …) when they were interpolated (None when exact):
    other periodic quantities derived from the terms are interpolated from them
    (:func:`interpolate_periodic`). ``pattern`` (n, n) bool covers every nonzero of M, C and K
    at every step (:func:`ced.response.step_pattern.nonzero_pattern` of what was evaluated;
    None: not known). Where the step matrices are sparse, ``order`` is their
    :class:`ced.response.step_pattern.StepOrder` and ``mass``, ``damping``, ``stiffness`` are
    held **packed**, (case, P, nnz) (:func:`ced.response.step_pattern.pack`); :meth:`dense`
    gives them as matrices either way. ``projection`` (case, P, row, nfree) holds the rows
    ``layout.projection_rows`` of P's joint-coordinate columns, the others being zero
    (:attr:`ced.fem.coupling.Layout.projection_rows`; :func:`ced.response.kernels.expand`).
    """

    mass: np.ndarray | None
    damping: np.ndarray | None
    stiffness: np.ndarray
    force: np.ndarray
    projection: np.ndarray
    samples: int
    interpolation_error: np.ndarray
    sampled: dict | None = None
    pattern: np.ndarray | None = None
    order: StepOrder | None = None

    @property
    def period(self) -> int:
        return self.stiffness.shape[1]

    @property
    def n(self) -> int:
        """Order of the step matrices (elastic DOFs)."""
        return self.force.shape[-1]

    def dense(self, name: str, steps=slice(None), cases=slice(None)) -> np.ndarray | None:
        """Term ``name`` of ``cases`` at ``steps`` (indices or slices), matrices as
        (case, step, n, n) whether held packed or not; None where absent.

        Parameters
        ----------
        name : str
            ``mass``, ``damping``, ``stiffness``, ``force`` or ``projection``.
        steps : slice or numpy.ndarray, optional
            Steps of the period (default: all).
        cases : slice or numpy.ndarray, optional
            Cases (default: all).
        """
        x = getattr(self, name)
        if x is None:
            return None
        x = x[cases][:, steps]
        if self.order is None or name not in _MATRICES:
            return x
        return unpack(x, self.order, self.n)

    def __call__(self, k: int):
        """(M, C, K, F) at step k (F (case, n)), the ``terms`` of
        :func:`ced.response.integrators.march` through
        :func:`ced.response.integrators.forced_columns`."""
        j = k % self.period
        M, C, K = (self.dense(name, j) for name in _MATRICES)
        return M, C, K, self.force[:, j]


def interpolation_weights(points: np.ndarray, samples: int):
    """Periodic :data:`STENCIL`-point Lagrange stencil at ``points`` in sample units
    (phase × samples / 2π).

    Returns (index (m, STENCIL) int, weight (m, STENCIL)): the value at a point is
    Σ_j weight[:, j] × value[index[:, j]].

    Parameters
    ----------
    points : numpy.ndarray
        Points in sample units, shape (m,).
    samples : int
        Number of samples per period (the index wraps modulo it).
    """
    points = np.ascontiguousarray(points, dtype=float)
    return _kept_weights(points.tobytes(), int(samples))


@functools.lru_cache(maxsize=32)
def _kept_weights(points: bytes, samples: int):
    """:func:`interpolation_weights` at the points given as float64 bytes, read-only: a
    batch's step grids recur (every part of a batch, every rung of a pilot ladder at the same
    steps), and the stencil costs a quarter of a millisecond at a thousand points."""
    index, weight = _weights(np.frombuffer(points, dtype=float), samples)
    index.flags.writeable = weight.flags.writeable = False
    return index, weight


def _weights(points: np.ndarray, samples: int):
    """:func:`interpolation_weights`, computed afresh."""
    base = np.floor(points)
    f = points - base
    index = (base.astype(np.int64)[:, None] + _NODES[None, :]) % samples
    weight = np.ones((len(points), STENCIL))
    for i, xi in enumerate(_NODES):
        for xj in _NODES:
            if xj != xi:
                weight[:, i] *= (f - xj) / (xi - xj)
    return index, weight


@nb.njit(cache=True, nogil=True)
def _interpolate(values, index, weight, out):
    """out[c, m] = Σ_j weight[m, j] values[c, index[m, j]]; values (case, samples, D).

    The sum runs over j in order from 0.0 either way. For the 10-point :data:`STENCIL` it is
    written out over the ten source rows, the loop along D inside: one store per entry
    instead of ten read-modify-writes of ``out`` (1.7× faster on the reference four-bar's
    196-entry matrices, the same bits).

    Parameters
    ----------
    values : numpy.ndarray
        The terms at the samples, shape (case, samples, D), C-contiguous.
    index, weight : numpy.ndarray
        The stencil (:func:`interpolation_weights`), shape (m, STENCIL): int and 1.
    out : numpy.ndarray
        The terms at the m points, shape (case, m, D), overwritten.
    """
    ncase, D = values.shape[0], values.shape[2]
    if index.shape[1] == 10:
        for c in range(ncase):
            v = values[c]
            for m in range(index.shape[0]):
                i, w, o = index[m], weight[m], out[c, m]
                a0, a1, a2, a3, a4 = v[i[0]], v[i[1]], v[i[2]], v[i[3]], v[i[4]]
                a5, a6, a7, a8, a9 = v[i[5]], v[i[6]], v[i[7]], v[i[8]], v[i[9]]
                w0, w1, w2, w3, w4 = w[0], w[1], w[2], w[3], w[4]
                w5, w6, w7, w8, w9 = w[5], w[6], w[7], w[8], w[9]
                for d in range(D):
                    x = 0.0 + w0 * a0[d]
                    x += w1 * a1[d]
                    x += w2 * a2[d]
                    x += w3 * a3[d]
                    x += w4 * a4[d]
                    x += w5 * a5[d]
                    x += w6 * a6[d]
                    x += w7 * a7[d]
                    x += w8 * a8[d]
                    x += w9 * a9[d]
                    o[d] = x
        return
    for c in range(ncase):
        for m in range(index.shape[0]):
            for d in range(D):
                out[c, m, d] = 0.0
            for j in range(index.shape[1]):
                wj = weight[m, j]
                src = index[m, j]
                for d in range(D):
                    out[c, m, d] += wj * values[c, src, d]


_NAMES = ("mass", "damping", "stiffness", "force", "projection")
_MATRICES = ("mass", "damping", "stiffness")


def _interpolate_terms(values: dict, points: np.ndarray, samples: int) -> dict:
    """Each term at ``points`` (in sample units) from its values at the samples
    (case, samples, …), into its own C-contiguous array."""
    index, weight = interpolation_weights(points, samples)
    out = {}
    for name, x in values.items():
        flat = np.empty((x.shape[0], len(points), int(np.prod(x.shape[2:]))))
        _interpolate(np.ascontiguousarray(x).reshape(x.shape[:2] + (-1,)), index, weight, flat)
        out[name] = flat.reshape((x.shape[0], len(points)) + x.shape[2:])
    return out


def _relative_error(approx: dict, exact: dict) -> np.ndarray:
    """(case,) largest error of any term relative to that term's largest entry."""
    worst = None
    for name, x in exact.items():
        axes = tuple(range(1, x.ndim))
        scale = np.abs(x).max(axis=axes)
        err = np.abs(approx[name] - x).max(axis=axes)
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(scale > 0, err / scale, 0.0)
        rel = np.where(np.isfinite(rel), rel, np.inf)
        worst = rel if worst is None else np.maximum(worst, rel)
    return worst


#: Bytes of terms evaluated at once (the effects' temporaries are a few times this).
_CHUNK_BYTES = 50e6


def evaluate_terms(model: Model, h: np.ndarray, phases: np.ndarray) -> dict[str, np.ndarray]:
    """Terms at ``phases`` of every case, each its own array, evaluated in chunks of phases
    (those a kept model evaluated before in this call are reused:
    :func:`ced.response.model_cache.kept_terms`).

    Parameters
    ----------
    model : Model
        The batch's model.
    h : numpy.ndarray
        Step size per case, s, shape (case,).
    phases : numpy.ndarray
        Where to evaluate, in steps of ``h`` (fractional allowed), shape (phase,).

    Returns
    -------
    dict of str to numpy.ndarray
        ``mass``, ``damping``, ``stiffness`` (case, phase, ny, ny), ``force`` (case, phase, ny)
        and ``projection`` (case, phase, row, nfree), its rows ``layout.projection_rows`` (the
        others are zero); ``mass`` and ``damping`` are absent where no effect forms them.
    """
    return kept_terms(model, h, phases, lambda columns: _evaluate(
        model, h[:, None] * phases[None, columns]))


def _evaluate(model: Model, times: np.ndarray) -> dict[str, np.ndarray]:
    """:func:`evaluate_terms` at ``times`` (case, time), s."""
    layout = model.layout
    per_phase = model.batch.size * 8 * (4 * layout.ny**2 + 3 * layout.nz * layout.ny)
    chunk = int(max(4, _CHUNK_BYTES // max(per_phase, 1)))
    out: dict[str, np.ndarray] = {}
    for start in range(0, times.shape[1], chunk):
        part = times[:, start:start + chunk]
        # The projection's rows that can be nonzero only (Layout.projection_rows); the modal
        # damping is added by the callers from its table (with_modal_damping).
        terms, P = terms_at(model, part, compact=True, modal_damping=False)
        parts = {"projection": P,
                 **{name: getattr(terms, name) for name in _NAMES[:-1]
                                     if getattr(terms, name) is not None}}
        for name, x in parts.items():
            if name not in out:
                out[name] = np.empty((x.shape[0], times.shape[1]) + x.shape[2:])
            out[name][:, start:start + part.shape[1]] = x
    return out


def _interleave(even: dict, odd: dict) -> dict:
    out = {}
    for name, x in even.items():
        y = np.empty((x.shape[0], 2 * x.shape[1]) + x.shape[2:])
        y[:, 0::2], y[:, 1::2] = x, odd[name]
        out[name] = y
    return out


def period_terms(model: Model, h: np.ndarray, period: int, samples: int = SAMPLES,
                 tolerance: float = TOLERANCE, exact: bool = False) -> PeriodTerms:
    """The system at every step of one period (``period`` steps of ``h`` s per case).

    Sampled and interpolated where that is accurate to ``tolerance`` (module docstring),
    evaluated at every step otherwise, or when ``exact``: the check sees the samples only, so a
    motion with features narrower than their spacing (a case ``near_singular``) must ask for it.
    Samples that fall on steps are reused when every step has to be evaluated after all.

    Parameters
    ----------
    model : Model
        The batch's model.
    h : numpy.ndarray
        Step size per case, s, shape (case,).
    period : int
        Steps per input period P.
    samples : int, optional
        Initial number of samples per period (doubled until accurate).
    tolerance : float, optional
        Relative interpolation error allowed (dimensionless).
    exact : bool, optional
        Evaluate every step.

    Returns
    -------
    PeriodTerms
        M, C, K, F and the projection at the P steps, each (case, P, …).

    The modal damping (:mod:`ced.response.modal_damping`) is not sampled: it is interpolated
    linearly from its own table, not smooth at its samples, and the check would have every
    step evaluated for it. It is added at every step from the table (:func:`with_modal_damping`).
    """
    return with_modal_damping(model, _period_terms(model, h, period, samples, tolerance, exact),
                              h)


def _period_terms(model: Model, h: np.ndarray, period: int, samples: int, tolerance: float,
                  exact: bool) -> PeriodTerms:
    """:func:`period_terms` but for the modal damping."""
    ncase = model.batch.size
    n = samples
    if not exact and 4 * n <= period:  # else every step costs little more than sampling
        values = evaluate_terms(model, h, np.arange(n) * (period / n))
        while True:
            # Sparse matrices are checked and interpolated packed: an entry zero at every
            # sample is zero at every step, and adds nothing to the error or its scale.
            pattern = _pattern(values)
            order = step_order(pattern)
            packed = {name: pack(x, order) if order is not None and name in _MATRICES
                      else x for name, x in values.items()}
            # Interpolate the odd samples from the even ones: the half set's error.
            even = {name: x[:, 0::2] for name, x in packed.items()}
            approx = _interpolate_terms(even, np.arange(n // 2) + 0.5, n // 2)
            estimate = _relative_error(approx, {k: x[:, 1::2] for k, x in packed.items()})
            estimate /= _HALVING_GAIN
            if (estimate <= tolerance).all():
                return PeriodTerms(**_with_none(_interpolate_terms(
                    packed, np.arange(period) * (n / period), n)), samples=n,
                    interpolation_error=estimate, sampled=values, pattern=pattern,
                    order=order)
            if 4 * n > period:
                break  # as many samples as steps: evaluate every step
            middle = evaluate_terms(model, h, (np.arange(n) + 0.5) * (period / n))
            values, n = _interleave(values, middle), 2 * n
        if period % n == 0:  # the samples are steps: evaluate only the others
            stride = period // n
            rest = np.setdiff1d(np.arange(period), np.arange(0, period, stride))
            others = evaluate_terms(model, h, rest.astype(float))
            full = {}
            for name, x in values.items():
                y = np.empty((ncase, period) + x.shape[2:])
                y[:, ::stride], y[:, rest] = x, others[name]
                full[name] = y
            return _exact(full)
    return _exact(evaluate_terms(model, h, np.arange(period, dtype=float)))


def with_modal_damping(model: Model, terms: PeriodTerms, h: np.ndarray) -> PeriodTerms:
    """``terms`` with the modal damping added at every step of the period from its table
    (:meth:`ced.response.modal_damping.ModalDamping.at`); ``terms`` itself where there is none.

    Parameters
    ----------
    model : Model
        The batch's model.
    terms : PeriodTerms
        Its terms over the period without the modal damping.
    h : numpy.ndarray
        Step size per case, s, shape (case,).
    """
    if model.modal_damping is None or "damping" not in model.effects:
        return terms

    def added(damping, steps):
        modal = model.modal_damping.at(h[:, None] * steps[None, :], model.batch.speed)
        return modal if damping is None else damping + modal

    dense = {name: terms.dense(name) for name in _MATRICES}
    dense["damping"] = added(dense["damping"], np.arange(terms.period, dtype=float))
    sampled = terms.sampled
    if sampled is not None:  # the samples stand for the terms too (their other users)
        n = sampled["force"].shape[1]
        sampled = {**sampled, "damping": added(sampled.get("damping"),
                                               np.arange(n) * (terms.period / n))}
    # Dense: C = MΦ diag(2ζω)ΦᵀM couples every DOF (no pattern to scan for).
    return dataclasses.replace(terms, order=None, pattern=np.ones((terms.n, terms.n), bool),
                               sampled=sampled, **dense)


def _pattern(values: dict) -> np.ndarray:
    """Nonzeros of M, C, K wherever ``values`` holds them (and, interpolated, at every step)."""
    return nonzero_pattern(*(values.get(name) for name in _MATRICES))


def _exact(values: dict) -> PeriodTerms:
    """The terms evaluated at every step, their matrices packed where sparse."""
    pattern = _pattern(values)
    order = step_order(pattern)
    if order is not None:
        values = {name: pack(x, order) if name in _MATRICES else x
                  for name, x in values.items()}
    return PeriodTerms(**_with_none(values), samples=len(values["force"][0]),
                       interpolation_error=np.zeros(len(values["force"])), pattern=pattern,
                       order=order)


def with_sparsity(terms: PeriodTerms) -> PeriodTerms:
    """``terms`` given as dense matrices, with their pattern, and packed where sparse.

    Parameters
    ----------
    terms : PeriodTerms
        Dense terms (``order`` None), e.g. made by hand.
    """
    values = {name: getattr(terms, name) for name in _MATRICES}
    pattern = _pattern(values)
    order = step_order(pattern)
    packed = {name: None if x is None or order is None else pack(x, order)
              for name, x in values.items()}
    return dataclasses.replace(terms, pattern=pattern, order=order,
                               **({} if order is None else packed))


def interpolate_periodic(values: np.ndarray, period: int,
                         tolerance: float = TOLERANCE) -> np.ndarray | None:
    """A periodic quantity at every step of the period from its values at the samples, or
    None where the interpolation is not accurate to ``tolerance`` (checked as for the terms:
    the even half of the samples interpolates the odd half).

    Parameters
    ----------
    values : numpy.ndarray
        The quantity at ``samples`` equally spaced phases, shape (case, samples, …).
    period : int
        Steps per period P.
    tolerance : float, optional
        Estimated interpolation error allowed, relative to the quantity's largest entry in
        each case.

    Returns
    -------
    numpy.ndarray or None
        Shape (case, P, …).
    """
    n = values.shape[1]
    half = _interpolate_terms({"x": values[:, 0::2]}, np.arange(n // 2) + 0.5, n // 2)
    estimate = _relative_error(half, {"x": values[:, 1::2]}) / _HALVING_GAIN
    if not (estimate <= tolerance).all():
        return None
    return _interpolate_terms({"x": values}, np.arange(period) * (n / period), n)["x"]


def _with_none(parts: dict[str, np.ndarray]) -> dict:
    return {name: parts.get(name) for name in _NAMES}
