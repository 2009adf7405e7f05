"""What ``discretization: auto``'s pilots cost on the benchmark's sweep, with and without sharing.

Run ``python benchmarks/auto_pilots.py`` (about four minutes on an idle machine); results go to
``benchmarks/auto_pilots.json`` and are printed. One process, one BLAS thread.

The sweep of ``benchmarks/run.py`` (reference flexible four-bar, 100 speeds 90–110 rad/s, two
revolutions from the undeformed state) with ``tolerance: 1e-2`` and ``discretization: auto``,
through :func:`ced.simulate`, resolved two ways in the same run, interleaved, three times each:
every distinct case climbing its own ladders (``stride=1``, as before sharing) and sweeps
sharing them (the default: :data:`ced.auto.discretization.STRIDE` from a start transient,
:data:`~ced.auto.discretization.PERIODIC_STRIDE` for periodic states, whose sweep is searched
for resonances). Per run: the wall time of the pilots
(all of :func:`~ced.auto.discretization.resolve_discretization`) and of the whole call, and
their CPU times (the machine is shared: CPU time depends less on the other load), the
pilot solves, the cases that climbed and the setting chosen. The same sweep from a periodic
start is timed alike (its ladders vary smoothly in speed), and again with
``periodic_solver: spectral`` (a Fourier series: no time ladder, its tail bounded instead; its
true error is measured at all 100 speeds). The marched settings' true error is
measured at six speeds (the ends, the speed whose ladder sets the steps, and three more)
against ced's converged value (32 elements, every FE DOF, 32768 steps per revolution), on peak
stress (what ``tolerance`` is about) and on peak coupler strain (what ``run.py`` compares).
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import sweep  # noqa: E402  (imports single_thread: one BLAS thread)

import numpy as np  # noqa: E402

import ced.simulation.simulate as simulate_module  # noqa: E402
from ced.auto import discretization  # noqa: E402
from ced.response.batch import make_batch  # noqa: E402

RESULTS = HERE / "auto_pilots.json"
TOLERANCE = 1e-2
#: Speeds (indices into sweep.SPEEDS) whose true error is measured: the ends, 95.45 rad/s
#: (its time ladder set the sweep's steps until the ladders had to resolve every mode of their
#: model, 2026-11-29) and three more; ``run.py`` measures all 100.
CHECKED = [0, 20, 27, 50, 75, 99]


def scenes(start: str, solver: str = "shooting") -> list[dict]:
    time, outputs = {"revolutions": 2, "start": start}, sweep.REFERENCE_SCENE["outputs"]
    if solver != "shooting":  # the series' steps are its output instants: 128 a revolution
        time.update(periodic_solver=solver, steps_per_revolution=128)
        outputs = {**outputs, "error_estimate": True}  # the prediction (no companion solved)
    return [{**sweep.REFERENCE_SCENE, "drive": {"speed": float(s)}, "tolerance": TOLERANCE,
             "discretization": "auto", "time": time, "outputs": outputs}
            for s in sweep.SPEEDS]


def timed_auto(raw: list[dict], stride: int | None) -> tuple[dict, object]:
    """One ``simulate`` call with the pilots resolved at ``stride`` (None: the default): its
    times and dataset."""
    spent = {}

    def resolve(normalized, solve, **injected):
        solves = [0]

        def counted(pilots):
            solves[0] += len(pilots)
            return solve(pilots)

        t0, c0 = time.perf_counter(), time.process_time()
        out = discretization.resolve_discretization(normalized, counted, stride=stride,
                                                   **injected)
        spent.update(pilots=time.perf_counter() - t0, cpu=time.process_time() - c0,
                     solves=solves[0])
        return out

    original = simulate_module.resolve_discretization
    simulate_module.resolve_discretization = resolve
    try:
        t0, c0 = time.perf_counter(), time.process_time()
        ds = simulate_module.simulate(raw)
        total, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        simulate_module.resolve_discretization = original
    reports = [json.loads(str(v)) for v in ds.discretization_auto.values]
    return {"stride": stride, "seconds_total": total, "seconds_pilots": spent["pilots"],
            "pilot_share": spent["pilots"] / total, "cpu_seconds_total": cpu,
            "cpu_seconds_pilots": spent["cpu"], "pilot_share_cpu": spent["cpu"] / cpu,
            "pilot_solves": spent["solves"],
            "cases_climbed": sum(r["ladder"] == "own" for r in reports),
            "setting": [reports[0]["elements_per_link"], reports[0]["steps_per_revolution"],
                        reports[0]["modes_per_link"]],
            "max_predicted_error": max(r["predicted_error"] for r in reports),
            "tolerance_unmet": sum(not r["tolerance_met"] for r in reports)}, ds


def compare(start: str, repeat: int = 3, solver: str = "shooting") -> tuple[dict, dict]:
    """Both resolutions of the sweep, interleaved, ``repeat`` times; what the true errors need
    of the last datasets (:func:`kept`)."""
    raw = scenes(start, solver)
    simulate_module.simulate(raw[:2])  # compile before timing
    runs, last = {"before": [], "after": []}, {}
    for _ in range(repeat):
        for name, stride in (("before", 1), ("after", None)):
            row, ds = timed_auto(raw, stride)
            # Only a few arrays are kept: a whole dataset of the start transient (100 cases,
            # 8,193 steps) alive through the next call made it fault in ~1.4 GB of new pages,
            # 3 s of system time in every other call.
            last[name] = kept(ds)
            del ds
            runs[name].append(row)
            print(f"{start} {solver} {name} (stride {stride or 'default'}): "
                  f"{row['seconds_total']:.2f} s, "
                  f"pilots "
                  f"{row['seconds_pilots']:.2f} s ({row['pilot_share']:.0%}; CPU "
                  f"{row['pilot_share_cpu']:.0%}), "
                  f"{row['pilot_solves']} pilot solves, {row['cases_climbed']} climbed, "
                  f"setting {row['setting']}", flush=True)
    return runs, last


def kept(ds) -> dict[str, np.ndarray]:
    """Of a sweep's dataset, what :func:`true_errors` and :func:`series_true_errors` read:
    peak stress over the links, error estimate (None without) and status at every speed, and
    the coupler's peak |bending strain| at the CHECKED speeds."""
    strain = np.abs(ds.isel(case=CHECKED).bending_strain.sel(link="coupler"))
    return {"stress": ds.peak_stress.max("link").values,
            "estimate": ds.error_estimate.values.copy() if "error_estimate" in ds else None,
            "status": ds.status.values.copy(),
            "checked_strain": strain.max(("step", "station")).values}


