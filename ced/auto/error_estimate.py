"""Per-case discretization error estimates (docs/reference/dataset.md, ``error_estimate``).

The estimate is relative, on the case's peak stress (the largest peak over its links). It
comes from one coarser companion solution and the known convergence orders:

* **Space.** The beams' curvature is recovered from its superconvergent points and converges
  as O(h³); their axial strain (linear bars) as O(h²); peak stress combines both, so order 2
  is taken for every formulation (conservative where bending dominates).
* **Time.** Every integrator is second order (Newmark, HHT, generalized-α, Houbolt); the peak
  between samples is interpolated (:func:`ced.fem.recovery.peaks`), so it converges smoothly.

The companion halves the steps and coarsens the mesh so that both error parts grow about
fourfold; then a fine solution σ and its companion σ_c give Richardson's asymptotic error
|σ − σ_c|/3 whatever the signs of the parts. The estimate is a safety factor times that,
calibrated on the validation sets so that it is an upper bound where the asymptotic constants
are only approached: :data:`SAFETY_PERIODIC` = 2.5 for a periodic start (convergence study,
421 settings: true error ≤ estimate on 97.6 %, 95 % inside [estimate/10, estimate]; 168 hard
cases of the default study, 0.8 < ω₁h < π: 93 %), :data:`SAFETY` = 2.5 from a start
transient as well (five sweeps of 100 speeds at 2 to 7 settings each: 97.7 %; 4 until
2026-11-29, docs/accuracy.md).

Richardson's argument needs both solutions in the asymptotic range. From a start transient
(``undeformed``, ``quasi_static``) every mode the start excites rings freely, and its phase
error, (ωh)²/12 per period, accumulates over the run: a coarser companion is far from that
range wherever the scene is near it (measured on the benchmark sweep, 20 speeds: the estimate
from a halved companion was below the true error at 55–65 % of the speeds at 256 and 512
steps per revolution). The steps are then always refined instead
(:func:`_time_companion_finer`).
From a periodic start, halving the step leaves it when the companion would have fewer than
:data:`MIN_COMPANION_STEPS` steps per revolution (the crank harmonics that carry the load are
then under-resolved) or, for a scheme that damps the first mode, when its ω₁h would cross 1
while the scene's is below π (a strongly dissipative scheme such as Houbolt is far from its
limit there); a non-dissipative scheme halves whatever ω₁h, since the steady state holds no
free vibration at ω₁ (:func:`_forced_only`). The step is then coarsened by less than 2, as
far as ω₁h may grow to 1 (at least by :data:`MIN_COARSENING`, the mesh
coarsened to match: one companion still, cheaper than the scene's solution), and where even
that is not possible the steps are doubled instead (:func:`coarser_steps`), at about three
times the cost of the scene's solution; so is a mesh of four elements or fewer refined
rather than coarsened.
Measured on the convergence study (``config/studies/convergence.yaml``, issue 6): see
``docs/accuracy.md``.

Not estimated: the modal truncation of ``modes_per_link`` — with static load vectors it is
below 1e-5 in the periodic steady state of the reference four-bar even with one mode per link,
but a start transient rings in the higher modes: from ``undeformed``, over 90–110 rad/s, at 8
elements and 1,280 steps per revolution, four modes per link are up to 0.93 % off the
converged peak coupler strain, eight modes 0.51 % and every FE DOF 0.48 %
(``benchmarks/results.json``, ``ced.candidates``); ``discretization: auto`` measures it
against the full mesh (``ced.auto.discretization``, stage 3); and model error (beam vs plane
stress), which the fidelity ladder measures.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from ..problem.scene import SPECTRAL_TAIL
from ..response.integrators import amplification_matrix, integrator_for

__all__ = ["Companion", "companions", "coarser_steps", "algorithmic_damping", "combine",
           "error_estimates", "MIN_COMPANION_STEPS", "MIN_COARSENING", "SPACE_ORDER",
           "TIME_ORDER", "SAFETY", "SAFETY_PERIODIC", "SAFETY_TAIL"]

#: Convergence order of peak stress in the element length, per formulation. The beams'
#: curvature is read at its superconvergent points (O(h³), ced.fem.elements.link.
#: superconvergent_rows), but their axial strain is that of linear bars, O(h²) even at its
#: superconvergent midpoints, and peak stress combines both: order 2 is taken (measured: a
#: bending-dominated crank-rocker converges at 3, the axially loaded double crank at 2). The
#: plane-stress and seed_lame strains are read at the stations, order 2 as well.
SPACE_ORDER = {"euler_bernoulli": 2, "timoshenko": 2, "plane_stress": 2, "seed_lame": 2}
#: Convergence order in the time step (every integrator of ced.response.integrators).
TIME_ORDER = 2
#: Factor between the estimate and Richardson's asymptotic error estimate, from a start
#: transient (``undeformed``, ``quasi_static``). Calibrated on 2,100 (speed, setting) pairs:
#: five sweeps of 100 speeds from rest (``benchmarks/estimate_sharing.py``'s and the
#: benchmark sweep at four more settings from 6 to 16 elements and 256 to 1,024 steps per
#: revolution), every case with its own companions, against converged values: with 2.5 the
#: true error is at most the estimate on 97.7 % of them, at least 92 % for every setting (8
#: elements at 256 steps the lowest), the median estimate 4.9 times the true error; with 4
#: (until 2026-11-29) 99.4 %, at least 97 %, the median 7.8 times; with 2, 95.8 % and 86 %.
SAFETY = 2.5
#: Factor on the spectral tail of a Fourier-series steady state (its time error). The tail
#: was above the true error on 96–97 % of 228 default-study cases at every P, by a median
#: factor of 7–21 (docs/performance.md): it is an upper bound by itself.
SAFETY_TAIL = 1.0
#: The same for a periodic start, calibrated on the convergence study (4 kept 99 % of its
#: settings' true errors below the estimate but put only 90 % inside [estimate/10, estimate],
#: most of the rest above 10× their true error; 2.5: 97.6 % and 95 %; 2: 96 % and 95 %).
SAFETY_PERIODIC = 2.5


class Companion(NamedTuple):
    """A companion discretization of a scene and the factor turning |σ − σ_c|/σ into the
    estimate's share."""

    scene: dict
    factor: float


