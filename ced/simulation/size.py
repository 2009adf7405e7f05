"""What a run asks of the machine, estimated before any work: output bytes, peak memory and
run time.

``ced check`` sizes a study with it (:mod:`ced.study.config`) and :func:`ced.simulate` refuses
a set of scenes whose estimated peak memory exceeds this machine's
(:func:`check_run_memory`), naming the scene key that drives it — instead of starting a run
that would exhaust the memory hours later.
"""
from __future__ import annotations

import math
import os
from decimal import Decimal

from ..problem.errors import SceneError
from ..problem.mechanism import topology
from ..response.batch import MOTION_TURNS, case_family, step_count
from ..response.modal_damping import MAX_PHASES

__all__ = ["case_bytes", "elastic_dofs", "case_seconds", "solver_bytes", "case_memory",
           "run_memory", "check_run_memory", "cases_per_solve", "machine_memory", "size_text",
           "WORKING_MEMORY_FACTOR", "BASE_MEMORY_BYTES", "SOLVER_BUDGET_BYTES",
           "MAX_CASES_PER_SOLVE"]

#: Peak memory of a chunk job ≈ BASE + FACTOR × chunk_size × (in-memory bytes of one case):
#: the solver's float64 arrays, their concatenation across batches and the dataset handed to
#: the netCDF writer (measured with tracemalloc on chunks of 16-64 cases of 256-1024 steps:
#: 2.6-3.0).
WORKING_MEMORY_FACTOR = 3
#: Interpreter, numpy/scipy/xarray/netCDF4 and compiled kernels of a chunk job, bytes.
BASE_MEMORY_BYTES = 300 * 2**20


def case_bytes(scene: dict, itemsize: int = 4) -> int:
    """Bytes of one case's output variables (docs/reference/dataset.md), uncompressed.

    With S output steps (``revolutions × steps_per_revolution // every + 1``), L links,
    J joints, P stations, A modal angles, M modes, g = 1 for a slider-crank (guide force), e = 1
    for an elastic formulation and m = 1 if a modal analysis is asked::

        bytes = 8 S (3 + g + 3 L + 4 J) + e itemsize S 6 L P + e (8·5 L + 8 m A M) + 8·3 + 161

    (time, crank angle, input torque, guide force; link angle, velocity, acceleration; joint
    position and force; six station fields — four, and the stress at two fibres — float32 on
    disk (``itemsize`` 4) and float64 in the solver (8); five per-link peaks; natural frequencies; three per-case scalars; status,
    message and case coordinates.)

    Parameters
    ----------
    scene : dict
        A normalized scene (:func:`ced.problem.scene.load_scene`).
    itemsize : int
        Bytes per value of the station fields.
    """
    topo = topology(scene["mechanism"])
    steps = step_count(scene) // scene["outputs"]["every"] + 1
    links, joints = len(topo.link_names), len(topo.joint_names)
    stations = scene["outputs"]["stations"]
    disc = scene["discretization"]
    elastic = disc == "auto" or disc["formulation"] != "rigid"
    guide = bool(topo.sliders)
    modal = scene.get("modal") or {"angles": 0, "modes": 0}
    total = 8 * steps * (3 + guide + 3 * links + 4 * joints) + 8 * 3 + 161
    if elastic:
        total += itemsize * steps * 6 * links * stations + 8 * 5 * links
        total += 8 * modal["angles"] * modal["modes"]
    return total


