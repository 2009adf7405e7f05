"""
A first scene
=============

Simulate one flexible four-bar and plot the stress at the middle of its coupler over the
crank cycle. The scene is a Python mapping here; a YAML file with the same keys works the same
way (``ced.simulate("scene.yaml")`` or ``ced run scene.yaml``). Every key not given takes its
default (:doc:`/reference/scene`).
"""
import matplotlib.pyplot as plt

import ced

scene = {
    "name": "first",
    "mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                  "rocker": 0.35},
    "links": {"default": {"material": "steel",
                          "section": {"shape": "rectangle", "height": 0.005, "width": 0.01}},
              "crank": {"flexible": False}},
    "drive": {"speed": 100.0},                       # rad/s
    "time": {"revolutions": 1, "steps_per_revolution": 128, "start": "periodic"},
}
ds = ced.simulate(scene)
print(ds)

# %%
# ``status`` is a bit field; here the coupler's peak deflection passes 1 % of its length
# (``large_deflection``: the linear model is stretched, see :doc:`/guide/status`).
from ced.problem.status import status_names  # noqa: E402

print(status_names(int(ds.status[0])))

# %%
# ``stress`` is (case, step, link, station, fibre) in Pa, signed, at both outer fibres
# (y/h = -0.5 and +0.5); ``crank_angle`` gives the x-axis.
mid = ds.stress.isel(case=0).sel(link="coupler", station=0.5)
angle = ds.crank_angle.isel(case=0)
fig, ax = plt.subplots()
for fibre in mid.fibre.values:
    ax.plot(angle, mid.sel(fibre=fibre) / 1e6, label=f"fibre y/h = {fibre:+g}")
ax.legend()
ax.set_xlabel("crank angle [rad]")
ax.set_ylabel("stress at mid-coupler [MPa]")
ax.set_title(f"peak {float(ds.peak_stress.sel(link='coupler')[0]) / 1e6:.0f} MPa")

# %%
# The peak over the cycle and the estimated relative error of the case's peak stress:
print(ds.peak_stress.isel(case=0).to_series() / 1e6)
print("error estimate:", float(ds.error_estimate[0]))
