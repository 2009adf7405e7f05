"""The elastic response of a batch: start, march, recover, flag (docs/theory.md).

Integrates the KED model (:mod:`ced.response.model`) from the requested start state
(``undeformed``, ``quasi_static`` or the exact ``periodic`` steady state of
:mod:`ced.response.periodic`), recovers deflections, strains and stresses at the stations
(:mod:`ced.fem.recovery`) beside the quasi-static response for the dynamic amplification,
runs the modal analysis over the cycle (:mod:`ced.response.frequencies`) and sets the elastic
status flags. Everything is vectorized across the cases of the batch.
"""
from __future__ import annotations

import dataclasses
import marshal
import math
import os
from collections.abc import Callable

import numpy as np

from ..fem.recovery import deflection, link_fields, peaks
from ..fem.recovery_kernel import recover
from ..problem.errors import SceneError
from ..problem.linkage import ASSEMBLY_SAMPLES, describe, transmission
from ..problem.mechanism import NEAR_SINGULAR_SIN, near_singular
from ..problem.status import STATUS_FLAGS
from .axial_force import (MAX_ITERATIONS, TOLERANCE, ElasticAxialForce, added_axial_force,
                          axial_strain, relative_change)
from .batch import Batch
from .collocation import SpectralSteadyState, spectral_steady_state
from .frequencies import buckled, check_modes, cycle_frequencies, modal_phases
from .integrators import (forced_columns, from_independent, integrator_for, march,
                          stability_limit, start)
from .kernels import expand, static_period, static_period_packed
from .marching import Marcher
from .model import Model, StepTerms, terms_at
from .model_cache import model_for
from .period_terms import PeriodTerms, interpolate_periodic, period_terms
from .periodic import INSTABILITY_MARGIN, floquet, monodromy, periodic_state
from .resonance import forced_resonance

__all__ = ["elastic_response", "thick_links", "LARGE_DEFLECTION", "THICK_LINK_RATIO",
           "SERIES_SAMPLES"]

#: Deflection / link length above which the linear model's validity is flagged.
LARGE_DEFLECTION = 0.01
#: Link length / in-plane section height below which beam theory does not hold (shear and
#: the section's own deformation: docs/fidelity.md's rule of thumb, plane_stress below 3; at 3
#: Timoshenko's first frequency is already 0.86 of Euler–Bernoulli's).
THICK_LINK_RATIO = 3.0
#: Key of ``result`` under which :func:`_response` passes the spectral solution to the recovery.
_SERIES = "_series"
#: Key of the result that holds, per case, its spectral series in mesh-independent terms
#: (:func:`ced.response.warm_start.mesh_free_samples`; None where the case has none): the
#: initial guess of its error estimate's companion, not a dataset variable.
SERIES_SAMPLES = "series_samples"
#: Formulations that model a link as a beam (plane_stress models the continuum).
BEAMS = ("euler_bernoulli", "timoshenko", "seed_lame")


def _near_singular(batch: Batch) -> np.ndarray:
    """(case,) bool: :func:`ced.problem.mechanism.near_singular` for four-bars (exact); for
    linkages of dyads, the smallest transmission measure of any dyad
    (:func:`ced.problem.linkage.transmission`, from positions only) over one input period
    sampled at :data:`ced.problem.linkage.ASSEMBLY_SAMPLES` instants (0.1° of a crank) below
    :data:`ced.problem.mechanism.NEAR_SINGULAR_SIN`; other mechanisms have no dyad that can
    fold."""
    if batch.mechanism_type == "four_bar":
        L = batch.lengths
        return near_singular(L["ground"], L["crank"], L["coupler"], L["rocker"],
                             batch.initial_angle, batch.amplitude)
    if batch.mechanism_type in ("slider_crank", "single_link"):
        return np.zeros(batch.size, bool)
    phase = np.linspace(0.0, 2.0 * math.pi, ASSEMBLY_SAMPLES)
    descriptions = batch.descriptions or [describe(s["mechanism"]) for s in batch.scenes]
    # The cases of a speed sweep share their mechanism and input range: one minimum for
    # them all, keyed by marshal's bytes (every float told apart by its bits; a quarter of
    # repr's time, which wrote each description's floats as text: 2 against 8 µs a Watt II
    # case).
    kept: dict[bytes, float] = {}
    worst = np.empty(batch.size)
    for c, description in enumerate(descriptions):
        initial, amplitude = batch.initial_angle[c], batch.amplitude[c]
        key = marshal.dumps((description, float(initial), float(amplitude)), 2)
        if key not in kept:
            # The input's angle over one period, Ωt from 0 to 2π (kinematics.input_motion's).
            angle = initial + (amplitude * np.sin(phase) if np.isfinite(amplitude) else phase)
            kept[key] = transmission(description, angle).min()
        worst[c] = kept[key]
    return worst < NEAR_SINGULAR_SIN


