"""Figures of a study (matplotlib; every figure is written as PNG and SVG)."""
from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from ..problem.mechanism import topology  # noqa: E402
from ..problem.status import STATUS_FILL, STATUS_FLAGS, status_names  # noqa: E402

__all__ = ["overview_figure", "campbell_figure", "representative_geometry", "save",
           "resonance_map", "map_slice", "worst_case_figure", "magnification", "HARMONICS",
           "MAP_HARMONICS"]

#: Harmonics k of the curves k·Ω/2π = f_1 on resonance maps.
MAP_HARMONICS = tuple(range(1, 6))

#: Crank harmonics k·Ω/2π drawn on Campbell diagrams.
HARMONICS = tuple(range(1, 11))

#: Lengths (m) and six-bar arm angles (rad) that identify a geometry, by mechanism type.
_LENGTHS = ("ground", "crank", "coupler", "rocker", "rocker_arm", "rocker_arm_angle",
            "coupler_arm", "coupler_arm_angle", "coupler2", "rocker2", "pivot2_x", "pivot2_y",
            "rod", "offset")


def _unit(key: str) -> str:
    return "rad" if key.endswith("_angle") else "m"


def save(fig, png: str | Path, svg: str | Path | None = None) -> None:
    """Save ``fig`` as ``png`` and as ``svg`` (default: the same name with .svg).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure (closed afterwards).
    png : str or Path
        The PNG file written.
    svg : str or Path, optional
        The SVG file written (default: ``png`` with ``.svg``).
    """
    png = Path(png)
    svg = png.with_suffix(".svg") if svg is None else Path(svg)
    for path in (png, svg):
        path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=120, bbox_inches="tight")
    fig.savefig(svg, bbox_inches="tight", metadata={"Date": None})  # reproducible SVG
    plt.close(fig)


def overview_figure(paths: list[str], png: str | Path, svg: str | Path | None = None) -> None:
    """Peak input torque (and peak stress where present) against speed, one panel a family.

    Cases with status ok are drawn in colour, flagged ones in grey (failed cases, with no
    values, are left out).

    Parameters
    ----------
    paths : list of str
        Family summary files (``maps/<family>.nc``).
    png : str or Path
        The PNG file written.
    svg : str or Path, optional
        The SVG file written (default: ``png`` with ``.svg``).
    """
    datasets = [xr.open_dataset(p, engine="netcdf4") for p in paths]
    has_stress = any("peak_stress" in ds for ds in datasets)
    rows = 2 if has_stress else 1
    fig, axes = plt.subplots(rows, len(datasets), figsize=(3.2 * len(datasets), 3.0 * rows),
                             squeeze=False, constrained_layout=True)
    for col, ds in enumerate(datasets):
        family = str(ds.family.values[0])
        ok = (np.nan_to_num(ds.status.values) == 0) if "status" in ds else np.ones(
            ds.sizes["case"], bool)
        panels = [(ds.peak_input_torque, "peak input torque [N m]", "C0")]
        if has_stress and "peak_stress" in ds:
            panels.append((ds.peak_stress.max("link") / 1e6, "peak stress [MPa]", "C3"))
        for row, (values, label, colour) in enumerate(panels):
            ax = axes[row, col]
            finite = _finite(values)
            for mask, c, name in ((finite & ~ok, "0.6", "flagged"), (finite & ok, colour, "ok")):
                ax.scatter(ds.speed[mask], values[mask], s=6, alpha=0.5, color=c,
                           label=f"{name} ({int(mask.sum())})")
            ax.set_xlabel("speed [rad/s]")
            ax.set_ylabel(label)
            _log_if_positive(ax, values[finite])
            ax.legend(fontsize=6, loc="upper left", markerscale=1.5)
        axes[0, col].set_title(f"{family} ({ds.sizes['case']} cases)", fontsize=9)
        ds.close()
    save(fig, png, svg)


#: Error estimates marked on :func:`estimate_figure` (relative).
ESTIMATE_MARKS = (0.01, 0.02, 0.05)


