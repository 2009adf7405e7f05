"""``ced.simulate``: scenes in, one CF-described xarray dataset out.

Scenes are normalized, their automatic choices resolved (:mod:`ced.auto.effects`), grouped into
batches of identical structure, and each batch is solved vectorized across its cases. A batch
that raises is re-run case by case so that one bad case is recorded in ``status``/``message``
and the others survive. The automatic choices and the error estimate get their solutions
through this module's solver, injected into them, so they batch like any run.
"""
from __future__ import annotations

import json
import time as _time
from collections.abc import Mapping

import numpy as np
import xarray as xr

from ..auto.discretization import resolve_discretization
from ..auto.effects import resolve_auto
from ..auto.error_estimate import error_estimates
from ..auto.sweep_estimate import sweep_estimates
from ..problem.errors import SceneError, join
from ..problem.mechanism import topology
from ..problem.scene import EFFECTS, load_scene
from ..problem.status import STATUS_DTYPE, STATUS_FLAGS
from ..response.batch import Batch, make_batch, structure_key
from ..response.elastic import SERIES_SAMPLES, elastic_response
from ..response.frequencies import cycle_frequencies, first_natural_frequency, modal_phases
from ..response import model_cache
from ..response.model_cache import model_for
from ..response.resonance import cycle_spectrum
from .dataset import ESTIMATE_SOURCES, VARIABLES, case_coordinates, make_dataset
from .memory import keep_freed_memory
from .size import cases_per_solve, check_run_memory

__all__ = ["simulate", "solve_batch"]


def _as_list(scenes) -> list:
    if isinstance(scenes, (str, Mapping)) or hasattr(scenes, "__fspath__"):
        return [scenes]
    return list(scenes)


def solve_batch(batch: Batch, peaks_only: bool = False,
                allocate=None, guesses: list | None = None) -> dict[str, np.ndarray]:
    """Solve one batch: rigid motion, inverse dynamics and (when asked) the elastic response.

    Returns arrays named as in :data:`ced.simulation.dataset.VARIABLES`, each with a leading
    ``case`` axis, sampled every ``outputs.every`` steps. A batch larger than
    :func:`ced.simulation.size.cases_per_solve` is solved in parts, whose large arrays reuse
    the memory the process holds (:mod:`ced.simulation.memory`). ``peaks_only`` is the
    solve of a pilot or an error estimate's companion: the elastic peaks and the status,
    without the rigid results (no inverse dynamics) and the histories
    (:func:`ced.response.elastic.elastic_response`).

    Parameters
    ----------
    batch : Batch
        Structurally identical cases (:func:`ced.response.batch.make_batch`).
    peaks_only : bool, optional
        Return the elastic peaks and the status only.
    allocate : callable, optional
        ``allocate(name, shape, dtype)`` gives the arrays the station fields of a batch
        solved in one part are written into (:func:`_into`; default: new arrays).
    guesses : list, optional
        Per case, its scene's series in mesh-independent terms, or None: the initial guesses
        of an error estimate's companions (:func:`ced.response.elastic.elastic_response`).

    Returns
    -------
    dict of str to numpy.ndarray
        The dataset variables (and, where the scenes ask for an error estimate,
        :data:`ced.response.elastic.SERIES_SAMPLES`, their companions' initial guesses).
    """
    keep_freed_memory()
    limit = cases_per_solve(batch.scenes[0])
    if batch.size <= limit:
        return _solve_part(batch, peaks_only, allocate, guesses)
    out: dict[str, np.ndarray] = {}
    for first in range(0, batch.size, limit):
        part = _solve_part(make_batch(batch.scenes[first:first + limit]), peaks_only,
                           _into(out, batch.size, first),
                           None if guesses is None else guesses[first:first + limit])
        for name, value in part.items():
            if name not in out:  # filled part by part: no second copy of the histories
                out[name] = np.empty((batch.size,) + value.shape[1:], value.dtype)
            if value.base is not out[name]:  # the station fields were written in place
                out[name][first:first + len(value)] = value
    return out


