"""Maps: chunk datasets → per-family summaries and grid maps (docs/guide/first_study.md).

A family's chunks are opened lazily as one dataset (:func:`ced.study.browse.open_family`) and
reduced block by block of cases (peaks over the cycle, fatigue); the small results are
concatenated, so memory stays bounded by one block whatever the study or chunk size
(:func:`reduce_family`; ``benchmarks/reduce_memory.py`` measures it). The per-case summary is then unstacked from ``case`` into the grid
dimensions of the study — the varied lengths, ``speed``, ``material``, ``section`` — so that a
family reads as a map (:func:`family_grid`); grid points that belong to another family (or
cannot be assembled) are NaN there.

Examples
--------
>>> import numpy as np, xarray as xr
>>> ds = xr.Dataset({"peak_input_torque": ("case", [1.0, 2.0, 3.0],
...                                        {"units": "N m", "long_name": "peak input torque"})},
...                 coords={"case": [0, 1, 2], "crank": ("case", [0.1, 0.1, 0.2]),
...                         "coupler": ("case", [0.4, 0.4, 0.4]),
...                         "rocker": ("case", [0.3, 0.3, 0.3]), "ground": ("case", [0.5] * 3),
...                         "speed": ("case", [50.0, 100.0, 50.0]),
...                         "material": ("case", ["steel"] * 3), "section": ("case", [0, 0, 0])})
>>> grid = family_grid(ds)
>>> dict(grid.sizes)
{'crank': 2, 'coupler': 1, 'rocker': 1, 'speed': 2, 'material': 1, 'section': 1}
>>> grid.peak_input_torque.sel(crank=0.2, speed=100.0).item()
nan
"""
from __future__ import annotations


import numpy as np
import xarray as xr

from ..io import write_dataset
from ..problem.status import STATUS_DTYPE, STATUS_FILL, STATUS_FLAGS
from ..response.periodic import INSTABILITY_MARGIN
from .browse import open_family
from .fatigue import case_fatigue, link_strengths

__all__ = ["case_summary", "family_grid", "reduce_family", "harmonic_ratio", "stable_flag",
           "GRID_ORDER", "HARMONIC_ORDER"]

#: Crank harmonics k = 1..K searched by :func:`harmonic_ratio`.
HARMONIC_ORDER = 20

#: Per-case variables carried over unchanged when present.
_PER_CASE = ("peak_deflection", "peak_stress", "dynamic_amplification",
             "floquet_multiplier_max", "error_estimate", "error_estimate_source", "solve_time",
             "status", "message")

#: Candidate grid dimensions, in the order of the unstacked arrays.
GRID_ORDER = ("crank", "coupler", "rocker", "rocker_arm", "rocker_arm_angle", "coupler_arm",
              "coupler_arm_angle", "coupler2", "rocker2", "pivot2_x", "pivot2_y", "rod", "offset",
              "speed", "material", "section")

#: Fill of integer variables at grid points without a case (CF _FillValue).
_INT_FILL = {STATUS_DTYPE: STATUS_FILL, "int8": -1, "int32": -1, "int64": -1}


