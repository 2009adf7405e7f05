"""``discretization: auto``: elements, steps and model from the scene's tolerance, at least cost.

The scene's ``tolerance`` is a target relative error on peak stress. Its error is modelled as
a sum of a space, a time and a model part, e(n_e, s_r, m) ≈ E_x(n_e) + E_t(s_r) + E_m(m), each
*measured* on cheap batched pilots rather than assumed from a convergence order, so that
pre-asymptotic behaviour (an under-resolved mode, a sign change, wrapped phases) is seen,
not guessed:

1. **Time ladder.** The pilot mesh (:data:`LADDER_ELEMENTS` elements per link, reduced to
   :data:`MODES` modes per flexible link, the most a choice keeps) is solved at
   s = :data:`FIRST_STEPS`, 2s, 4s, … steps per revolution. The first rung gives 8 steps per
   period of the 4th crank harmonic, the coarsest resolution at which a peak over the cycle
   is meaningful; it also carries a frozen modal analysis. In a periodic state its first
   natural frequency ω₁ decides whether the mode can be excited by the crank harmonics that
   matter (ω₁ ≤ :data:`RESONANT_HARMONICS` Ω): then the ladder must resolve it (ω₁h ≤ 1/2)
   before it may stop, so that its resonant contribution is seen converging. From a start
   transient every mode rings: the ladder must resolve all of its model's modes (the
   :data:`MODES` × flexible links lowest), for rungs that damp them numerically agree
   without converging (the benchmark sweep's ladders stopped at 256 steps per revolution,
   1.2 % off, on two rungs that agreed to 0.05 %). The ladder stops once its last rung's error
   is below tolerance / (2 :data:`SAFETY`).
2. **Space ladder**, at the coarsest rung of the time ladder whose time error is within the
   tolerance and that resolves what the time ladder had to (the interaction of the two
   errors, a few per cent of the time error on the convergence study's scenes, is then
   negligible): 2, 4, 8, … elements per link until the last rung's error is within the same
   budget as the time ladder's.
3. **Model.** The truncation of a reduced model with each of :data:`MODE_CHOICES` modes per
   flexible link, measured against the full mesh at :data:`LADDER_ELEMENTS` elements and the
   finest rung of the time ladder, which resolves every mode of the ladders' model from a
   start transient (coarser steps damp the modes left out and hide the truncation: 0.1 % at
   128 steps per revolution where it is 1.1 % at 1624). With static load vectors it is
   negligible in a periodic state, but a start transient rings in the modes left out: on the
   benchmark sweep four modes leave up to 1.1 % of peak stress, eight 0.12 %.
4. **Ladder errors** (:func:`ladder_errors`). Where the last three rungs converge at about
   the theoretical order (:data:`ASYMPTOTIC_ORDERS`), the limit is Richardson-extrapolated
   from the last two rungs at order 2; each rung's error is its distance to that limit, the
   last rung's the larger of its Richardson correction and the previous rung's correction
   carried one level further. Elsewhere (phases wrapped from a start transient: the peak
   then moves erratically by up to 1.6 % from 1024 to 8192 steps per revolution) there is no
   extrapolation: the last rung errs by the larger of its own change and the previous one
   carried a level further, every other rung by its distance to the last plus that. Errors
   are made non-increasing under refinement so that a rung that happens to sit near a sign
   change is not trusted. Between rungs the error follows the power law through the two
   (their observed order); beyond the finest rung it falls at order 2 (:func:`interpolate`):
   peak stress converges at order 2 in time and between 2 and 3 in space
   (``ced.auto.error_estimate``), so that errs on the safe side. Where the error drops faster
   than at twice that order between two rungs (a mode resolved in between: the double
   crank's falls 130× from 32 to 64 steps, and is still 4e-4 at 40), the coarser rung's error
   holds up to the finer rung. **Choice** (:func:`choose`). The cheapest (n_e, s_r, m) on a
   grid (n_e from 2, s_r in multiples of 8 from the first rung, both up to the ladders'
   finest rungs; m one of :data:`MODE_CHOICES`, or the full mesh on the meshes where the
   space ladder's pilots are the full mesh, since only there is its space error measured)
   with E_x + E_t + E_m ≤ tolerance / :data:`SAFETY`, by :func:`cost`, a model of the solve
   time per case fitted to the convergence study's timings (:data:`COST`). The full mesh is
   not assumed to converge like the reduced models beyond what was measured (with the modal
   damping frozen at the start, before 2026-11-29, it was 11 % off them at the change
   point's 8 elements; docs/accuracy.md). With a series in the call the mesh is one its
   space ladders measured (stage 6).
5. **Sweeps share their ladders.** Cases that differ only in their drive speed (and name) form
   a sweep (:func:`sweeps`). Every marched case solves the first rung, with its own modal
   analysis; the ladders are climbed by every :data:`STRIDE`-th case in the order of speed
   and the last (:func:`representatives`). A case between two climbers is predicted to err
   :data:`INTERPOLATION_MARGIN` times the larger of their errors at the chosen setting, and
   that prediction is verified before it is used (:func:`unverified`): where it exceeds
   tolerance / :data:`SAFETY`, or where the same rule applied to a climber from its climbing
   neighbours under-predicts its own ladder (leave-one-out: the error varies faster in speed
   than the climbers resolve), the middle case of the gap climbs too (bisection, until every
   gap is verified or has no case left in it); a case whose excitable first mode needs finer
   steps than both its climbers' time ladders reached climbs itself. No case takes the shared
   setting on a prediction that was not checked, and in the worst case every case climbs, as
   without sharing. A case that did not climb and whose own solve flags it ``resonant`` or
   ``parametrically_unstable`` is not bounded by its neighbours (a resonance is narrower than
   their spacing): :mod:`ced.simulation.simulate` gives it the ordinary companions' estimate,
   its prediction a floor under it. Speed is the one parameter shared over: it is scalar (a
   gap has two ends), it is what sweeps vary, and it leaves the structure alone; link lengths
   change the family and meet singular positions (the change point), material and section
   change the natural frequencies and the balance of axial and bending stress together, so
   cases near in them need not have similar ladders, and several of them at once leave no
   order to bisect in.
   From a start transient the ladders vary much faster in speed than in the steady state (the
   benchmark's undeformed sweep: neighbouring speeds' own choices range from 48 to 1624 steps
   per revolution, where its periodic sweep's are smooth): there bisection climbs about half
   of the cases, in the steady state about a fifth. Sharing saves where the most demanding
   case stands out: where every case of a sweep needs about the same setting, the climbers'
   errors at it sit near tolerance / :data:`SAFETY` and no gap can be bounded by
   :data:`INTERPOLATION_MARGIN` times them. The shared setting is then raised until it can
   (each climber chosen for tolerance / :data:`INTERPOLATION_MARGIN`) where the modelled cost
   of the raise over the batch is below :data:`PILOTS_PER_CLIMBER` solves per climber it
   spares (from a start transient it seldom is: √3 times the steps); else the gaps are
   bisected, and in the worst case every case climbs.
   **A sweep of periodic states is searched for resonances** (with ``spectra`` injected, as
   :mod:`ced.simulation.simulate` does). Its error varies slowly in speed except where a crank
   harmonic meets a mode's mean frozen frequency, a resonance narrower than the climbers'
   spacing whose neighbours' errors do not see it (the benchmark's undamped 4:1 at 90.9 rad/s:
   2.2 % at 90.81 rad/s between climbers 0.1 % off, when the climbers were sparser). The frozen
   spectra of the first climbers (:func:`ced.response.resonance.cycle_spectrum`), interpolated
   in speed, give every case's resonance weight W
   (:func:`ced.response.resonance.resonance_weight`), about proportional to the part of its
   error a resonance drives; a case between climbers is predicted to err
   :data:`INTERPOLATION_MARGIN` × the larger of their errors each scaled by W over theirs
   (:func:`interpolated_error`), and where that exceeds the bar the case where it is largest
   climbs. Found so, a resonance need not be met by bisection, so the first climbers are
   every :data:`PERIODIC_STRIDE`-th case.

6. **A Fourier series climbs no time ladder.** With ``periodic_solver: spectral`` the
   periodic state is a series whose time error is its spectral tail
   (:mod:`ced.response.collocation`), which its adaptive collocation points keep below
   ``time.spectral_tail``; ``auto`` sets that to :data:`SERIES_SHARE` of tolerance /
   :data:`SAFETY` (or the scene's own, where tighter) and adds it to the prediction as a time
   error that holds at any steps; its space ladder climbs to :data:`SERIES_SPACE_SHARE` of
   the marched ladders' budget (the rungs are cheap, and the finer measured error lets the
   sweep's other cases be bounded by it), and the mesh chosen is one of its rungs (a reduced
   series costs about the same at any mesh, and between rungs the interpolated error was
   found short: the convergence study's slider-crank at 1e-3, 7.5e-4 at 5 elements where
   4.6e-4 was interpolated from 4 and 8). The pilots are series at the scene's own steps
   (its output instants): the first rung, the space ladder and the truncation; none of them
   needs the modal analysis, and a case that does not climb solves no pilot (its first mode decides
   nothing here). Between climbers :data:`INTERPOLATION_MARGIN` multiplies the measured part
   only: each case keeps its own tail bound. A full mesh slows a series' GMRES (its stiff
   interior modes), so its truncation pilot is solved at :data:`SERIES_FULL_POINTS` fixed
   points, where GMRES may iterate longer, and with a series in the call the full mesh is
   chosen only where no reduced model exists (4 elements or fewer). A case with a pilot shot
   instead (near a change point, or GMRES did not converge: a shot pilot carries the output
   steps' time error, unmeasured) climbs the marched ladders like any other, and so does
   every such case of its sweep that was solved; one predicted as a series but shot in its
   own solve gets the companions of :mod:`ced.auto.error_estimate` instead of the prediction,
   and one whose own tail ends above the bound (a resonant series left unresolved) adds the
   excess to it (:mod:`ced.simulation.simulate`). On the benchmark's sweep from a periodic
   start (100 speeds, ``tolerance: 1e-2``, ``benchmarks/auto_pilots.json``) this chose 15
   elements and 4 modes in 0.44–0.51 s where the shooting ladders chose 31 elements, 4 modes
   and 3592 steps per revolution in 2.9–4.9 s (the same run); true error at most 0.10 % at
   every speed against 32 elements of every FE DOF at 256 points, 98 of the 100 within their
   estimates (the other two 1.5e-5 and 3.5e-6 off).

One discretization serves all ``auto`` scenes of a call, the cheapest at which every climber
is predicted to meet its tolerance (:func:`choose_shared`), so that they share one time grid
(one ``step`` dimension) and batch together. Per case the variable
``discretization_auto`` (JSON) records the choice and the predicted error, and whether the
tolerance was reachable within the ladders' limits (where it was not, the ladders' finest
rungs are used and ``status`` has ``tolerance_unmet``); a climber also its own choice
(elements, steps, modes), both ladders and its truncation (``ladder: own``), a case that did
not climb the two climbers whose ladders bound it (``ladder: interpolated``,
``ladder_cases``, ``interpolation_margin``). The predicted error at
the chosen setting is also the case's ``error_estimate``: the ladders are its companion
solutions (``ced.auto.error_estimate``'s are not run for ``auto`` cases). Cases that differ
only in name share one set of ladders: a batch of identical cases pays for one case's pilots.
"""
from __future__ import annotations