def _into(out: dict[str, np.ndarray], size: int, first: int):
    """``allocate(name, shape, dtype)`` for the part of a batch of ``size`` cases that starts
    at case ``first``: the view of the batch's output ``out[name]`` (made on first request)
    that the part's cases fill, so that the solver writes there and nothing is copied."""
    def allocate(name: str, shape: tuple, dtype) -> np.ndarray:
        if name not in out:
            out[name] = np.empty((size,) + tuple(shape[1:]), dtype)
        return out[name][first:first + shape[0]]
    return allocate


def _solve_part(batch: Batch, peaks_only: bool = False,
                allocate=None, guesses: list | None = None) -> dict[str, np.ndarray]:
    """Solve a batch of at most :func:`ced.simulation.size.cases_per_solve` cases: its cases
    of each period (:attr:`ced.response.batch.Batch.motion_turns`) as a batch of their own."""
    turns = batch.motion_turns
    if np.all(turns == turns[0]):
        return _solve_period(batch, peaks_only, allocate, guesses)
    return _solve_by_turns(batch, turns, peaks_only, allocate, guesses)


def _solve_by_turns(batch: Batch, turns: np.ndarray, peaks_only: bool = False,
                    allocate=None, guesses: list | None = None) -> dict[str, np.ndarray]:
    """Solve the cases of each number of ``turns`` (case,) apart and gather their results in
    the batch's order of cases, into ``allocate``'s arrays where given.

    A change-point batch holds cases whose motion repeats every turn and cases whose motion
    repeats every two: their periods differ, so each is solved over its own, with arrays of
    one period length."""
    out: dict[str, np.ndarray] = {}
    for count in np.unique(turns):
        cases = np.flatnonzero(turns == count)
        part = _solve_period(make_batch([batch.scenes[c] for c in cases]), peaks_only,
                             guesses=None if guesses is None else [guesses[c] for c in cases])
        for name, value in part.items():
            if name not in out:
                shape = (batch.size,) + value.shape[1:]
                out[name] = (np.empty(shape, value.dtype) if allocate is None
                             else allocate(name, shape, value.dtype))
            out[name][cases] = value
    return out