def machine_memory() -> int:
    """Physical memory of this machine, bytes (``os.sysconf``)."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


#: DOFs per element of each formulation's flexible link (beams: u, v, θ per node; seed_lame:
#: u, u', v, v', v'' per node; plane_stress: 2 per node of a quadratic mesh, per element along
#: the link and per ``elements_across``).
_DOFS_PER_ELEMENT = {"euler_bernoulli": 3, "timoshenko": 3, "seed_lame": 5, "plane_stress": 16}


def elastic_dofs(scene: dict) -> int:
    """Elastic DOFs of a scene's model, roughly (an upper bound; ``auto`` counts its finest
    ladder rung, 128 elements).

    Parameters
    ----------
    scene : dict
        A normalized scene.

    Returns
    -------
    int
        Elastic degrees of freedom of the flexible links (0 for ``rigid``).
    """
    disc = scene["discretization"]
    if disc == "auto":
        disc = {"formulation": "euler_bernoulli", "elements_per_link": 128,
                "elements_across": 2, "modes_per_link": 4}
    if disc["formulation"] == "rigid":
        return 0
    per_link = _DOFS_PER_ELEMENT[disc["formulation"]] * disc["elements_per_link"]
    if disc["formulation"] == "plane_stress":
        per_link *= disc["elements_across"]
    if disc.get("modes_per_link"):
        per_link = min(per_link, disc["modes_per_link"] + 9)
    return per_link * sum(bool(link["flexible"]) for link in scene["links"].values())


def solver_bytes(scene: dict) -> int:
    """Working arrays of the solver for one case beyond its outputs, bytes: the system over
    one period (:mod:`ced.response.period_terms`: M, C, K, their step factorizations and the
    projection, 8·P·(5n² + n) for P steps per period and n DOFs: two turns' worth for a
    change point, whose motion may repeat only every two,
    :attr:`ced.response.batch.Batch.motion_turns`); the modal analysis holds K
    and M (and two factors) at every modal angle at once, 8·4·A·n²; the periodic shooting a
    3n × 3n monodromy matrix and its factors, 8·4·9n², and 3n + 1 state columns; modal
    damping with ζ > 0 its table over the period (:mod:`ced.response.modal_damping`), at most
    8·(16·2⁶ + 1)·n² (33 phases for a smooth linkage, 161 at a change point). With
    ``outputs.every`` > 1 the displacements are held at every step of the run (the peaks are
    over all of them, :mod:`ced.response.elastic`) where only every n-th is written:
    16·(S + 1)·n for S steps (the independent and the link coordinates).

    Parameters
    ----------
    scene : dict
        A normalized scene.

    Returns
    -------
    int
        Bytes.
    """
    n = elastic_dofs(scene)
    if not n:
        return 0
    modal = scene.get("modal") or {"angles": 0}
    shooting = scene["time"]["start"] == "periodic"
    turns = max(MOTION_TURNS) if case_family(scene) == "change_point" else 1
    period = 8 * turns * scene["time"]["steps_per_revolution"] * (5 * n * n + n)
    history = 16 * (step_count(scene) + 1) * n if scene["outputs"]["every"] > 1 else 0
    damping = scene["damping"]
    damped = scene["effects"] == "auto" or "damping" in scene["effects"]
    table = (8 * MAX_PHASES * n * n
             if damped and damping["model"] == "modal" and damping["ratio"] > 0 else 0)
    return (period + history + table
            + 8 * 4 * n * n * (modal["angles"] + (9 if shooting else 0)))


#: Bytes of solver working arrays one batch may hold: a larger batch is solved in parts
#: (:func:`cases_per_solve`), so per-case cost and memory stay flat with the batch size.
SOLVER_BUDGET_BYTES = 256 * 2**20
#: Cases per part at most: numpy's per-call cost is amortized well before this.
MAX_CASES_PER_SOLVE = 256


def cases_per_solve(scene: dict) -> int:
    """Cases of ``scene``'s structure solved together: as many as fit
    :data:`SOLVER_BUDGET_BYTES` of :func:`solver_bytes`, between 1 and
    :data:`MAX_CASES_PER_SOLVE`.

    Parameters
    ----------
    scene : dict
        A normalized scene (its structure: mechanism, discretization, steps, outputs).

    Returns
    -------
    int
        Number of cases per solve.
    """
    return int(min(MAX_CASES_PER_SOLVE,
                   max(1, SOLVER_BUDGET_BYTES // max(solver_bytes(scene), 1))))


def case_memory(scene: dict) -> int:
    """Peak memory one case's outputs add to a run, bytes: ``WORKING_MEMORY_FACTOR ×
    case_bytes(itemsize=8)`` (the solver's working arrays are bounded per part, see
    :func:`run_memory`).

    Parameters
    ----------
    scene : dict
        A normalized scene.

    Returns
    -------
    int
        Bytes.
    """
    return WORKING_MEMORY_FACTOR * case_bytes(scene, itemsize=8)


#: Scene keys that make a case large, with their defaults: the key that drives an estimate is
#: the one furthest above its default.
_DRIVERS = {("time", "revolutions"): 2.0, ("time", "steps_per_revolution"): 512,
            ("outputs", "stations"): 11, ("modal", "angles"): 36, ("modal", "modes"): 6,
            ("discretization", "elements_per_link"): 8}


def _driver(scenes: list[dict]) -> str:
    """The scene key furthest above its default over ``scenes`` (``time.steps_per_revolution``
    when none is above)."""
    ratio = {}
    for scene in scenes:
        for (block, key), default in _DRIVERS.items():
            value = scene.get(block)
            if isinstance(value, dict):
                name = f"{block}.{key}"
                ratio[name] = max(ratio.get(name, 0.0), value[key] / default)
    return max(ratio, key=ratio.get) if max(ratio.values()) > 1 else "time.steps_per_revolution"


def run_memory(scenes: list[dict]) -> tuple[int, str]:
    """Estimated peak memory of solving ``scenes`` together, bytes: ``BASE_MEMORY_BYTES + Σ
    case_memory`` plus the largest part's solver arrays (:func:`cases_per_solve` cases of
    :func:`solver_bytes`); and the scene key that drives it (the one furthest above its
    default).

    Parameters
    ----------
    scenes : list of dict
        Normalized scenes solved together.

    Returns
    -------
    bytes : int
        Estimated peak memory.
    key : str
        Dotted scene key that drives it (``time.steps_per_revolution``, …).
    """
    solver = max((solver_bytes(s) * min(cases_per_solve(s), len(scenes)) for s in scenes),
                 default=0)
    return (BASE_MEMORY_BYTES + sum(case_memory(s) for s in scenes) + solver,
            _driver(scenes))


def check_run_memory(scenes: list[dict], memory: int | None = None) -> int:
    """Refuse scenes whose estimated peak memory (:func:`run_memory`) exceeds ``memory``
    (default: this machine's, :func:`machine_memory`); return the estimate, bytes.

    Parameters
    ----------
    scenes : list of dict
        Normalized scenes solved together.
    memory : int, optional
        Memory available, bytes.

    Returns
    -------
    int
        The estimated peak memory, bytes.

    Raises
    ------
    SceneError
        At the scene key that drives the estimate, when it exceeds ``memory``.
    """
    need, key = run_memory(scenes)
    memory = machine_memory() if memory is None else memory
    if need > memory:
        raise SceneError(key, f"the run needs about {size_text(need)} of memory, more than the "
                              f"{size_text(memory)} of this machine ({len(scenes)} case(s); "
                              f"reduce {key} or run fewer cases at once)")
    return need


def size_text(n: float) -> str:
    """``1.2 GB`` (decimal units) for a byte count.

    Parameters
    ----------
    n : float
        A size, bytes.

    Returns
    -------
    str
        Three significant digits and a decimal unit.

    Examples
    --------
    >>> size_text(1234), size_text(2.5e9), size_text(10**400)
    ('1.23 kB', '2.5 GB', '1.00e+385 PB')
    """
    if isinstance(n, int):  # exact: a grid of 1e308 speeds counts beyond a float's range
        n = Decimal(n)
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if n < 1000 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1000
    raise AssertionError


# ------------------------------------------------------------------------------ run time
# Measured cost model of one case inside a vectorized batch, one core, one BLAS thread, by
# benchmarks/calibrate_cost.py (batches of 8 reference four-bars with a flexible coupler and
# rocker, 1 revolution of 128 steps, fastest of 2 runs; 2026-11-24, this project's 2-core
# machine, re-measured after the one-period compiled solver; the default study's estimate,
# 8 min on 2 cores, against its measured 7.6 min). Re-measure when the solver changes; benchmarks/estimate_check.py compares the
# resulting study estimate with a measured run of config/studies/test.yaml.
#: Rigid analysis (kinematics, inverse dynamics, dataset), s per case per time step.
COST_RIGID_STEP = 1.44e-05
#: Elastic response marching from rest, s per case per time step, at n elastic DOFs: (n, s).
COST_STEP_UNDEFORMED = ((6, 3.49e-05), (12, 4.57e-05), (24, 8.67e-05), (48, 0.000237),
                        (96, 0.000944))
#: The same over one revolution with ``start: periodic`` (marching plus shooting), (n, s).
COST_STEP_PERIODIC = ((6, 3.49e-05), (12, 4.74e-05), (24, 0.000108), (48, 0.000476),
                      (96, 0.00244))
#: Modal analysis, s per case per modal angle (4 modes), (n, s).
COST_MODAL_ANGLE = ((12, 4.33e-05), (48, 0.000331))
#: Factor on a case's cost for its error estimate from a start transient (a coarser mesh and
#: finer steps, ced.auto.error_estimate.companions); 8 elements reduced to 4 modes per link,
#: 12 modal angles (re-measured 2026-11-25, after the companions changed).
COST_ERROR_ESTIMATE = 2.16
#: The same from a periodic start (one coarser companion; 1.33 over 1,000 cases of the
#: default study).
COST_ERROR_ESTIMATE_PERIODIC = 1.31


def _interpolate(table: tuple, n: float) -> float:
    """Log-log interpolation in a measured (n, cost) table, extrapolated with the end slopes."""
    xs = [math.log(x) for x, _ in table]
    ys = [math.log(y) for _, y in table]
    x = math.log(max(n, 1.0))
    i = 1 if x <= xs[0] else len(xs) - 1 if x >= xs[-1] else \
        next(k for k in range(1, len(xs)) if x <= xs[k])
    slope = (ys[i] - ys[i - 1]) / (xs[i] - xs[i - 1])
    return math.exp(ys[i - 1] + slope * (x - xs[i - 1]))


def case_seconds(scene: dict) -> float:
    """Estimated solve time of one case in a vectorized batch, one core, s.

    From the measured tables above: the rigid analysis per step; the elastic response per
    step at the model's elastic DOFs (:func:`elastic_dofs`), with the periodic start's extra
    cost over one revolution; the modal analysis per angle; times
    :data:`COST_ERROR_ESTIMATE` (:data:`COST_ERROR_ESTIMATE_PERIODIC` from a periodic start)
    when the case's error is estimated. An estimate within a
    factor of about two: the machine's load and the scene's effects are not modelled.

    Parameters
    ----------
    scene : dict
        A normalized scene.

    Returns
    -------
    float
        Seconds.

    Examples
    --------
    >>> from ced.problem.scene import load_scene
    >>> rigid = load_scene({"mechanism": {"type": "single_link", "length": 0.5},
    ...                     "discretization": {"formulation": "rigid"}})
    >>> round(case_seconds(rigid), 4)  # 1025 steps x 1.44e-05 s
    0.0148
    """
    steps = step_count(scene) + 1
    seconds = COST_RIGID_STEP * steps
    n = elastic_dofs(scene)
    if not n:
        return seconds
    elastic = _interpolate(COST_STEP_UNDEFORMED, n) * steps
    time_ = scene["time"]
    if time_["start"] == "periodic":
        extra = _interpolate(COST_STEP_PERIODIC, n) - _interpolate(COST_STEP_UNDEFORMED, n)
        elastic += max(extra, 0.0) * (time_["steps_per_revolution"] + 1)
    modal = scene.get("modal")
    if modal:
        elastic += _interpolate(COST_MODAL_ANGLE, n) * modal["angles"]
    if scene["outputs"]["error_estimate"]:
        elastic *= (COST_ERROR_ESTIMATE_PERIODIC if time_["start"] == "periodic"
                    else COST_ERROR_ESTIMATE)
    return seconds + elastic
