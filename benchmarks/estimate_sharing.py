"""Is ``error_estimate`` still an upper bound when a speed sweep shares its companions?

From a start transient a case's estimate takes two companion solutions, one at twice its
steps (``ced.auto.error_estimate``); a sweep of 17 or more speeds solves them for every 16th
case (``sweep_estimate.STRIDE``) and bounds the others by 1.5 × the larger estimate of their
two neighbours that did (``ced.auto.sweep_estimate``). This runs six sweeps of 100 speeds, two
revolutions from rest, each at settings from coarse to fine, twice in the same run: every case
solving its own companions (``outputs.error_estimate_sharing: false``) and shared (the
default). Against each
sweep's converged value it reports, per setting: the cases that solved companions, the share
of speeds whose true error of peak stress is at most the estimate (shared and own), how often
a shared estimate is below the case's own, the median of shared / own and of estimate / true,
and the largest true error / shared estimate of a case between climbers.

* the benchmark's sweep (``sweep.py``: reference flexible four-bar, 90–110 rad/s) against
  its converged value (32 elements of every FE DOF, 32,768 steps per revolution);
* the same four-bar over 40–160 rad/s, against the same converged setting;
* Sung and Thompson's crank-rocker (``config/scenes/sung_thompson.yaml``: coupler and rocker
  flexible) over 15–45 rad/s, against 16 elements at 8,192 steps per revolution, itself
  checked against 32 elements at 16,384 at every 20th speed (``reference_check``);
* after the margin was chosen on those three, two more to test it: the in-line slider-crank
  of ``config/scenes/slider_crank.yaml`` with its rod flexible over 100–250 rad/s, and the
  reference four-bar with every link flexible over 60–120 rad/s, each against 16 elements at
  8,192 steps (checked against 32 elements at 16,384, and against 16,384 steps);
* after the stride was chosen (every 8th case until 2026-11-30), one more to test it: the
  reference four-bar from its ``quasi_static`` state over 60–140 rad/s, against 16 elements at
  8,192 steps, checked against 32 elements at 16,384.

Results go to ``benchmarks/estimate_sharing.json``; docs/accuracy.md quotes them. Run
``.venv/bin/python benchmarks/estimate_sharing.py`` (about twelve minutes on one core).
"""
from __future__ import annotations

import json
from pathlib import Path

import sweep  # noqa: F401  (imports single_thread: one BLAS thread, before numpy)

import numpy as np  # noqa: E402
import yaml  # noqa: E402

from ced.auto import sweep_estimate  # noqa: E402
from ced.problem.scene import load_scene  # noqa: E402
from ced.simulation.dataset import ESTIMATE_SOURCES  # noqa: E402
from ced.simulation.simulate import _case_peak, simulate  # noqa: E402

HERE = Path(__file__).resolve().parent
OUT = HERE / "estimate_sharing.json"
#: Speeds of a converged value solved at once (its histories at every step are large).
CHUNK = 10


def _sung_thompson() -> dict:
    raw = yaml.safe_load((HERE.parent / "config/scenes/sung_thompson.yaml").read_text())
    raw.pop("modal")
    raw.pop("time")  # every setting's own, from rest (scenes)
    raw["outputs"] = {"stations": 11, "every": 1}
    return raw


def _slider_crank() -> dict:
    raw = yaml.safe_load((HERE.parent / "config/scenes/slider_crank.yaml").read_text())
    raw.pop("discretization")  # the scene is rigid; its rod is flexible here
    raw.pop("time", None)  # every setting's own, from rest (scenes)
    raw["effects"] = ["inertia", "elastic_inertia", "coriolis", "centrifugal",
                      "axial_stiffening"]
    raw["outputs"] = {"stations": 11, "every": 1}
    return raw


#: The reference four-bar with crank, coupler and rocker flexible: its modes move over the
#: cycle, and its estimates vary by 20 times between neighbouring speeds.
EVERY_LINK_FLEXIBLE = {**sweep.REFERENCE_SCENE,
                       "links": {"default": sweep.REFERENCE_SCENE["links"]["default"]}}
