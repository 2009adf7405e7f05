"""Resonance maps of a family: peak stress over input speed × one link length, one panel per
material and section of the study, with the speeds where crank harmonics meet the first
natural frequency (rule ``resonance_map``).

A panel is a slice of the family's grid map (``maps/<family>_grid.nc``, :func:`map_slice`):
its material and section, a y length (the config's ``resonance_map.y``, else the length with
the most values holding cases) and every other length fixed (``resonance_map.fixed``, else the
value whose slice holds the most cases). A slice whose y holds cases at one value only — a
one-dimensional speed sweep such as the Sung–Thompson study — is drawn as lines of peak stress
against speed instead of a degenerate map.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from ..io import open_dataset
from ..problem.errors import SceneError
from ..problem.status import STATUS_FLAGS
from .figures import plain_ticks, plt, rpm_axis, save
from .safe_speed import credibility

__all__ = ["MAP_HARMONICS", "MAP_LENGTHS", "map_slice", "harmonic_speeds", "resonance_map"]

#: Harmonics k of the speeds Ω = 2π f₁ / k at which k·Ω/2π meets the first natural frequency.
MAP_HARMONICS = tuple(range(1, 6))
#: Lengths a map's y axis can be, in order of preference on ties.
MAP_LENGTHS = ("crank", "coupler", "rocker", "rocker_arm", "coupler_arm", "coupler2", "rocker2",
               "pivot2_x", "pivot2_y", "rod", "offset")
#: Grid dimensions fixed in a slice besides the lengths: six-bar arm angles, rad (never y).
_ANGLES = ("rocker_arm_angle", "coupler_arm_angle")


def _unit(key: str) -> str:
    return "rad" if key in _ANGLES else "m"
_RESONANT = STATUS_FLAGS["resonant"] | STATUS_FLAGS["parametrically_unstable"]
_LOW = "low confidence: other flag or error estimate above tolerance"


def map_slice(grid: xr.Dataset, material: str | None = None, section: int | None = None,
              y: str | None = None, fixed: dict | None = None) -> tuple[xr.Dataset, str, dict]:
    """The (speed × length) slice of a family grid drawn in one panel of its resonance map.

    Parameters
    ----------
    grid : xarray.Dataset
        A family's grid map, labels restored (:func:`ced.io.open_dataset`).
    material : str, optional
        The material of the slice (default: the grid's first).
    section : int, optional
        The section index of the slice (default: the first).
    y : str, optional
        The length on the y axis (default: the length with the most values holding cases;
        ties: the larger range). Ignored where the family has no such length.
    fixed : dict, optional
        Length → value (m) for the other lengths (default: the value whose slice holds the
        most cases; ties: the median such value). Lengths the family lacks are ignored.

    Returns
    -------
    slice : xarray.Dataset
        The grid at the material, section and fixed lengths (dims: y, speed, …).
    y : str
        The y length.
    fixed : dict
        Every fixed coordinate (material, section, lengths in m).

    Raises
    ------
    SceneError
        At ``resonance_map.fixed.<length>`` for a value not on the grid, naming the values.
    """
    material = str(grid.material.values[0]) if material is None else material
    fixed_out: dict = {"material": material}
    has = np.isfinite(grid["case"]).sel(material=material)
    if "section" in grid.dims:
        fixed_out["section"] = int(grid.section.values[0] if section is None else section)
        has = has.sel(section=fixed_out["section"])
    lengths = [d for d in (*MAP_LENGTHS, *_ANGLES) if d in grid.dims]
    given = {k: v for k, v in (fixed or {}).items() if k in lengths}
    for key, value in given.items():
        values = grid[key].values
        if not np.isclose(values, value).any():
            raise SceneError(f"resonance_map.fixed.{key}", f"{value!r} {_unit(key)} is not a "
                             f"grid value of {key}; allowed: "
                             f"{', '.join(f'{v:g}' for v in values)}")
        given[key] = float(values[np.isclose(values, value)][0])

    def spread(d):
        used = has.any([x for x in has.dims if x != d])
        values = grid[d].values[used.values]
        return (int(used.sum()), float(np.ptp(values)) if values.size else 0.0)

    candidates = [d for d in lengths if d not in _ANGLES]
    y = y if y in candidates and y not in given else max(
        [d for d in candidates if d not in given] or candidates, key=spread)
    rest = has
    for d in lengths:
        if d == y:
            continue
        if d in given:
            value = given[d]
        else:
            count = rest.sum([x for x in rest.dims if x != d])
            best = grid[d].values[(count == count.max()).values]
            value = best[len(best) // 2].item()
        fixed_out[d] = value
        rest = rest.sel({d: value})
    return grid.sel(fixed_out), y, fixed_out


def harmonic_speeds(f1: np.ndarray, harmonics=MAP_HARMONICS) -> np.ndarray:
    """Speeds Ω = 2π f₁ / k at which the crank harmonic k·Ω/2π meets f₁.

    Parameters
    ----------
    f1 : array_like
        First natural frequency, Hz.
    harmonics : sequence of int
        The harmonics k.

    Returns
    -------
    numpy.ndarray
        Shape ``(k, *f1.shape)``, rad/s; NaN where f₁ is not positive.

    Examples
    --------
    >>> harmonic_speeds([10.0], (1, 2)).round(3).tolist()
    [[62.832], [31.416]]
    """
    f1 = np.asarray(f1, float)
    f1 = np.where(f1 > 0, f1, np.nan)
    return 2.0 * np.pi * f1[None] / np.asarray(harmonics, float).reshape((-1,) + (1,) * f1.ndim)


def _value(sl: xr.Dataset) -> tuple[xr.DataArray, str]:
    if "peak_stress" in sl:
        return sl.peak_stress.max("link") / 1e6, "peak stress, max over links [MPa]"
    return sl.peak_input_torque, "peak input torque [N m]"


def _colour_norm(slices: list[xr.Dataset], error_tolerance: float):
    """The maps' log colour scale and whether it is clipped: up to a hundred times the largest
    value of a case not flagged resonant or unstable (where every case is, their median), so
    that one blown-up case (1e14 MPa at a change point) does not squeeze the others into one
    colour; cells above take the scale's top colour (the colour bar's arrow), and each is
    marked resonant / unstable anyway."""
    from matplotlib.colors import LogNorm

    values, calm = [], []
    for sl in slices:
        value = _value(sl)[0]
        value = value.transpose(*sl.status.dims).values if "status" in sl else value.values
        resonant, _ = _confidence(sl, error_tolerance)
        values.append(value.ravel())
        calm.append(value[~resonant].ravel())
    values, calm = np.concatenate(values), np.concatenate(calm)
    positive = values[np.isfinite(values) & (values > 0)]
    if not positive.size:
        return None, False
    calm = calm[np.isfinite(calm) & (calm > 0)]
    top = min(positive.max(), 100.0 * (calm.max() if calm.size else np.median(positive)))
    return LogNorm(positive.min(), top), bool(positive.max() > top)


def _confidence(sl: xr.Dataset, error_tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """(resonant or unstable, other low confidence) masks of the slice's cases, its shape."""
    has = np.isfinite(sl["case"].values)
    status = sl.status.values if "status" in sl else np.zeros(has.shape)
    error = sl.error_estimate.values if "error_estimate" in sl else np.full(has.shape, np.nan)
    reasons = np.array(credibility(status.ravel(), error.ravel(), error_tolerance),
                       object).reshape(has.shape)
    bits = np.nan_to_num(status, nan=0).astype(int)
    resonant = has & ((bits & _RESONANT) > 0)
    low = has & (reasons != "") & ~resonant
    return resonant, low


