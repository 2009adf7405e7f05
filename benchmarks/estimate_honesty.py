"""Is ``error_estimate`` an upper bound from a start transient? (issue 14, point 4)

The convergence study (``config/studies/convergence.yaml``) validates the estimate in the
periodic steady state only. This checks it where free vibrations ring: the benchmark's sweep
(reference flexible four-bar, undeformed start, two revolutions, no damping; all 100 of its
speeds, every 5th until 2026-11-29), at settings from coarse to fine, against ced's
converged value of ``run.py`` (:data:`sweep.CONVERGED`: 32 elements of every FE DOF at 32,768
steps per revolution; 16 elements at 16,384 steps until 2026-11-29 evening, themselves up to a
few tenths of a percent off in space and time). For each setting: the largest true error of peak
stress, the share of speeds whose true error is at most the estimate, and the median
estimate / true.
Every case solves its own companions here (``outputs.error_estimate_sharing: false``; the sweep
would share them otherwise, ``ced.auto.sweep_estimate``): this validates the companions' estimate itself;
``estimate_sharing.py`` validates the shared one.
Results go to ``benchmarks/estimate_honesty.json``; docs/accuracy.md quotes them.

Run ``.venv/bin/python benchmarks/estimate_honesty.py`` (about ten minutes on one core).
"""
from __future__ import annotations

import json
from pathlib import Path

import single_thread  # noqa: F401,E402  (before numpy: one BLAS thread)

import numpy as np  # noqa: E402

import sweep  # noqa: E402
from ced.simulation.simulate import _case_peak, simulate  # noqa: E402

SPEEDS = sweep.SPEEDS
#: Speeds of the converged value solved at once (its histories are stored at every 64th step
#: only: the peaks are over every step).
CHUNK = 10
REFERENCE = sweep.CONVERGED
#: (elements, modes per link (0: every FE DOF), steps per revolution).
SETTINGS = [(4, 0, 256), (8, 0, 256), (8, 0, 512), (8, 0, 768), (8, 0, 1024), (6, 0, 1024),
            (8, 8, 1024), (16, 0, 1024), (8, 0, 2048)]
OUT = Path(__file__).with_name("estimate_honesty.json")


def scenes(setting: tuple[int, int, int], estimate: bool) -> list[dict]:
    elements, modes, steps = setting
    return [{**sweep.REFERENCE_SCENE, "drive": {"speed": float(speed)},
             "outputs": {**sweep.REFERENCE_SCENE["outputs"], "error_estimate": estimate,
                         "error_estimate_sharing": False},  # every case its own companions
             "discretization": {"elements_per_link": elements, "modes_per_link": modes},
             "time": {"revolutions": 2, "steps_per_revolution": steps, "start": "undeformed"}}
            for speed in SPEEDS]


def main() -> None:
    thin = [{**s, "outputs": {**s["outputs"], "every": 64}} for s in scenes(REFERENCE, False)]
    reference = np.concatenate([_case_peak(simulate(thin[i:i + CHUNK]).peak_stress.values)
                                for i in range(0, len(thin), CHUNK)])
    rows = []
    for setting in SETTINGS:
        ds = simulate(scenes(setting, True))
        true = np.abs(_case_peak(ds.peak_stress.values) / reference - 1.0)
        estimate = ds.error_estimate.values
        rows.append({"setting": list(setting), "max_true_error": float(true.max()),
                     "upper_bound_share": float(np.mean(true <= estimate)),
                     "median_estimate_over_true": float(np.median(estimate / true)),
                     "max_estimate": float(estimate.max())})
        print(f"{setting}: true ≤ {true.max():.2%}, estimate ≥ true at "
              f"{rows[-1]['upper_bound_share']:.0%} of the speeds, median estimate/true "
              f"{rows[-1]['median_estimate_over_true']:.1f}", flush=True)
    OUT.write_text(json.dumps({
        "problem": "reference flexible four-bar, undeformed start, 2 revolutions, "
                   f"{len(SPEEDS)} speeds 90-110 rad/s; peak stress",
        "reference": list(REFERENCE), "settings": rows,
        "all_speeds_share": float(np.mean([r["upper_bound_share"] for r in rows]))},
        indent=2) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
