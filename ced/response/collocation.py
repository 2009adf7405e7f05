"""The periodic steady state by Fourier collocation, with as many harmonics as it needs.

``time.periodic_solver: spectral``. The elastic system of a periodic start is linear and
periodic in the input period, so its steady state is a Fourier series in the input phase θ.
Collocated at P equally spaced phases (:func:`ced.response.spectral.solve_periodic`) it
converges exponentially in P once P/2 clears the harmonics the response holds; shooting
with a second-order integrator instead carries a period error (ωh)²/12 on every harmonic,
which near an undamped mode sitting on a high crank harmonic (the 20th–47th in the default
study) turns into an amplitude error of tens of percent at 128 steps per revolution.

P is chosen per case. It starts at :data:`START_POINTS` and doubles, up to
:data:`MAX_POINTS`, while the response's highest resolved harmonics still carry more than
``time.spectral_tail`` (:data:`TAIL_TOLERANCE` by default) of its peak: the **spectral
tail**, the summed amplitude of the signed stress's harmonics in the top quarter of the
resolved band (3P/8 < k ≤ P/2), largest over link, station and fibre, relative to the peak
stress. A converged series has a negligible tail; one that is cut inside a resonant band
does not. Measured on 228 unflagged cases of the
default study against P = 384 (``docs/performance.md``): this ladder put every case within
2 % (largest error 0.83 %, mean final P 55), where fixed P = 32, 64, 128 left 8, 3 and 1.5 %
of them outside; the tail was above the true error on 96–97 % of the cases at every P.

The peaks are taken from the series, not from the output steps: the displacements at the
collocation points are resampled by their trigonometric interpolant to :data:`PEAK_SAMPLES`
× P points and the peaks recovered there (:func:`ced.fem.recovery.peaks`'s parabola between
samples), so that a resonant high harmonic is not under-sampled by a coarse output grid (at
128 points per period the peak was off by more than 2 % on 3 of 228 cases).

Cases near a change point or toggle (``near_singular``) have motions with features narrower
than any global Fourier basis resolves (GMRES stalls there, and the series does not
converge): they, and any case whose solve does not converge, are left to the shooting
(:func:`spectral_steady_state` says which).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fem.recovery import peaks
from ..fem.recovery_kernel import recover
from ..problem.scene import SPECTRAL_TAIL
from .batch import make_batch
from .kernels import expand
from .model import Model
from .model_cache import model_for
from .period_terms import PeriodTerms, evaluate_terms, interpolate_periodic
from .spectral import evaluate, solve_periodic
from .step_pattern import unpack
from .warm_start import mesh_free_samples, reduced_from_samples

__all__ = ["SpectralSteadyState", "spectral_steady_state", "resample", "spectral_tail",
           "START_POINTS", "MAX_POINTS", "MAX_ITERATIONS", "LADDER_ITERATIONS",
           "TAIL_TOLERANCE", "PEAK_SAMPLES"]

#: Collocation points to start from: enough for the load's own harmonics (the reference
#: four-bar's first mode carries 0.12 % of its load at the 6th), and the cheapest solve.
START_POINTS = 32
#: Most collocation points: the 128th harmonic; the sharpest resonances of the default study
#: needed 256 (6 of 228 cases).
MAX_POINTS = 256
#: GMRES iterations allowed per solve (:func:`ced.response.spectral.solve_periodic`). The
#: time-averaged preconditioner needs 12–35 on the default study's four-bars and slider-cranks
#: at P = 32–64; double cranks whose stiffness swings over the cycle need hundreds, and
#: a case that has not converged by then is better shot than iterated (500 iterations cost
#: 75 ms at P = 128, five times its shooting). At the first level (P = 32) an iteration is a
#: quarter of that, and 200 let 23 more of a 500-case double-crank chunk's cases converge
#: (455 → 478; 100–200 iterations each, where their shooting cost ~20 ms): the chunk took
#: 6.7 s against 6.9–7.0, its estimate's companions (shot too, before) 29 % of the solve
#: against 37–38 %; 300 converged 6 more and saved nothing. A full mesh needs more than 100
#: too (the convergence study's rocker-crank at 8 elements: 157).
MAX_ITERATIONS = 200
#: GMRES iterations allowed per solve above the first level: a case that climbs the ladder is
#: near a resonance of a high harmonic, where the time-averaged preconditioner is weaker (a
#: default-study crank-rocker at 50 rad/s needed 331 at P = 128 and 173 at P = 256), and
#: stopping early would leave its series unresolved.
LADDER_ITERATIONS = 500
#: Spectral tail above which P doubles by default (0.5 %: the ladder's largest true error was
#: 0.83 %); a scene sets its own (``time.spectral_tail``; ``discretization: auto`` from its
#: tolerance).
TAIL_TOLERANCE = SPECTRAL_TAIL
#: Peaks are recovered at this many points per collocation point (the series resampled).
PEAK_SAMPLES = 8
#: Bytes of collocation terms held at once (cases are solved in blocks of this size).
_BLOCK_BYTES = 50e6
_TERMS = ("mass", "damping", "stiffness", "force", "projection")
#: Series at fewer points than this are kept as their companions' initial guesses. A case
#: that climbs to MAX_POINTS sits on a resonance of a high harmonic, which the companion's
#: coarser mesh shifts: its series is no better a start than zero there (measured on the
#: default study: at P = 128, 2,810 → 1,855 companion iterations on a triple-rocker chunk,
#: 4,584 → 3,335 on a double-crank chunk; at P = 256, 1,601 → 1,754 and 645 → 1,391, where
#: restarted GMRES stalled from the guess and the case was solved again from zero).
_KEEP_GUESS_BELOW = MAX_POINTS


@dataclass
class SpectralSteadyState:
    """The periodic state of the cases the spectral solver took.

    ``solved`` (case,) bool marks them; for the others (near-singular, or not converged at
    :data:`START_POINTS`) the arrays hold zeros and the caller shoots. ``displacement`` (case,
    steps, ny) is y at every step of one period of the step grid, m (None where no history
    was asked for: the peaks are the series' own); ``points`` (case,) the collocation points used;
    ``tail`` (case,) the spectral tail (module docstring), dimensionless; ``peak_deflection``
    and ``peak_stress`` (case, link) the peaks of the series, m and Pa. ``unresolved`` (case,)
    bool marks the cases of the adaptive ladder whose tail stayed above
    ``time.spectral_tail`` at the last level solved, because the next level's GMRES did not
    converge or :data:`MAX_POINTS` was reached: their series misses harmonics the response
    holds, and the tail is no bound on the error (the caller flags them ``resonant``).
    ``samples`` (case,) object, where asked for: each solved case's series at its collocation
    points in mesh-independent terms (:func:`ced.response.warm_start.mesh_free_samples`,
    (points, m) m and rad; None for the others and at :data:`MAX_POINTS`), the initial guess
    of its error estimate's companion.
    """

    solved: np.ndarray
    displacement: np.ndarray | None
    points: np.ndarray
    tail: np.ndarray
    peak_deflection: np.ndarray
    peak_stress: np.ndarray
    unresolved: np.ndarray
    samples: np.ndarray | None = None


def spectral_steady_state(model: Model, period: PeriodTerms | None, candidates: np.ndarray,
                          steps: int | None = None, climb: np.ndarray | None = None,
                          history: bool = True, samples: bool = False,
                          guesses: list | None = None) -> SpectralSteadyState:
    """Periodic steady state of the ``candidates`` (case,) bool by Fourier collocation, at
    the scene's ``time.collocation_points``: adaptive (``auto``, module docstring) or fixed.

    Parameters
    ----------
    model : Model
        The batch's model (input speed Ω in rad/s).
    period : PeriodTerms or None
        The batch's terms over one period of its step grid (the collocation points are taken
        from its samples, or interpolated from them); None: the terms are evaluated at the
        collocation points themselves (with a fixed number of points: one evaluation).
    candidates : numpy.ndarray
        Cases to solve, shape (case,), bool.
    steps : int, optional
        Steps per input period (default: ``period``'s).
    climb : numpy.ndarray, optional
        Cases allowed past the first level of the adaptive ladder, shape (case,), bool
        (default: all); the others keep their first converged series.
    history : bool, optional
        Evaluate the series at every step of the period (``displacement``); without it (an
        error estimate's companion, which reads the peaks alone) ``displacement`` is None:
        that evaluation cost 7 % of a crank-rocker chunk's companions.
    samples : bool, optional
        Keep each solved case's series in mesh-independent terms (``samples``): the initial
        guesses of its companion.
    guesses : list, optional
        Per case, such samples of another mesh of the case at this model's collocation
        points, or None: the initial guesses of GMRES (a companion's solve starts from its
        scene's series, which differs from its own by the mesh's error only). Guesses of
        another number of points are ignored.

    Returns
    -------
    SpectralSteadyState
    """
    batch, layout = model.batch, model.layout
    steps = period.period if steps is None else steps
    ncase, nlink = batch.size, len(layout.topology.links)
    out = SpectralSteadyState(
        solved=np.zeros(ncase, bool),
        displacement=np.zeros((ncase, steps, layout.ny)) if history else None,
        points=np.zeros(ncase, np.int64), tail=np.full(ncase, np.nan),
        peak_deflection=np.zeros((ncase, nlink)), peak_stress=np.zeros((ncase, nlink)),
        unresolved=np.zeros(ncase, bool),
        samples=np.full(ncase, None, object) if samples else None)
    todo = np.flatnonzero(candidates)
    fixed = batch.scenes[0]["time"]["collocation_points"]
    adaptive = fixed == "auto"
    threshold = batch.scenes[0]["time"]["spectral_tail"]  # one per batch (its time block)
    points = START_POINTS if adaptive else int(fixed)
    while todo.size:
        retry = []
        evaluated = None if period is not None else _evaluate_at_points(model, steps, points,
                                                                          todo)
        for block in _blocks(todo, points, model):
            terms = (collocation_terms(model, period, points, block) if evaluated is None
                     else {name: None if x is None else x[np.searchsorted(todo, block)]
                           for name, x in evaluated.items()})
            solution = solve_periodic(terms["stiffness"], terms["force"], batch.speed[block],
                                      terms["mass"], terms["damping"],
                                      maxiter=MAX_ITERATIONS if points == START_POINTS
                                      else LADDER_ITERATIONS,
                                      initial=_initial(model, block, terms["projection"],
                                                       guesses))
            # A case that does not converge keeps the series of its last level, unresolved,
            # or, at the first, is shot.
            out.unresolved[block[~solution.converged & out.solved[block]]] = True
            ok = block[solution.converged]
            if not ok.size:
                continue
            y = solution.displacement[solution.converged]
            z = _displacements(layout, terms["projection"][solution.converged], y)
            tail, peak_deflection, peak_stress = _series_peaks(model, ok, z)
            out.solved[ok] = True
            out.points[ok] = points
            out.tail[ok] = tail
            out.peak_deflection[ok] = peak_deflection
            out.peak_stress[ok] = peak_stress
            if samples:  # a lower level's series is no guess at these points
                out.samples[ok] = None
            if samples and points < _KEEP_GUESS_BELOW:
                kept = mesh_free_samples(model, ok, terms["projection"][solution.converged],
                                         z, y)
                for i, case in enumerate(ok):
                    out.samples[case] = kept[i]
            if history:
                out.displacement[ok] = evaluate(y, 2.0 * np.pi * np.arange(steps) / steps)
            if adaptive:
                coarse = ok[(tail > threshold) & (True if climb is None else climb[ok])]
                if points < MAX_POINTS:
                    retry.append(coarse)
                else:
                    out.unresolved[coarse] = True
        todo = np.concatenate(retry) if retry else todo[:0]
        points *= 2
    return out


def _initial(model: Model, block: np.ndarray, projection: np.ndarray,
             guesses: list | None) -> np.ndarray | None:
    """GMRES's initial guesses (block, P, ny) from the cases' ``guesses`` at these P points
    (zero for a case without one), or None where no case has one."""
    P = projection.shape[1]
    have = [i for i, case in enumerate(block) if guesses is not None
            and guesses[case] is not None and guesses[case].shape[0] == P]
    if not have:
        return None
    initial = np.zeros((len(block), P, model.layout.ny))
    initial[have] = reduced_from_samples(model, block[have], projection[have],
                                         np.stack([guesses[block[i]] for i in have]))
    return initial


def _evaluate_at_points(model: Model, steps: int, points: int, cases: np.ndarray
                        ) -> dict[str, np.ndarray | None]:
    """The terms at ``points`` equally spaced phases of the period (``steps`` steps) for
    the given cases, each (case, points, …). A model serves all the cases of its batch at
    once: for fewer than half of them (the few that climb the ladder) a model of those
    cases alone is built, which costs less than evaluating the others."""
    phases = np.arange(points) * (steps / points)
    if 2 * len(cases) < model.batch.size:
        sub = model_for(make_batch([model.batch.scenes[i] for i in cases]))
        exact = evaluate_terms(sub, sub.batch.step_size, phases)
        out = {name: exact.get(name) for name in _TERMS}
    else:
        exact = evaluate_terms(model, model.batch.step_size, phases)
        whole = len(cases) == model.batch.size
        out = {name: (None if exact.get(name) is None else exact[name] if whole else
                      np.ascontiguousarray(exact[name][cases])) for name in _TERMS}
    if model.modal_damping is not None and "damping" in model.effects:
        # evaluate_terms leaves the modal damping to its callers (its own table)
        times = model.batch.step_size[cases, None] * phases[None, :]
        modal = model.modal_damping.at(times, model.batch.speed[cases], cases)
        out["damping"] = modal if out["damping"] is None else out["damping"] + modal
    return out


def _blocks(cases: np.ndarray, points: int, model: Model) -> list[np.ndarray]:
    """The cases in blocks whose collocation terms and resampled fields fit in
    :data:`_BLOCK_BYTES`."""
    layout = model.layout
    fields = 6 * len(layout.topology.links) * len(model.stations)  # float32, at PEAK_SAMPLES
    per_case = points * (8 * (3 * layout.ny**2 + layout.ny + layout.nz * layout.ny)
                         + 4 * PEAK_SAMPLES * fields)
    size = int(max(1, _BLOCK_BYTES // per_case))
    return [cases[i:i + size] for i in range(0, len(cases), size)]


def collocation_terms(model: Model, period: PeriodTerms, points: int, cases: np.ndarray
                      ) -> dict[str, np.ndarray | None]:
    """M, C, K, F and the projection's joint columns (its rows ``layout.projection_rows``,
    :func:`ced.response.period_terms.evaluate_terms`) at ``points`` equally spaced phases
    2πj/points (j = 0 … points − 1) for the given cases, each (case, points, …).

    Taken from the period's samples (exact terms) or its steps where the points are among
    them; else interpolated from them by :func:`ced.response.period_terms.interpolate_periodic`
    (checked to its tolerance), or, where that check fails, evaluated at the points.
    """
    out: dict[str, np.ndarray | None] = {}
    for name in _TERMS:
        if period.sampled is not None:
            values, packed = period.sampled.get(name), False
        else:  # the period's steps, matrices packed where sparse: unpacked at the points only
            values = getattr(period, name)
            packed = period.order is not None and name in ("mass", "damping", "stiffness")
        if values is None:
            out[name] = None
            continue
        available = values.shape[1]
        if available % points == 0:
            out[name] = np.ascontiguousarray(values[cases, ::available // points])
        else:
            out[name] = interpolate_periodic(values[cases], points)
            if out[name] is None:  # not smooth enough between the samples: evaluate
                return _evaluate_at_points(model, period.period, points, cases)
        if packed:
            out[name] = unpack(out[name], period.order, period.n)
    return out


def _displacements(layout, projection: np.ndarray, y: np.ndarray) -> np.ndarray:
    """z = P y at each collocation point: projection (case, P, row, nfree), its rows
    ``layout.projection_rows``, y (case, P, ny)."""
    z = np.empty(y.shape[:2] + (layout.nz,))
    expand(np.ascontiguousarray(projection), np.ascontiguousarray(y),
           np.arange(y.shape[1], dtype=np.int64), layout.projection_rows,
           layout.interior_rows().astype(np.int64), z)
    return z


def resample(values: np.ndarray, samples: int) -> np.ndarray:
    """The trigonometric interpolant of periodic ``values`` (case, P, …), P even, at
    ``samples`` ≥ P equally spaced phases from 0 (the Nyquist harmonic split evenly between
    ±P/2, as :func:`ced.response.spectral.evaluate`).

    Parameters
    ----------
    values : numpy.ndarray
        Samples at phases 2πj/P, shape (case, P, …).
    samples : int
        Number of phases to return, a multiple of P.

    Returns
    -------
    numpy.ndarray
        Shape (case, samples, …).
    """
    P = values.shape[1]
    if samples == P:
        return values.copy()
    spectrum = np.fft.rfft(values, axis=1)
    spectrum[:, P // 2] *= 0.5  # and its mirror at −P/2, which irfft adds
    padded = np.zeros((values.shape[0], samples // 2 + 1) + values.shape[2:], complex)
    padded[:, :P // 2 + 1] = spectrum
    return np.fft.irfft(padded, n=samples, axis=1) * (samples / P)


def spectral_tail(stress: np.ndarray, peak: np.ndarray) -> np.ndarray:
    """Summed amplitude of the harmonics 3P/8 < k ≤ P/2 of the signed stress, largest over
    link, station and fibre, relative to ``peak`` (module docstring).

    Parameters
    ----------
    stress : numpy.ndarray
        Signed stress at the P collocation points, Pa, shape (case, P, link, station, fibre).
    peak : numpy.ndarray
        The case's peak stress, Pa, shape (case,).

    Returns
    -------
    numpy.ndarray
        Shape (case,), dimensionless; 0 where the peak is 0.
    """
    P = stress.shape[1]
    amplitude = np.abs(np.fft.rfft(stress, axis=1)) * (2.0 / P)
    amplitude[:, P // 2] *= 0.5  # the Nyquist harmonic is counted once
    k = np.arange(P // 2 + 1)
    band = amplitude[:, k > 3 * P / 8].sum(axis=1)
    band = band.reshape(len(stress), int(np.prod(band.shape[1:]))).max(axis=1, initial=0.0)
    return np.divide(band, peak, out=np.zeros_like(band), where=peak > 0)


def _series_peaks(model: Model, cases: np.ndarray, z: np.ndarray):
    """Spectral tail and peaks of the series whose displacements at the collocation points
    are z (case, P, nz), for the given cases of the model's batch."""
    batch, layout = model.batch, model.layout
    links = layout.topology.links
    zero = np.zeros(batch.size)
    height, E = (np.stack([batch.link_property(name, group, key) if name in model.recovery
                           else zero for name in links], axis=1)[cases]
                 for group, key in (("section", "height"), ("material", "E")))
    operators = [None if name not in model.recovery else
                 {key: (op[cases] if op.ndim == 3 else op)
                  for key, op in model.recovery[name].items()} for name in links]
    rows = [layout.link_offsets[name] for name in links]
    fine = recover(resample(z, PEAK_SAMPLES * z.shape[1]), rows, operators, model.stations,
                   height, E, fields=True)
    stress = fine["stress"]
    larger = np.maximum(np.abs(stress[..., 0]), np.abs(stress[..., 1])).astype(float)
    peak_stress = peaks(larger, periodic=True)
    peak_deflection = peaks(fine["deflection"].astype(float), periodic=True)
    # The collocation points are every PEAK_SAMPLES-th of the resampled points.
    tail = spectral_tail(stress[:, ::PEAK_SAMPLES].astype(float), peak_stress.max(axis=1))
    return tail, peak_deflection, peak_stress