def _out_of_range(omegas, low: float, high: float) -> str:
    """Which harmonics' speeds (one array per k, rad/s) all fall outside [low, high]."""
    above, below = [], []
    for k, omega in zip(MAP_HARMONICS, omegas):
        w = np.atleast_1d(omega)
        w = w[np.isfinite(w)]
        if w.size and not ((w >= low) & (w <= high)).any():
            (above if np.median(w) > high else below).append(str(k))
    parts = [f"k = {', '.join(above)} above the speed range"] if above else []
    parts += [f"k = {', '.join(below)} below it"] if below else []
    return "; ".join(parts)


def _sweep_panel(ax, sl: xr.Dataset, y: str, error_tolerance: float) -> str:
    """A one-dimensional slice: peak stress against speed, low-confidence cases marked."""
    value, label = _value(sl)
    keep = np.isfinite(sl["case"]).any("speed").values
    sl, value = sl.isel({y: np.flatnonzero(keep)}), value.isel({y: np.flatnonzero(keep)})
    resonant, low = (m.any(axis=0) for m in _confidence(sl.transpose(y, "speed", ...),
                                                          error_tolerance))
    speed = sl.speed.values
    v = value.max(y).values
    ax.plot(speed, v, color="C0", lw=1.2, marker="o", ms=3, label="peak stress (dot: a case)")
    if low.any():
        ax.plot(speed[low], v[low], "o", mfc="w", mec="C1", ms=6, label=_LOW)
    if resonant.any():
        ax.plot(speed[resonant], v[resonant], "x", color="C3", ms=7, mew=1.5,
                label="resonant / unstable")
    if "stress_utilisation" in sl and "peak_stress" in sl:
        allowable = (sl.peak_stress / sl.stress_utilisation).median().item() / 1e6
        if np.isfinite(allowable):
            ax.axhline(allowable, color="k", lw=0.8, ls="--",
                       label=f"yield / safety factor ({allowable:.4g} MPa)")
    finite = v[np.isfinite(v) & (v > 0)]
    if finite.size and finite.max() / finite.min() > 20:
        ax.set_yscale("log")
    plain_ticks(ax.yaxis)
    ax.set_ylabel(label)
    note = ""
    if "natural_frequency_min" in sl:
        f1 = float(sl.natural_frequency_min.isel(mode=0).median().item())
        omega = harmonic_speeds(np.array(f1))
        lo, hi = float(speed.min()), float(speed.max())
        for k, w in zip(MAP_HARMONICS, omega):
            if lo <= w <= hi:
                ax.axvline(w, color="0.4", lw=0.8, ls=":",
                           label="Ω = 2π f₁ / k (median f₁)" if k == max(
                               j for j, x in zip(MAP_HARMONICS, omega) if lo <= x <= hi)
                           else None)
                ax.text(w, 1.0, f" k={k}", transform=ax.get_xaxis_transform(), fontsize=7,
                        va="top", color="0.3")
        note = _out_of_range(omega, lo, hi)
    ax.set_xlim(speed.min() - 0.02 * np.ptp(speed), speed.max() + 0.02 * np.ptp(speed))
    return note


