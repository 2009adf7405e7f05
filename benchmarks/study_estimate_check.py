"""Is the default study's ``error_estimate`` true, case by case? (issue 14, points 3 and 4)

The convergence study validates the estimate on one reference scene per family; the default
study's 11,536 cases hold what that cannot see (an undamped mode on a high crank harmonic, the
estimate's blind spot while the periodic state was shot). This draws unflagged cases spread
evenly over every family of ``config/config.yaml``, solves them as the study does (its base
scene: 8 elements, 4 modes per link, the spectral periodic state), and compares each peak
stress with an independent converged value of the same model: 32 elements (space error 64×
smaller at order 3) at twice the case's Fourier collocation points per period and at least 128
(the series converges exponentially), GMRES allowed 3,000 iterations; cases whose reference
does not converge are counted and left out. It records the share of cases whose true error
is at most the estimate (the issue asks ≥ 90 %), the share with a true error within 2 %, the
median estimate / true, and the estimate's cost against the solve (companions timed apart).
That sample is solved in small batches (one per mechanism type), where the companions' fixed
costs weigh more than in the study's chunks of 500; so every chunk of the study is also solved
as its chunk job solves it, with the companions timed apart (``whole_study``: the share the
study pays, overall and by family; about a minute and a half more on one core).
Results go to ``benchmarks/study_estimate_check.json``; docs/accuracy.md quotes them.

Run ``.venv/bin/python benchmarks/study_estimate_check.py`` (about three minutes on 2 cores).
"""
from __future__ import annotations

import copy
import json
import time
from pathlib import Path

import single_thread  # noqa: F401,E402  (before numpy: one BLAS thread)

import numpy as np  # noqa: E402

import ced.response.collocation as collocation  # noqa: E402
import ced.simulation.simulate as simulation  # noqa: E402
from ced.problem.yaml_files import load_yaml  # noqa: E402
from ced.study.cases import chunk_rows  # noqa: E402
from ced.study.config import check_config  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
OUT = Path(__file__).with_name("study_estimate_check.json")
#: Cases drawn per chunk (evenly spaced through it) before the flagged ones are dropped.
PER_CHUNK = 12
REFERENCE = {"elements_per_link": 32, "least_points": 128, "iterations": 3000}


def _cases() -> list[dict]:
    config = load_yaml(ROOT / "config" / "config.yaml")
    chunks = check_config(config)
    scenes = []
    for family, count in sorted(chunks.items()):
        for index in range(count):
            rows = chunk_rows(config, family, index)
            pick = np.linspace(0, len(rows) - 1, min(PER_CHUNK, len(rows))).round().astype(int)
            scenes += [copy.deepcopy(rows[i]["scene"]) for i in np.unique(pick)]
    return scenes


def _reference(scene: dict, points: int) -> dict:
    out = copy.deepcopy(scene)
    out["discretization"]["elements_per_link"] = REFERENCE["elements_per_link"]
    out["time"]["collocation_points"] = max(2 * int(points), REFERENCE["least_points"])
    out["outputs"] = {**out["outputs"], "error_estimate": False, "every": 8}
    out["modal"] = None
    return out


def _timed_companions(companion_time: list[float]):
    """``simulate``'s solver of the estimate's companions, adding its time to
    ``companion_time[0]``."""
    peaks = simulation._peaks

    def timed(*args, **kwargs):
        start = time.perf_counter()
        try:
            return peaks(*args, **kwargs)
        finally:
            companion_time[0] += time.perf_counter() - start
    return timed


