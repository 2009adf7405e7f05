"""Safe speed limits: the largest simulated speed of each geometry at which it and every lower
speed are credible and within the yield and fatigue limits (rule ``safe_speed_table``).

Credible: no status flag that makes the result untrustworthy (:data:`NOT_CREDIBLE`) and an
``error_estimate`` within the study's ``error_tolerance``. Within the limits: ``stress_utilisation``
≤ 1 (the stress safety factor times the peak stress within the yield strength, on every link)
and a fatigue safety factor (:mod:`ced.study.fatigue`) of at least the required one. A limit
at the highest simulated speed is a lower bound (the true limit lies above the grid) and says
so; a row whose lowest speed already fails says why.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import xarray as xr

from ..problem.errors import SceneError
from ..problem.materials import resolve_material
from ..problem.status import STATUS_FLAGS, status_names

__all__ = ["NOT_CREDIBLE", "credibility", "safe_speed", "limit_text", "section_label",
           "safe_speed_table", "write_safe_speed_table"]

#: Status flags that make a case's result not credible, so no safe speed can rest on it:
#: its stresses are wrong (failed, tolerance_unmet, thick_link: beam theory does not hold,
#: large_deflection: the linear model is stretched) or the steady state is no design point
#: (resonant, parametrically_unstable, buckled).
NOT_CREDIBLE = ("failed", "not_assemblable", "resonant", "parametrically_unstable", "buckled",
                "large_deflection", "tolerance_unmet", "thick_link")
_NOT_CREDIBLE_BITS = sum(STATUS_FLAGS[name] for name in NOT_CREDIBLE)

#: Geometry columns of the table, in order.
_GEOMETRY = ("ground", "crank", "coupler", "rocker", "rocker_arm", "rocker_arm_angle",
             "coupler_arm", "coupler_arm_angle", "coupler2", "rocker2", "pivot2_x", "pivot2_y",
             "rod", "offset", "slider_mass")


def credibility(status, error_estimate, error_tolerance: float) -> list[str]:
    """Why each case is not credible, '' where it is.

    Parameters
    ----------
    status : array_like of int, (case,)
        Status codes (NaN is read as failed).
    error_estimate : array_like, (case,)
        Estimated relative error of the peak stress (dimensionless); NaN where no estimate
        was made, which does not count against the case.
    error_tolerance : float
        Largest credible error estimate (dimensionless).

    Returns
    -------
    list of str
        Per case: the disqualifying flags (``"large_deflection, resonant"``) or
        ``"error estimate 41 % > 5 %"``, '' when credible.

    Examples
    --------
    >>> credibility([0, 1, 0], [0.01, 0.01, 0.41], 0.05)
    ['', 'large_deflection', 'error estimate 41 % > 5 %']
    """
    codes = np.nan_to_num(np.asarray(status, float), nan=STATUS_FLAGS["failed"]).astype(int)
    errors = np.asarray(error_estimate, float) * np.ones(len(codes))
    out = []
    for code, error in zip(codes, errors):
        flags = [n for n in status_names(int(code) & _NOT_CREDIBLE_BITS) if n != "ok"]
        if flags:
            out.append(", ".join(flags))
        elif error > error_tolerance:
            out.append(f"error estimate {100 * error:.0f} % > {100 * error_tolerance:g} %")
        else:
            out.append("")
    return out


def safe_speed(speeds, failures) -> tuple[float | None, str]:
    """The largest speed such that it and every lower simulated speed pass, and what ends the
    range.

    Parameters
    ----------
    speeds : array_like
        Input speeds of one geometry, rad/s, in any order.
    failures : sequence of str
        Per speed, why it fails ('' when it passes).

    Returns
    -------
    limit : float or None
        The safe speed limit, rad/s; None when even the lowest speed fails.
    stop : str
        ``"grid top"`` when every speed passes (the limit is a lower bound), else
        ``"<reason> at <speed> rad/s"`` of the first failing speed.

    Examples
    --------
    >>> safe_speed([100, 50, 200], ["", "", "resonant"])
    (100.0, 'resonant at 200 rad/s')
    >>> safe_speed([100, 50], ["", ""])
    (100.0, 'grid top')
    """
    speeds = np.asarray(speeds, float)
    limit = None
    for i in np.argsort(speeds, kind="stable"):
        if failures[i]:
            return limit, f"{failures[i]} at {speeds[i]:g} rad/s"
        limit = float(speeds[i])
    return limit, "grid top"


def limit_text(limit: float | None, stop: str) -> str:
    """A safe speed limit as a designer reads it: rad/s and rpm, a lower bound marked.

    Parameters
    ----------
    limit : float or None
        The limit, rad/s (None: no safe speed).
    stop : str
        What ends the range (:func:`safe_speed`).

    Returns
    -------
    str
        ``"≥ 400 rad/s (3820 rpm, grid top)"``, ``"150 rad/s (1432 rpm)"`` or
        ``"none (large_deflection at 50 rad/s)"``.

    Examples
    --------
    >>> limit_text(200.0, "grid top")
    '≥ 200 rad/s (1910 rpm, grid top)'
    >>> limit_text(None, "resonant at 50 rad/s")
    'none (resonant at 50 rad/s)'
    """
    if limit is None:
        return f"none ({stop})"
    rpm = limit * 60.0 / (2.0 * math.pi)
    if stop == "grid top":
        return f"≥ {limit:g} rad/s ({rpm:.0f} rpm, grid top)"
    return f"{limit:g} rad/s ({rpm:.0f} rpm)"


def section_label(section: dict) -> str:
    """A cross-section by shape and dimensions in mm.

    Parameters
    ----------
    section : dict
        ``{shape: rectangle, height, width}`` or ``{shape: circle, diameter}``, m.

    Returns
    -------
    str
        e.g. ``"rectangle 20 × 10 mm (h × w)"``, ``"circle ⌀ 12 mm"``.

    Examples
    --------
    >>> section_label({"shape": "rectangle", "height": 0.02, "width": 0.01})
    'rectangle 20 × 10 mm (h × w)'
    """
    if section.get("shape") == "circle":
        return f"circle ⌀ {1e3 * section['diameter']:g} mm"
    return (f"{section.get('shape', 'rectangle')} {1e3 * section['height']:g} × "
            f"{1e3 * section['width']:g} mm (h × w)")


def _strength(material: str, key: str) -> float:
    try:
        value = resolve_material(material)[key]
    except SceneError:  # an inline material: no library entry to look up
        return float("nan")
    return float("nan") if value is None else float(value)


def _sections(ds: xr.Dataset) -> dict[int, str]:
    """Section index -> label, from the study's sections stored with the chunks."""
    try:
        sections = json.loads(ds.attrs["study_sections"])
    except (KeyError, ValueError):
        return {}
    return {i: section_label(s) for i, s in enumerate(sections)}


