"""What a run asks of the machine, estimated before any work: output bytes and peak memory.

``ced check`` sizes a study with it (:mod:`ced.study.config`) and :func:`ced.simulate` refuses
a set of scenes whose estimated peak memory exceeds this machine's
(:func:`check_run_memory`), naming the scene key that drives it — instead of starting a run
that would exhaust the memory hours later.
"""
from __future__ import annotations

import os

from ..problem.errors import SceneError
from ..problem.mechanism import topology
from ..response.batch import step_count

__all__ = ["case_bytes", "solver_bytes", "case_memory", "run_memory", "check_run_memory",
           "cases_per_solve", "machine_memory", "size_text", "WORKING_MEMORY_FACTOR",
           "BASE_MEMORY_BYTES", "SOLVER_BUDGET_BYTES", "MAX_CASES_PER_SOLVE"]

#: Peak memory of a chunk job ≈ BASE + FACTOR × chunk_size × (in-memory bytes of one case):
#: the solver's float64 arrays, their concatenation across batches and the dataset handed to
#: the netCDF writer (measured with tracemalloc on chunks of 16-64 cases of 256-1024 steps:
#: 2.6-3.0).
WORKING_MEMORY_FACTOR = 3
#: Interpreter, numpy/scipy/xarray/netCDF4 and compiled kernels of a chunk job, bytes.
BASE_MEMORY_BYTES = 300 * 2**20


def case_bytes(scene: dict, itemsize: int = 4) -> int:
    """Bytes of one case's output variables (DESIGN §5), uncompressed.

    With S output steps (``revolutions × steps_per_revolution // every + 1``), L links,
    J joints, P stations, A modal angles, M modes, g = 1 for a slider-crank (guide force), e = 1
    for an elastic formulation and m = 1 if a modal analysis is asked::

        bytes = 8 S (3 + g + 3 L + 4 J) + e itemsize S 5 L P + e (8·5 L + 8 m A M) + 8·3 + 161

    (time, crank angle, input torque, guide force; link angle, velocity, acceleration; joint
    position and force; the five station fields, float32 on disk (``itemsize`` 4) and float64
    in the solver (8); five per-link peaks; natural frequencies; three per-case scalars; status,
    message and case coordinates.)

    Parameters
    ----------
    scene : dict
        A normalized scene (:func:`ced.problem.scene.load_scene`).
    itemsize : int
        Bytes per value of the station fields.
    """
    topo = topology(scene["mechanism"]["type"])
    steps = step_count(scene) // scene["outputs"]["every"] + 1
    links, joints = len(topo.link_names), len(topo.joint_names)
    stations = scene["outputs"]["stations"]
    disc = scene["discretization"]
    elastic = disc == "auto" or disc["formulation"] != "rigid"
    guide = scene["mechanism"]["type"] == "slider_crank"
    modal = scene.get("modal") or {"angles": 0, "modes": 0}
    total = 8 * steps * (3 + guide + 3 * links + 4 * joints) + 8 * 3 + 161
    if elastic:
        total += itemsize * steps * 5 * links * stations + 8 * 5 * links
        total += 8 * modal["angles"] * modal["modes"]
    return total


def machine_memory() -> int:
    """Physical memory of this machine, bytes (``os.sysconf``)."""
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


#: DOFs per element of each formulation's flexible link (beams: u, v, θ per node; seed_lame:
#: u, u', v, v', v'' per node; plane_stress: 2 per node of a quadratic mesh, per element along
#: the link and per ``elements_across``).
_DOFS_PER_ELEMENT = {"euler_bernoulli": 3, "timoshenko": 3, "seed_lame": 5, "plane_stress": 16}


def _dofs(scene: dict) -> int:
    """Elastic DOFs of a scene's model, roughly (an upper bound; ``auto`` counts its finest
    ladder rung, 128 elements)."""
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
    projection, 8·P·(5n² + n) for P steps per revolution and n DOFs); the modal analysis holds K
    and M (and two factors) at every modal angle at once, 8·4·A·n²; the periodic shooting a
    3n × 3n monodromy matrix and its factors, 8·4·9n², and 3n + 1 state columns."""
    n = _dofs(scene)
    if not n:
        return 0
    modal = scene.get("modal") or {"angles": 0}
    shooting = scene["time"]["start"] == "periodic"
    period = 8 * scene["time"]["steps_per_revolution"] * (5 * n * n + n)
    return period + 8 * 4 * n * n * (modal["angles"] + (9 if shooting else 0))


#: Bytes of solver working arrays one batch may hold: a larger batch is solved in parts
#: (:func:`cases_per_solve`), so per-case cost and memory stay flat with the batch size.
SOLVER_BUDGET_BYTES = 256 * 2**20
#: Cases per part at most: numpy's per-call cost is amortized well before this.
MAX_CASES_PER_SOLVE = 256


def cases_per_solve(scene: dict) -> int:
    """Cases of ``scene``'s structure solved together: as many as fit
    :data:`SOLVER_BUDGET_BYTES` of :func:`solver_bytes`, between 1 and
    :data:`MAX_CASES_PER_SOLVE`."""
    return int(min(MAX_CASES_PER_SOLVE,
                   max(1, SOLVER_BUDGET_BYTES // max(solver_bytes(scene), 1))))


def case_memory(scene: dict) -> int:
    """Peak memory one case's outputs add to a run, bytes: ``WORKING_MEMORY_FACTOR ×
    case_bytes(itemsize=8)`` (the solver's working arrays are bounded per part, see
    :func:`run_memory`)."""
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
    default)."""
    solver = max((solver_bytes(s) * min(cases_per_solve(s), len(scenes)) for s in scenes),
                 default=0)
    return (BASE_MEMORY_BYTES + sum(case_memory(s) for s in scenes) + solver,
            _driver(scenes))


def check_run_memory(scenes: list[dict], memory: int | None = None) -> int:
    """Refuse scenes whose estimated peak memory (:func:`run_memory`) exceeds ``memory``
    (default: this machine's, :func:`machine_memory`); return the estimate, bytes."""
    need, key = run_memory(scenes)
    memory = machine_memory() if memory is None else memory
    if need > memory:
        raise SceneError(key, f"the run needs about {size_text(need)} of memory, more than the "
                              f"{size_text(memory)} of this machine ({len(scenes)} case(s); "
                              f"reduce {key} or run fewer cases at once)")
    return need


def size_text(n: float) -> str:
    """``1.2 GB`` (decimal units) for a byte count."""
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if n < 1000 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1000
    raise AssertionError
