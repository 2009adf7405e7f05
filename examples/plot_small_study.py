"""
A small study, read back with xarray
====================================

A study is a grid of geometries × speeds × materials × sections. The pipeline
(``snakemake --configfile …``) runs it in chunks, one dataset per chunk; here the same
functions run two chunks by hand, laid out as the pipeline lays them out, and the study is
read back as one lazily loaded xarray dataset with ``ced.open_study``.
"""
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import ced
from ced.study.cases import chunks
from ced.study.chunk_job import run_chunk
from ced.study.config import study_estimate, validate_config

config = validate_config({
    "study": "gallery",
    "grids": {"four_bar": {"ground": 0.5, "crank": [0.08, 0.1, 0.12], "coupler": [0.45],
                           "rocker": [0.35]}},
    "speeds": [50.0, 100.0],
    "materials": ["steel", "aluminium"],
    "sections": [{"shape": "rectangle", "height": 0.005, "width": 0.01}],
    "families": ["crank_rocker"],
    "chunk_size": 6,
    "base_scene": {"links": {"crank": {"flexible": False}},
                   "discretization": {"elements_per_link": 4},
                   "time": {"revolutions": 1, "steps_per_revolution": 64},
                   "outputs": {"error_estimate": False}},
})
print(study_estimate(config).cases, "cases in", chunks(config))

out = Path(tempfile.mkdtemp())
paths = [run_chunk(config, family, index, out / "chunks" / family / f"{index}.nc")
         for family, n in chunks(config).items() for index in range(n)]

# %%
# Each chunk is a CF dataset (``ced.open_dataset`` reads one, link names restored);
# ``ced.open_study`` joins every chunk of the study along ``case``, lazily (dask): values are
# read when computed. Its ``case`` runs over the whole study; ``case_id`` is the id within
# the family.
ds = ced.open_study(out)
peak = (ds.peak_stress.sel(link="coupler") / 1e6).compute()
print(peak.to_dataframe(name="MPa")[["crank", "speed", "material", "MPa"]])

# %%
# Group by the case coordinates to see how the peak stress depends on them.
fig, ax = plt.subplots()
for (material, speed), group in peak.groupby(["material", "speed"]):
    ax.plot(group.crank, group, "o-", label=f"{material}, {speed:g} rad/s")
ax.set_xlabel("crank length [m]")
ax.set_ylabel("peak coupler stress [MPa]")
ax.legend()