def case_summary(ds: xr.Dataset, stress_safety_factor: float | None = None) -> xr.Dataset:
    """Peaks over the cycle of one simulated dataset, one value per case (and link).

    With ``stress_safety_factor`` and the peak stress present, adds ``stress_utilisation`` =
    factor × peak stress / yield strength (≤ 1 means safe with that factor).

    Parameters
    ----------
    ds : xarray.Dataset
        A chunk dataset (:func:`ced.study.chunk_job.run_chunk`).
    stress_safety_factor : float, optional
        Required ratio of yield strength to peak stress (dimensionless).

    Returns
    -------
    xarray.Dataset
        Per case: peak stress (Pa) and deflection (m) per link, fatigue safety factor per link
        (:func:`ced.study.fatigue.case_fatigue`), first natural frequency band (Hz), distance
        from the nearest crank harmonic, stability, status, …
    """
    with xr.set_options(keep_attrs=True):
        out = xr.Dataset(coords={k: v for k, v in ds.coords.items()
                                 if "step" not in v.dims and k not in ("station",)})
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
            if "speed" in ds.coords:
                out["harmonic_ratio_min"] = harmonic_ratio(low, high, ds.speed)
        if "floquet_multiplier_max" in ds or "status" in ds:
            out["stable"] = stable_flag(ds.get("floquet_multiplier_max"), ds.get("status"))
        fatigue = case_fatigue(ds)
        if fatigue is not None:
            out.update(fatigue)
        if stress_safety_factor is not None and "peak_stress" in ds:
            strengths = link_strengths(ds)
            if strengths is not None:
                use = stress_safety_factor * ds.peak_stress / strengths.yield_strength
                use.attrs = {"units": "1", "long_name": "stress safety factor times peak stress "
                             "over yield strength (safe where <= 1)",
                             "stress_safety_factor": float(stress_safety_factor)}
                out["stress_utilisation"] = use
    if "modal_angle" in out.coords and "natural_frequency_min" in out:
        out = out.drop_vars("modal_angle")
    out.attrs = {k: v for k, v in ds.attrs.items() if k not in ("scenes", "chunk")}
    return out


def harmonic_ratio(f_low: xr.DataArray, f_high: xr.DataArray, speed: xr.DataArray,
                   harmonics: int = HARMONIC_ORDER) -> xr.DataArray:
    """Distance of the natural-frequency bands from the nearest crank harmonic.

    min over modes i and k = 1..``harmonics`` of |f_i / (kΩ/2π) − 1|, where f_i ranges over
    the band [``f_low``, ``f_high``] of mode i over the cycle: 0 when a band contains a
    harmonic kΩ/2π, else the distance from the nearer band edge. ``speed`` Ω in rad/s.

    Parameters
    ----------
    f_low, f_high : xarray.DataArray, (case, mode)
        Lowest and highest natural frequency of each mode over the cycle, Hz.
    speed : xarray.DataArray, (case,)
        Input speed Ω, rad/s.
    harmonics : int
        Crank harmonics considered, k = 1 … harmonics.

    Returns
    -------
    xarray.DataArray, (case,)
        The relative distance (dimensionless).

    Examples
    --------
    >>> import numpy as np, xarray as xr
    >>> lo = xr.DataArray([[9.0, 43.0]], dims=("case", "mode"))
    >>> hi = xr.DataArray([[9.5, 44.0]], dims=("case", "mode"))
    >>> w = xr.DataArray([2 * np.pi * 10.0], dims="case")   # harmonics 10, 20, 30 ... Hz
    >>> round(float(harmonic_ratio(lo, hi, w)[0]), 6)          # 9.5 vs 10 Hz
    0.05
    >>> float(harmonic_ratio(lo, hi + 1.0, w)[0])                # band 9-10.5 contains 10 Hz
    0.0
    """
    k = xr.DataArray(np.arange(1, harmonics + 1, dtype=float), dims="harmonic")
    h = k * speed / (2.0 * np.pi)
    inside = (f_low <= h) & (h <= f_high)
    edge = np.minimum(abs(f_low / h - 1.0), abs(f_high / h - 1.0))
    dist = xr.where(inside, 0.0, edge).where(np.isfinite(f_low) & np.isfinite(f_high))
    dims = [d for d in ("mode", "harmonic") if d in dist.dims]
    out = dist.min(dims, skipna=True).astype("float32")
    out.attrs = {"units": "1", "long_name": "distance of the natural-frequency bands from the "
                 "nearest crank harmonic, min over modes i and k of |f_i/(k*speed/2pi) - 1|",
                 "harmonics": f"1..{harmonics}",
                 "comment": "f_i over the band [natural_frequency_min, natural_frequency_max] "
                            "of mode i over the cycle; 0 where a band contains a harmonic"}
    return out


