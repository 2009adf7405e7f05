"""ced against the peer (Exudyn) at equal accuracy, batch scaling, and what accuracy costs.

Run ``python benchmarks/run.py`` (``make bench``); results go to ``benchmarks/results.json``
and are printed as they come. One process, one BLAS thread: this measures one core.

1. **Sweep at equal accuracy** (:mod:`sweep`): the reference flexible four-bar at 100 speeds,
   Ω = 90 … 110 rad/s, two revolutions from the undeformed state. ced's converged value
   (32 elements, 32768 steps per revolution) at every speed, then every candidate setting
   timed as one batch of the 100 cases; the cheapest whose peak coupler strain is within 1 %
   of the converged value at every speed, less the converged value's own uncertainty, is
   ced's setting. The converged value is checked against twice its steps per revolution and
   against twice its elements at every fifth speed, and so is a quarter of its steps (8192,
   the converged value until 2026-11-28): the sum of the two largest differences is its
   uncertainty (``ced_reference.refinement``).
2. **The peer in the same run** (``benchmarks/peer/``): Exudyn, installed from PyPI into its
   own venv by the benchmark, at its cheapest 1 %-setting — found by
   ``benchmarks/peer/compare.py`` against the peer's own converged value, stored in
   ``benchmarks/peer_results.json`` — re-run here over the 100 speeds, its accuracy
   re-checked against its stored converged peaks and its solver time measured beside ced's.
   ``--peer-search`` redoes the peer's whole search (about 30 min).
3. **Batch scaling**: ced's setting in batches of 100, 1,000 and 10,000 cases.
4. **Error estimate and ``discretization: auto``** on the sweep: the estimate's cost against
   the solve it estimates, its companions shared along the sweep (the default) and with every
   case solving its own; ``tolerance: 1e-2`` with ``discretization: auto`` — its time per
   case and its true error at every speed against the converged value.
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE / "peer"))

import sweep  # noqa: E402

from ced.simulation.dataset import ESTIMATE_SOURCES  # noqa: E402
from ced.simulation.simulate import simulate  # noqa: E402

RESULTS = HERE / "results.json"
PEER_RESULTS = HERE / "peer_results.json"


def log(msg: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", flush=True)


def peer_at_chosen(search: bool) -> dict:
    """The peer's cheapest setting re-run over the sweep: accuracy against its converged peaks,
    solver time per case. ``search`` redoes the peer's search first."""
    import compare  # benchmarks/peer/compare.py (installs the peer on first use)
    version = compare.setup_peer()
    if search:
        compare.main([])
    stored = json.loads(PEER_RESULTS.read_text())
    elements, steps = stored["chosen"]["elements"], stored["chosen"]["steps_per_revolution"]
    reference = np.array(stored["reference"]["peak_strain"])
    run = compare.peer_sweep(sweep.SPEEDS, elements, steps, cached=False)
    peaks, seconds = compare._peaks(run), compare._seconds(run)
    error = np.abs(peaks / reference - 1.0)
    return {"exudyn": version, "elements": elements, "steps_per_revolution": steps,
            "reference": [stored["reference"]["elements"],
                          stored["reference"]["steps_per_revolution"]],
            "max_error": float(error.max()), "p95_error": float(np.percentile(error, 95)),
            "seconds_per_case": float(seconds.mean())}


