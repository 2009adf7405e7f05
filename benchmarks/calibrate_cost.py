"""Measure the per-case cost table of ``ced check``'s run-time estimate.

The estimate (:func:`ced.simulation.size.case_seconds`) interpolates measured costs: seconds
per case and per time step of a batch of cases, as a function of the elastic DOFs n of the
model, from the ``undeformed`` and the ``periodic`` start; seconds per case and per modal
angle; and the rigid analysis's cost per step. This script measures them on this machine, one
BLAS thread (one core, as one Snakemake job per core runs), batches of ``BATCH`` cases of the
reference four-bar with a flexible coupler and rocker, and prints the tables to paste into
``ced/simulation/size.py`` (``COST_*``). Each value is the fastest of ``REPEATS`` runs (a
loaded machine only ever slows a run down).

Run ``.venv/bin/python benchmarks/calibrate_cost.py`` (a few minutes).
"""
from __future__ import annotations

import copy
import time

import single_thread  # noqa: F401,E402  (before numpy: one BLAS thread)

from ced.problem.scene import load_scene  # noqa: E402
from ced.simulation.simulate import simulate  # noqa: E402
from ced.simulation.size import elastic_dofs  # noqa: E402

BATCH = 8
REPEATS = 2
STEPS = 128
BASE = {
    "mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                  "rocker": 0.35},
    "links": {"crank": {"flexible": False}},
    "time": {"revolutions": 1, "steps_per_revolution": STEPS},
    "outputs": {"error_estimate": False},
}


def per_case(change: dict) -> tuple[float, int]:
    """Fastest wall time per case of a batch, s; and the model's elastic DOFs."""
    scenes = []
    for i in range(BATCH):
        scene = copy.deepcopy(BASE)
        for key, value in change.items():
            scene[key] = {**scene.get(key, {}), **value}
        scene["drive"] = {"speed": 60.0 + 5.0 * i}
        scenes.append(scene)
    best = float("inf")
    for _ in range(REPEATS):
        start = time.perf_counter()
        simulate(scenes)
        best = min(best, (time.perf_counter() - start) / BATCH)
    return best, elastic_dofs(load_scene(scenes[0]))


def main() -> None:
    per_case({"discretization": {"formulation": "rigid"}})  # imports, caches: not measured
    rigid, _ = per_case({"discretization": {"formulation": "rigid"}})
    print(f"COST_RIGID_STEP = {rigid / (STEPS + 1):.3g}")
    for start in ("undeformed", "periodic"):
        rows = []
        for elements in (1, 2, 4, 8, 16):
            seconds, dofs = per_case({"discretization": {"elements_per_link": elements},
                                      "time": {"start": start}})
            rows.append((dofs, (seconds - rigid) / (STEPS + 1)))
        print(f"COST_STEP[{start!r}] = (" + ", ".join(f"({n}, {s:.3g})" for n, s in rows)
              + ")")
    rows = []
    for elements in (2, 8):
        plain, dofs = per_case({"discretization": {"elements_per_link": elements}})
        modal, _ = per_case({"discretization": {"elements_per_link": elements},
                             "modal": {"modes": 4, "angles": 36}})
        rows.append((dofs, max(modal - plain, 0.0) / 36))
    print("COST_MODAL_ANGLE = (" + ", ".join(f"({n}, {s:.3g})" for n, s in rows) + ")")
    # The estimate's companions depend on the start (ced.auto.error_estimate.companions): one
    # coarser companion in the periodic steady state, a coarser mesh and finer steps from a
    # start transient. The default study's discretization: 8 elements (a mesh the companion
    # can coarsen) reduced to 4 modes per link, a modal analysis at 12 angles.
    for start, name in (("undeformed", "COST_ERROR_ESTIMATE"),
                        ("periodic", "COST_ERROR_ESTIMATE_PERIODIC")):
        change = {"discretization": {"elements_per_link": 8, "modes_per_link": 4},
                  "time": {"start": start}, "modal": {"modes": 3, "angles": 12}}
        plain, _ = per_case(change)
        estimated, _ = per_case({**change, "outputs": {"error_estimate": True}})
        print(f"{name} = {estimated / plain:.3g}  # factor on the case's cost")


if __name__ == "__main__":
    main()