def peaks(setting: tuple[int, int, int], indices) -> tuple[np.ndarray, np.ndarray]:
    """Peak stress (Pa, over the links) and peak coupler strain at sweep.SPEEDS[indices]."""
    out = sweep.solve_batch(make_batch([sweep.scene(s, *setting)
                                        for s in sweep.SPEEDS[indices]]))
    stress = np.nanmax(out["peak_stress"], axis=1)
    return stress, np.abs(out["bending_strain"][:, :, 1]).max(axis=(1, 2)).astype(float)


def true_errors(datasets: dict) -> dict:
    """Each resolution's true error at the CHECKED speeds against the converged value
    (``datasets``: per resolution, :func:`kept`)."""
    stress_ref, strain_ref = peaks(sweep.CONVERGED, CHECKED)  # 6 speeds: one batch fits
    out = {"speeds": [float(s) for s in sweep.SPEEDS[CHECKED]],
           "reference": list(sweep.CONVERGED)}
    for name, ds in datasets.items():
        stress, strain = ds["stress"][CHECKED], ds["checked_strain"]
        out[name] = {"stress_error": np.abs(stress / stress_ref - 1.0).tolist(),
                     "strain_error": np.abs(strain / strain_ref - 1.0).tolist()}
        out[name]["max_stress_error"] = max(out[name]["stress_error"])
        out[name]["max_strain_error"] = max(out[name]["strain_error"])
        print(f"{name}: true error at {len(CHECKED)} speeds: stress max "
              f"{out[name]['max_stress_error']:.2%}, coupler strain max "
              f"{out[name]['max_strain_error']:.2%}", flush=True)
    return out


def series_true_errors(ds: dict) -> dict:
    """The spectral sweep's true error on peak stress at every speed, against 32 elements of
    every FE DOF at 256 collocation points (the series converges exponentially), and how
    often the estimate bounds it."""
    converged = simulate_module.simulate([
        {**sweep.REFERENCE_SCENE, "drive": {"speed": float(s)},
         "discretization": {"elements_per_link": 32, "modes_per_link": 0},
         "time": {"revolutions": 1, "start": "periodic", "periodic_solver": "spectral",
                  "steps_per_revolution": 128, "collocation_points": 256},
         "outputs": {**sweep.REFERENCE_SCENE["outputs"], "every": 128}}
        for s in sweep.SPEEDS])
    error = np.abs(ds["stress"] / converged.peak_stress.max("link").values - 1.0)
    estimate = ds["estimate"]
    out = {"reference": [32, 0, "256 collocation points"], "max_stress_error": float(error.max()),
           "p95_stress_error": float(np.percentile(error, 95)),
           "estimate_bounds_true": float(np.mean(error <= estimate)),
           "max_estimate": float(estimate.max()),
           "flagged_resonant": int(((ds["status"] & 4) > 0).sum())}
    print(f"periodic spectral: true error at {len(error)} speeds: max "
          f"{out['max_stress_error']:.2%}, estimate above it at "
          f"{out['estimate_bounds_true']:.0%}", flush=True)
    return out


def main() -> None:
    started = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    results = {"started": started, "tolerance": TOLERANCE, "cases": len(sweep.SPEEDS),
               "stride": discretization.STRIDE,
               "periodic_stride": discretization.PERIODIC_STRIDE,
               "interpolation_margin": discretization.INTERPOLATION_MARGIN}
    runs, last = compare("undeformed")
    results["undeformed"] = runs
    results["undeformed_true_error"] = true_errors(last)
    results["periodic"], _ = compare("periodic", repeat=2)
    runs, last = compare("periodic", solver="spectral")
    results["periodic_spectral"] = runs
    results["periodic_spectral_true_error"] = series_true_errors(last["after"])
    RESULTS.write_text(json.dumps(results, indent=2) + "\n")
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
