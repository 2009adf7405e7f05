"""
A speed sweep at a tolerance
============================

``discretization: auto`` chooses the mesh for the scene's ``tolerance`` (a relative error on
peak stress). In the periodic steady state solved as a Fourier series
(``periodic_solver: spectral``) the series bounds its own time error, so only the mesh and the
model are chosen: a few speeds of the sweep climb the error ladders and the others are
bounded by them (docs/accuracy.md, "discretization: auto"). Every case carries its
``error_estimate``; a case whose series meets a resonance is flagged ``resonant``.
"""
import json

import matplotlib.pyplot as plt
import numpy as np

import ced

speeds = np.linspace(40.0, 160.0, 41)  # rad/s
scenes = [{
    "mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                  "rocker": 0.35},
    "links": {"default": {"material": "steel",
                          "section": {"shape": "rectangle", "height": 0.005, "width": 0.01}},
              "crank": {"flexible": False}, "rocker": {"flexible": False}},
    "drive": {"speed": float(speed)},
    "discretization": "auto",
    "tolerance": 1e-2,
    "time": {"revolutions": 1, "steps_per_revolution": 128, "start": "periodic",
             "periodic_solver": "spectral"},
} for speed in speeds]
ds = ced.simulate(scenes)

# %%
# One discretization serves the whole call; each case's report says whether it climbed the
# ladders itself (``own``) or was bounded by its neighbours (``interpolated``). The sweep is
# searched for resonances: where a crank harmonic meets the coupler's first mode (3Ω at
# 121 rad/s, 4Ω at 91 rad/s) the error of a mesh spikes over a few rad/s, so the speeds there
# climb their own ladders, and the shared mesh is refined until they meet the tolerance too.
# Each report carries the speed's ``resonance_weight``, which locates them.
reports = [json.loads(str(r)) for r in ds.discretization_auto.values]
print(f"{reports[0]['elements_per_link']} elements, {reports[0]['modes_per_link']} modes per "
      f"link; {sum(r['ladder'] == 'own' for r in reports)} of {len(reports)} speeds climbed")
print(f"largest error estimate {ds.error_estimate.max().item():.2%} "
      f"(tolerance {reports[0]['tolerance']:.0%})")
weight = np.array([r["resonance_weight"] for r in reports])
print("climbed:", ", ".join(f"{s:g}" for s, r in zip(speeds, reports) if r["ladder"] == "own"),
      f"rad/s; largest resonance weight at {speeds[np.argmax(weight)]:g} rad/s")

# %%
# Peak coupler stress with its estimated error, on a log scale: undamped, the resonance at
# 121 rad/s reads a hundred times the stress beside it. The result there is converged (its
# own ladders bound it), but it is a resonance: the flag ``resonant`` is the message, not the
# number. A speed flagged ``resonant`` that did not climb is not bounded by its neighbours:
# its estimate comes from a solve on a coarser mesh, like a case of a fixed discretization's
# (never below what its neighbours predict), and where it exceeds the tolerance ``status``
# says ``tolerance_unmet``.
peak = 1e-6 * ds.peak_stress.sel(link="coupler").values  # MPa
estimate = ds.error_estimate.values
resonant = (ds.status.values & 4) > 0
unmet = (ds.status.values & 128) > 0
fig, ax = plt.subplots()
ax.fill_between(speeds, peak / (1 + estimate), peak * (1 + estimate), alpha=0.3,
                label="× (1 ± error_estimate)")
ax.plot(speeds, peak, "k.-", lw=0.8, label="peak coupler stress")
ax.plot(speeds[resonant], peak[resonant], "rx", label="resonant")
ax.plot(speeds[unmet], peak[unmet], "o", mfc="none", mec="C1", ms=9, label="tolerance_unmet")
ax.set_yscale("log")
ax.set_xlabel("crank speed Ω [rad/s]")
ax.set_ylabel("peak stress [MPa]")
ax.legend()
for speed, e, flags in zip(speeds, estimate, ds.status.values):
    if flags & 128:
        print(f"{speed:5.1f} rad/s: error estimate {e:.0%}, tolerance unmet")