#: The reference four-bar started from its quasi-static deflection: a smaller transient.
QUASI_STATIC = {**sweep.REFERENCE_SCENE, "time": {"start": "quasi_static"}}

#: (name, base scene, speeds (rad/s), converged (elements, modes, steps), its check (None:
#: ``run.py`` checks it) and the speeds solved at once there, settings). The first three
#: chose the margin; the slider-crank and the every-link-flexible four-bar came after, to test
#: it; the four-bar from ``quasi_static`` after the stride was chosen, to test that.
#: Strides at which the sharing rule is replayed on the measured own estimates (``replay``).
REPLAYED_STRIDES = (8, 12, 16, 20, 24, 32)

SWEEPS = [
    ("reference four-bar, 90-110 rad/s", sweep.REFERENCE_SCENE, np.linspace(90.0, 110.0, 100),
     sweep.CONVERGED, None, [(4, 0, 256), (8, 0, 512), (8, 8, 1280)]),
    ("reference four-bar, 40-160 rad/s", sweep.REFERENCE_SCENE, np.linspace(40.0, 160.0, 100),
     sweep.CONVERGED, None, [(8, 0, 512), (8, 4, 1024), (8, 8, 1280)]),
    ("Sung-Thompson crank-rocker, 15-45 rad/s", _sung_thompson(), np.linspace(15.0, 45.0, 100),
     (16, 0, 8192), ((32, 0, 16384), CHUNK), [(6, 0, 256), (8, 4, 512), (8, 4, 1024)]),
    ("slider-crank, rod flexible, 100-250 rad/s", _slider_crank(),
     np.linspace(100.0, 250.0, 100), (16, 0, 8192), ((32, 0, 16384), CHUNK),
     [(6, 0, 384), (8, 4, 512)]),
    ("reference four-bar, every link flexible, 60-120 rad/s", EVERY_LINK_FLEXIBLE,
     np.linspace(60.0, 120.0, 100), (16, 0, 8192), ((16, 0, 16384), 1),
     [(6, 0, 384), (8, 4, 512)]),
    ("reference four-bar from quasi_static, 60-140 rad/s", QUASI_STATIC,
     np.linspace(60.0, 140.0, 100), (16, 0, 8192), ((32, 0, 16384), 1),
     [(8, 4, 512), (8, 8, 1280)]),
]


def scenes(base: dict, speeds, setting: tuple, estimate: bool, shared: bool = True
           ) -> list[dict]:
    elements, modes, steps = setting
    start = base.get("time", {}).get("start", "undeformed")  # QUASI_STATIC's, else from rest
    return [{**base, "drive": {**base.get("drive", {}), "speed": float(v)},
             "outputs": {**base["outputs"], "error_estimate": estimate,
                         "error_estimate_sharing": shared},
             "discretization": {**base.get("discretization", {}),
                                "elements_per_link": elements, "modes_per_link": modes},
             "time": {"revolutions": 2, "steps_per_revolution": steps, "start": start}}
            for v in speeds]


def peak_stress(base: dict, speeds, setting: tuple, chunk: int = CHUNK) -> np.ndarray:
    """Peak stress (Pa, over the links) at every speed, ``chunk`` speeds at a time, the
    histories stored at every 64th step only (the peaks are over every step)."""
    thin = {**base, "outputs": {**base["outputs"], "every": 64}}
    return np.concatenate([
        _case_peak(simulate(scenes(thin, speeds[i:i + chunk], setting, False))
                   .peak_stress.values) for i in range(0, len(speeds), chunk)])


def estimated(base: dict, speeds, setting: tuple, shared: bool):
    """Peak stress, estimate, estimate source and status at every speed, one call."""
    ds = simulate(scenes(base, speeds, setting, True, shared))
    return (_case_peak(ds.peak_stress.values), ds.error_estimate.values,
            ds.error_estimate_source.values, ds.status.values)


class _Own:
    """A stand-in for the companions: each case's own estimate, as solved."""

    def __init__(self, own: np.ndarray):
        self.own, self.solved = own, set()

    def __call__(self, known: dict) -> np.ndarray:
        self.solved |= set(range(len(self.own))) - set(known)
        return np.array([known.get(i, e) for i, e in enumerate(self.own)])