import copy
import marshal
import math
from typing import Callable, NamedTuple

import numpy as np

from ..problem.scene import SPECTRAL_TAIL, dump_scene
from ..response.resonance import resonance_weight
from .error_estimate import TIME_ORDER

__all__ = ["resolve_discretization", "ladder_errors", "interpolate", "predicted_error",
           "MODE_CHOICES", "choose_shared",
           "choose", "cost", "sweeps", "sweep_key", "representatives", "bracket", "unverified",
           "interpolated_error", "MODES", "SAFETY", "STRIDE", "PERIODIC_STRIDE",
           "INTERPOLATION_MARGIN", "PILOTS_PER_CLIMBER", "SERIES_SHARE",
           "SERIES_SPACE_SHARE", "SERIES_FULL_POINTS"]

#: Order of peak stress in space with superconvergent recovery (observed 8× per halving).
SPACE_ORDER = 3

#: Fixed-interface modes per flexible link a reduced model may keep; the full mesh (0) is the
#: third choice. Their truncation is measured against the full mesh per climber (module
#: docstring, stage 3).
MODE_CHOICES = (4, 8)
#: Modes per flexible link of the ladders' reduced model: the most a choice keeps, so that the
#: ladders see (and, from a start transient, resolve) every mode a chosen model has.
MODES = max(MODE_CHOICES)
#: Interior DOFs of a reduced link beyond its modes: the static load vectors.
STATIC_VECTORS = 5
#: Interior DOFs of the reduced link :data:`COST` was fitted at (4 modes).
_FITTED_DOFS = 4 + STATIC_VECTORS
#: Elements per link of the time ladder.
LADDER_ELEMENTS = 8
#: First rung of the time ladder, and the fewest steps per revolution chosen: 8 steps per
#: period of the 4th crank harmonic.
FIRST_STEPS = 32
#: Finest rungs of the ladders (and of the choice): a tolerance they do not reach is flagged.
MAX_LADDER_STEPS, MAX_LADDER_ELEMENTS = 4096, 128
#: A mode below this crank harmonic can be resonantly excited: the time ladder resolves it,
#: ω₁h ≤ RESOLVED (the asymptotic range of the integrators, as in ``ced.auto.error_estimate``).
RESONANT_HARMONICS, RESOLVED = 16, 0.5
#: A ladder is in its asymptotic range where its last two changes fall at an observed order
#: within these of the theoretical one (the space ladder's 2 to 3 included); only then is its
#: limit extrapolated. From a start transient the ringing modes' phases wrap between rungs
#: (the benchmark sweep's peak stress moves by up to 1.6 % between 1,024 and 8,192 steps per
#: revolution, erratically), and a Richardson correction there under-states the error.
ASYMPTOTIC_ORDERS = (-1.0, 1.5)
#: Predicted error must be below tolerance / SAFETY. The rungs' errors are measured against
#: each ladder's extrapolated limit, which is itself uncertain by up to the last rung's error
#: (at most tolerance / (2 SAFETY)): the margin covers the two.
SAFETY = 1.5
#: Every STRIDE-th case of a sweep (its cases sorted by speed) climbs the ladders, and both
#: ends: 14 of the benchmark's 100 speeds (module docstring, stage 5).
STRIDE = 8
#: The same for a sweep of periodic states, whose errors vary slowly in speed except at a
#: resonance, which is searched for instead (:func:`unverified`): 4 of the benchmark's 100
#: speeds, at most the largest stride :data:`INTERPOLATION_MARGIN` was measured at.
PERIODIC_STRIDE = 33
#: A case of a sweep that does not climb is predicted to err at most INTERPOLATION_MARGIN times
#: the larger of its two bracketing climbers' errors at the chosen setting. Measured on the
#: ladders of every case of the benchmark's 100-speed sweep (undeformed start, strides 4–11;
#: periodic start, strides 4–33), the whole procedure replayed on them: with 3 every case's
#: own-ladder error at the chosen setting was within its prediction; with 2 one case of the
#: undeformed sweep (95.45 rad/s, 1.6 %) was missed by 3.3–3.8× at strides 6 and 11, with 1.5
#: by up to 5×. The bound is the larger error times a factor, not the larger plus a multiple of
#: the two's difference: that one bounded sweeps whose cases all need the same setting, but it
#: missed the same case by 4× at stride 11.
INTERPOLATION_MARGIN = 3.0
#: Solve time per case, ms, of a batch of 4 on one core (least squares over the convergence
#: study's Euler–Bernoulli generalized-α settings, the full mesh up to 4 elements and reduced
#: meshes above; within −20 %/+25 % of the measured time for 90 % of them):
#: fixed per case, reduction per flexible link at 128 elements (∝ n_e²), per step and flexible
#: link of a reduced link, and of a full link (constant + per interior DOF).
COST = {"case": 2.4, "reduction": 41.0, "step_reduced": 0.037, "step_full": 0.018,
        "step_full_dof": 0.0032}
