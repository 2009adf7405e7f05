"""Does ``discretization: auto`` bound its error over a wide speed sweep?

The benchmarks' sweeps span 90–110 rad/s, where 4–8 of 100 speeds climb the ladders and the
rest are bounded by them. This widens the span to 40–160 rad/s, 100 speeds, on the reference
flexible four-bar in its periodic steady state as a Fourier series (``periodic_solver:
spectral``, ``tolerance: 1e-2``), undamped and with the stiffness-proportional damping of
``steady_state.py`` (β = 1e-4 s). Every speed's peak stress is compared with ced's converged
value (32 elements of every FE DOF at 256 collocation points, as ``auto_pilots.py``'s series
reference). Per sweep: the setting chosen, the speeds that climbed, the pilots' share of the
call, the true error at every speed, and how often the ``error_estimate`` is at least the
true error — as ``ced.simulate`` reports it, and, in the same run, without the floor that a
case between climbers flagged ``resonant`` or ``parametrically_unstable`` keeps under its
companions' estimate (``ced.simulation.simulate._auto_estimates``). Results go to
``benchmarks/auto_wide_sweeps.json``; docs/accuracy.md quotes them.

Run ``.venv/bin/python benchmarks/auto_wide_sweeps.py`` (about two minutes on one core).
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import sweep  # noqa: E402  (imports single_thread: one BLAS thread)
import auto_pilots  # noqa: E402  (its timed_auto: the pilots' share)

import numpy as np  # noqa: E402

import ced.simulation.simulate as simulate_module  # noqa: E402
from ced.problem.status import STATUS_FLAGS  # noqa: E402

OUT = HERE / "auto_wide_sweeps.json"
SPEEDS = np.linspace(40.0, 160.0, 100)
TOLERANCE = 1e-2
DAMPING_BETA = 1e-4  # s, as steady_state.py
REFERENCE = {"elements_per_link": 32, "modes_per_link": 0, "collocation_points": 256}
#: Speeds of the converged value solved at once.
CHUNK = 10


def scene(speed: float, damped: bool) -> dict:
    """The sweep's four-bar at ``speed`` in its periodic steady state, as a series."""
    out = {**sweep.REFERENCE_SCENE, "drive": {"speed": float(speed)},
           "time": {"revolutions": 1, "start": "periodic", "periodic_solver": "spectral",
                    "steps_per_revolution": 128}}
    if damped:
        out["effects"] = ["inertia", "elastic_inertia", "coriolis", "centrifugal",
                          "axial_stiffening", "damping"]
        out["damping"] = {"model": "rayleigh", "beta": DAMPING_BETA}
    return out


def converged(damped: bool) -> np.ndarray:
    """ced's converged peak stress (Pa, over the links) at every speed."""
    parts = []
    for first in range(0, len(SPEEDS), CHUNK):
        raws = [scene(s, damped) for s in SPEEDS[first:first + CHUNK]]
        ds = simulate_module.simulate([
            {**raw, "discretization": {k: v for k, v in REFERENCE.items()
                                       if k != "collocation_points"},
             "time": {**raw["time"], "collocation_points": REFERENCE["collocation_points"]},
             "outputs": {**raw["outputs"], "every": 128}} for raw in raws])
        parts.append(ds.peak_stress.max("link").values)
    return np.concatenate(parts)


_AUTO_ESTIMATES = simulate_module._auto_estimates


def _unfloored(reports, tail, status):
    """``_auto_estimates`` without the floors: the companions' estimate alone."""
    known, _ = _AUTO_ESTIMATES(reports, tail, status)
    return known, {}


def estimated(raws: list[dict], floor: bool):
    """The sweep's dataset through ``ced.simulate``, the floor removed where ``floor`` is
    false."""
    simulate_module._auto_estimates = _AUTO_ESTIMATES if floor else _unfloored
    try:
        return simulate_module.simulate(raws)
    finally:
        simulate_module._auto_estimates = _AUTO_ESTIMATES


def check(damped: bool) -> dict:
    """One sweep: its converged value, then ``auto`` with and without the floor."""
    reference = converged(damped)
    raws = [{**scene(s, damped), "tolerance": TOLERANCE, "discretization": "auto",
             "outputs": {**sweep.REFERENCE_SCENE["outputs"], "error_estimate": True}}
            for s in SPEEDS]
    simulate_module.simulate(raws[:2])  # compiled before timing
    timing, ds = min((auto_pilots.timed_auto(raws, None) for _ in range(2)),
                     key=lambda run: run[0]["seconds_total"])
    reports = [json.loads(str(r)) for r in ds.discretization_auto.values]
    stress = ds.peak_stress.max("link").values
    error = np.abs(stress / reference - 1.0)
    sharp = (ds.status.values & (STATUS_FLAGS["resonant"]
                                 | STATUS_FLAGS["parametrically_unstable"])) > 0
    between = np.array([r["ladder"] == "interpolated" for r in reports])
    out = {"damping_beta": DAMPING_BETA if damped else 0.0,
           "setting": timing["setting"], "seconds": timing["seconds_total"],
           "pilot_share": timing["pilot_share"],
           "speeds_climbed": [float(s) for s, r in zip(SPEEDS, reports) if r["ladder"] == "own"],
           "max_true_error": float(error.max()),
           "speed_of_max_true_error": float(SPEEDS[error.argmax()]),
           "speeds_over_tolerance": int((error > TOLERANCE).sum()),
           "flagged_between_climbers": int((sharp & between).sum())}
    for name, floor in (("estimate", True), ("estimate_without_floor", False)):
        ds = None
        ds = estimated(raws, floor)
        # the floor moves the estimates only
        np.testing.assert_array_equal(ds.peak_stress.max("link").values, stress)
        estimate = ds.error_estimate.values
        under = error > estimate
        out[name] = {"bounds_true_error": float(np.mean(~under)),
                     "speeds_below_true_error": [float(s) for s in SPEEDS[under]],
                     "largest_true_over_estimate": float(np.max(error / estimate)),
                     "max_estimate": float(estimate.max())}
        ds = None
    print(f"{'damped' if damped else 'undamped'}: setting {out['setting']}, "
          f"{len(out['speeds_climbed'])} climbed, pilots {out['pilot_share']:.0%}, true error "
          f"max {out['max_true_error']:.3%}; estimate bounds it at "
          f"{out['estimate']['bounds_true_error']:.0%} "
          f"(without the floor {out['estimate_without_floor']['bounds_true_error']:.0%}, "
          f"worst {out['estimate_without_floor']['largest_true_over_estimate']:.1f}x)",
          flush=True)
    return out


def main() -> None:
    started = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    results = {"started": started, "speeds": [float(SPEEDS[0]), float(SPEEDS[-1]), len(SPEEDS)],
               "tolerance": TOLERANCE, "reference": REFERENCE,
               "undamped": check(False), "damped": check(True)}
    OUT.write_text(json.dumps(results, indent=2) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