def _case_frame(ds: xr.Dataset, fatigue_safety_factor: float, error_tolerance: float):
    """One row per case: geometry keys, speed and why it fails each criterion."""
    import pandas as pd

    keys = [k for k in _GEOMETRY if k in ds.coords and ds[k].dims == ("case",)]
    keys += [k for k in ("material", "section") if k in ds.coords]
    frame = pd.DataFrame({k: ds[k].values for k in keys})
    if "section" in frame:
        labels = _sections(ds)
        frame["section"] = [labels.get(int(i), f"section {int(i)}") for i in frame.section]
    frame.insert(0, "family", ds.family.values if "family" in ds.coords else "unknown")
    n = ds.sizes["case"]
    frame["speed"] = ds.speed.values
    status = ds.status.values if "status" in ds else np.zeros(n)
    error = ds.error_estimate.values if "error_estimate" in ds else np.full(n, np.nan)
    credible = credibility(status, error, error_tolerance)
    use = (ds.stress_utilisation.max("link", skipna=False).values
           if "stress_utilisation" in ds else np.full(n, np.nan))
    fatigue = (ds.fatigue_safety_factor.min("link", skipna=False).values
               if "fatigue_safety_factor" in ds else np.full(n, np.nan))
    frame["stress_utilisation"], frame["fatigue_safety_factor"] = use, fatigue
    frame["credible"] = credible
    frame["yield_failure"] = [c or ("yield strength unknown" if not np.isfinite(u) else
                                    f"stress utilisation {u:.2f} > 1" if u > 1 else "")
                              for c, u in zip(credible, use)]
    frame["fatigue_failure"] = [
        c or ("endurance limit unknown" if np.isnan(f) else
              f"fatigue factor {f:.2f} < {fatigue_safety_factor:g}"
              if f < fatigue_safety_factor else "")
        for c, f in zip(credible, fatigue)]
    frame["failure"] = [y or f for y, f in zip(frame.yield_failure, frame.fatigue_failure)]
    return frame, ["family", *keys]