#: A climber's pilots cost about this many of its final solves (the benchmark's 100-speed
#: sweep: 4.1–4.2 undamped, marched and as series; 4–6 damped, as series). Where raising the
#: shared setting costs the batch less than that per climber it spares, it is raised instead
#: of bisecting (stage 5).
PILOTS_PER_CLIMBER = 4.0
#: Share of tolerance / :data:`SAFETY` left to a Fourier series' time error (its spectral
#: tail, stage 6). The tail falls exponentially with the collocation points, so a tenth costs
#: at most a doubling of them more than the default 0.5 % does, and leaves the mesh and the
#: model nine tenths of the budget.
SERIES_SHARE = 0.1
#: A series' space ladder climbs until its last rung errs at most this share of the budget
#: a marched one stops at (stage 6).
SERIES_SPACE_SHARE = 1.0 / 3.0
#: Fixed collocation points of a series' full-mesh truncation pilot. A full mesh's stiff
#: interior modes slow the series' GMRES (the rocker-crank reference at 8 elements: 157
#: iterations at 32 points, where 4 and 8 modes take 28, and the adaptive ladder's first level
#: shoots a case past :data:`ced.response.collocation.MAX_ITERATIONS`); at fixed points above
#: the first level it may iterate as long as a ladder's higher levels do (190 there).
SERIES_FULL_POINTS = 64
_ELEMENTS = np.unique(np.round(np.geomspace(2, 256, 40)).astype(int))


def _pilot(scene: dict, elements: int, steps: int, modes: int = MODES) -> dict:
    # The blocks it changes are new, the others shared: normalized scenes are never changed
    # in place, and a deep copy of each of a sweep's 355 pilots was 13 % of their time.
    # The full mesh where a reduced link would be no smaller (it keeps every mode).
    modes = modes if _reduced_allowed(elements, modes) else 0
    time = {**scene["time"], "steps_per_revolution": steps}
    if time["start"] == "periodic" and time["revolutions"] >= 1.0:
        time["revolutions"] = 1.0  # the periodic state: one revolution has every peak
    return {**scene, "time": time, "modal": None,
            "discretization": {"formulation": "euler_bernoulli", "elements_per_link": elements,
                               "elements_across": 2, "modes_per_link": modes},
            "outputs": {**scene["outputs"], "every": 1, "error_estimate": False}}


def _reduced_allowed(elements, modes: int = MODES):
    """A reduced link is smaller than the full mesh (3n_e − 3 interior DOFs)."""
    return 3 * np.asarray(elements) - 3 > modes + STATIC_VECTORS


def _full_cost(elements, steps, revolutions: float, flexible_links: int) -> np.ndarray:
    """Modelled solve time per case of the full mesh, ms (:data:`COST`)."""
    ne = np.asarray(elements, float)
    return COST["case"] + flexible_links * np.asarray(steps, float) * revolutions * (
        COST["step_full"] + COST["step_full_dof"] * (3.0 * ne - 3.0))


def _full_measured(elements):
    """Meshes whose space-ladder pilots are the full mesh (a reduced link of :data:`MODES`
    modes would be no smaller): only there does the space ladder measure the full mesh's
    error, so only there may it be chosen."""
    return ~_reduced_allowed(elements, MODES)


def _reduced_cost(elements, steps, revolutions: float, flexible_links: int,
                  modes: int = MODES) -> np.ndarray:
    """Modelled solve time per case of the reduced model, ms, infinite where it is no smaller
    than the full mesh; its per-step cost, fitted at 4 modes, scaled by its DOFs."""
    ne = np.asarray(elements, float)
    per_step = COST["step_reduced"] * (modes + STATIC_VECTORS) / _FITTED_DOFS
    reduced = COST["case"] + flexible_links * (
        COST["reduction"] * (ne / 128.0) ** 2
        + per_step * np.asarray(steps, float) * revolutions)
    return np.where(_reduced_allowed(ne, modes), reduced, np.inf)


def cost(elements, steps, revolutions: float, flexible_links: int, modes: int = MODES):
    """Modelled solve time per case, ms, and whether the full mesh is the cheaper model.

    Parameters
    ----------
    elements, steps : array_like
        Elements per link and steps per revolution.
    revolutions : float
        Simulated input periods.
    flexible_links : int
        Number of flexible links of the scene.
    modes : int
        Modes per link of the reduced model.

    Returns
    -------
    cost : ndarray
        ms per case (:data:`COST`), of the cheaper of the full and the reduced model.
    full : ndarray of bool
        True where the full mesh is cheaper than the reduced one.
    """
    full = _full_cost(elements, steps, revolutions, flexible_links)
    reduced = _reduced_cost(elements, steps, revolutions, flexible_links, modes)
    return np.minimum(reduced, full), full <= reduced


def ladder_errors(peaks, order: float = TIME_ORDER) -> np.ndarray:
    """Relative error of each rung of a refinement ladder (the step halved from rung to rung).

    Parameters
    ----------
    peaks : array_like, at least 3 values
        Peak stress at each rung, coarsest first.
    order : float
        Convergence order assumed for the extrapolated limit.

    Returns
    -------
    ndarray
        Where the last three rungs converge at about ``order`` (:data:`ASYMPTOTIC_ORDERS`),
        |σ_k − σ_∞|/|σ_∞| with σ_∞ Richardson-extrapolated from the last two rungs, the last
        rung's the larger of its Richardson correction and the previous one's divided by
        2^order. Elsewhere the ladder is not in its asymptotic range and earns no
        extrapolation: the last rung's error is the larger of its own change and the previous
        one's divided by 2^order, and another rung's its distance to the last plus that.
        Non-increasing under refinement (module docstring, stage 4).
    """
    sigma = np.asarray(peaks, float)
    last, previous = abs(sigma[-1] - sigma[-2]), abs(sigma[-2] - sigma[-3])
    ratio = 2.0**order - 1.0
    if _asymptotic(previous, last, order):
        limit = sigma[-1] + (sigma[-1] - sigma[-2]) / ratio
        error = np.abs(sigma - limit)
        error[-1] = max(last / ratio, previous / (ratio * 2.0**order))
    else:  # σ_K is no limit: a rung errs by its distance to σ_K plus σ_K's own error
        limit = sigma[-1]
        error = np.abs(sigma - limit)
        error[-1] = max(last, previous / 2.0**order)
        error[:-1] += error[-1]
    error = np.maximum.accumulate(error[::-1])[::-1]
    if limit == 0.0:  # extrapolated to zero: a relative error is unbounded unless there is none
        return np.where(error == 0.0, 0.0, np.inf)
    return error / abs(limit)


def _asymptotic(previous: float, last: float, order: float) -> bool:
    """Whether two successive changes of a ladder fall at an observed order within
    :data:`ASYMPTOTIC_ORDERS` of ``order`` (both zero: converged)."""
    if last == 0.0:
        return previous == 0.0
    low, high = (2.0 ** (order + shift) for shift in ASYMPTOTIC_ORDERS)
    return low <= previous / last <= high