def stable_flag(floquet: xr.DataArray | None, status: xr.DataArray | None) -> xr.DataArray:
    """1 where the periodic response is stable (Floquet multipliers |μ| ≤ 1 + margin and no
    parametrically_unstable flag), 0 where unstable, −1 where unknown (no multiplier, failed).

    Parameters
    ----------
    floquet : xarray.DataArray or None, (case,)
        ``floquet_multiplier_max`` (dimensionless), if present.
    status : xarray.DataArray or None, (case,)
        ``status``, if present.

    Returns
    -------
    xarray.DataArray of int8, (case,)
        1, 0 or −1.
    """
    ref = floquet if floquet is not None else status
    value = xr.full_like(ref, -1, dtype="int8")
    unstable = xr.zeros_like(ref, dtype=bool)
    known = xr.zeros_like(ref, dtype=bool)
    if floquet is not None:
        finite = np.isfinite(floquet)
        known = known | finite
        unstable = unstable | (finite & (floquet > 1.0 + INSTABILITY_MARGIN))
    if status is not None:
        bits = status.fillna(0).astype(int)
        unstable = unstable | ((bits & STATUS_FLAGS["parametrically_unstable"]) > 0)
        known = known & ((bits & STATUS_FLAGS["failed"]) == 0)
    value = xr.where(unstable, 0, xr.where(known, 1, -1)).astype("int8")
    value.attrs = {"units": "1", "long_name": "stability of the periodic response (Floquet)",
                   "flag_values": np.array([0, 1], "int8"), "flag_meanings": "unstable stable",
                   "_FillValue": np.array(-1, "int8"),
                   "comment": f"stable: floquet_multiplier_max <= 1 + {INSTABILITY_MARGIN:g} "
                              "and status not parametrically_unstable; -1 (fill) where unknown"}
    return value


def _grid_dims(summary: xr.Dataset) -> list[str]:
    return [d for d in GRID_ORDER if d in summary.coords and summary[d].dims == ("case",)]


def family_grid(summary: xr.Dataset) -> xr.Dataset:
    """Unstack ``case`` of a family summary into its grid dimensions.

    The dimensions are those of :data:`GRID_ORDER` present as case coordinates (lengths,
    ``speed``, ``material``, ``section``); each takes the sorted distinct values of the family.
    Case coordinates constant over the family (``ground``, ``family``, ``slider_mass``) become
    scalar coordinates; the section sizes (``section_height``, …) become coordinates on
    ``section``; ``case`` itself stays as a variable (the id of the grid point's
    case, −1 where none) to find a case in the per-case file. Floating variables are NaN and
    integer ones their ``_FillValue`` where the grid point has no case in this family.

    Parameters
    ----------
    summary : xarray.Dataset
        A family's per-case summary (:func:`case_summary` of its chunks).

    Returns
    -------
    xarray.Dataset
        The same variables on the grid dimensions.
    """
    dims = _grid_dims(summary)
    if not dims:
        raise ValueError("family_grid: no grid coordinates on case")
    index = summary.set_index(case=dims).indexes["case"]
    if not index.is_unique:
        raise ValueError(f"family_grid: cases are not unique over {', '.join(dims)}")
    scalar, per_section, dropped = {}, {}, []
    for name, coord in summary.coords.items():
        if coord.dims != ("case",) or name in dims or name == "case":
            continue
        values = coord.values
        if "section" in dims and name.startswith("section_") and _depends_only_on(
                coord, summary["section"]):
            per_section[name] = coord
        elif (values == values[0]).all():
            scalar[name] = xr.Variable((), values[0], coord.attrs)
        else:
            dropped.append(name)
    keep = [n for n, v in summary.data_vars.items() if v.dtype.kind in "fiu"]
    flat = summary[keep].drop_vars(list(scalar) + list(per_section) + dropped)
    flat["case_id"] = xr.DataArray(summary.case.values, dims="case",
                                   attrs={"units": "1", "long_name": "case id within the family "
                                          "(index into the per-case file), -1 where none"})
    fills = {}
    for name, var in flat.data_vars.items():
        if var.dtype.kind in "iu":
            fills[name] = _INT_FILL.get(str(var.dtype), -1)
    stacked = flat.set_index(case=dims)
    grid = stacked.unstack("case", fill_value={**{n: np.nan for n in flat.data_vars}, **fills})
    grid = grid.transpose(*dims, ...)
    for name, fill in fills.items():
        grid[name] = grid[name].astype(flat[name].dtype)
        grid[name].attrs["_FillValue"] = np.array(fill, dtype=flat[name].dtype)
    grid = grid.rename_vars(case_id="case")
    grid = grid.assign_coords(scalar)
    for name, coord in per_section.items():
        first = coord.groupby(summary["section"]).first()
        grid = grid.assign_coords({name: ("section", first.sel(section=grid.section).values,
                                          coord.attrs)})
    for d in dims:  # re-assert the CF attributes of the dimension coordinates
        grid[d].attrs = dict(summary[d].attrs)
    if "status" in grid:
        grid["status"].attrs["comment"] = f"{STATUS_FILL} where the grid point has no case"
    grid.attrs = dict(summary.attrs)
    grid.attrs["grid_dimensions"] = " ".join(dims)
    grid.attrs["comment"] = ("per-case results unstacked onto the study grid; NaN where the "
                             "grid point belongs to another family or cannot be assembled")
    return grid