def safe_speed_table(summaries: list[xr.Dataset], stress_safety_factor: float = 2.0,
                     fatigue_safety_factor: float = 2.0, error_tolerance: float = 0.05):
    """Safe speed limit per geometry (family, lengths, material, section) of family summaries.

    Three limits per row, each the largest speed at which it and every lower speed are
    credible (:func:`credibility`) and pass: ``yield_limit`` (stress utilisation ≤ 1),
    ``fatigue_limit`` (fatigue safety factor ≥ ``fatigue_safety_factor``) and ``safe_speed``
    (both). Text columns read ``"≥ 400 rad/s (3820 rpm, grid top)"`` for a lower bound and
    ``"none (<reason> at <speed> rad/s)"`` for a row without a safe speed.

    Parameters
    ----------
    summaries : list of xarray.Dataset
        Family summaries (:func:`ced.study.maps.case_summary`).
    stress_safety_factor : float
        Required ratio of yield strength to peak stress (the summaries' ``stress_utilisation``
        includes it; recorded in the table's attributes).
    fatigue_safety_factor : float
        Required fatigue safety factor (dimensionless).
    error_tolerance : float
        Largest credible ``error_estimate`` (dimensionless).

    Returns
    -------
    pandas.DataFrame
        One row per geometry: family, lengths (m), material, section (shape and mm),
        ``yield_strength_MPa``, ``endurance_limit_MPa``, ``yield_limit``, ``fatigue_limit``,
        ``safe_speed_rad_s`` (NaN: none), ``safe_speed_rpm``, ``safe_speed_is_lower_bound``,
        ``safe_speed`` (text) and ``limited_by`` (what ends the safe range), sorted by family
        then geometry.
    """
    import pandas as pd

    rows, names = [], ["family"]
    for ds in summaries:
        frame, names = _case_frame(ds, fatigue_safety_factor, error_tolerance)
        for geometry, group in frame.groupby(names, sort=True, dropna=False):
            row = dict(zip(names, geometry))
            material = str(row.get("material", ""))
            row["yield_strength_MPa"] = _strength(material, "yield_strength") / 1e6
            row["endurance_limit_MPa"] = _strength(material, "endurance_limit") / 1e6
            row["yield_limit"] = limit_text(*safe_speed(group.speed, list(group.yield_failure)))
            row["fatigue_limit"] = limit_text(*safe_speed(group.speed,
                                                          list(group.fatigue_failure)))
            limit, stop = safe_speed(group.speed, list(group.failure))
            row["safe_speed_rad_s"] = float("nan") if limit is None else limit
            row["safe_speed_rpm"] = row["safe_speed_rad_s"] * 60.0 / (2.0 * math.pi)
            row["safe_speed_is_lower_bound"] = stop == "grid top"
            row["safe_speed"] = limit_text(limit, stop)
            row["limited_by"] = stop
            rows.append(row)
    columns = ["family", *[k for k in (*_GEOMETRY, "material", "section")
                           if any(k in r for r in rows)],
               "yield_strength_MPa", "endurance_limit_MPa", "yield_limit", "fatigue_limit",
               "safe_speed_rad_s", "safe_speed_rpm", "safe_speed_is_lower_bound", "safe_speed",
               "limited_by"]
    table = pd.DataFrame(rows, columns=columns)
    table.attrs.update(stress_safety_factor=float(stress_safety_factor),
                       fatigue_safety_factor=float(fatigue_safety_factor),
                       error_tolerance=float(error_tolerance))
    return table


