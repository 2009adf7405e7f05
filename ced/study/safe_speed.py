"""Safe speed limits: the largest speed of each geometry at which it and every lower speed
are within the stress limit and not flagged (rule ``safe_speed_table``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..problem.errors import SceneError
from ..problem.materials import resolve_material
from ..problem.status import STATUS_FLAGS

__all__ = ["safe_speed", "safe_speed_table", "write_safe_speed_table"]

#: Status bits that disqualify a case from the safe speed range (buckled: a link compressed
#: beyond its Euler load at some phase is no safe design, whatever its linear stress).
_UNSAFE_BITS = (STATUS_FLAGS["resonant"] | STATUS_FLAGS["parametrically_unstable"]
                | STATUS_FLAGS["failed"] | STATUS_FLAGS["not_assemblable"]
                | STATUS_FLAGS["buckled"])

def safe_speed(speeds, peak_stress, status, yield_strength: float | None,
               stress_safety_factor: float = 2.0) -> float | None:
    """The largest speed such that it and every lower simulated speed are safe.

    Safe: ``stress_safety_factor`` × ``peak_stress`` ≤ ``yield_strength`` and no status bit of
    resonant, parametrically_unstable, failed or not_assemblable. Returns NaN when the yield
    strength is unknown, None ("none") when even the lowest speed fails.

    Parameters
    ----------
    speeds : array_like
        Input speeds of one geometry, rad/s, in any order.
    peak_stress : array_like
        Peak stress at each speed, Pa.
    status : array_like of int
        Status code at each speed.
    yield_strength : float or None
        Yield strength of the material, Pa.
    stress_safety_factor : float
        Required ratio of yield strength to peak stress.

    Returns
    -------
    float or None
        The safe speed limit, rad/s; NaN or None as above.

    Examples
    --------
    >>> safe_speed([100, 50, 200, 300], [60e6, 50e6, 130e6, 90e6], [0, 0, 0, 0], 235e6, 2.0)
    100.0
    """
    if yield_strength is None or not np.isfinite(yield_strength):
        return float("nan")
    order = np.argsort(np.asarray(speeds, float))
    speeds = np.asarray(speeds, float)[order]
    stress = np.asarray(peak_stress, float)[order]
    bits = np.nan_to_num(np.asarray(status, float)[order], nan=STATUS_FLAGS["failed"])
    ok = (np.isfinite(stress) & (stress_safety_factor * stress <= yield_strength)
          & ((bits.astype(int) & _UNSAFE_BITS) == 0))
    n = len(ok) if ok.all() else int(np.argmin(ok))
    return float(speeds[n - 1]) if n else None


_GEOMETRY = ("ground", "crank", "coupler", "rocker", "rocker_arm", "rocker_arm_angle",
             "coupler_arm", "coupler_arm_angle", "coupler2", "rocker2", "pivot2_x", "pivot2_y",
             "rod", "offset", "slider_mass")


def safe_speed_table(summaries: list[xr.Dataset], stress_safety_factor: float = 2.0):
    """Safe speed limit per geometry (family, lengths, material, section) of family summaries.

    Returns a pandas DataFrame with the geometry columns, ``yield_strength_MPa``,
    ``safe_speed_rad_s`` (float, NaN when the yield strength is unknown or no speed is safe)
    and ``safe_speed`` (text: the speed, "none" or "unknown"), sorted by family then geometry.

    Parameters
    ----------
    summaries : list of xarray.Dataset
        Family summaries (:func:`ced.study.maps.case_summary`).
    stress_safety_factor : float
        Required ratio of yield strength to peak stress.

    Returns
    -------
    pandas.DataFrame
        One row per geometry.
    """
    import pandas as pd

    rows = []
    for ds in summaries:
        keys = [k for k in _GEOMETRY if k in ds.coords and ds[k].dims == ("case",)]
        keys += [k for k in ("material", "section") if k in ds.coords]
        stress = (ds.peak_stress.max("link") if "peak_stress" in ds
                  else xr.full_like(ds.speed, np.nan, dtype=float))
        status = ds.status if "status" in ds else xr.zeros_like(ds.speed)
        frame = pd.DataFrame({k: ds[k].values for k in keys})
        frame["family"] = ds.family.values if "family" in ds.coords else "unknown"
        frame["speed"], frame["stress"] = ds.speed.values, stress.values
        frame["status"] = status.values
        for geometry, group in frame.groupby(["family", *keys], sort=True, dropna=False):
            row = dict(zip(["family", *keys], geometry))
            try:
                strength = resolve_material(str(row["material"]))["yield_strength"]
            except SceneError:  # an inline material: no library entry to look up
                strength = None
            limit = safe_speed(group.speed, group.stress, group.status, strength,
                               stress_safety_factor)
            row["yield_strength_MPa"] = strength / 1e6 if strength else float("nan")
            row["peak_stress_at_lowest_speed_MPa"] = float(
                group.sort_values("speed").stress.iloc[0]) / 1e6
            row["safe_speed_rad_s"] = float("nan") if limit is None else limit
            row["safe_speed"] = ("none" if limit is None else "unknown"
                                 if not np.isfinite(limit) else f"{limit:g}")
            rows.append(row)
    columns = ["family", *[k for k in (*_GEOMETRY, "material", "section")
                           if any(k in r for r in rows)],
               "yield_strength_MPa", "peak_stress_at_lowest_speed_MPa", "safe_speed_rad_s",
               "safe_speed"]
    table = pd.DataFrame(rows, columns=columns)
    table.attrs["stress_safety_factor"] = float(stress_safety_factor)
    return table


def write_safe_speed_table(paths: list[str], csv: str, markdown: str,
                           stress_safety_factor: float = 2.0) -> None:
    """:func:`safe_speed_table` of the family summary files ``paths`` as CSV and markdown.

    Parameters
    ----------
    paths : list of str
        Family summary files (``results/<study>/maps/<family>.nc``).
    csv, markdown : str
        The files written.
    stress_safety_factor : float
        Required ratio of yield strength to peak stress.
    """
    summaries = []
    for path in paths:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            summaries.append(ds.load())
    table = safe_speed_table(summaries, stress_safety_factor)
    Path(csv).parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(csv, index=False, float_format="%.6g")
    counts = table.groupby("family").safe_speed.agg(
        geometries="size", none=lambda s: int((s == "none").sum()),
        unknown=lambda s: int((s == "unknown").sum()))
    lines = [f"# Safe speed limit per geometry (stress safety factor {stress_safety_factor:g})",
             "", "Largest simulated speed [rad/s] at which it and every lower speed satisfy "
             "factor x peak stress <= yield strength and are not flagged resonant, "
             "parametrically unstable or failed; `none` if even the lowest speed fails, "
             "`unknown` if the material has no yield strength.", "",
             "| family | geometries | none | unknown |", "|---|---|---|---|"]
    lines += [f"| {f} | {r.geometries} | {r.none} | {r.unknown} |" for f, r in counts.iterrows()]
    lines += ["", _markdown(table)]
    Path(markdown).write_text("\n".join(lines) + "\n")


def _markdown(table) -> str:
    def cell(v):
        return f"{v:.4g}" if isinstance(v, float) else str(v)

    out = ["| " + " | ".join(table.columns) + " |", "|" + "---|" * len(table.columns)]
    out += ["| " + " | ".join(cell(v) for v in row) + " |"
            for row in table.itertuples(index=False)]
    return "\n".join(out)