def whole_study() -> dict:
    """Every chunk of the default study solved as its chunk job does (one ``simulate`` of
    its cases), the companions timed apart: their cost over the rest, overall and by family."""
    config = load_yaml(ROOT / "config" / "config.yaml")
    peaks, companion_time = simulation._peaks, [0.0]
    simulation._peaks = _timed_companions(companion_time)
    by_family, total = {}, {"solve": 0.0, "companions": 0.0}
    try:
        for family, count in sorted(check_config(config).items()):
            solve = companions = 0.0
            for index in range(count):
                scenes = [copy.deepcopy(row["scene"]) for row in chunk_rows(config, family, index)]
                companion_time[0] = 0.0
                start = time.perf_counter()
                simulation.simulate(scenes)
                spent = time.perf_counter() - start
                solve += spent - companion_time[0]
                companions += companion_time[0]
            by_family[family] = {"chunks": count, "solve_seconds": round(solve, 2),
                                 "companion_seconds": round(companions, 2),
                                 "estimate_cost_over_solve": round(companions / solve, 3)}
            total["solve"] += solve
            total["companions"] += companions
            print(family, by_family[family], flush=True)
    finally:
        simulation._peaks = peaks
    return {"solve_seconds": round(total["solve"], 1),
            "companion_seconds": round(total["companions"], 1),
            "estimate_cost_over_solve": round(total["companions"] / total["solve"], 3),
            "by_family": by_family}


def main() -> None:
    scenes = _cases()
    companion_time = [0.0]
    peaks = simulation._peaks
    timed = _timed_companions(companion_time)
    simulation._peaks = timed
    iterations = collocation.MAX_ITERATIONS, collocation.LADDER_ITERATIONS
    solve_time = 0.0
    true, estimate, families, no_reference = [], [], [], 0
    for kind in sorted({s["mechanism"]["type"] for s in scenes}):  # one dataset per type
        group = [s for s in scenes if s["mechanism"]["type"] == kind]
        start = time.perf_counter()
        ds = simulation.simulate(group)
        solve_time += time.perf_counter() - start
        keep = (ds.status.values == 0) & (ds.collocation_points.values > 0)
        simulation._peaks = peaks  # the references are not part of the cost
        collocation.MAX_ITERATIONS = collocation.LADDER_ITERATIONS = REFERENCE["iterations"]
        ref = simulation.simulate([_reference(group[i], ds.collocation_points.values[i])
                                   for i in np.flatnonzero(keep)])
        collocation.MAX_ITERATIONS, collocation.LADDER_ITERATIONS = iterations
        simulation._peaks = timed
        converged = ref.collocation_points.values > 0
        no_reference += int((~converged).sum())
        reference = simulation._case_peak(ref.peak_stress.values[converged])
        keep[np.flatnonzero(keep)[~converged]] = False
        peak = simulation._case_peak(ds.peak_stress.values[keep])
        true.append(np.abs(peak / reference - 1.0))
        estimate.append(ds.error_estimate.values[keep])
        families.append(ds.family.values[keep])
    simulation._peaks = peaks
    true, estimate, families = (np.concatenate(x) for x in (true, estimate, families))
    by_family = {str(f): {"cases": int((families == f).sum()),
                          "upper_bound_share": float(np.mean(true[families == f]
                                                             <= estimate[families == f])),
                          "max_true_error": float(true[families == f].max())}
                 for f in np.unique(families)}
    result = {
        "problem": "unflagged default-study cases solved by the spectral periodic solver, "
                   f"{PER_CHUNK} drawn per chunk; reference: the same model at "
                   f"{REFERENCE['elements_per_link']} elements and twice the case's "
                   f"collocation points (at least {REFERENCE['least_points']})",
        "cases": len(true), "drawn": len(scenes), "no_converged_reference": no_reference,
        "upper_bound_share": float(np.mean(true <= estimate)),
        "true_within_2_percent": float(np.mean(true <= 0.02)),
        "estimate_within_2_percent": float(np.mean(estimate <= 0.02)),
        "max_true_error": float(true.max()),
        "median_estimate_over_true": float(np.median(estimate / np.maximum(true, 1e-300))),
        "smallest_estimate_over_true": float(np.min(estimate / np.maximum(true, 1e-300))),
        "estimate_cost_over_solve": companion_time[0] / (solve_time - companion_time[0]),
        "by_family": by_family,
        "whole_study": whole_study(),
    }
    OUT.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
