"""Is ``discretization: auto`` with the periodic state as a Fourier series true to its tolerance?

The convergence study's reference scene of every family (``config/studies/convergence.yaml``:
1 % modal damping, 200 rad/s unless the family says otherwise) in its periodic steady state
with ``periodic_solver: spectral`` and ``discretization: auto``, at tolerances 1e-2 and 1e-3,
against an independent reference of the same model: 32 elements, 8 modes per link, shot at
4096 steps per revolution (a marched solve, not a series). Per case: the setting chosen,
whether it was taken as a series (``time_error: spectral_tail``; a change point falls back to
the marched ladders), its predicted error (its ``error_estimate``), the true error on peak
stress (None where the reference's motion is ``near_singular``: the change point's converged
value is uncertain by about 9 %, the convergence study's accuracy table), and the time of
the call. Results go to ``benchmarks/auto_series_check.json``;
docs/accuracy.md quotes them.

Run ``.venv/bin/python benchmarks/auto_series_check.py`` (about a minute).
"""
from __future__ import annotations

import copy
import json
import time
from pathlib import Path

import single_thread  # noqa: F401,E402  (before numpy: one BLAS thread)

from ced import simulate  # noqa: E402
from ced.problem.status import STATUS_FLAGS  # noqa: E402
from ced.problem.yaml_files import load_yaml  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
OUT = Path(__file__).with_name("auto_series_check.json")
TOLERANCES = (1e-2, 1e-3)
REFERENCE = {"elements_per_link": 32, "modes_per_link": 8, "steps_per_revolution": 4096}


def _merge(base: dict, extra: dict) -> dict:
    out = copy.deepcopy(base)
    for key, value in extra.items():
        out[key] = (_merge(out[key], value) if isinstance(value, dict)
                    and isinstance(out.get(key), dict) else copy.deepcopy(value))
    return out


def main() -> None:
    convergence = load_yaml(ROOT / "config" / "studies" / "convergence.yaml")["convergence"]
    rows = []
    for family, entry in convergence["families"].items():
        scene = _merge(convergence["base_scene"], entry)
        scene["modal"] = None
        scene["time"] = {"revolutions": 1, "steps_per_revolution": 128, "start": "periodic"}
        reference = simulate(_merge(scene, {
            "discretization": {k: REFERENCE[k] for k in ("elements_per_link",
                                                          "modes_per_link")},
            "time": {"steps_per_revolution": REFERENCE["steps_per_revolution"]},
            "outputs": {"error_estimate": False}}))
        peak = float(reference.peak_stress.max())
        verifiable = not int(reference.status.values[0]) & STATUS_FLAGS["near_singular"]
        for tolerance in TOLERANCES:
            auto = _merge(scene, {"tolerance": tolerance,
                                  "time": {"periodic_solver": "spectral"}})
            auto["discretization"] = "auto"
            start = time.perf_counter()
            ds = simulate(auto)
            seconds = time.perf_counter() - start
            report = json.loads(str(ds.discretization_auto.values[0]))
            row = {"family": family, "tolerance": tolerance,
                   "setting": [report["elements_per_link"], report["steps_per_revolution"],
                               report["modes_per_link"]],
                   "series": report.get("time_error") == "spectral_tail",
                   "predicted_error": report["predicted_error"],
                   "error_estimate": float(ds.error_estimate.values[0]),
                   "true_error": (abs(float(ds.peak_stress.max()) / peak - 1.0)
                                  if verifiable else None),
                   "tolerance_met": report["tolerance_met"],
                   "status": int(ds.status.values[0]), "seconds": round(seconds, 3)}
            row["estimate_bounds_true"] = (None if row["true_error"] is None
                                           else row["true_error"] <= row["error_estimate"])
            rows.append(row)
            true = "not verifiable" if row["true_error"] is None else f"{row['true_error']:.2e}"
            print(f"{family:14s} {tolerance:g}: {row['setting']} series {row['series']} "
                  f"true {true} estimate {row['error_estimate']:.2e} {seconds:.2f} s",
                  flush=True)
    series = [r for r in rows if r["series"]]
    summary = {"cases": len(rows), "series": len(series),
               "series_within_tolerance": sum(r["true_error"] <= r["tolerance"]
                                              for r in series),
               "series_bounded_by_estimate": sum(r["estimate_bounds_true"] for r in series)}
    OUT.write_text(json.dumps({"started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                               "reference": REFERENCE, "summary": summary, "cases": rows},
                              indent=2) + "\n")
    print(summary)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