def elastic_response(batch: Batch, status: np.ndarray, peaks_only: bool = False,
                     allocate: Callable[[str, tuple, type], np.ndarray] | None = None,
                     guesses: list | None = None) -> dict[str, np.ndarray]:
    """Elastic variables of the dataset (docs/reference/dataset.md) for a batch, arrays with a
    leading case axis.

    ``status`` (case,) holds the flags of the rigid analysis; the returned ``status`` adds the
    elastic ones (resonant, parametrically_unstable, large_deflection, near_singular where the
    pin-jointed structure loses its stiffness, buckled). ``peaks_only`` returns the per-link
    peaks, the modal analysis and the status alone — what an error estimate's companion or a
    pilot needs — without the station fields, the quasi-static response (dynamic
    amplification) and the forced-resonance check. A full solve whose scenes ask for an
    error estimate adds :data:`SERIES_SAMPLES`, the initial guesses of their companions
    (``guesses``, per case: a companion's spectral solve starts from them).

    Parameters
    ----------
    batch : Batch
        The batch of cases.
    status : numpy.ndarray
        Status flags of the rigid analysis, shape (case,), int.
    peaks_only : bool, optional
        Return only the peaks, the modal analysis and the status.
    allocate : callable, optional
        ``allocate(name, shape, dtype)`` gives the arrays the station fields are written into
        (:func:`ced.fem.recovery_kernel.recover`): parts of a larger batch's outputs.
    guesses : list, optional
        Per case, the :data:`SERIES_SAMPLES` of another mesh of the case, or None: the initial
        guesses of a spectral solve at a fixed number of points (a companion's).

    Returns
    -------
    dict of str to numpy.ndarray
        Dataset variables (displacements in m, stresses in Pa, frequencies in Hz, …) with a
        leading case axis, and ``status``.
    """
    model = model_for(batch)
    scene = batch.scenes[0]
    check_modes(scene, model.layout.ny)
    status = status.copy()
    status[_near_singular(batch)] |= STATUS_FLAGS["near_singular"]
    status[thick_links(batch)] |= STATUS_FLAGS["thick_link"]
    result: dict[str, np.ndarray] = {}
    qz, qz_static, period = _response(model, status, result, full=not peaks_only,
                                      guesses=guesses)
    if "elastic_axial_force" in model.effects and "elastic_inertia" in model.effects:
        qz = _with_elastic_axial_force(model, status, qz, period)
    series = result.pop(_SERIES, None)
    if series is not None and series.samples is not None:
        result[SERIES_SAMPLES] = series.samples
    every = scene["outputs"]["every"]
    if qz is None:  # every case's peaks are its series' (peaks only, spectral)
        result.update(peak_deflection=series.peak_deflection, peak_stress=series.peak_stress)
    elif every > 1 or qz.shape[1] > batch.n_steps + 1:
        # The station fields at the output steps of the run; the peaks (and the
        # amplification) over every step, and over the whole period of a two-turn motion
        # longer than the run (_peak_span): a peak is no less for not being written.
        if not peaks_only:
            result.update(_recover(model, np.ascontiguousarray(qz[:, :batch.n_steps + 1:every]),
                                   None, True, allocate, series))
        result.update(_recover(model, qz, qz_static, False, None, series))
    else:
        result.update(_recover(model, qz, qz_static, not peaks_only, allocate, series))
    relative = result["peak_deflection"] / batch.link_lengths
    status[(relative > LARGE_DEFLECTION).any(axis=1)] |= STATUS_FLAGS["large_deflection"]
    modal = scene.get("modal")
    if modal and model.layout.ny:
        freq = cycle_frequencies(model, modal_phases(modal["angles"]), modal["modes"])
        result["natural_frequency"] = freq
        status[buckled(freq)] |= STATUS_FLAGS["buckled"]
    if scene["discretization"]["formulation"] == "seed_lame":
        # The thesis's wave analysis (III.3.1.a), reported per link material.
        for key, name in (("c1", "longitudinal_wave_speed"), ("c2", "transverse_wave_speed")):
            result[name] = np.stack([batch.link_property(link, "material", key)
                                     for link in batch.topology.links], axis=1)
    result["status"] = status
    return result