def _factor(growth: float, safety: float) -> float:
    """``safety`` × Richardson's factor, referred to the scene's own solution.

    ``growth`` is the companion's error over the scene's error, (step ratio)^order: > 1 for
    a coarser companion (the scene's error is |Δ|/(G − 1)), < 1 for a finer one (the scene's
    error is |Δ|/(1 − G)).
    """
    return safety / abs(growth - 1.0)


def _elements_for_growth(ne: int, order: int, growth: float) -> int | None:
    """The element count n ≠ ne whose error growth (ne/n)^order is nearest ``growth`` (> 1:
    coarser, < 1: finer), so that space and time errors grow alike; None below 5 elements,
    where a coarser mesh leaves the asymptotic range (2 and 4 elements gave nearly the same
    peak stress on the double rocker, whose 4-element error is 0.19 %: the difference
    understated it 4×) — the mesh is then refined instead, in a separate companion."""
    if growth > 1 and ne <= 4:
        return None
    candidates = np.arange(1, ne) if growth > 1 else np.arange(ne + 1, 8 * ne + 2)
    best = int(candidates[np.argmin(np.abs(np.log((ne / candidates) ** order / growth)))])
    return best if best >= 2 else None


#: Fewest steps per revolution of a coarser companion: below, the crank harmonics that carry
#: the load (up to about the 8th) are not in the asymptotic range (measured on the reference
#: scenes: the error ratio between 32 and 64 steps is 2, not 4).
MIN_COMPANION_STEPS = 64
#: Algorithmic damping ratio above which a scheme counts as dissipative at a given ωh, and the
#: ω₁h its finer companion must then reach (at most 8 times the scene's steps).
DAMPED = 0.01
DISSIPATIVE_OMEGA_H = 0.5
#: Largest ω₁h of a coarser companion whose first mode is resolved; between this and π the
#: mode is neither resolved nor quasi-static, and halving the step leaves the asymptotic range.
MAX_COMPANION_OMEGA_H = 1.0