def _depends_only_on(coord: xr.DataArray, key: xr.DataArray) -> bool:
    pairs = {}
    for k, v in zip(key.values.tolist(), coord.values.tolist()):
        if pairs.setdefault(k, v) != v and not (v != v and pairs[k] != pairs[k]):
            return False
    return True


def reduce_family(paths: list[str], output: str, grid_output: str | None = None,
                  stress_safety_factor: float | None = None, block: int = 256) -> None:
    """Reduce a family's chunk files into ``output`` (per case) and ``grid_output`` (map).

    Both are netCDF, CF-described, written atomically.

    Parameters
    ----------
    paths : list of str
        The family's chunk files.
    output : str
        The per-case summary file.
    grid_output : str, optional
        The grid map file.
    stress_safety_factor : float, optional
        For ``stress_utilisation`` (dimensionless).
    block : int
        Cases read and reduced at a time.
    """
    # Lazily, block by block (ced.study.browse.open_family): memory is bounded by one block
    # of cases and the summaries, whatever the number of cases or the chunk size.
    # xarray keeps up to 128 files open, each with its decompressed-chunk caches: a few are
    # enough when the blocks are read in order. One thread reads (Snakemake runs the jobs in
    # parallel): dask's thread pool left each thread's malloc arena fragmented, and the
    # resident memory then grew with the number of blocks read.
    import dask

    parts = []
    with xr.set_options(file_cache_maxsize=4), dask.config.set(scheduler="synchronous"), \
            open_family(paths) as family:
        for start in range(0, family.sizes["case"], block):
            ds = family.isel(case=slice(start, start + block)).load()
            parts.append(case_summary(ds, stress_safety_factor))
    combined = xr.concat(parts, dim="case", data_vars="all", coords="different",
                         compat="equals", join="exact", combine_attrs="drop_conflicts")
    if not combined.indexes["case"].is_unique:
        raise ValueError("reduce_family: case ids repeat across the chunk files")
    combined = combined.sortby("case")
    combined.attrs.update(
        title=f"ced family summary: {_family(combined)}",
        history=(combined.attrs.get("history", "") +
                 f"; reduced from {len(paths)} chunk files by ced.study.maps").lstrip("; "))
    _check_cf(combined)
    write_dataset(combined, output)
    if grid_output is not None:
        grid = family_grid(combined)
        grid.attrs["title"] = f"ced family map: {_family(combined)}"
        _check_cf(grid)
        write_dataset(grid, grid_output)


def _family(ds: xr.Dataset) -> str:
    if "family" not in ds.coords:
        return "unknown"
    return str(ds.family.values.flat[0])


def _check_cf(ds: xr.Dataset) -> None:
    """Every variable needs a long_name, and units unless it is a string or label."""
    for name, var in ds.variables.items():
        var.attrs.setdefault("long_name", name.replace("_", " "))
        if var.dtype.kind in "fiu" and "units" not in var.attrs and name != "status":
            var.attrs["units"] = "1"
    if "status" in ds:
        flags = ds["status"].attrs
        if "flag_meanings" not in flags:
            flags.update(flag_masks=np.array(list(STATUS_FLAGS.values()), STATUS_DTYPE),
                         flag_meanings=" ".join(STATUS_FLAGS))