def _response(model: Model, status: np.ndarray, result: dict, full: bool = True,
              guesses: list | None = None):
    """Joint and link displacements z at every step of the run (whatever ``outputs.every``:
    the peaks are over all of them), dynamic and quasi-static (case, step, nz), and the terms
    over one period (None without elastic DOFs); adds the Floquet results of a periodic
    start, and the series of a spectral one, to ``result``, and the forced-resonance flag to
    ``status``.
    Without ``full``, neither the quasi-static response (None, unless the model is
    quasi-static) nor the Floquet analysis nor the forced-resonance check; a spectral solve at
    a fixed number of points then returns (None, None, None) when every case has its series
    (its peaks are the series', :func:`elastic_response`).

    The period is :attr:`ced.response.batch.Batch.period_steps`: one input turn, or two for
    a motion that passes a change point once a turn; the steps then run on to the end
    of that period where the run is shorter (:func:`_peak_span`: its peaks cover both turns).
    The terms are formed over one period (:mod:`ced.response.period_terms`) and marched
    over by :class:`ced.response.marching.Marcher`; the quasi-static response, periodic too,
    is solved over the period only, and, unless it is the response itself (a quasi-static
    model), returned at the steps of :func:`_one_period` only. A spectral periodic
    state (:mod:`ced.response.collocation`) is found after the shooting and the
    forced-resonance check, so that flagged cases need not climb its ladder; the cases it
    leaves are shot and marched. A two-turn period is always shot: the series are in the
    harmonics of one turn. ``guesses`` (per case, or None) start a companion's spectral
    solve (:func:`ced.response.collocation.spectral_steady_state`); a full solve of scenes
    that ask for an error estimate keeps its series' samples for theirs."""
    batch, layout = model.batch, model.layout
    scene = batch.scenes[0]
    ncase, ny, h = batch.size, layout.ny, batch.step_size
    time_cfg = scene["time"]
    quasi_static = "elastic_inertia" not in model.effects  # K q = F at each instant
    turns = batch.period_steps // time_cfg["steps_per_revolution"]
    n_steps = _peak_span(batch.n_steps, batch.period_steps, turns,
                         quasi_static or time_cfg["start"] == "periodic")
    # Every step, whatever the output's spacing: the peaks are over all of them.
    out_steps = np.arange(n_steps + 1)
    qz = np.zeros((ncase, len(out_steps), layout.nz))
    if not ny:
        return qz, qz.copy(), None
    spectral = time_cfg["start"] == "periodic" and time_cfg["periodic_solver"] == "spectral"
    # Near a change point or toggle the terms have features narrower than any sampling can
    # see between its samples: a batch holding such a case evaluates every step.
    sharp = bool((status & STATUS_FLAGS["near_singular"]).any())
    series = None
    if (spectral and not full and not sharp and time_cfg["collocation_points"] != "auto"
            and not quasi_static and turns == 1):
        # Peaks only, at a fixed number of points (an error estimate's companion): the terms
        # are needed at the collocation points alone, not at every step of the period.
        series = spectral_steady_state(model, None, np.ones(ncase, bool),
                                       time_cfg["steps_per_revolution"], history=False,
                                       guesses=guesses)
        _add_series(result, series)
        if series.solved.all():
            return None, None, None
    period = period_terms(model, h, batch.period_steps, exact=sharp)
    if full:
        status[forced_resonance(model, period, turns)] |= STATUS_FLAGS["resonant"]
    qz_static = None
    if full or quasi_static:
        # Beside a dynamic response only its peak is read: one period of it is enough.
        steps = out_steps if quasi_static else _one_period(out_steps, period.period)
        qz_static = _expand(layout, period, _static(period)[:, steps % period.period], steps)
    if quasi_static:
        return qz_static, qz_static, period
    scheme = integrator_for(time_cfg)
    _check_stable_step(model, stability_limit(scheme))
    marcher = Marcher(scheme, period, h)
    terms = marcher.columns(1)
    state = None
    one_period = None
    if time_cfg["start"] == "periodic" and (not spectral or full):
        # The monodromy of the scene's steps gives the Floquet multipliers, and the periodic
        # state of the cases the spectral solver leaves (solved for those alone, below).
        one_period = monodromy(scheme, marcher, h, period.period, ny, ncase)
        if full:
            mu, resonant = floquet(one_period, ny, turns)
            largest = _per_turn(np.abs(mu).max(axis=-1), turns)
            result["floquet_multiplier_max"] = largest
            status[largest > 1.0 + INSTABILITY_MARGIN] |= STATUS_FLAGS["parametrically_unstable"]
            status[resonant] |= STATUS_FLAGS["resonant"]
        if not spectral:
            state = from_independent(terms, scheme, *periodic_state(one_period, ny))
    if spectral and series is None:
        # Near-singular cases are shot: no global Fourier series converges there. A case
        # already flagged resonant or parametrically unstable keeps its first converged series
        # (the flag says its result is not to be acted on; its tail stays in its estimate):
        # climbing the ladder there costs most and changes no decision.
        flagged = STATUS_FLAGS["resonant"] | STATUS_FLAGS["parametrically_unstable"]
        series = spectral_steady_state(model, period,
                                       ((status & STATUS_FLAGS["near_singular"]) == 0)
                                       & (turns == 1),
                                       climb=(status & flagged) == 0,
                                       samples=full and any(s["outputs"]["error_estimate"]
                                                            for s in batch.scenes))
        _add_series(result, series)
        # A series the ladder could not resolve: a harmonic sits on a mode so closely that
        # the undamped response is not determined (the collocation system nearly singular).
        status[series.unresolved] |= STATUS_FLAGS["resonant"]
    if state is None and time_cfg["start"] == "periodic" and not series.solved.all():
        if one_period is None:
            one_period = monodromy(scheme, marcher, h, period.period, ny, ncase)
        state = from_independent(terms, scheme,
                                 *periodic_state(one_period, ny, ~series.solved))
    elif state is None and time_cfg["start"] != "periodic":
        q0 = np.zeros((ncase, ny, 1))
        v0 = np.zeros_like(q0)
        if time_cfg["start"] == "quasi_static":
            q0, v0 = _quasi_static_start(model, h)
        state = start(terms, q0, v0)
    if series is None or not series.solved.all():
        _, record = marcher.march(state, n_steps, 1)
    else:
        record = np.empty((ncase, len(out_steps), ny))
    if series is not None and series.displacement is not None:  # the series' period repeats
        record[series.solved] = series.displacement[series.solved][:, out_steps % period.period]
    elif series is not None:  # peaks only: the solved cases' peaks are their series'
        record[series.solved] = 0.0
    return _expand(layout, period, record, out_steps), qz_static, period