def write_safe_speed_table(paths: list[str], csv: str, markdown: str,
                           stress_safety_factor: float = 2.0, fatigue_safety_factor: float = 2.0,
                           error_tolerance: float = 0.05) -> None:
    """:func:`safe_speed_table` of the family summary files ``paths`` as CSV and markdown.

    Parameters
    ----------
    paths : list of str
        Family summary files (``results/<study>/maps/<family>.nc``).
    csv, markdown : str
        The files written.
    stress_safety_factor, fatigue_safety_factor : float
        Required yield and fatigue safety factors (dimensionless).
    error_tolerance : float
        Largest credible ``error_estimate`` (dimensionless).
    """
    from ..io import open_dataset

    summaries = []
    for path in paths:
        with open_dataset(path) as ds:
            summaries.append(ds.load())
    table = safe_speed_table(summaries, stress_safety_factor, fatigue_safety_factor,
                             error_tolerance)
    Path(csv).parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(csv, index=False, float_format="%.6g")
    stop = table.limited_by.fillna("")
    table["_top"] = stop == "grid top"
    table["_none"] = table.safe_speed_rad_s.isna()
    table["_fatigue"] = stop.str.startswith("fatigue") | stop.str.startswith("endurance")
    table["_yield"] = stop.str.startswith("stress") | stop.str.startswith("yield")
    counts = table.groupby("family").agg(
        geometries=("_top", "size"), top=("_top", "sum"), none=("_none", "sum"),
        yielding=("_yield", "sum"), fatigue=("_fatigue", "sum"))
    table = table.drop(columns=["_top", "_none", "_fatigue", "_yield"])
    lines = [f"# Safe speed limit per geometry (stress safety factor {stress_safety_factor:g}, "
             f"fatigue safety factor {fatigue_safety_factor:g})", "",
             "Largest simulated speed at which it and every lower speed are credible (none of "
             f"the flags {', '.join(NOT_CREDIBLE)}; error estimate <= "
             f"{100 * error_tolerance:g} %) and within the limits: factor x peak stress <= "
             "yield strength on every link (`yield_limit`) and a Goodman fatigue safety factor "
             f">= {fatigue_safety_factor:g} against the endurance limit (`fatigue_limit`); "
             "`safe_speed` needs both. `≥ … (grid top)`: every simulated speed passes, the "
             "limit lies above the grid. `none (…)`: even the lowest speed fails, and why. "
             "`limited_by`: what ends the safe range.", "",
             "| family | geometries | safe to the grid top | no safe speed | ended by yield "
             "| ended by fatigue |", "|---|---|---|---|---|---|"]
    lines += [f"| {f} | {r.geometries} | {r.top} | {r.none} | {r.yielding} | {r.fatigue} |"
              for f, r in counts.iterrows()]
    lines += ["", _markdown(table)]
    Path(markdown).write_text("\n".join(lines) + "\n")


def _markdown(table) -> str:
    def cell(v):
        if isinstance(v, float):
            return "—" if np.isnan(v) else f"{v:.4g}"  # a length the family does not have
        return str(v)

    out = ["| " + " | ".join(table.columns) + " |", "|" + "---|" * len(table.columns)]
    out += ["| " + " | ".join(cell(v) for v in row) + " |"
            for row in table.itertuples(index=False)]
    return "\n".join(out)