#: Smallest step ratio of a coarser companion: below, the difference to it is too small a
#: multiple of the scene's error (Richardson's factor SAFETY_PERIODIC / (1.25² − 1) = 4.4
#: already; a coarser companion is a periodic start's only).
MIN_COARSENING = 1.25


def coarser_steps(steps: int, revolutions: float, omega1_h: float) -> int | None:
    """Steps per revolution of a coarser companion that stays in the asymptotic range, or None.

    Halved where that keeps the first mode resolved (companion ω₁h ≤
    :data:`MAX_COMPANION_OMEGA_H`) or quasi-static (the scene's ω₁h ≥ π); otherwise coarsened
    by less, as far as ω₁h may grow (at least by :data:`MIN_COARSENING`). Never below
    :data:`MIN_COMPANION_STEPS`, and a whole number of steps over the scene's revolutions.

    Parameters
    ----------
    steps : int
        The scene's steps per revolution.
    revolutions : float
        The scene's revolutions.
    omega1_h : float
        First natural frequency × the scene's step, rad per step (0 if unknown).

    Returns
    -------
    int or None
    """
    if omega1_h >= math.pi or omega1_h <= 0.0:
        ratio = 2.0
    else:  # a mode beyond π per step is quasi-static at both step sizes; else it stays resolved
        ratio = min(2.0, MAX_COMPANION_OMEGA_H / omega1_h)
    coarse = max(math.ceil(steps / ratio - 1e-9), MIN_COMPANION_STEPS)
    while coarse * revolutions % 1 != 0:
        coarse += 1
    return coarse if coarse * MIN_COARSENING <= steps else None


def algorithmic_damping(time_cfg: dict, omega_h: float) -> float:
    """Algorithmic damping ratio ξ̄ = −ln|λ|/arg λ of the scheme's principal root at ω h
    (1 where the scheme has no oscillatory root there: the mode is overdamped).

    Parameters
    ----------
    time_cfg : dict
        The normalized scene's ``time`` block (integrator name and its parameters).
    omega_h : float
        Mode frequency times step size, ω h, rad per step (values below 1e-6 are raised to it).

    Returns
    -------
    float
        Algorithmic damping ratio ξ̄ (dimensionless).
    """
    scheme = integrator_for(time_cfg)
    W = max(float(omega_h), 1e-6)
    roots = np.linalg.eigvals(amplification_matrix(scheme, W))
    # The principal root is the complex one whose phase per step is nearest ωh; spurious roots
    # are real (possibly negative, phase π).
    oscillatory = roots[roots.imag > 1e-12 * np.abs(roots)]
    if not len(oscillatory):
        return 1.0
    principal = oscillatory[np.argmin(np.abs(np.angle(oscillatory) - W))]
    return float(-np.log(np.abs(principal)) / np.abs(np.angle(principal)))


def _refinement(time_cfg: dict, omega1_h: float) -> int:
    """Factor of the steps of a finer companion: 2, or up to 8 for a scheme that damps the
    first mode at the companion's ω₁h — until ω₁h ≤ :data:`DISSIPATIVE_OMEGA_H` — because a
    dissipative scheme (Houbolt) stalls on a plateau there: 64 and 128 steps gave the same
    error (0.69 % and 0.61 %) on the triple-rocker reference, and the difference of the two
    understated it by 2.4."""
    factor = 2
    while (factor < 8 and omega1_h / factor > DISSIPATIVE_OMEGA_H
           and algorithmic_damping(time_cfg, omega1_h / factor) > DAMPED):
        factor *= 2
    return factor