def _with_elastic_axial_force(model: Model, status: np.ndarray, qz: np.ndarray,
                              period: PeriodTerms) -> np.ndarray:
    """The response with the elastic axial force in the geometric stiffness (effect
    ``elastic_axial_force``, :mod:`ced.response.axial_force`): fixed-point iterations from the
    linear response ``qz`` (case, step, nz) over its ``period`` terms, each a solve of the whole
    run with the last iterate's force (from a periodic start: of the periodic state, the force
    periodic with it), until the displacements change by less than
    :data:`~ced.response.axial_force.TOLERANCE` of their largest value. A case still changing
    after :data:`~ced.response.axial_force.MAX_ITERATIONS`, or whose iterate is no longer
    finite, keeps its linear response and is flagged ``large_deflection`` in ``status``: the
    second-order model has no settled answer there."""
    batch, layout = model.batch, model.layout
    if not model.recovery:
        return qz
    h, n_steps = batch.step_size, qz.shape[1] - 1
    steps = np.arange(n_steps + 1)
    time_cfg = batch.scenes[0]["time"]
    # From a periodic start the response, and so the added force, repeat every period: its
    # steps 0 … P (the last equal to the first) are all the force needs.
    periodic = period.period if time_cfg["start"] == "periodic" else 0
    window = steps[:periodic + 1] if periodic else steps
    static = _expand(layout, period, _static(period)[:, window % period.period], window)
    offsets, sizes = layout.link_offsets, layout.link_sizes
    static_strain = axial_strain(model.recovery, offsets, sizes, static)
    names = list(batch.topology.links)
    stiffness = {name: batch.link_property(name, "material", "E")
                 * batch.link_property(name, "section", "area") for name in model.recovery}
    length = {name: batch.link_lengths[:, names.index(name)] for name in model.recovery}
    q0 = np.zeros((batch.size, layout.ny, 1))
    v0 = np.zeros_like(q0)
    if time_cfg["start"] == "quasi_static":
        q0, v0 = _quasi_static_start(model, h)
    linear = qz
    converged = np.zeros(batch.size, bool)
    stuck = np.zeros(batch.size, bool)  # an iterate no longer finite: kept at the last one
    for _ in range(MAX_ITERATIONS):
        added = added_axial_force(axial_strain(model.recovery, offsets, sizes, qz[:, window]),
                                  static_strain, stiffness, length, model.stations)
        iterate = dataclasses.replace(
            model, elastic_axial_force=ElasticAxialForce(h, added, periodic),
            origin=None)  # its terms are its own: not those kept for the linear model
        if periodic:  # the periodic state of the iterate, shot over its period's terms
            new = _response(iterate, status.copy(), {}, full=False)[0]
        else:
            y = march_every_step(iterate, integrator_for(time_cfg), n_steps, q0, v0)
            new = _expand(layout, period, y, steps)  # the projection is the rigid motion's
        # A diverging iteration (near buckling) keeps its last finite iterate, flagged below.
        stuck |= ~np.isfinite(new).all(axis=(1, 2))
        new[stuck] = qz[stuck]
        converged = (relative_change(new, qz) <= TOLERANCE) & ~stuck
        qz = new
        if (converged | stuck).all():
            break
    # Unsettled: its iterates drift away, as in an undamped periodic state near resonance,
    # where a small change of stiffness moves the response a lot. The linear response stands.
    qz[~converged] = linear[~converged]
    status[~converged] |= STATUS_FLAGS["large_deflection"]
    return qz