def replay(pairs: list[tuple]) -> list[dict]:
    """The sharing rule at each of :data:`REPLAYED_STRIDES`, applied afresh to every
    (sweep, setting)'s own estimates (no solve): per stride and pair, the cases that would
    solve companions, the share of speeds whose true error the shared estimate bounds, and the
    largest true error / shared estimate between climbers."""
    rows, chosen = [], sweep_estimate.STRIDE
    try:
        for stride in REPLAYED_STRIDES:
            sweep_estimate.STRIDE = stride
            row = {"stride": stride, "cases_with_companions": [], "upper_bound_share": [],
                   "worst_true_over_shared_between": []}
            for normalized, status, own, true in pairs:
                companions = _Own(own)
                shared, between = sweep_estimate.sweep_estimates(normalized, status, {},
                                                                 companions)
                row["cases_with_companions"].append(len(companions.solved))
                row["upper_bound_share"].append(float(np.mean(true <= shared)))
                row["worst_true_over_shared_between"].append(
                    float(np.max(true[between] / shared[between], initial=0.0)))
            rows.append(row)
            print(f"replay, stride {stride}: {np.mean(row['cases_with_companions']):.1f} cases "
                  f"with companions on average; bounded at {min(row['upper_bound_share']):.0%}"
                  f" of the speeds or more; worst true/shared "
                  f"{max(row['worst_true_over_shared_between']):.2f}", flush=True)
    finally:
        sweep_estimate.STRIDE = chosen
    return rows


def main() -> None:
    rows, pairs = [], []
    for name, base, speeds, converged, checked, settings in SWEEPS:
        reference = peak_stress(base, speeds, converged)
        check = None
        if checked is not None:
            finer, chunk = checked
            at = speeds[::20]
            difference = np.abs(reference[::20] / peak_stress(base, at, finer, chunk) - 1.0)
            check = {"setting": list(finer), "speeds": at.tolist(),
                     "max_difference": float(difference.max())}
        for setting in settings:
            peak, own, _, status = estimated(base, speeds, setting, shared=False)
            peak_shared, shared, source, _ = estimated(base, speeds, setting, shared=True)
            assert np.array_equal(peak, peak_shared)
            true = np.abs(peak / reference - 1.0)
            pairs.append(([load_scene(s) for s in scenes(base, speeds, setting, True)],
                          status, own, true))
            between = source == ESTIMATE_SOURCES["sweep_neighbours"]
            row = {"sweep": name, "setting": list(setting), "converged": list(converged),
                   "reference_check": check,
                   "cases_with_companions": int((source == ESTIMATE_SOURCES["companions"]).sum()),
                   "max_true_error": float(true.max()),
                   "upper_bound_share_shared": float(np.mean(true <= shared)),
                   "upper_bound_share_own": float(np.mean(true <= own)),
                   "shared_below_own_share": float(np.mean(shared[between] < own[between])),
                   "median_shared_over_own": float(np.median(shared[between] / own[between])),
                   "median_estimate_over_true_shared": float(np.median(shared / true)),
                   "median_estimate_over_true_own": float(np.median(own / true)),
                   "worst_true_over_shared_between": float(np.max(true[between]
                                                                  / shared[between]))}
            rows.append(row)
            print(f"{name} {setting}: {row['cases_with_companions']} cases with companions; "
                  f"true ≤ estimate at {row['upper_bound_share_shared']:.0%} shared, "
                  f"{row['upper_bound_share_own']:.0%} own; shared/own median "
                  f"{row['median_shared_over_own']:.2f}; worst true/shared "
                  f"{row['worst_true_over_shared_between']:.2f}", flush=True)
    OUT.write_text(json.dumps({
        "problem": "six sweeps of 100 speeds, two revolutions from rest; "
                   "error_estimate of peak stress with companions shared along the sweep "
                   "against every case's own",
        "stride": sweep_estimate.STRIDE, "margin": sweep_estimate.MARGIN,
        "min_cases": sweep_estimate.MIN_CASES, "max_gap": sweep_estimate.MAX_GAP,
        "settings": rows, "replayed_strides": replay(pairs)}, indent=2) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