def _time_companion_finer(time_cfg: dict) -> bool:
    """Whether the time part of the error must come from a finer companion: from a start
    transient, whose free vibrations accumulate phase error over the run.

    Measured on the benchmark sweep (reference four-bar, undeformed start, two revolutions,
    every 5th of its 100 speeds, against 16 elements at 16,384 steps per revolution): with
    one coarser companion the estimate was an upper bound at 35–95 % of the speeds depending
    on the setting (35 % at 8 elements and 512 steps, where the true error reaches 2.4 %);
    with the steps doubled on the scene's mesh and the mesh coarsened at its steps, at 95–100 %
    of them for every one of nine settings (4–16 elements, 256–2,048 steps), at +140 % of
    the scene's solve (8 elements, 8 modes per link, 1,024 steps; +101 % before).
    """
    return time_cfg["start"] != "periodic"


def _forced_only(time_cfg: dict, omega1_h: float) -> bool:
    """Whether halving the step of a periodic start may ignore the first mode's ω₁h: the scheme
    does not dissipate that mode at the companion's step.

    The periodic steady state holds only the input's harmonics, no free vibration at ω₁; each
    harmonic's error is set by its own resolution kΩh (kept asymptotic by
    :data:`MIN_COMPANION_STEPS`), whatever ω₁h, as long as the scheme does not damp the mode
    that carries the response (Houbolt, or HHT at large ω₁h, do: there the rule stays).
    Measured on 168 unflagged cases of the default study whose ω₁h at 128 steps per
    revolution lies between 0.8 and π (generalized-α, no damping) against 32 elements at 1,024
    steps: one halved companion is an upper bound on 95 % of them (all 150 outside the
    double-crank family) where the two companions of the rule are on 99 %, at about half their
    cost (docs/accuracy.md).
    """
    return algorithmic_damping(time_cfg, min(2.0 * omega1_h, math.pi)) <= DAMPED