def march_every_step(model: Model, scheme, n_steps: int, q0: np.ndarray,
                     v0: np.ndarray) -> np.ndarray:
    """The response y (case, step, ny) of ``model`` over ``n_steps`` steps from (q0, v0)
    (case, ny, 1), its terms evaluated step by step a chunk at a time
    (:class:`ced.response.model.StepTerms`: memory bounded whatever the run's length) and
    marched by :func:`ced.response.integrators.march`. The path of terms that are not
    periodic; the periodic ones go through :class:`ced.response.marching.Marcher`.

    Parameters
    ----------
    model : Model
        The batch's model.
    scheme : NewmarkFamily or Houbolt
        The integrator (:func:`ced.response.integrators.integrator_for`).
    n_steps : int
        Steps of the run.
    q0, v0 : numpy.ndarray
        Initial displacements (m) and velocities (m/s) in the independent coordinates,
        (case, ny, 1).

    Returns
    -------
    numpy.ndarray
        Displacements at steps 0 … n_steps, shape (case, n_steps + 1, ny).
    """
    h = model.batch.step_size
    terms = forced_columns(StepTerms(model, h, n_steps), 1)
    y = np.empty((model.batch.size, n_steps + 1, model.layout.ny))

    def keep(k: int, state) -> None:
        y[:, k] = state.q[..., 0]

    march(scheme, terms, h, n_steps, start(terms, q0, v0), record=keep)
    return y