def _solve_period(batch: Batch, peaks_only: bool = False,
                  allocate=None, guesses: list | None = None) -> dict[str, np.ndarray]:
    """Solve a batch whose cases repeat after the same number of input turns
    (:attr:`ced.response.batch.Batch.period_steps`)."""
    scene = batch.scenes[0]
    effects = scene["effects"]
    if effects == "auto":
        raise ValueError("effects: auto must be resolved before solving "
                         "(ced.auto.effects.resolve_auto, as simulate does)")
    if peaks_only:  # a pilot or a companion: only the elastic peaks are read from it
        out, singular = {}, _singular(batch)
    else:
        out, singular = _rigid_outputs(batch, "inertia" in effects, allocate)
    flags = np.zeros(batch.size, STATUS_DTYPE)
    flags[singular] |= STATUS_FLAGS["near_singular"]
    out["status"] = flags
    if not peaks_only:
        out["motion_turns"] = np.full(batch.size, batch.period_steps
                                      // scene["time"]["steps_per_revolution"], np.int32)
    if scene["discretization"] == "auto":
        raise ValueError("discretization: auto must be resolved before solving "
                         "(ced.auto.discretization.resolve_discretization, as simulate does)")
    if scene["discretization"]["formulation"] != "rigid":
        out.update(elastic_response(batch, out["status"], peaks_only, allocate, guesses))
    return out


def _singular(batch: Batch) -> np.ndarray:
    """(case,) bool: the transmission is singular at some step of the first period (the
    rigid motion alone, without the inverse dynamics: what a peaks-only solve needs).

    Not marched for a four-bar: its singular steps (|sin μ| < 1e-7,
    :data:`ced.rigid.kinematics.SINGULAR_SIN`) lie inside the exact check of
    :func:`ced.problem.mechanism.near_singular` (|sin μ| < 0.1 anywhere in the motion), which
    the elastic response flags anyway; nor for a slider-crank, whose motion has none (a
    tenth of a small pilot's solve)."""
    if batch.mechanism_type in ("four_bar", "slider_crank", "single_link"):
        return np.zeros(batch.size, bool)
    period = batch.period_steps
    solved = np.arange(min(batch.n_steps, period) + 1)
    return batch.rigid_motion(batch.step_size[:, None] * solved[None, :]).singular.any(axis=1)


def _rigid_outputs(batch: Batch, inertia: bool,
                   allocate=None) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Rigid motion and inverse dynamics at the output steps, and the cases whose
    transmission is singular somewhere (case,).

    The motion repeats every period (:attr:`ced.response.batch.Batch.period_steps`: one
    input turn, or two for a change point passed once a turn): it is solved over one period
    and repeated, the link angles advanced by the turns each link makes per period.
    Each output is gathered from the solved steps straight into the array ``allocate``
    gives (:func:`_into`: the run's output, not copied again), or a new one.
    """
    scene = batch.scenes[0]
    every = scene["outputs"]["every"]
    period = batch.period_steps
    solved = np.arange(min(batch.n_steps, period) + 1)
    steps = np.arange(0, batch.n_steps + 1, every)
    times = batch.step_size[:, None] * solved[None, :]
    motion = batch.rigid_motion(times)
    forces = batch.rigid_forces(times, inertia, motion=motion)
    out: dict[str, np.ndarray] = {}

    def put(name: str, x: np.ndarray, at: np.ndarray | None) -> None:
        """out[name] = x at the output steps ``at`` of its step axis (None: x as it is)."""
        shape = (x.shape[0], len(steps)) + x.shape[2:]
        out[name] = (np.empty(shape, x.dtype) if allocate is None
                     else allocate(name, shape, x.dtype))
        if at is None:
            out[name][...] = x
        else:  # "clip" (the steps are in range) gathers without a buffer
            np.take(x, at, axis=1, out=out[name], mode="clip")

    if batch.n_steps <= period:  # every output step was solved
        j = steps
        angle, angle_at = motion.link_angle, j
    else:
        j, turns = steps % period, steps // period
        per_period = np.round((motion.link_angle[:, period] - motion.link_angle[:, 0])
                              / (2.0 * np.pi))
        angle = (motion.link_angle[:, j]
                 + 2.0 * np.pi * turns[None, :, None] * per_period[:, None, :])
        angle_at = None
    put("time", batch.step_size[:, None] * steps[None, :], None)
    put("crank_angle", angle[:, :, 0], angle_at)
    put("joint_position", motion.joint_position, j)
    put("link_angle", angle, angle_at)
    put("link_angular_velocity", motion.link_angular_velocity, j)
    put("link_angular_acceleration", motion.link_angular_acceleration, j)
    put("joint_force", forces.joint_force, j)
    put("input_torque", forces.input_torque, j)
    if forces.guide_force is not None:
        put("guide_force", forces.guide_force, j)
    return out, motion.singular.any(axis=1)


#: Variables whose NaN means "not applicable to this case" (dataset reference), not divergence.
_NAN_WHERE_ABSENT = {"spectral_tail"}


def _nonfinite(result: dict[str, np.ndarray]) -> dict[int, list[str]]:
    """Cases with a value that is not finite as stored (float32 fields overflow above 3.4e38),
    and the variables that have one."""
    bad: dict[int, list[str]] = {}
    for name, values in result.items():
        if name == SERIES_SAMPLES:  # not a dataset variable: guesses, checked where used
            continue
        dtype = VARIABLES[name][3]
        if dtype not in ("float32", "float64") or name in _NAN_WHERE_ABSENT:
            continue
        with np.errstate(over="ignore", invalid="ignore"):  # as stored; no copy if it is
            stored = np.asarray(values).astype(dtype, copy=False)
        finite = np.isfinite(stored).reshape(len(stored), -1).all(axis=1)
        for case in np.flatnonzero(~finite):
            bad.setdefault(int(case), []).append(name)
    return bad


#: Rigid joint forces (N) or drive torque (N m) beyond which a non-finite elastic result is
#: blamed on the input rather than on the solver: no machine sees 1e30 N, and the stresses of
#: such loads overflow float32 (3.4e38).
OVERFLOW_LOAD = 1e30
#: Results of the rigid analysis: non-finite there means an input overflowed.
_RIGID = {"time", "crank_angle", "joint_position", "link_angle", "link_angular_velocity",
          "link_angular_acceleration", "joint_force", "input_torque", "guide_force"}


def _fail_nonfinite(result: dict[str, np.ndarray], messages: list[str]) -> None:
    """Flag ``failed`` every case whose result is not finite, naming why (in place): no case
    carries a non-finite value unless it is failed."""
    for case, names in _nonfinite(result).items():
        if result["status"][case] & STATUS_FLAGS["failed"]:
            continue  # already failed, with its own message
        result["status"][case] |= STATUS_FLAGS["failed"]
        loads = max((float(np.max(np.abs(result[k][case])))
                     for k in ("joint_force", "input_torque") if k in result), default=0.0)
        if _RIGID & set(names) or loads > OVERFLOW_LOAD:
            cause = f"an input overflows: loads of {loads:.3g} N (N m) in the rigid analysis"
        else:
            cause = "the elastic response diverges (an unstable or ill-conditioned system)"
        messages[case] = f"failed: non-finite {', '.join(names)}: {cause}"


def _solve_isolated(batch: Batch, peaks_only: bool = False, allocate=None,
                    guesses: list | None = None) -> tuple[dict[str, np.ndarray], list[str]]:
    """Solve a batch (its station fields into ``allocate``'s arrays, :func:`solve_batch`);
    if it fails, solve its cases one by one and record the failures."""
    try:
        result = solve_batch(batch, peaks_only, allocate, guesses)
        messages = [""] * batch.size
        _fail_nonfinite(result, messages)
        return result, messages
    except Exception:  # noqa: BLE001 — isolate the failing case(s) below
        if batch.size == 1:
            raise
    results, messages = [], []
    for c, scene in enumerate(batch.scenes):
        try:
            results.append(solve_batch(make_batch([scene]), peaks_only,
                                       guesses=None if guesses is None else [guesses[c]]))
            messages.append("")
        except Exception as err:  # noqa: BLE001 — a failed case is recorded, not fatal
            results.append(None)
            messages.append(f"failed: {type(err).__name__}: {err}")
    template = next((r for r in results if r is not None), None)
    if template is None:
        raise RuntimeError("every case of the batch failed: " + "; ".join(messages))
    merged = {}
    for name, value in template.items():
        parts = []
        for r in results:
            if r is None:
                filler = np.full_like(value[:1], np.nan if value.dtype.kind == "f" else 0)
                if name == "status":
                    filler[:] = STATUS_FLAGS["failed"]
                parts.append(filler)
            else:
                parts.append(r[name])
        merged[name] = np.concatenate(parts)
    _fail_nonfinite(merged, messages)
    return merged, messages


def _solve_groups(scenes: list[dict], groups: dict[tuple, list[int]],
                  peaks_only: bool = False, guesses: list | None = None) -> list[tuple]:
    """Solve each group of structurally identical scenes as one batch (``guesses``, per
    scene or None: :func:`solve_batch`'s).

    Returns (batch, indices, result, (messages, seconds per case)) per group.
    """
    solved = []
    for group in groups.values():
        limit = cases_per_solve(scenes[group[0]])  # parts of bounded memory, failures isolated
        # The parts write their station fields into the group's arrays (_in_order then has
        # nothing to copy where the group holds the run's cases in order).
        fields: dict[str, np.ndarray] = {}
        for first in range(0, len(group), limit):
            indices = group[first:first + limit]
            batch = make_batch([scenes[i] for i in indices])
            start = _time.perf_counter()
            result, messages = _solve_isolated(
                batch, peaks_only, _into(fields, len(group), first),
                None if guesses is None else [guesses[i] for i in indices])
            seconds = (_time.perf_counter() - start) / batch.size
            solved.append((batch, indices, result, (messages, seconds)))
    return solved


def _in_order(parts: list[np.ndarray], solved: list[tuple]) -> np.ndarray:
    """One variable of the solved groups in the caller's order of cases, copied once (not at
    all when a single group holds the cases in order, in one part or in parts written into
    one array (:func:`_solve_groups`): the histories are most of the memory)."""
    indices = [np.asarray(ix) for _, ix, _, _ in solved]
    total = sum(len(ix) for ix in indices)
    if np.array_equal(np.concatenate(indices), np.arange(total)):
        if len(parts) == 1:
            return parts[0]
        whole = parts[0].base
        if (isinstance(whole, np.ndarray) and len(whole) == total
                and all(_is_rows(part, whole, first) for part, first in
                        zip(parts, np.cumsum([0] + [len(ix) for ix in indices[:-1]])))):
            return whole
    out = np.empty((sum(len(p) for p in parts),) + parts[0].shape[1:], parts[0].dtype)
    for ix, part in zip(indices, parts):
        out[ix] = part
    return out


def _is_rows(part: np.ndarray, whole: np.ndarray, first: int) -> bool:
    """``part`` is the view ``whole[first:first + len(part)]``."""
    rows = whole[first:first + len(part)]
    return (part.base is whole and part.shape == rows.shape and part.strides == rows.strides
            and part.__array_interface__["data"][0] == rows.__array_interface__["data"][0])


def _case_peak(peak_stress: np.ndarray) -> np.ndarray:
    """(case, link) → (case,): the largest peak over the links (NaN-safe), Pa."""
    with np.errstate(invalid="ignore"):
        return np.where(np.isnan(peak_stress).all(axis=1), np.nan,
                        np.nanmax(np.where(np.isnan(peak_stress), -np.inf, peak_stress), axis=1))


def _first_frequency(solved: list[tuple], data: dict, order: np.ndarray) -> np.ndarray:
    """Largest first natural frequency over the cycle, rad/s, per case (caller's order).

    Taken from the modal analysis when the scenes ask for one; otherwise a frozen analysis at
    four phases is made here (only for the error estimate).
    """
    if "natural_frequency" in data:
        return first_natural_frequency(data["natural_frequency"])
    parts = [first_natural_frequency(cycle_frequencies(model_for(batch), modal_phases(4), 1))
             for batch, *_ in solved]
    return np.concatenate(parts)[order]


def _peaks(scenes: list[dict], keep_going: bool = False,
           guesses: list | None = None) -> dict[str, np.ndarray]:
    """Peak stress, first and highest natural frequency (rad/s, where the scenes ask for a
    modal analysis), speed and spectral tail (NaN where the periodic state is not a Fourier
    series) of scenes solved in batches, in the order given: the solver
    injected into :func:`ced.auto.discretization.resolve_discretization` (pilots) and
    :func:`ced.auto.error_estimate.error_estimates` (companions, ``keep_going``: a group whose
    every case fails leaves NaN instead of raising; ``guesses``, per scene or None: the
    initial guesses of their spectral solves, :func:`solve_batch`)."""
    groups: dict[tuple, list[int]] = {}
    for index, scene in enumerate(scenes):
        groups.setdefault(structure_key(scene), []).append(index)
    out = {key: np.full(len(scenes), np.nan) for key in ("peak", "omega1", "omega_top",
                                                          "speed", "tail")}
    limits = {key: cases_per_solve(scenes[indices[0]]) for key, indices in groups.items()}
    parts = [group[i:i + limits[key]] for key, group in groups.items()
             for i in range(0, len(group), limits[key])]
    for indices in parts:
        try:
            ((batch, _, result, _),) = _solve_groups(scenes, {0: indices}, peaks_only=True,
                                                     guesses=guesses)
        except Exception:  # noqa: BLE001 — with keep_going: every companion of the part
            if keep_going:  # failed, so these cases get no estimate; their own results stand
                continue
            raise
        failed = (result["status"] & STATUS_FLAGS["failed"]) > 0
        out["peak"][indices] = np.where(failed, np.nan, _case_peak(result["peak_stress"]))
        out["speed"][indices] = batch.speed
        if "spectral_tail" in result:
            out["tail"][indices] = np.where(failed, np.nan, result["spectral_tail"])
        if "natural_frequency" in result:
            frequency = result["natural_frequency"]
            out["omega1"][indices] = first_natural_frequency(frequency)
            # the highest mode asked for, at its highest over the cycle
            out["omega_top"][indices] = first_natural_frequency(frequency[:, :, -1:])
    return out


def _spectra(scenes: list[dict]) -> list[tuple]:
    """Per scene its frozen spectrum over the cycle (mean frequencies, load harmonics,
    damping ratios: :func:`ced.response.resonance.cycle_spectrum`), in the order given: the
    resonance search injected into :func:`ced.auto.discretization.resolve_discretization`.
    Scenes of one structure share a batch, and a model the call already built. None for a
    scene whose motion repeats only every two turns (a change point passed straight
    through): its load's harmonics are not the crank's."""
    groups: dict[tuple, list[int]] = {}
    for index, scene in enumerate(scenes):
        groups.setdefault(structure_key(scene), []).append(index)
    out: list = [None] * len(scenes)
    for indices in groups.values():
        batch = make_batch([scenes[i] for i in indices])
        once = np.flatnonzero(batch.motion_turns == 1)
        if len(once) < len(indices):
            batch = make_batch([scenes[indices[c]] for c in once]) if len(once) else None
        if batch is not None:
            spectrum = cycle_spectrum(model_for(batch))
            for c, case in enumerate(once):
                out[indices[case]] = tuple(part[c] for part in spectrum)
    return out


def _auto_estimates(reports: list[dict], tail: np.ndarray | None,
                    status: np.ndarray) -> tuple[dict[int, float], dict[int, float]]:
    """``error_estimate`` of the cases ``discretization: auto`` resolved, and floors under the
    estimates left to companions.

    A case's predicted error is its estimate (the ladders are its companions). A case predicted
    as a Fourier series adds what its own series' tail exceeds the bound it was refined to (a
    series left unresolved at the most points, flagged ``resonant``); one that was shot in the
    end after all is left to the companions of :func:`ced.auto.error_estimate.error_estimates`,
    and so is a case that did not climb and is flagged ``resonant`` or
    ``parametrically_unstable``: its error was bounded by its neighbours' in speed, and a
    resonance between them is narrower than they see (the reference four-bar at 121 rad/s, in a
    sweep not searched for resonances: bounded by 0.46 %, 335 % off). Its prediction stays a
    floor under the companions' estimate: the coarser mesh of a companion sees the resonance
    but can miss the error the neighbours measured (the reference four-bar's undamped
    periodic sweep over 40–160 rad/s: 10 of its 35 such estimates below the true error, by up
    to 6.9 times, every one within its prediction; ``benchmarks/auto_wide_sweeps.py``).

    Returns
    -------
    known : dict
        Case → its estimate, no companion solved.
    floors : dict
        Case → the least its companions' estimate is raised to.
    """
    sharp = (status & (STATUS_FLAGS["resonant"] | STATUS_FLAGS["parametrically_unstable"])) > 0
    known, floors = {}, {}
    for i, report in enumerate(reports):
        if not report:
            continue
        if report.get("time_error") != "spectral_tail":
            value = report["predicted_error"]
        elif tail is not None and np.isfinite(tail[i]):
            value = report["predicted_error"] + max(
                0.0, float(tail[i]) - report["spectral_tail_bound"])
        else:
            continue
        if report["ladder"] == "interpolated" and sharp[i]:
            floors[i] = value
        else:
            known[i] = value
    return known, floors


def _estimate_source(estimate: np.ndarray, known: dict[int, float],
                     interpolated: np.ndarray) -> np.ndarray:
    """Where each case's ``error_estimate`` comes from (``error_estimate_source``'s flag
    values, :data:`ced.simulation.dataset.ESTIMATE_SOURCES`)."""
    source = np.full(len(estimate), ESTIMATE_SOURCES["companions"])
    source[list(known)] = ESTIMATE_SOURCES["discretization_auto"]
    source[interpolated] = ESTIMATE_SOURCES["sweep_neighbours"]
    return np.where(np.isnan(estimate), ESTIMATE_SOURCES["none"], source).astype("int8")


def simulate(scenes) -> xr.Dataset:
    """Run one scene or many and return the dataset of docs/reference/dataset.md.

    Parameters
    ----------
    scenes : path, dict, or an iterable of them
        Scenes in the format of docs/reference/scene.md. All must share the mechanism type and
        the number of output steps (one dataset has one ``step`` dimension).

    Returns
    -------
    xarray.Dataset
        One entry per scene along ``case``, in the order given.

    Examples
    --------
    >>> ds = simulate({"mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1,
    ...                              "coupler": 0.45, "rocker": 0.35},
    ...                "discretization": {"formulation": "rigid"},
    ...                "time": {"revolutions": 1, "steps_per_revolution": 64}})
    >>> ds.sizes["case"], str(ds.family.values[0])
    (1, 'crank_rocker')
    """
    normalized = [load_scene(s) for s in _as_list(scenes)]
    if not normalized:
        raise ValueError("simulate: no scenes given")
    check_run_memory(normalized)  # before any work
    # Models are kept within a call (its pilots, parts and companions share them), not from
    # one call to the next: a call's time and bits do not depend on what came before it.
    model_cache.clear()
    auto_reports = None
    if any(s["effects"] == "auto" for s in normalized):
        resolved = [resolve_auto(s) for s in normalized]
        normalized = [scene for scene, _ in resolved]
        auto_reports = [json.dumps(report, sort_keys=True) if report else "" for _, report in
                        resolved]
    auto_discretization = None
    reports: list[dict] = [{} for _ in normalized]
    if any(s["discretization"] == "auto" for s in normalized):
        normalized, reports = resolve_discretization(normalized, _peaks, spectra=_spectra)
        auto_discretization = [json.dumps(r, sort_keys=True) if r else "" for r in reports]
    kinds = {s["mechanism"]["type"] for s in normalized}
    if len(kinds) > 1:
        raise SceneError("mechanism.type", f"the scenes of one run must share it (one "
                                           f"dataset), got {join(sorted(kinds))}")
    groups: dict[tuple, list[int]] = {}
    for index, scene in enumerate(normalized):
        groups.setdefault(structure_key(scene), []).append(index)
    n_out = {k[1] // k[2] + 1 for k in groups}
    if len(n_out) > 1:
        raise SceneError("time.revolutions", "the scenes of one run must share the number of "
                                             "output steps (time.revolutions × "
                                             "time.steps_per_revolution / outputs.every): one "
                                             "dataset has one step dimension")

    solved = _solve_groups(normalized, groups)
    batches = [batch for batch, _, _, _ in solved]
    positions = [i for _, indices, _, _ in solved for i in indices]
    # Restore the caller's order of cases.
    order = np.argsort(np.array(positions))
    results = [result for _, _, result, _ in solved]
    names = set.intersection(*(set(r) for r in results))
    data = {name: _in_order([r[name] for r in results], solved) for name in names}
    samples = data.pop(SERIES_SAMPLES, None)  # the companions' initial guesses
    data["solve_time"] = np.concatenate(
        [np.full(len(ix), seconds) for _, ix, _, (_, seconds) in solved])[order]
    data["message"] = np.array([m for *_, (msgs, _) in solved for m in msgs], dtype=object)[order]
    if "peak_stress" in data and any(s["outputs"]["error_estimate"] for s in normalized):
        known, floors = _auto_estimates(reports, data.get("spectral_tail"), data["status"])
        peak = _case_peak(data["peak_stress"])
        failed = (data["status"] & STATUS_FLAGS["failed"]) > 0
        step_size = np.concatenate([b.step_size for b in batches])[order]
        guesses = None if samples is None else [
            g if isinstance(g, np.ndarray) else None for g in samples]

        def estimate(given: dict[int, float]) -> np.ndarray:
            return error_estimates(
                normalized, peak, failed, lambda: _first_frequency(solved, data, order),
                step_size, lambda companions, starts: _peaks(companions, True, starts)["peak"],
                known=given, spectral_tail=data.get("spectral_tail"),
                collocation_points=data.get("collocation_points"), guesses=guesses)

        data["error_estimate"], interpolated = sweep_estimates(
            normalized, data["status"], known, estimate, alone=floors)
        for i, floor in floors.items():  # NaN (a failed case) stays NaN
            data["error_estimate"][i] = np.maximum(data["error_estimate"][i], floor)
        data["error_estimate_source"] = _estimate_source(
            data["error_estimate"], known, interpolated)
    if auto_discretization is not None:
        data["discretization_auto"] = np.array(auto_discretization, dtype=object)
        estimate = data.get("error_estimate")
        unmet = np.array([bool(r) and (not r["tolerance_met"] or (
            estimate is not None and estimate[i] > r["tolerance"]))
            for i, r in enumerate(reports)])
        data["status"] = np.where(unmet, data["status"] | STATUS_FLAGS["tolerance_unmet"],
                                  data["status"]).astype(data["status"].dtype)
    if auto_reports is not None:
        data["effects_auto"] = np.array(auto_reports, dtype=object)

    first = normalized[0]
    topo = topology(first["mechanism"])
    coords = {
        "case": ("case", np.arange(len(normalized)), {"units": "1", "long_name": "case index"}),
        "step": ("step", np.arange(next(iter(n_out))) * first["outputs"]["every"],
                 {"units": "1", "long_name": "time step index"}),
        "link": ("link", np.array(topo.link_names, dtype=object), {"long_name": "link"}),
        "joint": ("joint", np.array(topo.joint_names, dtype=object), {"long_name": "joint"}),
        "axis": ("axis", np.array(["x", "y"], dtype=object), {"long_name": "global axis"}),
        **case_coordinates(batches, order),
    }
    used = {d for name in data for d in VARIABLES[name][0]}
    if "modal_angle" in used:
        n = first["modal"]["angles"]
        coords["modal_angle"] = ("modal_angle", 2.0 * np.pi * np.arange(n) / n, {
            "units": "rad", "long_name": "phase of the input cycle (crank angle − initial "
                                        "angle for a rotating input)",
            "comment": "of the two-turn period, at input angle 2 × modal_angle, for a case "
                       "whose motion repeats only every two turns (a change point passed once "
                       "a turn)"})
        coords["mode"] = ("mode", np.arange(1, first["modal"]["modes"] + 1),
                          {"units": "1", "long_name": "mode number, by ascending frequency"})
    if "station" in used:
        n = first["outputs"]["stations"]
        coords["station"] = ("station", np.linspace(0.0, 1.0, n),
                             {"units": "1", "long_name": "normalized position along the link"})
    effects = sorted({e for s in normalized for e in s["effects"]},
                     key=EFFECTS.index)
    return make_dataset(data, coords, scenes=normalized, effects=effects)