def estimate_figure(paths: list[str], png: str | Path, svg: str | Path | None = None) -> None:
    """How accurate the study is, by its own estimate: the cumulative distribution of
    ``error_estimate`` over the cases with status ok, one curve a family and one for all; the
    title gives the share within each of :data:`ESTIMATE_MARKS`.

    Flagged cases are left out: their flag, not the estimate, decides whether to trust them.
    """
    fig, ax = plt.subplots(figsize=(7.5, 4.0), constrained_layout=True)
    everything = []
    for i, path in enumerate(paths):
        with xr.open_dataset(path, engine="netcdf4") as ds:
            if "error_estimate" not in ds:
                continue
            ok = np.nan_to_num(ds.status.values) == 0
            values = ds.error_estimate.values[ok]
            values = np.sort(values[np.isfinite(values)])
            family = str(ds.family.values[0])
        if not len(values):
            continue
        everything.append(values)
        ax.step(np.maximum(values, 1e-7), np.arange(1, len(values) + 1) / len(values),
                where="post", color=f"C{i}", lw=1.2, label=f"{family} ({len(values)})")
    if everything:
        total = np.sort(np.concatenate(everything))
        ax.step(np.maximum(total, 1e-7), np.arange(1, len(total) + 1) / len(total),
                where="post", color="k", lw=2.0, label=f"all ({len(total)})")
        shares = ", ".join(f"{np.mean(total <= m):.0%} ≤ {m:.0%}" for m in ESTIMATE_MARKS)
        ax.set_title(f"error estimate of the {len(total)} unflagged cases: {shares}",
                     fontsize=9)
    for m in ESTIMATE_MARKS:
        ax.axvline(m, color="0.5", lw=0.8, ls="--")
    ax.set_xscale("log")
    ax.xaxis.set_major_formatter(plt.FuncFormatter(lambda x, _: f"{100 * x:g} %"))
    ax.set_xlabel("estimated relative error of peak stress (error_estimate)")
    ax.set_ylabel("share of unflagged cases at or below")
    ax.set_ylim(0.0, 1.0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), title="family (cases)",
              title_fontsize=7)
    save(fig, png, svg)


def _finite(values: xr.DataArray) -> np.ndarray:
    return np.isfinite(values.values)


def _log_if_positive(ax, values) -> None:
    if np.size(values) and (np.asarray(values) > 0).all():
        ax.set_yscale("log")


def _frequency_limits(fmin: xr.DataArray, fmax: xr.DataArray) -> tuple[float, float]:
    """Log-axis limits from the 1st percentile of the positive lowest frequencies to the 99th
    percentile of the highest (robust to the odd near-singular case; non-positive frequencies
    are drawn at the bottom edge)."""
    low = fmin.values[np.isfinite(fmin.values) & (fmin.values > 0)]
    high = fmax.values[np.isfinite(fmax.values) & (fmax.values > 0)]
    if not low.size or not high.size:
        return 1.0, 10.0
    top = float(np.percentile(high, 99)) * 1.5
    return max(float(np.percentile(low, 1)) * 0.7, top * 1e-4), top


#: Status bits that make a case's frequencies unrepresentative (near_singular, failed).
_UNRELIABLE = 2 | 16


