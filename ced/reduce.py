"""Reductions: chunk datasets → one per-family dataset of per-case peaks (DESIGN §6).

Each chunk is reduced on its own (peaks over the cycle) and the small results are
concatenated, so memory stays bounded by one chunk whatever the study size.
"""
from __future__ import annotations

import xarray as xr

from .io import write_dataset

__all__ = ["case_summary", "reduce_family"]

#: Per-case variables carried over unchanged when present.
_PER_CASE = ("peak_deflection", "peak_stress", "dynamic_amplification",
             "floquet_multiplier_max", "error_estimate", "solve_time", "status", "message")


def case_summary(ds: xr.Dataset) -> xr.Dataset:
    """Peaks over the cycle of one simulated dataset, one value per case (and link)."""
    with xr.set_options(keep_attrs=True):
        out = xr.Dataset(coords={k: v for k, v in ds.coords.items() if "step" not in v.dims})
        torque = abs(ds.input_torque).max("step")
        torque.attrs.update(units="N m", long_name="peak absolute input torque")
        out["peak_input_torque"] = torque
        force = ((ds.joint_force**2).sum("axis") ** 0.5).max("step")
        force.attrs.update(units="N", long_name="peak joint force magnitude")
        out["peak_joint_force"] = force
        for name in _PER_CASE:
            if name in ds:
                out[name] = ds[name]
        if "natural_frequency" in ds:
            f = ds.natural_frequency
            low, high = f.min("modal_angle"), f.max("modal_angle")
            low.attrs.update(units="Hz", long_name="lowest natural frequency over the cycle")
            high.attrs.update(units="Hz", long_name="highest natural frequency over the cycle")
            out["natural_frequency_min"], out["natural_frequency_max"] = low, high
    out.attrs = {k: v for k, v in ds.attrs.items() if k != "scenes"}
    return out


def reduce_family(paths: list[str], output: str) -> None:
    """Reduce a family's chunk files into ``output`` (netCDF, written atomically)."""
    parts = []
    for path in paths:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            parts.append(case_summary(ds).load())
    combined = xr.concat(parts, dim="case", data_vars="all", coords="different",
                         compat="equals", join="exact", combine_attrs="drop_conflicts")
    combined.attrs["title"] = "ced family summary"
    combined.attrs["history"] = (combined.attrs.get("history", "") +
                                 f"; reduced from {len(paths)} chunk files").lstrip("; ")
    write_dataset(combined, output)
