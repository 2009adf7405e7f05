"""
Rigid versus elastic
====================

The same linkage as a rigid mechanism (``formulation: rigid``) and with flexible links.
The rigid analysis gives joint forces and the drive torque; the elastic one adds the links'
deflections and stresses. A rigid and an elastic scene give datasets with different variables
(a dataset holds the variables its cases share), so they are solved in two calls.
"""
import matplotlib.pyplot as plt

import ced

base = {
    "mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                  "rocker": 0.35},
    "links": {"default": {"section": {"shape": "rectangle", "height": 0.01, "width": 0.02}},
              "crank": {"flexible": False}},
    "drive": {"speed": 100.0},
    "time": {"revolutions": 1, "steps_per_revolution": 128, "start": "periodic"},
    "outputs": {"error_estimate": False},
}
rigid = {**base, "name": "rigid", "discretization": {"formulation": "rigid"}}
elastic = {**base, "name": "elastic",
           "discretization": {"formulation": "euler_bernoulli", "elements_per_link": 4}}
runs = {"rigid": ced.simulate(rigid), "elastic": ced.simulate(elastic)}
print(sorted(set(runs["elastic"].data_vars) - set(runs["rigid"].data_vars)))

# %%
# The force in the coupler–rocker joint C and the drive torque over the cycle.
fig, (top, bottom) = plt.subplots(2, 1, sharex=True)
for name, ds in runs.items():
    angle = ds.crank_angle.isel(case=0)
    force = ds.joint_force.isel(case=0).sel(joint="C")
    top.plot(angle, (force ** 2).sum("axis") ** 0.5, label=name)
    bottom.plot(angle, ds.input_torque.isel(case=0), label=name)
top.set_ylabel("|force at C| [N]")
bottom.set_ylabel("input torque [N m]")
bottom.set_xlabel("crank angle [rad]")
top.legend()

# %%
# The rigid analysis's joint forces are what the elastic model loads its links with; the
# elastic one adds, per link, the peak deflection (mm) and stress (MPa):
elastic_ds = runs["elastic"]
print((elastic_ds.peak_deflection.isel(case=0) * 1e3).to_series())
print((elastic_ds.peak_stress.isel(case=0) / 1e6).to_series())