def representative_geometry(ds: xr.Dataset) -> dict[str, float]:
    """A typical member of the family: among the geometries with the best share of usable
    cases (lowest frequency positive; and preferably no near-singular or failed status), the
    one whose lowest natural frequency (median over its cases) is the median.

    Parameters
    ----------
    ds : xarray.Dataset
        A family summary with natural frequencies.

    Returns
    -------
    dict of str to float
        The geometry's lengths, m.
    """
    keys = [k for k in _LENGTHS if k in ds.coords and ds[k].dims == ("case",)]
    f1 = ds.natural_frequency_min.isel(mode=0).values
    status = (np.nan_to_num(ds.status.values).astype(int) if "status" in ds
              else np.zeros(f1.shape, int))
    positive = np.isfinite(f1) & (f1 > 0)
    clean = positive & (status & _UNRELIABLE == 0)
    groups: dict[tuple, list[int]] = {}
    for i, geometry in enumerate(zip(*(ds[k].values.tolist() for k in keys))):
        groups.setdefault(geometry, []).append(i)
    score = {g: (bool(clean[i].all()), float(positive[i].mean())) for g, i in groups.items()}
    best = max(score.values())
    medians = sorted((float(np.median(f1[i][positive[i]])) if positive[i].any() else 0.0, g)
                     for g, i in groups.items() if score[g] == best)
    return dict(zip(keys, map(float, medians[len(medians) // 2][1])))


def campbell_figure(path: str | Path, png: str | Path, svg: str | Path | None = None) -> None:
    """Campbell diagram of one family: natural-frequency band over the cycle against speed.

    One panel per material. Grey: for each mode, the family's band at each speed — from the
    5th percentile over its cases of the lowest frequency over the cycle to the 95th
    percentile of the highest. Coloured: the bands of the
    family's representative geometry (:func:`representative_geometry`), with markers on the
    cases flagged resonant or parametrically unstable, and triangles on the bottom edge where
    its lowest frequency is ≤ 0 somewhere in the cycle (a negative eigenvalue of the frozen
    effective stiffness, stored as −√|λ|/2π by
    :func:`ced.fem.eigenproblem.natural_frequencies`; bands are clipped at the bottom edge). Dashed lines: crank harmonics k·Ω/2π, k = 1…10 — a mode
    band crossing a harmonic line is a candidate resonance.

    Parameters
    ----------
    path : str or Path
        The family summary file.
    png : str or Path
        The PNG file written.
    svg : str or Path, optional
        The SVG file written (default: ``png`` with ``.svg``).
    """
    with xr.open_dataset(path, engine="netcdf4") as ds:
        ds = ds.load()
    family = str(ds.family.values[0]) if "family" in ds.coords else Path(path).stem
    if "natural_frequency_min" not in ds:
        fig, ax = plt.subplots(figsize=(5, 3))
        ax.text(0.5, 0.5, f"{family}: no modal analysis in this study", ha="center",
                va="center", transform=ax.transAxes)
        ax.set_axis_off()
        save(fig, png, svg)
        return
    materials = list(dict.fromkeys(ds.material.values.tolist()))
    geometry = representative_geometry(ds)
    fig, axes = plt.subplots(1, len(materials), figsize=(5.0 * len(materials), 4.2),
                             squeeze=False, sharey=True, constrained_layout=True)
    speeds = np.unique(ds.speed.values)
    omega = np.linspace(0.0, speeds.max() * 1.05, 50)
    fmin, fmax = ds.natural_frequency_min, ds.natural_frequency_max
    ylow, yhigh = _frequency_limits(fmin, fmax)
    for ax, material in zip(axes[0], materials):
        in_material = (ds.material == material).values
        speed = ds.speed[in_material]
        for m in range(ds.sizes["mode"]):
            low = fmin.isel(mode=m)[in_material].groupby(speed).quantile(0.05)
            high = fmax.isel(mode=m)[in_material].groupby(speed).quantile(0.95)
            ax.fill_between(low.speed, low.clip(min=ylow), high.clip(min=ylow), color="0.85",
                            lw=0, label="family, 5–95 %" if m == 0 else None)
        mine = in_material.copy()
        for key, value in geometry.items():
            mine &= np.isclose(ds[key].values, value)
        sub = ds.isel(case=np.flatnonzero(mine)).sortby("speed")
        for m, mode in enumerate(sub["mode"].values):
            lo = sub.natural_frequency_min.isel(mode=m).clip(min=ylow)
            hi = sub.natural_frequency_max.isel(mode=m).clip(min=ylow)
            ax.fill_between(sub.speed, lo, hi, color=f"C{m}", alpha=0.45, lw=0)
            ax.vlines(sub.speed, lo, hi, color=f"C{m}", lw=2.5 if len(speeds) <= 12 else 0.8,
                      label=f"mode {mode}")
        soft = (sub.natural_frequency_min.isel(mode=0) <= 0).values
        if soft.any():
            ax.plot(sub.speed.values[soft], np.full(soft.sum(), ylow), "v", color="C3", ms=6,
                    clip_on=False, label="f ≤ 0 in part of the cycle")
        if "status" in sub:
            flagged = (np.nan_to_num(sub.status.values).astype(int) & (4 | 8)) > 0
            if flagged.any():
                y = sub.natural_frequency_max.isel(mode=0).values[flagged]
                ax.plot(sub.speed.values[flagged], y, "kx", ms=6, label="resonant / unstable")
        for k in HARMONICS:
            ax.plot(omega, k * omega / (2.0 * np.pi), color="0.3", lw=0.6, ls="--")
            y_end = k * omega[-1] / (2.0 * np.pi)
            if ylow < y_end < yhigh:
                ax.text(omega[-1], y_end, f" {k}×", fontsize=7, va="center", color="0.3")
        ax.set_yscale("log")
        ax.set_ylim(ylow, yhigh)
        ax.set_xlim(0.0, omega[-1] * 1.08)
        ax.set_xlabel("input speed Ω [rad/s]")
        ax.set_title(f"{material}", fontsize=9)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
    axes[0, 0].set_ylabel("natural frequency [Hz]")
    axes[0, 0].legend(fontsize=7, loc="lower right")
    shown = ", ".join(f"{k} {v:g} {_unit(k)}" for k, v in geometry.items())
    shown = shown if len(geometry) <= 4 else "\n" + shown + "\n"
    fig.suptitle(f"Campbell diagram, {family} — coloured: {shown}; dashed: k·Ω/2π, "
                 f"k = {HARMONICS[0]}…{HARMONICS[-1]}", fontsize=9)
    save(fig, png, svg)


# ------------------------------------------------------------------------------ resonance maps
_MAP_LENGTHS = ("crank", "coupler", "rocker", "rocker_arm", "coupler_arm", "coupler2", "rocker2",
                "pivot2_x", "pivot2_y", "rod", "offset")


def map_slice(grid: xr.Dataset, material: str | None = None) -> tuple[xr.Dataset, str, dict]:
    """The (speed × length) slice of a family grid drawn on its resonance map.

    The y axis is the length dimension with the most values that hold cases (ties: the larger
    range); the material is ``material`` (default the first of the grid), the section the
    first; every other length is fixed at the value whose slice holds the most cases (ties:
    the median of those values). Returns the slice, the y name and the fixed values.

    Parameters
    ----------
    grid : xarray.Dataset
        A family's grid map (``maps/<family>_grid.nc``).
    material : str, optional
        The material of the slice.
    """
    material = str(grid.material.values[0]) if material is None else material
    has = np.isfinite(grid["case"]).sel(material=material)
    if "section" in has.dims:
        has = has.isel(section=0)
    lengths = [d for d in _LENGTHS if d in grid.dims]  # six-bar arm angles fixed, never y
    def spread(d):
        used = has.any([x for x in has.dims if x != d])
        values = grid[d].values[used.values]
        return (int(used.sum()), float(np.ptp(values)) if values.size else 0.0)
    y = max([d for d in _MAP_LENGTHS if d in grid.dims], key=spread)
    fixed: dict = {"material": material}
    if "section" in grid.dims:
        fixed["section"] = grid.section.values[0].item()
    rest = has.sel(speed=has.speed)  # all speeds
    for d in lengths:
        if d == y:
            continue
        count = rest.sum([x for x in rest.dims if x != d])
        best = grid[d].values[(count == count.max()).values]
        value = best[len(best) // 2].item()
        fixed[d] = value
        rest = rest.sel({d: value})
    return grid.sel(fixed), y, fixed


def resonance_map(path: str | Path, png: str | Path, svg: str | Path | None = None,
                  material: str | None = None) -> None:
    """Resonance map of one family from its grid file: speed × one length, colour = peak
    stress (max over links, log scale; peak input torque where no stress was computed).

    Overlaid: the speeds Ω = 2π f_1 / k at which the crank harmonic k·Ω/2π meets the first
    natural frequency f_1, k = 1…5 (solid: lowest f_1 over the cycle, dotted: highest,
    each the median over the speeds of the slice); crosses: cases flagged resonant or
    parametrically unstable; hatched: no case. Slice chosen by :func:`map_slice`.

    Parameters
    ----------
    path : str or Path
        The family's grid file.
    png : str or Path
        The PNG file written.
    svg : str or Path, optional
        The SVG file written (default: ``png`` with ``.svg``).
    material : str, optional
        The material of the slice (default: the grid's first).
    """
    from matplotlib.colors import LogNorm

    with xr.open_dataset(path, engine="netcdf4") as grid:
        grid = grid.load()
    family = str(grid.family.values) if "family" in grid.coords else Path(path).stem
    sl, y, fixed = map_slice(grid, material)
    if "peak_stress" in sl:
        value, label = sl.peak_stress.max("link") / 1e6, "peak stress, max over links [MPa]"
    else:
        value, label = sl.peak_input_torque, "peak input torque [N m]"
    value = value.transpose(y, "speed")
    fig, ax = plt.subplots(figsize=(6.4, 4.4), constrained_layout=True)
    v = value.values
    positive = v[np.isfinite(v) & (v > 0)]
    norm = LogNorm(positive.min(), positive.max()) if positive.size else None
    speeds, ys = sl.speed.values, sl[y].values
    ax.set_facecolor("0.92")
    mesh = ax.pcolormesh(_edges(speeds), _edges(ys), np.ma.masked_invalid(v), norm=norm,
                         cmap="viridis", shading="flat")
    fig.colorbar(mesh, ax=ax, label=label)
    if "status" in sl:
        bits = np.nan_to_num(sl.status.transpose(y, "speed").values, nan=0).astype(int)
        bad = ((bits & (4 | 8)) > 0) & (bits != STATUS_FILL)
        if bad.any():
            yy, xx = np.nonzero(bad)
            ax.plot(speeds[xx], ys[yy], "x", color="r", ms=6, label="resonant / unstable")
    if "natural_frequency_min" in sl:
        f_lo = sl.natural_frequency_min.isel(mode=0).transpose(y, "speed").median("speed")
        f_hi = sl.natural_frequency_max.isel(mode=0).transpose(y, "speed").median("speed")
        for k in MAP_HARMONICS:
            for f, ls in ((f_lo, "-"), (f_hi, ":")):
                omega = 2.0 * np.pi * f.values / k
                ok = np.isfinite(omega) & (omega > 0)
                ax.plot(omega[ok], ys[ok], ls, color="w", lw=1.2)
            ok = np.isfinite(f_lo.values) & (f_lo.values > 0)
            if ok.any():
                i = np.flatnonzero(ok)[-1]
                x = 2.0 * np.pi * f_lo.values[i] / k
                if _edges(speeds)[0] < x < _edges(speeds)[-1]:
                    ax.text(x, ys[i], f"k={k}", color="w", fontsize=7, ha="left", va="bottom")
    ax.set_xlim(_edges(speeds)[0], _edges(speeds)[-1])
    ax.set_ylim(_edges(ys)[0], _edges(ys)[-1])
    ax.set_xlabel("input speed Ω [rad/s]")
    ax.set_ylabel(f"{y} length [m]")
    shown = ", ".join(f"{k} {v:g} {_unit(k)}" if k in _LENGTHS else f"{k} {v}"
                      for k, v in fixed.items())
    ax.set_title(f"{family}: {shown}\nwhite: k·Ω/2π = f₁, k = {MAP_HARMONICS[0]}…"
                 f"{MAP_HARMONICS[-1]} (solid min, dotted max of f₁ over the cycle)",
                 fontsize=8)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, loc="upper right")
    save(fig, png, svg)


def _edges(values: np.ndarray) -> np.ndarray:
    """Cell edges around sorted centres (half a step beyond the ends)."""
    values = np.asarray(values, float)
    if values.size == 1:
        return np.array([values[0] * 0.9, values[0] * 1.1]) if values[0] else np.array([-1, 1.])
    mid = (values[1:] + values[:-1]) / 2.0
    return np.concatenate([[2 * values[0] - mid[0]], mid, [2 * values[-1] - mid[-1]]])


# ------------------------------------------------------------------------------ worst case
def magnification(deflection: float, size: float, fraction: float = 0.1) -> float:
    """A round magnification (1, 2, 5 × 10^n, below 1 for a diverged response) that draws
    ``deflection`` at about ``fraction`` × ``size``.

    Parameters
    ----------
    deflection : float
        Largest deflection, m.
    size : float
        Size of the drawing, m.
    fraction : float
        Share of ``size`` the magnified deflection should take.

    Returns
    -------
    float
        The factor.

    Examples
    --------
    >>> magnification(1e-4, 0.3)
    200.0
    """
    if not np.isfinite(deflection) or deflection <= 0:
        return 1.0
    raw = fraction * size / deflection
    exponent = np.floor(np.log10(raw))
    mantissa = max((m for m in (1, 2, 5, 10) if m <= raw / 10**exponent), default=1)
    return float(mantissa * 10**exponent)


#: A resonant or parametrically unstable periodic state (finite but unbounded in reality), a
#: deflection beyond the linear model's validity, or a failed case is no design answer; the
#: worst case is chosen among the others; so is a buckled one (a link beyond its Euler load).
_NOT_A_DESIGN_CASE = (STATUS_FLAGS["failed"] | STATUS_FLAGS["resonant"]
                      | STATUS_FLAGS["parametrically_unstable"] | STATUS_FLAGS["large_deflection"]
                      | STATUS_FLAGS["buckled"])


def _worst_case(summary: xr.Dataset) -> int | None:
    """Case id with the largest peak stress (max over links) among cases not flagged failed,
    resonant, parametrically unstable or large_deflection (reported by flags and maps)."""
    stress = summary.peak_stress.max("link").values
    bits = (np.nan_to_num(summary.status.values).astype(int) if "status" in summary
            else np.zeros(stress.shape, int))
    ok = np.isfinite(stress) & ((bits & _NOT_A_DESIGN_CASE) == 0)
    if not ok.any():
        return None
    return int(summary.case.values[np.flatnonzero(ok)[np.argmax(stress[ok])]])


def worst_case_figure(summary_path: str | Path, chunk_paths: list[str], png: str | Path,
                      svg: str | Path | None = None) -> None:
    """Time history of a family's worst case: the case with the largest peak stress (max over
    links) not flagged failed, resonant, parametrically unstable or large_deflection.

    Left: stress and transverse deflection at mid-span of the coupler (four-bar), rod
    (slider-crank) or the link of the peak stress (six-bar) against the crank angle, the worst
    instant marked. Right: the linkage at the worst instant (the step of the largest |stress|
    anywhere), rigid (grey; a ternary link's arm to its point too) and deformed with the
    elastic deflection magnified by the factor in the title.

    Parameters
    ----------
    summary_path : str or Path
        The family summary file.
    chunk_paths : list of str
        The family's chunk files (the time history is read from the worst case's chunk).
    png : str or Path
        The PNG file written.
    svg : str or Path, optional
        The SVG file written (default: ``png`` with ``.svg``).
    """

    with xr.open_dataset(summary_path, engine="netcdf4") as summary:
        summary = summary.load()
    family = str(summary.family.values[0]) if "family" in summary.coords else "family"
    case = _worst_case(summary) if "peak_stress" in summary else None
    if case is None:
        fig, ax = plt.subplots(figsize=(5, 3))
        ax.text(0.5, 0.5, f"{family}: no elastic result to show", ha="center", va="center",
                transform=ax.transAxes)
        ax.set_axis_off()
        save(fig, png, svg)
        return
    ds = None
    for path in chunk_paths:
        with xr.open_dataset(path, engine="netcdf4") as chunk:
            if case in chunk.case.values:
                ds = chunk.sel(case=case).load()
                break
    if ds is None:
        raise ValueError(f"worst_case_figure: case {case} is in none of the chunk files")
    links = [str(n) for n in ds.link.values]
    body = "coupler" if "coupler" in links else "rod" if "rod" in links else links[-1]
    if "coupler2" in links:  # a six-bar: the link of the peak stress, wherever it is
        body = links[int(ds.peak_stress.argmax("link"))]
    mid = float(ds.station.sel(station=0.5, method="nearest"))
    angle = np.unwrap(ds.crank_angle.values)
    angle = np.degrees(angle - angle[0])
    stress = ds.stress.sel(link=body, station=mid) / 1e6
    defl = ds.deflection.sel(link=body, station=mid) * 1e3
    worst = int(abs(ds.stress).max(["link", "station"]).argmax("step"))
    fig = plt.figure(figsize=(10, 4.6), constrained_layout=True)
    grid = fig.add_gridspec(2, 2, width_ratios=(1.1, 1))
    ax1, ax2 = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0])
    ax1.sharex(ax2)
    ax1.plot(angle, stress, color="C3")
    ax1.set_ylabel(f"{body} mid-span\nstress [MPa]")
    ax2.plot(angle, defl, color="C0")
    ax2.set_ylabel(f"{body} mid-span\ndeflection [mm]")
    ax2.set_xlabel("crank angle from start of the cycle [deg]")
    for ax in (ax1, ax2):
        ax.axvline(angle[worst], color="0.4", lw=0.8, ls="--")
        ax.grid(True, lw=0.3)
    ax1.label_outer()
    # linkage at the worst instant
    ax3 = fig.add_subplot(grid[:, 1])
    topo = topology(json.loads(ds.attrs["scenes"])[0]["mechanism"] if "scenes" in ds.attrs
                    else "slider_crank" if "rod" in links else "four_bar")
    pos = ds.joint_position.isel(step=worst)
    size = float(np.ptp(ds.joint_position.values[..., 0])) + 1e-9
    size = max(size, float(np.ptp(ds.joint_position.values[..., 1])))
    w = ds.deflection.isel(step=worst)
    factor = magnification(float(abs(ds.deflection).max()), size)
    s = ds.station.values
    for name in links:
        a, b = (pos.sel(joint=j).values for j in topo.links[name])
        ax3.plot([a[0], b[0]], [a[1], b[1]], color="0.6", lw=3, solid_capstyle="round",
                 label="rigid" if name == links[0] else None)
        chord = b - a
        normal = np.array([-chord[1], chord[0]]) / (np.hypot(*chord) or 1.0)
        line = a + np.outer(s, chord) + factor * np.outer(w.sel(link=name).values, normal)
        ax3.plot(line[:, 0], line[:, 1], color="C3", lw=1.5,
                 label=f"deformed (×{factor:g})" if name == links[0] else None)
    for point, host in topo.points.items():  # a rigid ternary link's arm to its point
        a, b = pos.sel(joint=topo.links[host][0]).values, pos.sel(joint=point).values
        ax3.plot([a[0], b[0]], [a[1], b[1]], color="0.6", lw=3, solid_capstyle="round")
    xy = pos.values
    ax3.plot(xy[:, 0], xy[:, 1], "ko", ms=4)
    for j, (px, py) in zip(pos.joint.values, xy):
        ax3.annotate(str(j), (px, py), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax3.set_aspect("equal")
    ax3.legend(fontsize=7, loc="best")
    ax3.set_title(f"at the worst instant ({angle[worst]:.0f}°), deflection ×{factor:g}",
                  fontsize=9)
    keys = [k for k in _LENGTHS if k in ds.coords and ds[k].ndim == 0]
    geometry = ", ".join(f"{k} {float(ds[k]):g} {_unit(k)}" for k in keys)
    geometry = geometry if len(keys) <= 5 else "\n" + geometry + "\n"

    status = int(np.nan_to_num(ds.status.item())) if "status" in ds else 0
    fig.suptitle(f"{family}, worst case {case}: {geometry}, {ds.material.item()}, "
                 f"Ω = {float(ds.speed):g} rad/s, peak stress "
                 f"{float(ds.peak_stress.max()) / 1e6:.4g} MPa\nstatus: "
                 f"{', '.join(status_names(status))}; deflection magnified ×{factor:g}",
                 fontsize=9)
    save(fig, png, svg)