def _peak_span(n_steps: int, period: int, turns: int, periodic: bool) -> int:
    """Steps of the history the response is marched and recovered over: the run's
    ``n_steps``, or, for a periodic response whose period of ``turns`` input turns (more than
    one) is longer than the run, the whole ``period``, so that its peaks cover every turn
    of it (the station fields stay those of the run's steps: :func:`elastic_response`)."""
    if turns == 1 or not periodic:
        return n_steps
    return max(n_steps, period)


def _per_turn(multiplier: np.ndarray, turns: int) -> np.ndarray:
    """A Floquet multiplier's modulus per input turn: ``multiplier`` of a period of ``turns``
    turns to the power 1/turns.

    A motion that repeats only every two turns has a monodromy over two; its multipliers are
    those of one turn squared, so their square root is the growth per turn, comparable with
    other cases' and with the same instability threshold
    (:data:`ced.response.periodic.INSTABILITY_MARGIN`).

    Parameters
    ----------
    multiplier : numpy.ndarray
        Moduli of the period's multipliers, 1, any shape.
    turns : int
        Input turns per period.

    Returns
    -------
    numpy.ndarray
        The moduli per turn, 1, shaped as ``multiplier``.
    """
    return multiplier if turns == 1 else multiplier ** (1.0 / turns)


def _add_series(result: dict, series: SpectralSteadyState) -> None:
    result["collocation_points"] = series.points
    result["spectral_tail"] = series.tail
    result[_SERIES] = series