def interpolate(levels, errors, at, order: float = TIME_ORDER,
                steepest: float = 4.0**TIME_ORDER) -> np.ndarray:
    """The error at refinement ``at`` from a ladder's errors (module docstring, stage 4).

    Parameters
    ----------
    levels, errors : array_like
        The ladder's rungs (elements or steps, each twice the previous) and their errors.
    at : array_like
        Where the error is wanted.
    order : float
        Order at which the error is extrapolated beyond the finest rung (the lowest one
        expected: the safe side towards finer settings).
    steepest : float
        Largest error ratio between neighbouring rungs taken as a power law: that of twice
        the theoretical order (16 in time, 64 in space).

    Returns
    -------
    ndarray
        Between rungs k and k+1 the power law through e_k and e_{k+1} (the local observed
        order) where their ratio is at most ``steepest``, else e_k: a steeper drop is
        pre-asymptotic (a mode resolved between the two rungs) and says nothing about the
        error in between. Beyond the finest rung e_K (l_K/at)^order; below the coarsest
        infinite (not measured).
    """
    levels, errors = np.asarray(levels, float), np.asarray(errors, float)
    at = np.asarray(at, float)
    finer = np.searchsorted(levels, at, side="left").clip(1, len(levels) - 1)
    e_fine, e_coarse = errors[finer], errors[finer - 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        local = np.log(e_coarse / e_fine) / np.log(levels[finer] / levels[finer - 1])
        power = e_fine * (levels[finer] / at) ** local
        asymptotic = e_coarse <= steepest * e_fine
    between = np.where(asymptotic & (e_fine > 0) & np.isfinite(e_fine), power, e_coarse)
    beyond = errors[-1] * (levels[-1] / at) ** order
    out = np.where(at >= levels[-1], beyond, np.where(at == levels[finer], e_fine, between))
    return np.where(at < levels[0], np.inf, out)


def predicted_error(space: tuple, time: tuple, elements, steps) -> np.ndarray:
    """E_x(n_e) + E_t(s_r) from the space and time ladders, each (levels, errors).

    Parameters
    ----------
    space : tuple
        The space ladder ``(levels, errors)``: elements per link of each rung and its relative
        error on peak stress.
    time : tuple
        The time ladder ``(levels, errors)``: steps per revolution of each rung and its relative
        error on peak stress.
    elements : array_like
        Elements per link at which the error is predicted.
    steps : array_like
        Steps per revolution at which the error is predicted (broadcast against ``elements``).

    Returns
    -------
    numpy.ndarray
        Predicted relative error on peak stress (dimensionless), of the broadcast shape of
        ``elements`` and ``steps``.
    """
    return (interpolate(*space, elements, order=2.0, steepest=4.0**SPACE_ORDER)
            + interpolate(*time, steps))


def choose(space: tuple, time: tuple, tolerance: float, revolutions: float,
           flexible_links: int, truncation: dict[int, float]) -> tuple[int, int, int, float]:
    """The cheapest (elements, steps per revolution, modes per link) meeting the tolerance.

    Parameters
    ----------
    space, time : (levels, errors)
        The space ladder (elements per link) and the time ladder (steps per revolution) with
        their errors (:func:`ladder_errors`).
    tolerance : float
        Target relative error on peak stress.
    revolutions : float
        Simulated input periods.
    flexible_links : int
        Number of flexible links.
    truncation : dict of int to float
        Relative error on peak stress of a reduced model keeping each of
        :data:`MODE_CHOICES` modes per link, measured against the full mesh; it adds to the
        discretization error (the full mesh, 0 modes, has none).

    Returns
    -------
    elements, steps, modes (0: the full mesh) and the predicted error. Where no setting of the
    grid is predicted to meet the target, the ladders' finest rungs (measured, not
    extrapolated), with the least truncated reduced model (or the full mesh where it is
    measured and cheaper), and their predicted error.
    """
    return choose_shared([(space, time, truncation)], tolerance, revolutions, flexible_links)


def choose_shared(ladders: list[tuple], tolerance, revolutions: float,
                  flexible_links: int) -> tuple[int, int, int, float]:
    """:func:`choose` for several cases at once: the cheapest setting at which every one of
    them is predicted to meet the tolerance, and the largest of their predicted errors there.

    Parameters
    ----------
    ladders : list of (space, time, truncation) or (space, time, truncation, floor)
        Each case's ladders and truncation errors, as for :func:`choose`, and a time error
        that holds at any steps (a Fourier series' bound, stage 6; default 0). The steps
        considered include every time ladder's rungs.
    tolerance : float or array_like
        Target relative error on peak stress, of all cases or of each.
    revolutions, flexible_links
        As for :func:`choose`.

    Returns
    -------
    elements, steps, modes (0: the full mesh) and the largest predicted error. Where no
    setting meets the target, the finest rungs of any of the ladders.
    """
    floors = np.array([ladder[3] if len(ladder) > 3 else 0.0 for ladder in ladders])
    ladders = [ladder[:3] for ladder in ladders]
    # Within the ladders: they climb until their finest rungs meet the target with room to
    # spare, so a setting beyond them is only wanted where they did not converge.
    rungs = np.concatenate([np.asarray(t[0], float) for _, t, _ in ladders]).astype(int)
    steps = np.union1d(np.arange(FIRST_STEPS, rungs.max() + 1, 8), rungs)
    elements = _ELEMENTS[_ELEMENTS <= max(x[0][-1] for x, _, _ in ladders)]
    if floors.any():
        # With a series in the call, only meshes its space ladders measured: a reduced
        # series' solve costs about the same at any mesh (its DOFs are its modes), and between
        # rungs the error is interpolated, which has been found short (the convergence
        # study's slider-crank: 7.5e-4 at 5 elements, interpolated 4.6e-4 from 4 and 8).
        elements = np.unique(np.concatenate([x[0] for x, _, _ in ladders])).astype(int)
    discretization = np.array([predicted_error(x, t, elements[:, None], steps[None, :])
                               for x, t, _ in ladders]) + floors[:, None, None]
    bar = np.broadcast_to(np.asarray(tolerance, float), (len(ladders),)) / SAFETY
    best = (np.inf, None)
    # A series' GMRES converges far more slowly on a full mesh than on a reduced one (its
    # stiff interior modes: the rocker-crank reference at 5 elements needed over 100
    # iterations at 32 points where 4 modes took 28), and a series that does not converge
    # is shot at the output steps, whose time error no ladder measured: with a series in the
    # call the full mesh is chosen only where no reduced model exists.
    full = _full_measured(elements) & ~(
        floors.any() & _reduced_allowed(elements, min(MODE_CHOICES)))
    for modes in (0,) + tuple(MODE_CHOICES):
        model_cost = (_reduced_cost(elements[:, None], steps[None, :], revolutions,
                                    flexible_links, modes) if modes else
                      np.where(full[:, None],
                               _full_cost(elements[:, None], steps[None, :], revolutions,
                                          flexible_links), np.inf))
        cut = np.array([cut[modes] if modes else 0.0 for _, _, cut in ladders])
        each = discretization + cut[:, None, None]
        model_cost = np.where((each <= bar[:, None, None]).all(axis=0), model_cost, np.inf)
        predicted = each.max(axis=0)
        i, j = np.unravel_index(np.argmin(model_cost), model_cost.shape)
        if model_cost[i, j] < best[0]:
            best = (model_cost[i, j], (int(elements[i]), int(steps[j]), modes,
                                       float(predicted[i, j])))
    if best[1] is not None:
        return best[1]
    elements = int(max(x[0][-1] for x, _, _ in ladders))
    steps = int(max(t[0][-1] for _, t, _ in ladders))
    finest = np.array([predicted_error(x, t, elements, steps) for x, t, _ in ladders]) + floors
    modes = min(MODE_CHOICES, key=lambda m: max(cut[m] for _, _, cut in ladders))
    full = _full_measured(elements) and not (
        floors.any() and _reduced_allowed(elements, min(MODE_CHOICES)))
    if full and bool(cost(elements, steps, revolutions, flexible_links, modes)[1]):
        return elements, steps, 0, float(finest.max())
    cut = np.array([cut[modes] for _, _, cut in ladders])
    return elements, steps, modes, float((finest + cut).max())


def _tails(solved: dict, n: int) -> np.ndarray:
    """The pilots' spectral tails (NaN where the periodic state was not a series, or for a
    solver that reports none)."""
    return np.asarray(solved.get("tail", np.full(n, np.nan)), float)


def _ladder(scenes: list[dict], solve: Callable, rungs: Callable[[int], tuple[list, list]],
            done: Callable[[int, list[float]], bool], limit: int,
            known: list[dict[int, float]], shot: list[bool] | None = None
            ) -> list[list[float]]:
    """Peaks of each scene's ladder. Rung r of scene j is (elements[j], steps[j]) =
    ``rungs(r)``, solved batched over the scenes still climbing until ``done(j, peaks)`` or
    ``limit`` rungs; ``known[j]`` holds rungs already solved (rung → peak); ``shot[j]`` is
    set where a pilot's periodic state was not a Fourier series."""
    peaks: list[list[float]] = [[] for _ in scenes]
    climbing = list(range(len(scenes)))
    for rung in range(limit):
        elements, steps = rungs(rung)
        todo = [j for j in climbing if rung not in known[j]]
        if todo:
            solved = solve([_pilot(scenes[j], elements[j], steps[j]) for j in todo])
            for j, peak, tail in zip(todo, solved["peak"], _tails(solved, len(todo))):
                known[j][rung] = float(peak)
                if shot is not None and not np.isfinite(tail):
                    shot[j] = True
        for j in climbing:
            peaks[j].append(known[j][rung])
        climbing = [j for j in climbing if not done(j, peaks[j])]
        if not climbing:
            break
    return peaks


class _Climbed(NamedTuple):
    """A case's ladders, each (levels, errors), the steps of its space ladder, the
    truncation of each of :data:`MODE_CHOICES` (modes → relative error) at the finest rung of
    its time ladder, and the bound on its time error that holds at any steps: a Fourier
    series' spectral tail (0 for a marched or shot case, whose time error is its ladder's)."""

    space: tuple
    time: tuple
    space_steps: int
    truncation: dict[int, float]
    time_floor: float = 0.0
    #: A pilot of this series case was shot instead (GMRES did not converge): its peak has
    #: the output steps' time error, which no ladder measured; the case climbs marched.
    lost_series: bool = False


def _climb(work: list[dict], solve: Callable, first_peaks: list[float],
           resolved_at: np.ndarray, budget: list[float], series: np.ndarray
           ) -> list[_Climbed]:
    """Stages 1–3 of the module docstring for each scene, batched across them: the time ladder
    from its first rung (``first_peaks``, solved with the modal analysis), then the space
    ladder at the coarsest time rung within the tolerance that
    resolves what the time ladder had to (else the finest), and the truncation at the finest
    time rung. A Fourier series (``series``, stage 6) climbs no time ladder: its first rung,
    at the scene's own steps, is where its space ladder and truncation are measured."""
    marched = [j for j in range(len(work)) if not series[j]]
    time_peaks: list[list[float]] = [[peak] for peak in first_peaks]
    if marched:
        known = [{0: first_peaks[j]} for j in marched]
        n_time = int(math.log2(MAX_LADDER_STEPS // FIRST_STEPS)) + 1

        def time_done(k: int, peaks: list[float]) -> bool:
            steps = FIRST_STEPS << (len(peaks) - 1)
            return (len(peaks) >= 3 and steps >= resolved_at[marched[k]]
                    and ladder_errors(peaks)[-1] <= budget[marched[k]])

        climbed = _ladder([work[j] for j in marched], solve,
                          lambda r: ([LADDER_ELEMENTS] * len(marched),
                                     [FIRST_STEPS << r] * len(marched)),
                          time_done, n_time, known)
        for j, peaks in zip(marched, climbed):
            time_peaks[j] = peaks
    time_levels, time_errors, space_steps, at_steps = [], [], [], []
    for j, peaks in enumerate(time_peaks):
        if series[j]:  # its time error is its tail, bounded at any steps: none left to steps
            levels = np.array([float(work[j]["time"]["steps_per_revolution"])])
            errors = np.zeros(1)
            chosen = int(levels[0])
        else:
            levels = FIRST_STEPS * 2.0 ** np.arange(len(peaks))
            errors = ladder_errors(peaks)
            within = np.flatnonzero((errors <= work[j]["tolerance"])
                                    & (levels >= resolved_at[j]))
            chosen = int(levels[within[0]] if len(within) else levels[-1])
        time_levels.append(levels)
        time_errors.append(errors)
        space_steps.append(chosen)
        at_steps.append(peaks[int(np.flatnonzero(levels == chosen)[0])])
    rungs_x = [2 << r for r in range(int(math.log2(MAX_LADDER_ELEMENTS)))]
    at_ladder_mesh = rungs_x.index(LADDER_ELEMENTS)
    known = [{at_ladder_mesh: peak} for peak in at_steps]

    def space_done(j: int, peaks: list[float]) -> bool:
        # A series' space rungs are cheap beside its final solve: it climbs to a finer
        # error, which the sweep's other cases are then bounded by (stage 5).
        share = SERIES_SPACE_SHARE if series[j] else 1.0
        return len(peaks) >= 3 and ladder_errors(peaks, order=2.0)[-1] <= share * budget[j]

    shot = [False] * len(work)
    space_peaks = _ladder(work, solve, lambda r: ([rungs_x[r]] * len(work), space_steps),
                          space_done, len(rungs_x), known, shot)
    truncation = _truncation(work, solve, [int(levels[-1]) for levels in time_levels],
                             [peaks[-1] for peaks in time_peaks], series, shot)
    return [_Climbed((np.array(rungs_x[:len(sp)], float), ladder_errors(sp, order=2.0)),
                     (levels, errors), steps, cut,
                     _series_bound(scene) if in_series else 0.0, bool(in_series and lost))
            for sp, levels, errors, steps, cut, scene, in_series, lost in zip(
                space_peaks, time_levels, time_errors, space_steps, truncation, work, series,
                shot)]


def _truncation(work: list[dict], solve: Callable, steps: list[int],
                ladder_peaks: list[float], series: np.ndarray | None = None,
                shot: list[bool] | None = None) -> list[dict[int, float]]:
    """Per scene the relative error on peak stress of a reduced model with each of
    :data:`MODE_CHOICES` modes per link against the full mesh, both at
    :data:`LADDER_ELEMENTS` elements and its ``steps`` per revolution, the finest rung of its
    time ladder, whose peak (of the :data:`MODES` model) is ``ladder_peaks`` (module
    docstring, stage 3). A series' full mesh is solved at :data:`SERIES_FULL_POINTS` fixed
    points, and its tail (its time error) added to the truncation; ``shot[j]`` is set where
    a series' pilot was shot instead."""
    series = np.zeros(len(work), bool) if series is None else np.asarray(series, bool)
    modes = [0] + [m for m in MODE_CHOICES if m != MODES]
    pilots = []
    for m in modes:
        for scene, s, in_series in zip(work, steps, series):
            pilot = _pilot(scene, LADDER_ELEMENTS, s, m)
            if in_series and not m:  # fixed points: no tail to stop at
                pilot["time"] = {**pilot["time"], "collocation_points": SERIES_FULL_POINTS,
                                 "spectral_tail": SPECTRAL_TAIL}
            pilots.append(pilot)
    solved = solve(pilots)
    peaks = dict(zip(modes, np.asarray(solved["peak"], float).reshape(len(modes), len(work))))
    tails = _tails(solved, len(pilots)).reshape(len(modes), len(work))
    if shot is not None:
        for j in np.flatnonzero(series & ~np.isfinite(tails).all(axis=0)):
            shot[j] = True
    peaks[MODES] = np.asarray(ladder_peaks, float)
    full = peaks[0]
    own_time = np.where(series, np.nan_to_num(tails[0], nan=0.0), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        errors = {m: np.where(full == 0.0, np.where(peaks[m] == 0.0, 0.0, np.inf),
                              np.abs(peaks[m] - full) / np.abs(full) + own_time)
                  for m in MODE_CHOICES}
    # A failed pilot (NaN) leaves an infinite truncation: that model is never chosen.
    return [{m: float(np.nan_to_num(errors[m][j], nan=np.inf)) for m in MODE_CHOICES}
            for j in range(len(work))]


def sweep_key(scene: dict) -> bytes:
    """A key of a normalized scene without its name and drive speed: equal keys, one sweep in
    speed. :mod:`marshal`'s bytes, as :func:`ced.response.model_cache.model_key`'s: equal
    bytes are equal scenes, and a scene holding a value differently (another key order, 1
    against 1.0) only climbs its own ladders. A fifth of the canonical JSON's time
    (:func:`ced.problem.scene.dump_scene`), which was 8 % of the pilots of a 100-speed sweep.

    Parameters
    ----------
    scene : dict
        A normalized scene (:func:`ced.problem.scene.load_scene`).

    Returns
    -------
    bytes
        Equal for scenes of one sweep in speed (:func:`sweeps`).
    """
    drive = {k: v for k, v in scene["drive"].items() if k != "speed"}
    try:
        return marshal.dumps({**scene, "name": "", "drive": drive}, 2)
    except ValueError:  # a value marshal does not write (not one load_scene makes)
        return dump_scene({**scene, "name": "", "drive": drive}).encode()


def _pilot_key(scene: dict) -> tuple[bytes, float]:
    """A key of a normalized scene without its name: equal keys, equal pilots."""
    return sweep_key(scene), scene["drive"]["speed"]


def sweeps(keys: list, speeds) -> list[np.ndarray]:
    """Cases that differ only in their speed, each group sorted by speed.

    Parameters
    ----------
    keys : list of hashable
        Each case's scene without its name and speed (:func:`sweep_key`).
    speeds : array_like
        Each case's input speed, rad/s.

    Returns
    -------
    list of numpy.ndarray
        Per sweep the indices of its cases, by increasing speed (ties by index); in the order
        of each sweep's first case.
    """
    speeds = np.asarray(speeds, float)
    groups: dict = {}
    for i, key in enumerate(keys):
        groups.setdefault(key, []).append(i)
    return [np.array(sorted(g, key=lambda i: (speeds[i], i)), int) for g in groups.values()]


def representatives(n: int, stride: int = STRIDE) -> np.ndarray:
    """Positions, in a sweep of ``n`` cases sorted by speed, of the cases that climb first:
    every ``stride``-th and the last, so that no case lies outside two climbers.

    Parameters
    ----------
    n : int
        Cases in the sweep.
    stride : int
        Positions between climbers (1: every case climbs).

    Returns
    -------
    numpy.ndarray
        Sorted positions (int), 0 and n − 1 included.
    """
    return np.unique(np.append(np.arange(0, n, max(1, stride)), n - 1))


def bracket(climbed, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The climbers on either side of each position of a sweep (a climber is its own pair).

    Parameters
    ----------
    climbed : array_like of int
        Sorted positions of the climbers, 0 and n − 1 included.
    n : int
        Cases in the sweep.

    Returns
    -------
    below, above : numpy.ndarray
        Per position the nearest climber at or below it and at or above it.
    """
    climbed = np.asarray(climbed, int)
    position = np.arange(n)
    above = climbed[np.searchsorted(climbed, position, side="left")]
    below = climbed[np.searchsorted(climbed, position, side="right") - 1]
    return below, above


def interpolated_error(errors, weights=None, weight=None,
                       margin: float = INTERPOLATION_MARGIN):
    """Predicted error of a case of a sweep between two climbers.

    ``margin`` × the larger of the two climbers' errors, each first scaled by how much more
    strongly a resonance drives the case than that climber (its weight over the climber's,
    at least 1): the part of the error a resonance drives is bounded by about a constant times
    the weight (:func:`ced.response.resonance.resonance_weight`), so a climber far from a
    resonance, or one whose error the resonance happens to cancel, still bounds a case on it.

    Parameters
    ----------
    errors : (2,) array_like
        The two climbers' errors at the chosen setting.
    weights : (2,) array_like, optional
        Their resonance weights (None: no resonance search, plain ``margin`` × the larger).
    weight : float or (m,) array_like, optional
        The case's (or each of m cases') resonance weight.
    margin : float
        :data:`INTERPOLATION_MARGIN`.

    Returns
    -------
    float or numpy.ndarray
        The predicted relative error, of the shape of ``weight``.
    """
    errors = np.asarray(errors, float)
    if weights is None:
        return margin * errors.max()
    weights, weight = np.asarray(weights, float), np.asarray(weight, float)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        scale = np.where(weight[..., None] > weights, weight[..., None] / weights, 1.0)
        # a climber of no weight bounds no resonance: 0 × ∞ is no bound
        scaled = np.nan_to_num(errors * scale, nan=np.inf, posinf=np.inf)
        return margin * scaled.max(axis=-1)


def unverified(climbed, errors, top_steps, need_steps, bar: float,
               margin: float = INTERPOLATION_MARGIN, resonance=None) -> np.ndarray:
    """Positions of a sweep whose prediction from the climbers cannot be trusted, to climb.

    A position between two climbers is predicted to err as :func:`interpolated_error` says:
    ``margin`` × the larger of their errors at the chosen setting, scaled by the resonance
    weights where the sweep was searched for resonances (``resonance``). The prediction is not
    trusted, and the middle of the gap climbs next (bisection), where the unscaled one exceeds
    ``bar``, or where the rule fails at a climber itself: its error above the rule's
    prediction from its climbing neighbours (leave-one-out cross-validation: the error varies
    faster in speed than the spacing resolves). Where only the scaled one exceeds ``bar`` (a
    resonance inside the gap, narrower than the climbers' spacing), the position whose
    prediction is largest climbs. A position whose excitable first mode needs more steps per
    revolution than both climbers' time ladders reached climbs itself: their ladders did not
    look where its error may be.

    Parameters
    ----------
    climbed : array_like of int
        Sorted positions of the climbers, 0 and n − 1 included (n = len(need_steps)).
    errors : array_like
        Each climber's predicted error at the chosen setting (:func:`predicted_error`).
    top_steps : array_like
        Finest rung of each climber's time ladder, steps per revolution.
    need_steps : array_like
        Steps per revolution each position's first mode needs to be resolved (0 where the crank
        harmonics cannot excite it).
    bar : float
        Largest error a prediction may have: tolerance / :data:`SAFETY`.
    margin : float
        :data:`INTERPOLATION_MARGIN`.
    resonance : array_like, optional
        Each position's resonance weight (a periodic state's sweep,
        :func:`ced.response.resonance.resonance_weight`), or None.

    Returns
    -------
    numpy.ndarray
        Sorted positions to climb (none when every prediction is trusted).
    """
    climbed, errors = np.asarray(climbed, int), np.asarray(errors, float)
    need = np.asarray(need_steps, float)
    weight = None if resonance is None else np.asarray(resonance, float)
    out = set()

    def predicted(a: int, b: int, at):  # climbers a, b (indices into climbed), positions at
        if weight is None:
            return interpolated_error(errors[[a, b]], margin=margin)
        return interpolated_error(errors[[a, b]], weight[climbed[[a, b]]], weight[at], margin)

    # Leave-one-out at the inner climbers: a failure there opens both gaps around it.
    suspect = np.zeros(len(climbed), bool)
    for c in range(1, len(climbed) - 1):
        suspect[c] = errors[c] > predicted(c - 1, c + 1, climbed[c])
    for k, (low, high) in enumerate(zip(climbed[:-1], climbed[1:])):
        if high - low < 2:
            continue
        if suspect[k] or suspect[k + 1] or margin * max(errors[k], errors[k + 1]) > bar:
            out.add((low + high) // 2)
        elif weight is not None:
            inside = predicted(k, k + 1, np.arange(low + 1, high))
            if inside.max() > bar:
                out.add(low + 1 + int(np.argmax(inside)))
        reached = max(top_steps[k], top_steps[k + 1])
        out.update(int(p) for p in np.flatnonzero(need[low + 1:high] > reached) + low + 1)
    return np.array(sorted(out), int)


def _flexible_links(scene: dict) -> int:
    return sum(bool(link["flexible"]) for link in scene["links"].values())


def _spectral(scene: dict) -> bool:
    return scene["time"]["periodic_solver"] == "spectral"


def _series_bound(scene: dict) -> float:
    """The bound on a Fourier series' time error that its adaptive collocation keeps, from
    the scene's tolerance (:data:`SERIES_SHARE` of what a prediction may reach, stage 6), or
    the scene's own ``time.spectral_tail`` where that is tighter."""
    return min(scene["time"]["spectral_tail"], SERIES_SHARE * scene["tolerance"] / SAFETY)


def _with_series_bound(scene: dict) -> dict:
    """A spectral scene whose series stops refining at :func:`_series_bound` (others as
    they are)."""
    if not _spectral(scene):
        return scene
    return {**scene, "time": {**scene["time"], "spectral_tail": _series_bound(scene)}}


def _setting_for(scene: dict, elements: int, steps: int, modes: int) -> dict:
    # New blocks where it differs, the others shared, as for _pilot.
    scene = _with_series_bound(scene)
    return {**scene, "time": {**scene["time"], "steps_per_revolution": steps},
            "discretization": {"formulation": "euler_bernoulli", "elements_per_link": elements,
                               "elements_across": 2, "modes_per_link": modes}}


def _setting_cost(setting: tuple, revolutions: float, flexible_links: int) -> float:
    """Modelled solve time per case of (elements, steps, modes; 0: the full mesh), ms."""
    elements, steps, modes = setting
    if modes:
        return float(_reduced_cost(elements, steps, revolutions, flexible_links, modes))
    return float(_full_cost(elements, steps, revolutions, flexible_links))


def _ladder_report(climbed: _Climbed, choice: tuple) -> dict:
    elements, steps, modes, predicted = choice
    report = {"own_choice": [elements, steps, modes], "own_predicted_error": predicted,
              "truncation": {str(m): e for m, e in climbed.truncation.items()},
              "time_ladder": [[int(n), float(e)] for n, e in zip(*climbed.time)],
              "space_ladder": [[int(n), float(e)] for n, e in zip(*climbed.space)],
              "space_ladder_steps_per_revolution": climbed.space_steps}
    if climbed.time_floor:
        report["time_ladder"] = []  # a series climbs its collocation points instead
    return report


def _sweep_resonance(speeds, climbers, spectra: list[tuple]) -> np.ndarray:
    """Resonance weight at every position of a periodic sweep, from the frozen spectra at some
    of its positions (``climbers``, sorted), interpolated linearly in speed: a mode's mean
    frequency, its load's harmonics and its damping change slowly with speed (by 0.1 % over
    the benchmark's 90–110 rad/s), unlike the weight they give.

    Parameters
    ----------
    speeds : (n,) array_like
        The sweep's speeds, rad/s, increasing.
    climbers : sequence of int
        Positions whose spectra are known.
    spectra : list of (frequency, share, damping_ratio)
        At each of them, :func:`ced.response.resonance.cycle_spectrum` of one case.

    Returns
    -------
    numpy.ndarray
        (n,) :func:`ced.response.resonance.resonance_weight`.
    """
    speeds = np.asarray(speeds, float)
    known = speeds[list(climbers)]

    def along(values):
        values = np.stack([np.asarray(v, float) for v in values])
        flat = values.reshape(len(values), -1)
        return np.stack([np.interp(speeds, known, column) for column in flat.T],
                        axis=-1).reshape((len(speeds),) + values.shape[1:])

    return resonance_weight(speeds, *(along(part) for part in zip(*spectra)))


def resolve_discretization(scenes: list[dict], solve: Callable, stride: int | None = None,
                           spectra: Callable | None = None) -> tuple[list[dict], list[dict]]:
    """Replace ``discretization: auto`` in normalized scenes by a chosen discretization.

    Parameters
    ----------
    scenes : list of dict
        Normalized scenes; those with ``discretization == "auto"`` are resolved.
    solve : callable
        list of scenes → dict of (case,) arrays: ``peak`` (peak stress, Pa), ``omega1`` and
        ``omega_top`` (the first and the highest natural frequency asked for, each at its
        largest over the cycle, rad/s, when the scenes ask for a modal analysis), ``speed``
        (rad/s); injected by :mod:`ced.simulation.simulate` so the pilots are batched like
        any run.
    stride : int, optional
        Cases of a sweep between its first climbers (:func:`representatives`; 1: every
        distinct case climbs its own ladders). Default :data:`STRIDE`, and
        :data:`PERIODIC_STRIDE` for a sweep of periodic states searched for resonances.
    spectra : callable, optional
        list of scenes → per scene its frozen spectrum (frequency, share, damping_ratio) of
        :func:`ced.response.resonance.cycle_spectrum`, or None where it is not known;
        injected by :mod:`ced.simulation.simulate`. With it a periodic sweep's gaps are
        searched for resonances (:func:`unverified`); without, they are not.

    Returns
    -------
    scenes, reports
        The scenes with the chosen discretization, and per scene a report (empty dict when
        the scene was not ``auto``).
    """
    reports: list[dict] = [{} for _ in scenes]
    # Scenes that differ only in name share their ladders: the pilots of a batch of identical
    # cases are solved once, not once per case.
    representative: dict = {}
    keys = {i: _pilot_key(s) for i, s in enumerate(scenes) if s["discretization"] == "auto"}
    for i, key in keys.items():
        representative.setdefault(key, i)
    auto = list(representative.values())
    if not auto:
        return scenes, reports
    # A spectral scene's pilots refine their series to its share of the error budget.
    work = [_with_series_bound(scenes[i]) for i in auto]
    budget = [s["tolerance"] / (2.0 * SAFETY) for s in work]

    n = len(work)
    transient = np.array([s["time"]["start"] != "periodic" for s in work])
    spectral = np.array([_spectral(s) for s in work])
    omega1, resolved_at = np.full(n, np.nan), np.zeros(n)
    first_peaks: list[float | None] = [None] * n
    # Stage 6: a spectral case is taken for a series (no time ladder) until its first rung
    # says otherwise; one that does not climb is checked by its own solve (simulate).
    series = spectral.copy()
    bound = np.array([_series_bound(s) for s in work])

    def first_rungs(cases: list[int]) -> None:
        """Stage 1's first rung of these cases, where not solved yet. A marched case's carries
        the frozen modal analysis: its own frequencies decide what its time ladder would have
        to resolve. A spectral case's is solved at its own steps (its output instants: the
        series' peak does not depend on them), without one; where it falls back to shooting
        (near a change point, or GMRES did not converge) it climbs the marched ladders from
        their first rung like any other case."""
        todo = [j for j in cases if first_peaks[j] is None and series[j]]
        if todo:
            solved = solve([_pilot(work[j], LADDER_ELEMENTS,
                                   work[j]["time"]["steps_per_revolution"]) for j in todo])
            for j, peak, tail in zip(todo, solved["peak"], solved["tail"]):
                series[j] = bool(np.isfinite(tail))
                first_peaks[j] = float(peak) if series[j] else None
        todo = [j for j in cases if first_peaks[j] is None]
        if not todo:
            return
        first = [_pilot(work[j], LADDER_ELEMENTS, FIRST_STEPS) for j in todo]
        for s, j in zip(first, todo):
            s["modal"] = {"modes": max(1, MODES * _flexible_links(s)) if transient[j] else 1,
                          "angles": 4, "mode_shapes": False}
        solved = solve(first)
        for k, j in enumerate(todo):
            first_peaks[j] = float(solved["peak"][k])
            omega1[j] = solved["omega1"][k]
            # The time ladder must resolve (ωh ≤ 1/2) a mode the crank harmonics can excite
            # and, from a start transient, every mode of the ladders' model: the start rings
            # in all of them, and rungs that damp them numerically agree without converging.
            speed = solved["speed"][k]
            if transient[j]:
                resolved_at[j] = 2.0 * np.pi * solved["omega_top"][k] / speed / RESOLVED
            elif omega1[j] <= RESONANT_HARMONICS * speed:
                resolved_at[j] = 2.0 * np.pi * omega1[j] / speed / RESOLVED

    # Every marched case's first rung: its first mode may need finer steps than its climbing
    # neighbours' ladders reached (stage 5).
    first_rungs([j for j in range(n) if not spectral[j]])
    # Stage 5: sweeps climb from representatives; gaps that cannot be trusted are bisected.
    groups = sweeps([keys[i][0] for i in auto], [s["drive"]["speed"] for s in work])
    # A periodic state's resonances are narrower than the climbers' spacing: their places
    # come from the frozen spectra of the first climbers, and the climbers can be sparser
    # (stage 5). A sweep whose spectra are not known (a motion that repeats every two turns)
    # is not searched.
    resonance: list = [None] * len(groups)
    searched = [k for k, g in enumerate(groups) if spectra is not None and len(g) > 2
                and work[g[0]]["time"]["start"] == "periodic"]
    if searched:
        at = {k: representatives(len(groups[k]), stride or PERIODIC_STRIDE) for k in searched}
        known = spectra([_pilot(work[groups[k][p]], LADDER_ELEMENTS,
                                work[groups[k][p]]["time"]["steps_per_revolution"])
                         for k, positions in at.items() for p in positions])
        for k, positions in at.items():
            mine, known = known[:len(positions)], known[len(positions):]
            if all(spectrum is not None for spectrum in mine):
                speeds = [work[j]["drive"]["speed"] for j in groups[k]]
                resonance[k] = _sweep_resonance(speeds, positions, mine)
    climbed = [set(g[representatives(len(g), stride or (
        STRIDE if weight is None else PERIODIC_STRIDE))].tolist())
        for g, weight in zip(groups, resonance)]
    first_rungs(sorted(j for c in climbed for j in c))
    # A case shot at its first rung in a sweep of series has a time error no climber's ladder
    # measured: it climbs its own.
    for g, c in zip(groups, climbed):
        if series[g].any():
            c.update(g[~series[g]].tolist())
    ladders: dict[int, _Climbed] = {}
    choices: dict[int, tuple] = {}

    def climb(cases: list[int]) -> None:
        """Stages 1–3 for these cases (their own choices too), batched."""
        first_rungs(cases)
        for j, ladder in zip(cases, _climb([work[j] for j in cases], solve,
                                           [first_peaks[j] for j in cases], resolved_at[cases],
                                           [budget[j] for j in cases], series[cases])):
            ladders[j] = ladder
            choices[j] = choose_shared(
                [(ladder.space, ladder.time, ladder.truncation, ladder.time_floor)],
                work[j]["tolerance"], work[j]["time"]["revolutions"], _flexible_links(work[j]))
        lost = [j for j in cases if ladders[j].lost_series]
        if lost:  # stage 6: a series whose pilot was shot climbs the marched ladders instead
            series[lost] = False
            for j in lost:
                first_peaks[j] = None
            climb(lost)

    revolutions = max(s["time"]["revolutions"] for s in work)
    flexible = max(_flexible_links(s) for s in work)
    group_of = {int(j): k for k, g in enumerate(groups) for j in g}

    def at_setting(tolerance: dict) -> tuple[tuple, dict]:
        """The cheapest setting at which every climber meets its ``tolerance``, and each
        climber's predicted error there."""
        elements, steps, modes, _ = choose_shared(
            [(ladders[j].space, ladders[j].time, ladders[j].truncation, ladders[j].time_floor)
             for j in ladders], [tolerance[j] for j in ladders], revolutions, flexible)
        return (elements, steps, modes), {
            j: float(predicted_error(ladders[j].space, ladders[j].time, elements, steps))
            + (ladders[j].truncation[modes] if modes else 0.0) + ladders[j].time_floor
            for j in ladders}

    def to_climb(error: dict) -> list[np.ndarray]:
        """Per sweep the positions whose prediction at these errors is not trusted."""
        out = []
        for g, c, weight in zip(groups, climbed, resonance):
            at = sorted(g.tolist().index(j) for j in c)
            # A series' time part is its own (its bound), not interpolated between climbers:
            # the margin is on the rest.
            out.append(unverified(at, [error[g[p]] - floor[g[p]] for p in at],
                                  [ladders[g[p]].time[0][-1] for p in at], resolved_at[g],
                                  work[g[0]]["tolerance"] / SAFETY - floor[g].max(),
                                  resonance=weight))
        return out

    # Raised: the setting is chosen so that INTERPOLATION_MARGIN times a climber's error fits,
    # where that costs the batch less than the climbers it spares (stage 5).
    raised = False
    while True:
        climb(sorted(j for c in climbed for j in c if j not in ladders))
        floor = np.where(series, bound, 0.0)
        own = {j: work[j]["tolerance"] for j in ladders}
        bounding = {j: SAFETY * (floor[j] + (work[j]["tolerance"] / SAFETY
                                             - floor[groups[group_of[j]]].max())
                                 / INTERPOLATION_MARGIN)
                    if len(groups[group_of[j]]) > 2 else own[j] for j in ladders}
        # One discretization for the call, the cheapest at which every climber meets its
        # tolerance: the cases then share one time grid (a dataset has one step dimension)
        # and batch together.
        setting, error = at_setting(bounding if raised else own)
        bisect = to_climb(error)
        if not raised and any(len(b) for b in bisect):
            higher, higher_error = at_setting(bounding)
            fewer = to_climb(higher_error)
            spared = sum(map(len, bisect)) - sum(map(len, fewer))
            extra = len(keys) * (_setting_cost(higher, revolutions, flexible)
                                 - _setting_cost(setting, revolutions, flexible))
            if spared > 0 and extra <= (PILOTS_PER_CLIMBER * spared
                                        * _setting_cost(setting, revolutions, flexible)):
                raised, setting, error, bisect = True, higher, higher_error, fewer
        for g, c, b in zip(groups, climbed, bisect):
            c.update(g[b].tolist())
        if not any(len(b) for b in bisect):
            break
    elements, steps, modes = setting

    for g, c in zip(groups, climbed):
        at = sorted(g.tolist().index(j) for j in c)
        below, above = bracket(at, len(g))
        for position, j in enumerate(g):
            i = auto[j]
            report = {"tolerance": work[j]["tolerance"],
                      "first_frequency": (float(omega1[j]) / (2.0 * math.pi)
                                          if np.isfinite(omega1[j]) else None),
                      "elements_per_link": elements, "steps_per_revolution": steps,
                      "modes_per_link": modes, "formulation": "euler_bernoulli"}
            if j in ladders:
                # The case's predicted error at the shared setting: its error estimate (the
                # ladders are its companions, ``ced.simulation.simulate``).
                predicted = error[j]
                report.update(_ladder_report(ladders[j], choices[j]), ladder="own")
            else:
                # Not climbed: bounded by its climbing neighbours in speed, verified above.
                pair = [int(g[below[position]]), int(g[above[position]])]
                weight = resonance[group_of[j]]
                predicted = float(interpolated_error(
                    [error[k] - floor[k] for k in pair],
                    None if weight is None else weight[[below[position], above[position]]],
                    None if weight is None else weight[position])) + floor[j]
                report.update(ladder="interpolated", ladder_cases=[auto[k] for k in pair],
                              interpolation_margin=INTERPOLATION_MARGIN)
            if resonance[group_of[j]] is not None:  # the sweep was searched (stage 5)
                report["resonance_weight"] = float(resonance[group_of[j]][position])
            report.update(predicted_error=predicted,
                          tolerance_met=bool(predicted <= work[j]["tolerance"]))
            if series[j]:
                # Its time part is the bound its final series is refined to (``time.
                # spectral_tail``): ``simulate`` adds what that series' own tail exceeds it by.
                report.update(time_error="spectral_tail", spectral_tail_bound=bound[j])
            reports[i] = report
    out = list(scenes)
    for i, scene in enumerate(scenes):
        if scene["discretization"] == "auto":
            source = representative[keys[i]]
            if source != i:  # a case that shared its pilots: a report of its own
                reports[i] = copy.deepcopy(reports[source])
            out[i] = _setting_for(scene, elements, steps, modes)
    return out, reports
