"""
A Campbell diagram
==================

Natural frequencies of the frozen linkage over the crank cycle (the ``modal`` block), for a
few speeds, against the crank harmonics k·Ω/2π. Where a harmonic that carries load crosses a
frequency band, the case is flagged ``resonant``.
"""
import matplotlib.pyplot as plt
import numpy as np

import ced

speeds = np.linspace(20.0, 200.0, 7)  # rad/s
scenes = [{
    "mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                  "rocker": 0.35},
    "links": {"crank": {"flexible": False}},
    "drive": {"speed": float(speed)},
    "discretization": {"elements_per_link": 4},
    "time": {"revolutions": 1, "steps_per_revolution": 64},
    "modal": {"modes": 2, "angles": 12},
    "outputs": {"error_estimate": False},
} for speed in speeds]
ds = ced.simulate(scenes)

# %%
# ``natural_frequency`` is (case, modal_angle, mode) in Hz: each mode's band over the cycle.
fig, ax = plt.subplots()
f = ds.natural_frequency
for mode in f.mode.values:
    band = f.sel(mode=mode)
    ax.fill_between(speeds, band.min("modal_angle"), band.max("modal_angle"), alpha=0.4,
                    label=f"mode {mode}")
for k in range(1, 6):
    ax.plot(speeds, k * speeds / (2 * np.pi), "k--", lw=0.8)
    ax.annotate(f"{k}×", (speeds[-1], k * speeds[-1] / (2 * np.pi)))
ax.set_xlabel("crank speed Ω [rad/s]")
ax.set_ylabel("frequency [Hz]")
ax.legend()

from ced.problem.status import status_names  # noqa: E402

for speed, code in zip(speeds, ds.status.values):
    print(f"{speed:6.1f} rad/s: {', '.join(status_names(int(code)))}")