def reference_refinement(reference: np.ndarray, reference_stress: np.ndarray,
                         stride: int = 5) -> tuple[dict, np.ndarray]:
    """Is ced's converged value converged? It against twice its steps per revolution and
    against twice its elements at every ``stride``-th speed, and a quarter of its steps
    against the finer steps; with the finer steps' peak strains. Its uncertainty is the sum of
    the two largest differences, on peak coupler strain and on peak stress (the start
    transient converges erratically in both: a halved difference is no bound)."""
    elements, modes, steps = sweep.CONVERGED
    finer = (elements, modes, 2 * steps)
    denser = (2 * elements, modes, steps)
    speeds = sweep.SPEEDS[::stride]
    chunk = sweep.CONVERGED_CHUNK // 2
    fine, fine_stress, _ = sweep.peaks(finer, speeds=speeds, chunk=chunk)
    dense, dense_stress, _ = sweep.peaks(denser, speeds=speeds, chunk=chunk)
    quarter, _ = sweep.peak_strain((elements, modes, steps // 4), speeds=speeds)

    def largest(a, b):
        return float(np.abs(a[::stride] / b - 1.0).max())

    time_difference, space_difference = largest(reference, fine), largest(reference, dense)
    stress_time = largest(reference_stress, fine_stress)
    stress_space = largest(reference_stress, dense_stress)
    return {"setting": list(finer), "space_setting": list(denser), "speeds": len(speeds),
            "stride": stride, "time_max_difference": time_difference,
            "space_max_difference": space_difference,
            "max_difference": time_difference + space_difference,
            "stress_time_max_difference": stress_time,
            "stress_space_max_difference": stress_space,
            "stress_max_difference": stress_time + stress_space,
            "quarter_steps_max_difference": float(np.abs(quarter / fine - 1.0).max())
            }, fine


def estimate_cost(setting: tuple[int, int, int], size: int = 100) -> dict:
    """Wall time per case of ``simulate`` on the sweep without ``error_estimate``, with it
    (companions shared along the sweep, the default: ``ced.auto.sweep_estimate``), and with
    every case solving its own companions (``outputs.error_estimate_sharing: false``),
    measured in this process, interleaved, best of two each."""
    elements, modes, steps = setting
    runs = ("without", "shared", "own")
    times = dict.fromkeys(runs, np.inf)
    for _ in range(2):  # interleaved, best of two: the load changes while it runs
        for run in runs:
            scenes = [{**sweep.REFERENCE_SCENE, "drive": {"speed": float(s)},
                       "outputs": {**sweep.REFERENCE_SCENE["outputs"],
                                   "error_estimate": run != "without",
                                   "error_estimate_sharing": run == "shared"},
                       "discretization": {"elements_per_link": elements,
                                          "modes_per_link": modes},
                       "time": {"revolutions": 2, "steps_per_revolution": steps,
                                "start": "undeformed"}}
                      for s in np.linspace(90.0, 110.0, size)]
            ds = None  # the last call's dataset, released first (sweep.timed_batch)
            t0 = time.perf_counter()
            ds = simulate(scenes)
            times[run] = min(times[run], (time.perf_counter() - t0) / size)
            assert ("error_estimate" in ds) == (run != "without")
            if run == "shared":
                source = ds.error_estimate_source.values
                companions = int((source == ESTIMATE_SOURCES["companions"]).sum())
    return {"setting": list(setting), "seconds_per_case_without": times["without"],
            "seconds_per_case_with": times["shared"], "overhead": times["shared"] / times[
                "without"] - 1.0, "cases_with_companions": companions,
            "seconds_per_case_every_case_its_own": times["own"],
            "overhead_every_case_its_own": times["own"] / times["without"] - 1.0}


def auto_at(tolerance: float, reference: np.ndarray, reference_stress: np.ndarray,
            uncertainty: float) -> dict:
    """``discretization: auto`` with ``tolerance`` over the sweep: time per case (pilots
    included), the settings chosen, the true error of peak coupler strain and of peak stress
    (what the tolerance is about) at every speed, and how often the predicted error bounds the
    true one — as measured, and allowing the converged stress its own ``uncertainty``
    (relative): a true error that small is not resolved."""
    scenes = [{**sweep.REFERENCE_SCENE, "drive": {"speed": float(s)}, "tolerance": tolerance,
               "discretization": "auto",
               "time": {"revolutions": 2, "start": "undeformed"}} for s in sweep.SPEEDS]
    t0 = time.perf_counter()
    ds = simulate(scenes)
    seconds = (time.perf_counter() - t0) / len(scenes)
    strain = np.abs(ds.bending_strain.sel(link="coupler")).max(("step", "station")).values
    error = np.abs(strain / reference - 1.0)
    stress = np.abs(ds.peak_stress.max("link").values / reference_stress - 1.0)
    reports = [json.loads(str(c)) for c in ds.discretization_auto.values]
    predicted = np.array([r["predicted_error"] for r in reports])
    choices = sorted({(c["elements_per_link"], c["steps_per_revolution"], c["modes_per_link"])
                      for c in reports})
    return {"tolerance": tolerance, "seconds_per_case": seconds,
            "max_error": float(error.max()), "p95_error": float(np.percentile(error, 95)),
            "max_stress_error": float(stress.max()),
            "p95_stress_error": float(np.percentile(stress, 95)),
            "speeds_over_tolerance": int((stress > tolerance).sum()),
            "max_predicted_error": float(predicted.max()),
            "predicted_bounds_true": float((stress <= predicted).mean()),
            "reference_stress_uncertainty": uncertainty,
            "predicted_bounds_true_within_uncertainty": float(
                (stress <= predicted + uncertainty).mean()),
            "tolerance_unmet": sum(not r["tolerance_met"] for r in reports),
            "cases_climbed": sum(r["ladder"] == "own" for r in reports),
            "settings_chosen": [list(c) for c in choices]}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--peer-search", action="store_true",
                        help="redo the peer's search for its cheapest setting (~30 min)")
    parser.add_argument("--no-peer", action="store_true", help="skip the peer")
    args = parser.parse_args(argv)
    results = {"machine": platform.machine(), "python": sys.version.split()[0],
               "numpy": np.__version__, "started": time.strftime("%Y-%m-%dT%H:%M:%SZ",
                                                                 time.gmtime()),
               "problem": "reference flexible four-bar, 100 speeds 90-110 rad/s, 2 revolutions "
                          "from undeformed, peak coupler strain within 1 % of each code's own "
                          "converged value at every speed"}
    log(f"ced converged value {sweep.CONVERGED} at {len(sweep.SPEEDS)} speeds")
    reference, reference_stress, seconds = sweep.peaks(sweep.CONVERGED,
                                                       chunk=sweep.CONVERGED_CHUNK)
    results["ced_reference"] = {"setting": list(sweep.CONVERGED), "seconds_per_case": seconds,
                                "peak_strain": reference.tolist(),
                                "peak_stress": reference_stress.tolist()}
    refinement, fine = reference_refinement(reference, reference_stress)
    results["ced_reference"]["refinement"] = refinement
    log(f"converged value against twice its steps: {refinement}")
    # A candidate passes within 1 % less the converged value's own uncertainty.
    search = sweep.cheapest(reference, refinement["max_difference"], log=log)
    results["ced"] = search
    best = search["cheapest"]
    if best is None:
        raise SystemExit("no ced candidate is within 1 % at every speed")
    setting = (best["elements_per_link"], best["modes_per_link"], best["steps_per_revolution"])
    log(f"ced cheapest: {setting}, {1e3 * best['seconds_per_case']:.2f} ms/case")
    cheap, _ = sweep.peak_strain(setting, speeds=sweep.SPEEDS[::refinement["stride"]])
    refinement["cheapest_max_error_against_it"] = float(np.abs(cheap / fine - 1.0).max())
    if not args.no_peer:
        peer = peer_at_chosen(args.peer_search)
        # ced's setting timed again right after the peer: both in the same conditions (best of
        # five: on a shared machine one batch's time scatters by ±20 %).
        _, ced_seconds = sweep.peak_strain(setting, repeat=5)
        peer["ced_seconds_per_case"] = ced_seconds
        peer["speedup"] = peer["seconds_per_case"] / ced_seconds
        results["peer"] = peer
        log(f"peer (Exudyn {peer['exudyn']}) {peer['elements']} elements × "
            f"{peer['steps_per_revolution']} steps/rev: {1e3 * peer['seconds_per_case']:.1f} "
            f"ms/case (max error {peer['max_error']:.2%}); ced {1e3 * ced_seconds:.2f} ms/case: "
            f"{peer['speedup']:.1f}× faster")
    results["batch_scaling"] = sweep.batch_scaling(setting, log=log)
    results["error_estimate"] = estimate_cost(setting)
    log(f"error_estimate at {setting}: +{results['error_estimate']['overhead']:.0%} shared "
        f"along the sweep, +{results['error_estimate']['overhead_every_case_its_own']:.0%} "
        f"with every case's own companions")
    results["discretization_auto"] = auto_at(1e-2, reference, reference_stress,
                                             refinement["stress_max_difference"])
    row = results["discretization_auto"]
    log(f"discretization auto, tolerance 1e-2: {1e3 * row['seconds_per_case']:.1f} ms/case, "
        f"max error {row['max_error']:.2%} (strain), {row['max_stress_error']:.2%} (stress; "
        f"{row['speeds_over_tolerance']} speeds over 1 %, predicted bounds the true error at "
        f"{row['predicted_bounds_true']:.0%}, within the converged value's uncertainty at "
        f"{row['predicted_bounds_true_within_uncertainty']:.0%}), settings "
        f"{row['settings_chosen']}")
    RESULTS.write_text(json.dumps(results, indent=2) + "\n")
    log(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