def _one_period(steps: np.ndarray, period: int) -> np.ndarray:
    """The first output steps that hold every value of a ``period``-periodic history, and the
    first repeated one (``steps`` equally spaced from 0; all of them when the spacing does not
    divide the period or they span less).

    The peak of the history at them (:func:`ced.fem.recovery.peaks`) is that at all the
    steps, bit for bit: the first largest sample lies before the first repeated one, which is
    its neighbour after when it is the last of the period, and a first largest sample at
    step 0 is an end of both histories (no parabola)."""
    spacing = int(steps[1] - steps[0]) if len(steps) > 1 else 1
    if period % spacing:
        return steps
    return steps[:period // spacing + 1]


def _static(period: PeriodTerms) -> np.ndarray:
    """Quasi-static response K y = F at every step of the period (case, P, ny).

    Where the terms were sampled, y is solved at the samples and interpolated like them
    (smooth and periodic as they are; the interpolation error checked the same way), else
    at every step."""
    if period.sampled is not None:
        y = interpolate_periodic(_solve_static(period.sampled["stiffness"],
                                               period.sampled["force"]), period.period)
        if y is not None:
            return y
    if period.order is None:
        return _solve_static(period.stiffness, period.force)
    y = np.empty(period.force.shape)
    ok = np.ones(len(y), bool)
    o = period.order
    static_period_packed(period.stiffness, np.ascontiguousarray(period.force), y, ok, o.perm,
                         o.rows_ptr, o.rows_idx, o.lu_ptr, o.lu_idx, o.diagonal, o.lu_source)
    if not ok.all():  # as numpy's solve would: the batch is re-run case by case
        raise np.linalg.LinAlgError(
            f"Singular matrix: the stiffness of case {int(np.argmax(~ok))}")
    return y


def _solve_static(K: np.ndarray, F: np.ndarray) -> np.ndarray:
    """K y = F for every (case, phase): K (case, m, n, n), F (case, m, n) → y (case, m, n)."""
    y = np.empty(F.shape)
    ok = np.ones(len(y), bool)
    static_period(np.ascontiguousarray(K), np.ascontiguousarray(F), y, ok)
    if not ok.all():  # as numpy's solve would: the batch is re-run case by case
        raise np.linalg.LinAlgError(
            f"Singular matrix: the stiffness of case {int(np.argmax(~ok))}")
    return y


def _expand(layout, period: PeriodTerms, y: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """Joint and link displacements z = P y at the given steps (case, step, nz)."""
    z = np.empty(y.shape[:2] + (layout.nz,))
    expand(period.projection, np.ascontiguousarray(y), steps.astype(np.int64),
           layout.projection_rows, layout.interior_rows().astype(np.int64), z)
    return z


def thick_links(batch: Batch) -> np.ndarray:
    """(case,) bool: a flexible link modelled as a beam is shorter than
    :data:`THICK_LINK_RATIO` × its in-plane section height.

    Parameters
    ----------
    batch : Batch
        The batch of cases (link lengths and section heights in m).

    Returns
    -------
    numpy.ndarray
        Shape (case,), bool.
    """
    scene = batch.scenes[0]
    flagged = np.zeros(batch.size, bool)
    if scene["discretization"]["formulation"] not in BEAMS:
        return flagged
    for i, name in enumerate(batch.topology.links):
        if scene["links"][name]["flexible"]:
            height = batch.link_property(name, "section", "height")
            flagged |= batch.link_lengths[:, i] < THICK_LINK_RATIO * height
    return flagged


def _check_stable_step(model: Model, limit: float) -> None:
    """Refuse a conditionally stable scheme whose step exceeds its stability limit: the highest
    natural frequency of the frozen system (at four phases of the cycle) times the step must
    stay within ``limit`` (:func:`ced.response.integrators.stability_limit`); beyond it the
    response grows without bound. Raised for the batch; the cases are then solved one by one
    and the offending ones recorded as failed with this message."""
    if not math.isfinite(limit):
        return
    frequency = cycle_frequencies(model, modal_phases(4), model.layout.ny)
    omega_max = 2.0 * math.pi * np.abs(frequency).max(axis=(1, 2))
    batch = model.batch
    worst = int(np.argmax(omega_max * batch.step_size))
    omega_h = float(omega_max[worst] * batch.step_size[worst])
    if omega_h > limit:
        spr = batch.scenes[worst]["time"]["steps_per_revolution"]
        needed = math.ceil(spr * omega_h / limit)
        raise SceneError(
            "time.steps_per_revolution",
            f"{spr} steps per revolution make the scheme unstable: its stability limit is "
            f"ω h ≤ {limit:.4g}, and the highest natural frequency "
            f"{omega_max[worst] / (2 * math.pi):.4g} Hz gives ω h = {omega_h:.4g}; use at "
            f"least {needed} steps per revolution or an unconditionally stable integrator "
            f"(newmark with 2β ≥ γ, hht, generalized_alpha, houbolt)")


def _recover(model: Model, qz: np.ndarray, qz_static: np.ndarray | None,
             fields: bool = True, allocate=None,
             series: SpectralSteadyState | None = None) -> dict[str, np.ndarray]:
    """Deflection, strains, stress at the stations, per-link peaks, dynamic amplification
    (without ``qz_static``: none).

    The station fields are returned in float32, as they are stored; the peaks are taken from
    the float64 values first, into the arrays of ``allocate`` where given (numpy's path
    ignores it). ``fields=False`` returns the peaks alone. The cases a spectral solver
    took (``series``) take their peaks from its series instead of the steps
    (:mod:`ced.response.collocation`). One compiled pass per
    case (:func:`ced.fem.recovery_kernel.recover`); ``CED_KERNEL=numpy`` takes the numpy path
    (:func:`ced.fem.recovery.link_fields` and :func:`ced.fem.recovery.peaks`), the reference
    the kernel is tested against."""
    if os.environ.get("CED_KERNEL", "numba") == "numpy":
        return _recover_numpy(model, qz, qz_static, fields, series=series)
    batch, layout = model.batch, model.layout
    links = layout.topology.links
    zero = np.zeros(batch.size)
    height, E = (np.stack([batch.link_property(name, group, key) if name in model.recovery
                           else zero for name in links], axis=1)
                 for group, key in (("section", "height"), ("material", "E")))
    out = recover(qz, [layout.link_offsets[name] for name in links],
                  [model.recovery.get(name) for name in links], model.stations, height, E,
                  fields, qz_static, allocate)
    static_peak = out.pop("static_peak_deflection", None)
    _series_peaks(out, series)
    if static_peak is not None:
        out["dynamic_amplification"] = _amplification(out["peak_deflection"], static_peak)
    return out


def _series_peaks(out: dict[str, np.ndarray], series: SpectralSteadyState | None) -> None:
    """Overwrite the peaks of the cases the spectral solver took by those of its series."""
    if series is not None:
        for name in ("peak_deflection", "peak_stress"):
            out[name][series.solved] = getattr(series, name)[series.solved]


def _amplification(peak: np.ndarray, static_peak: np.ndarray) -> np.ndarray:
    """Dynamic amplification (case, link): peak / quasi-static peak deflection, 1 where the
    latter is zero (a rigid link)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(static_peak > 0, peak / static_peak, 1.0)


def _recover_numpy(model: Model, qz: np.ndarray, qz_static: np.ndarray | None,
                   fields: bool = True, allocate=None,
                   series: SpectralSteadyState | None = None) -> dict[str, np.ndarray]:
    """:func:`_recover` through numpy (``CED_KERNEL=numpy``): the link fields by batched
    matmul, the peaks by :func:`ced.fem.recovery.peaks`; ``allocate`` is not used (the
    caller copies the fields)."""
    batch, layout = model.batch, model.layout
    topo = layout.topology
    ncase, nout = qz.shape[:2]
    nlink = len(topo.links)
    shape = (ncase, nout, nlink, len(model.stations))
    names = ("deflection", "axial_displacement", "bending_strain", "axial_strain")
    stored = {name: np.zeros(shape, np.float32) for name in names} if fields else {}
    if fields:  # signed, at both outer fibres (ced.fem.recovery.FIBRES)
        stored["stress"] = np.zeros(shape + (2,), np.float32)
    peak, peak_stress, static_peak = (np.zeros((ncase, nlink)) for _ in range(3))
    offsets = layout.link_offsets
    for i, name in enumerate(topo.links):
        if name not in model.recovery:
            continue  # rigid link: no strain
        rows = slice(offsets[name], offsets[name] + layout.link_sizes[name])
        height = batch.link_property(name, "section", "height")
        E = batch.link_property(name, "material", "E")
        link = link_fields(qz[..., rows], model.recovery[name], model.stations, height, E)
        for key, value in stored.items():
            value[:, :, i] = link[key]
        peak[:, i] = peaks(link["deflection"][:, :, None])[:, 0]
        # the larger magnitude of the two fibres: |axial| + |bending| (np.maximum of the two:
        # numpy's max over an axis of length 2 pays its reduction loop per pair, ~40× slower)
        stress = link["stress"]
        larger = np.maximum(np.abs(stress[..., 0]), np.abs(stress[..., 1]))
        peak_stress[:, i] = peaks(larger[:, :, None])[:, 0]
        if qz_static is not None:
            static = deflection(qz_static[..., rows], model.recovery[name]["v"],
                                model.stations)
            static_peak[:, i] = peaks(static[:, :, None])[:, 0]
    out = {**stored, "peak_deflection": peak, "peak_stress": peak_stress}
    _series_peaks(out, series)
    if qz_static is not None:
        out["dynamic_amplification"] = _amplification(peak, static_peak)
    return out


def _quasi_static_start(model: Model, h: np.ndarray):
    """q0 = K⁻¹F at t = 0 and q̇0 from the quasi-static solution at ±h (central difference)."""
    times = h[:, None] * np.array([-1.0, 0.0, 1.0])[None, :]
    terms, _ = terms_at(model, times)
    y = np.linalg.solve(terms.stiffness, terms.force[..., None])
    v0 = (y[:, 2] - y[:, 0]) / (2.0 * h[:, None, None])
    return y[:, 1], v0