def _map_panel(ax, sl: xr.Dataset, y: str, norm, error_tolerance: float):
    """A two-dimensional slice: peak stress in colour over speed × y, cases marked."""
    value, _ = _value(sl)
    value = value.transpose(y, "speed")
    speeds, ys = sl.speed.values, sl[y].values
    ax.set_facecolor("0.92")
    mesh = ax.pcolormesh(_edges(speeds), _edges(ys), np.ma.masked_invalid(value.values),
                         norm=norm, cmap="viridis", shading="flat")
    resonant, low = _confidence(sl.transpose(y, "speed", ...), error_tolerance)
    for mask, style, name in ((resonant, dict(marker="x", color="r", ms=6, mew=1.5, ls=""),
                               "resonant / unstable"),
                              (low, dict(marker="o", mfc="none", mec="w", ms=5, ls=""), _LOW)):
        if mask.any():
            yy, xx = np.nonzero(mask)
            ax.plot(speeds[xx], ys[yy], label=name, **style)
    note = ""
    if "natural_frequency_min" in sl:
        lo, hi = _edges(speeds)[0], _edges(speeds)[-1]
        f_lo = sl.natural_frequency_min.isel(mode=0).transpose(y, "speed").median("speed")
        f_hi = sl.natural_frequency_max.isel(mode=0).transpose(y, "speed").median("speed")
        for k, omega_lo, omega_hi in zip(MAP_HARMONICS, harmonic_speeds(f_lo.values),
                                         harmonic_speeds(f_hi.values)):
            for omega, ls, name in ((omega_lo, "-", "Ω = 2π f₁ / k, lowest f₁ of the cycle"),
                                    (omega_hi, ":", "Ω = 2π f₁ / k, highest f₁")):
                ok = np.isfinite(omega)
                ax.plot(omega[ok], ys[ok], ls, color="w", lw=1.2, label=name if k == 1 else None)
            inside = np.flatnonzero(np.isfinite(omega_lo) & (omega_lo > lo) & (omega_lo < hi))
            if inside.size:
                i = inside[-1]
                ax.text(omega_lo[i], ys[i], f"k={k}", color="w", fontsize=7, va="bottom")
        note = _out_of_range(harmonic_speeds(f_lo.values), lo, hi)
    ax.set_xlim(_edges(speeds)[0], _edges(speeds)[-1])
    ax.set_ylim(_edges(ys)[0], _edges(ys)[-1])
    ax.set_ylabel(f"{y} length [m]")
    return mesh, note


