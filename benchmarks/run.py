"""Cases per second of the KED solver on the reference four-bar (issue: batches and speed).

Reference four-bar: ground 0.5, crank 0.1, coupler 0.45, rocker 0.35 m; steel; rectangle
10 mm × 5 mm with 5 mm in-plane; rigid crank and rocker, flexible coupler; 100 rad/s;
2 revolutions, from ``undeformed`` and with the ``periodic`` start. Discretization for 1 %
error in peak coupler bending strain, measured by :func:`accuracy` against a 16-element,
4096-steps-per-revolution full FE solution: 8 elements, 128 steps per revolution — all FE DOFs
(``full``), and reduced to 4 fixed-interface modes plus static load vectors per flexible link
(``reduced``, :mod:`ced.fem.component_modes`).

Run ``python benchmarks/run.py`` (``make bench``); results go to benchmarks/results.json and
are printed as a table. Single process, one BLAS thread: this measures one core.
"""
from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from ced.response.batch import make_batch  # noqa: E402
from ced.problem.scene import load_scene  # noqa: E402
from ced.simulation.simulate import simulate, solve_batch  # noqa: E402

REFERENCE = {
    "mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                  "rocker": 0.35},
    "links": {"default": {"material": "steel",
                          "section": {"shape": "rectangle", "height": 0.005, "width": 0.01}},
              "crank": {"flexible": False}, "rocker": {"flexible": False}},
    "drive": {"speed": 100.0},
    "outputs": {"stations": 21},
}
ELEMENTS, STEPS = 8, 128
MODELS = {"full": 0, "reduced": 4}  # modes_per_link
BATCHES = (1, 10, 100, 1000)


def scene(start: str, elements: int = ELEMENTS, steps: int = STEPS, speed: float = 100.0,
          modes: int = 0):
    return load_scene({**REFERENCE, "drive": {"speed": speed},
                       "discretization": {"elements_per_link": elements,
                                          "modes_per_link": modes},
                       "time": {"revolutions": 2, "steps_per_revolution": steps,
                                "start": start}})


def peak_strain(s: dict) -> float:
    out = solve_batch(make_batch([s]))
    return float(np.abs(out["bending_strain"][0, :, 1]).max())


def accuracy(start: str, modes: int) -> float:
    """Relative error of peak coupler bending strain at the benchmark discretization."""
    reference = peak_strain(scene(start, 16, 4096))
    return abs(peak_strain(scene(start, modes=modes)) / reference - 1)


def throughput(start: str, size: int, repeat: int, modes: int) -> float:
    """Cases per second for a batch of ``size`` cases (slightly different speeds, so that no
    two cases are identical), best of ``repeat`` runs."""
    scenes = [scene(start, speed=100.0 + 1e-3 * i, modes=modes) for i in range(size)]
    batch = make_batch(scenes)
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        solve_batch(batch)
        best = min(best, time.perf_counter() - t0)
    return size / best


def estimate_overhead(steps: int, size: int = 100) -> dict:
    """Wall time of ``simulate`` with and without ``error_estimate``, reduced model, periodic
    start, one batch of ``size`` cases (one run each, measured in the same process)."""
    scenes = [{**REFERENCE, "drive": {"speed": 100.0 + 1e-3 * i},
               "discretization": {"elements_per_link": ELEMENTS, "modes_per_link": 4},
               "time": {"revolutions": 2, "steps_per_revolution": steps, "start": "periodic"},
               "modal": {"modes": 1, "angles": 12}} for i in range(size)]
    times = {}
    for flag in (False, True):
        batch = [{**s, "outputs": {**s["outputs"], "error_estimate": flag}} for s in scenes]
        t0 = time.perf_counter()
        simulate(batch)
        times[flag] = time.perf_counter() - t0
    return {"steps_per_revolution": steps, "batch": size,
            "ms_per_case_without": 1e3 * times[False] / size,
            "ms_per_case_with": 1e3 * times[True] / size,
            "overhead": times[True] / times[False] - 1.0}


def auto_cost(tolerance: float, size: int = 100) -> dict:
    """Wall time per case of ``discretization: auto`` (pilots included) and the choice."""
    scenes = [{**REFERENCE, "drive": {"speed": 100.0 + 1e-3 * i}, "discretization": "auto",
               "tolerance": tolerance, "outputs": {**REFERENCE["outputs"],
                                                   "error_estimate": False},
               "time": {"revolutions": 2, "start": "periodic"}} for i in range(size)]
    t0 = time.perf_counter()
    ds = simulate(scenes)
    elapsed = time.perf_counter() - t0
    choice = json.loads(str(ds.discretization_auto.values[0]))
    # The chosen setting's own solve; the rest of the wall time is the ladders' pilots.
    solve = float(ds.solve_time.mean())
    return {"tolerance": tolerance, "batch": size, "ms_per_case": 1e3 * elapsed / size,
            "solve_ms_per_case": 1e3 * solve, "pilot_share": 1.0 - solve * size / elapsed,
            "elements_per_link": choice["elements_per_link"],
            "steps_per_revolution": choice["steps_per_revolution"],
            "predicted_error": choice["predicted_error"]}


def main() -> None:
    results = {"machine": platform.machine(), "python": sys.version.split()[0],
               "numpy": np.__version__, "elements": ELEMENTS, "steps_per_revolution": STEPS,
               "revolutions": 2, "runs": []}
    for model, modes in MODELS.items():
        for start in ("undeformed", "periodic"):
            error = accuracy(start, modes)
            for size in BATCHES:
                rate = throughput(start, size, 3 if size <= 100 else 1, modes)
                results["runs"].append({"model": model, "modes_per_link": modes,
                                        "start": start, "batch": size,
                                        "cases_per_second": rate, "peak_strain_error": error})
                print(f"{model:8s} {start:11s} batch {size:5d}: {rate:8.1f} cases/s "
                      f"({1e3 / rate:7.2f} ms/case), peak strain error {error:.2%}", flush=True)
    results["error_estimate"] = [estimate_overhead(steps) for steps in (64, 128, 256)]
    for row in results["error_estimate"]:
        print(f"error_estimate, {row['steps_per_revolution']} steps/rev: "
              f"{row['ms_per_case_without']:.2f} → {row['ms_per_case_with']:.2f} ms/case "
              f"(+{row['overhead']:.0%})", flush=True)
    results["discretization_auto"] = [auto_cost(t) for t in (1e-2, 1e-3, 1e-4)]
    for row in results["discretization_auto"]:
        print(f"discretization auto, tolerance {row['tolerance']:g}: {row['ms_per_case']:.2f} "
              f"ms/case with pilots, {row['solve_ms_per_case']:.2f} without "
              f"({row['elements_per_link']} el, {row['steps_per_revolution']} steps/rev)",
              flush=True)
    out = Path(__file__).with_name("results.json")
    out.write_text(json.dumps(results, indent=2) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