def companions(scene: dict, omega1_h: float = 0.0, collocation_points: int = 0
               ) -> list[Companion]:
    """Companion discretizations of a normalized scene with an elastic formulation.

    From a periodic start, normally one coarser companion: steps halved (or, with a scheme
    that damps the first mode, coarsened by less where halving would leave the asymptotic
    range, :func:`coarser_steps` and :func:`_forced_only`), elements reduced so that the space
    error grows about as much as the time error (4× when halved). Then the difference to the
    companion is a known multiple of the scene's own error whatever the signs of the two
    parts, and no cancellation between them can hide in it; the smaller of the two growths
    sets Richardson's factor, which keeps the estimate conservative when they differ. From a
    start transient (:func:`_time_companion_finer`), where no coarser step stays in the
    asymptotic range, or where the mesh cannot be coarsened, two companions instead: the mesh
    coarsened (or refined) at the scene's steps, and the steps coarsened
    where possible, else doubled (up to 8×, for a dissipative scheme that does not resolve
    ω₁, :func:`_refinement`) on the scene's mesh — about three times the cost of the scene's
    own solution; their two estimates are added. Modes per link are kept; the companions make
    no modal analysis.

    A case whose periodic state is a Fourier series (``collocation_points`` > 0,
    :mod:`ced.response.collocation`) has its time error in the series' tail, added by
    :func:`error_estimates`: its one companion coarsens the mesh only (or refines it, from
    four elements or fewer), on the same solver at the case's own number of points, so that
    the difference is the mesh's alone (and the companion needs its terms at those points
    only).

    Parameters
    ----------
    scene : dict
        Normalized scene (:func:`ced.problem.scene.load_scene`) with ``discretization`` a dict.
    omega1_h : float
        First natural frequency × step, rad per step (0 if unknown).
    collocation_points : int
        The Fourier collocation points of the case's periodic state where the spectral solver
        found it; 0 where it was shot or marched, and so are its companions.

    Returns
    -------
    list of Companion (their terms add up)
    """
    disc, time = scene["discretization"], scene["time"]
    ne, spr = disc["elements_per_link"], time["steps_per_revolution"]
    order = SPACE_ORDER.get(disc["formulation"], 2)
    every = scene["outputs"]["every"]

    def variant(n_el: int, steps: int) -> dict:
        # New blocks where it differs, the others shared (normalized scenes are never changed
        # in place): a deep copy per case was 0.1 s of a 500-case chunk.
        time = {**scene["time"], "steps_per_revolution": steps}
        if collocation_points:  # the series at the case's own points (no tail to stop at)
            time["collocation_points"] = int(collocation_points)
            time["spectral_tail"] = SPECTRAL_TAIL
        else:  # the case was shot: so are its companions
            time["periodic_solver"] = "shooting"
            time["collocation_points"] = "auto"
            time["spectral_tail"] = SPECTRAL_TAIL
        # Output at least as dense in time as the scene's: the same instants when coarser,
        # every step's worth of the scene's when finer (the peaks are over every step).
        outputs = {**scene["outputs"],
                   "every": max(1, every * steps // spr) if steps < spr else every}
        return {**scene, "time": time, "outputs": outputs,
                "discretization": {**disc, "elements_per_link": n_el},
                "modal": None,  # only the peak stress is compared
                "name": f"{scene.get('name', '')} (error-estimate companion)"}

    periodic = time["start"] == "periodic"
    safety = SAFETY_PERIODIC if periodic else SAFETY
    if collocation_points:  # the time part is the series' own tail: the mesh alone is coarsened
        space = _elements_for_growth(ne, order, 4.0) or 2 * ne
        return [Companion(variant(space, spr), _factor((ne / space) ** order, safety))]
    coarse_steps = None if _time_companion_finer(time) else coarser_steps(
        spr, time["revolutions"], 0.0 if _forced_only(time, omega1_h) else omega1_h)
    time_growth = (spr / coarse_steps) ** TIME_ORDER if coarse_steps else 4.0
    coarse = _elements_for_growth(ne, order, time_growth)
    if coarse_steps and coarse is not None:
        growth = min((ne / coarse) ** order, time_growth)
        return [Companion(variant(coarse, coarse_steps), _factor(growth, safety))]
    # Separately: the mesh coarsened (or, from four elements or fewer, refined) at the scene's
    # steps, and the steps coarsened (or refined) on the scene's mesh. Each part is estimated
    # on its own and the parts are added, so they cannot cancel in the estimate.
    space = coarse if coarse is not None else 2 * ne
    steps = coarse_steps or spr * _refinement(time, omega1_h)
    return [Companion(variant(space, spr), _factor((ne / space) ** order, safety)),
            Companion(variant(ne, steps), _factor((spr / steps) ** TIME_ORDER, safety))]


def combine(peak: np.ndarray, companion_peaks: list[np.ndarray], factors: list[float]
            ) -> np.ndarray:
    """The relative error estimate of each case's peak stress.

    Parameters
    ----------
    peak : (case,) peak stress of the scene's own discretization, Pa
    companion_peaks : list of (case,) arrays, the companions' peak stress, Pa
    factors : list of float, :attr:`Companion.factor` of each companion

    Returns
    -------
    (case,) array, dimensionless; NaN where a companion failed
    """
    scale = np.where(np.abs(peak) > 0, np.abs(peak), np.nan)
    estimate = sum(f * np.abs(peak - c) for c, f in zip(companion_peaks, factors)) / scale
    return np.where(np.abs(peak) > 0, estimate, 0.0)


def error_estimates(scenes: list[dict], peak: np.ndarray, failed: np.ndarray,
                    first_frequency: Callable[[], np.ndarray], step_size: np.ndarray,
                    solve: Callable[[list[dict], list | None], np.ndarray],
                    known: dict[int, float] | None = None,
                    spectral_tail: np.ndarray | None = None,
                    collocation_points: np.ndarray | None = None,
                    guesses: list | None = None) -> np.ndarray:
    """``error_estimate`` of each case from its companion solutions.

    Parameters
    ----------
    scenes : list of dict
        The normalized scenes of the cases.
    peak : (case,) array
        Each case's peak stress, Pa (the largest over its links).
    failed : (case,) bool
        Failed cases: no estimate (NaN).
    first_frequency : callable
        () → (case,) first natural frequency over the cycle, rad/s; called only when a
        dynamic case needs it (:func:`companions` keeps ω₁h in the asymptotic range).
    step_size : (case,) array
        Each case's time step, s.
    solve : callable
        (list of scenes, their initial guesses or None) → (n,) peak stress, Pa, NaN where a
        companion could not be solved (injected by :mod:`ced.simulation.simulate`, which
        batches the companions like any run).
    known : dict, optional
        case → estimate of cases that already have one (``discretization: auto``'s ladders
        are their companions).
    spectral_tail : (case,) array, optional
        The spectral tail of each case whose periodic state is a Fourier series
        (:mod:`ced.response.collocation`), NaN for the others: their time error, added to the
        mesh companion's estimate (:data:`SAFETY_TAIL` ×).
    collocation_points : (case,) int array, optional
        The Fourier collocation points of those cases (0 for the others); their companions
        are solved at the same points. Required with ``spectral_tail``.
    guesses : list, optional
        Per case, its series in mesh-independent terms
        (:func:`ced.response.warm_start.mesh_free_samples`) or None: the initial guess of its
        mesh companion's GMRES, which differs from the case's own solution by the mesh's
        error only (measured on whole chunks of the default study: 19 % fewer companion
        iterations on double cranks, 40 % on triple rockers, 73 % on crank-rockers). The
        estimate is unchanged within GMRES's tolerance (by at most 3e-5 there).

    Returns
    -------
    (case,) array, dimensionless; NaN for failed cases, cases that asked for no estimate or a
    rigid formulation, and cases whose companions failed (their own results are kept).
    """
    known = known or {}
    wanted = [i for i, s in enumerate(scenes) if s["outputs"]["error_estimate"]
              and isinstance(s["discretization"], dict)
              and s["discretization"]["formulation"] != "rigid" and i not in known]
    estimate = np.full(len(scenes), np.nan)
    for i, value in known.items():
        if scenes[i]["outputs"]["error_estimate"]:
            estimate[i] = value
    if not wanted:
        return np.where(failed, np.nan, estimate)
    dynamic = [i for i in wanted if "elastic_inertia" in scenes[i]["effects"]]
    omega1_h = np.zeros(len(scenes))
    if dynamic:
        omega1 = first_frequency()
        omega1_h[dynamic] = omega1[dynamic] * step_size[dynamic]
    tail = np.full(len(scenes), np.nan) if spectral_tail is None else spectral_tail
    series = np.isfinite(tail)
    points = np.where(series, 0 if collocation_points is None else collocation_points, 0)
    plans = {i: companions(scenes[i], float(omega1_h[i]), int(points[i])) for i in wanted}
    terms = np.where(series, SAFETY_TAIL * tail, 0.0)
    for slot in range(max(len(p) for p in plans.values())):
        cases = [i for i in wanted if len(plans[i]) > slot]
        starts = (None if guesses is None else
                  [guesses[i] if points[i] else None for i in cases])
        companion_peak = solve([plans[i][slot].scene for i in cases], starts)
        factor = np.array([plans[i][slot].factor for i in cases])
        terms[cases] += combine(peak[cases], [companion_peak], [1.0]) * factor
    estimate[wanted] = terms[wanted]
    estimate[failed] = np.nan
    return estimate