def resonance_map(path: str | Path, png: str | Path, svg: str | Path | None = None,
                  y: str | None = None, fixed: dict | None = None,
                  error_tolerance: float = 0.05) -> None:
    """Resonance map of one family from its grid file: a panel per material (columns) and
    section (rows) of the study, colour = peak stress (max over links, log scale; peak input
    torque where no stress was computed) over input speed × a link length; the scale ends
    at a hundred times the largest case not flagged resonant or unstable (:func:`_colour_norm`),
    cells above taking its top colour (the colour bar's arrow).

    Overlaid: the speeds Ω = 2π f₁ / k at which the crank harmonic k·Ω/2π meets the first
    natural frequency f₁, k = 1…5 (solid: lowest f₁ over the cycle, dotted: highest, each the
    median over the slice's speeds; harmonics outside the speed range are listed under the
    panel); red crosses: cases flagged resonant or parametrically unstable; white circles:
    other low-confidence cases (:func:`ced.study.safe_speed.credibility`); grey: no case. A
    one-dimensional sweep is drawn as lines (:func:`map_slice`). Speeds in rad/s below and
    rpm on top.

    Parameters
    ----------
    path : str or Path
        The family's grid file.
    png : str or Path
        The PNG file written.
    svg : str or Path, optional
        The SVG file written (default: ``png`` with ``.svg``).
    y : str, optional
        The length on the y axis (config ``resonance_map.y``).
    fixed : dict, optional
        Values of the other lengths, m (config ``resonance_map.fixed``).
    error_tolerance : float
        Largest credible error estimate (dimensionless).
    """
    with open_dataset(path) as grid:
        grid = grid.load()
    family = str(grid.family.values) if "family" in grid.coords else Path(path).stem
    materials = [str(m) for m in grid.material.values]
    sections = [int(s) for s in grid.section.values] if "section" in grid.dims else [None]
    slices = {(m, s): map_slice(grid, m, s, y, fixed) for m in materials for s in sections}
    norm, clipped = _colour_norm([sl for sl, _, _ in slices.values()], error_tolerance)
    fig, axes = plt.subplots(len(sections), len(materials), squeeze=False,
                             figsize=(5.4 * len(materials), 4.3 * len(sections)),
                             constrained_layout=True)
    mesh = None
    for (row, s), (col, m) in ((r, c) for r in enumerate(sections) for c in enumerate(materials)):
        ax = axes[row, col]
        sl, yname, at = slices[m, s]
        sweep = int(np.isfinite(sl["case"]).any("speed").sum()) <= 1
        if sweep:
            note = _sweep_panel(ax, sl, yname, error_tolerance)
        else:
            mesh, note = _map_panel(ax, sl, yname, norm, error_tolerance)
        ax.set_xlabel("input speed Ω [rad/s]" + (f"\n{note}" if note else ""), fontsize=8)
        rpm_axis(ax)
        shown = ", ".join(f"{k} {v:g} {_unit(k)}" for k, v in at.items()
                          if k in (*MAP_LENGTHS, *_ANGLES))
        if sweep and yname in sl.dims:
            used = sl[yname].values[np.isfinite(sl["case"]).any("speed").values]
            shown = ", ".join([f"{yname} {v:g} m" for v in used] + ([shown] if shown else []))
        section = _section_label(grid, s)
        ax.set_title(f"{m}{', ' + section if section else ''}\n{shown}", fontsize=8)
    if mesh is not None:
        bar = fig.colorbar(mesh, ax=axes, shrink=0.9, label=_value(grid)[1],
                           extend="max" if clipped else "neither")
        plain_ticks(bar.ax.yaxis)
    labels = {}
    for ax in axes.flat:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            labels.setdefault(label, handle)
    if labels:
        legend = fig.legend(labels.values(), labels.keys(), loc="outside lower center",
                            ncols=min(3, len(labels)), fontsize=7, facecolor="0.7")
        legend.get_frame().set_edgecolor("0.6")
    fig.suptitle(f"Resonance map, {family}: where the crank harmonics k·Ω/2π meet the first "
                 f"natural frequency f₁, k = {MAP_HARMONICS[0]}…{MAP_HARMONICS[-1]}",
                 fontsize=9)
    save(fig, png, svg)


def _section_label(grid: xr.Dataset, section: int | None) -> str:
    if section is None:
        return ""
    from .safe_speed import section_label

    sizes = {k[len("section_"):]: float(grid[k].sel(section=section))
             for k in ("section_height", "section_width", "section_diameter") if k in grid}
    if "diameter" in sizes:
        return section_label({"shape": "circle", **sizes})
    if "height" in sizes and "width" in sizes:
        return section_label({"shape": "rectangle", **sizes})
    return f"section {section}"


def _edges(values: np.ndarray) -> np.ndarray:
    """Cell edges around sorted centres (half a step beyond the ends)."""
    values = np.asarray(values, float)
    if values.size == 1:
        return np.array([values[0] * 0.9, values[0] * 1.1]) if values[0] else np.array([-1, 1.])
    mid = (values[1:] + values[:-1]) / 2.0
    return np.concatenate([[2 * values[0] - mid[0]], mid, [2 * values[-1] - mid[-1]]])
