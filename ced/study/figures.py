"""Figures of a study (matplotlib; every figure is written as PNG and SVG)."""
from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from ..io import open_dataset  # noqa: E402
from ..problem.mechanism import topology  # noqa: E402
from ..problem.status import status_names  # noqa: E402
from ..simulation.dataset import ESTIMATE_SOURCES  # noqa: E402
from .safe_speed import NOT_CREDIBLE, credibility  # noqa: E402

__all__ = ["overview_figure", "campbell_figure", "representative_geometry", "save",
           "worst_case_figure", "worst_cases", "magnification", "plain_ticks", "rpm_axis",
           "HARMONICS"]

#: Crank harmonics k·Ω/2π drawn on Campbell diagrams.
HARMONICS = tuple(range(1, 11))
#: Resolution of the PNG files (dots per inch).
PNG_DPI = 120

#: Lengths that identify a geometry, by mechanism type.
#: Lengths (m) and six-bar arm angles (rad) that identify a geometry, by mechanism type.
_LENGTHS = ("ground", "crank", "coupler", "rocker", "rocker_arm", "rocker_arm_angle",
            "coupler_arm", "coupler_arm_angle", "coupler2", "rocker2", "pivot2_x", "pivot2_y",
            "rod", "offset")


def _unit(key: str) -> str:
    return "rad" if key.endswith("_angle") else "m"


def _geometry_text(values: dict[str, float], per_line: int = 5) -> str:
    """"crank 0.1 m, …" of a geometry; on a line of its own when it is long (six-bars)."""
    text = ", ".join(f"{k} {v:g} {_unit(k)}" for k, v in values.items())
    return text if len(values) <= per_line else "\n" + text + "\n"


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
    # The layout and the tight box once for both files: savefig(bbox_inches="tight") draws
    # twice per file, the layout engine running each time (the same PNG, bit for bit, in
    # 0.78 of the time on a Pareto figure; the SVG's positions now those of the PNG's layout).
    fig.set_dpi(PNG_DPI)
    fig.canvas.draw()
    bbox = fig.get_tightbbox(fig.canvas.get_renderer()).padded(
        matplotlib.rcParams["savefig.pad_inches"])
    fig.set_layout_engine("none")
    fig.savefig(png, dpi=PNG_DPI, bbox_inches=bbox)
    fig.savefig(svg, bbox_inches=bbox, metadata={"Date": None})  # reproducible SVG
    plt.close(fig)


def plain_ticks(axis) -> None:
    """Plain numbers (20, 50, 100) instead of 2×10¹ on a (log) axis or colorbar axis: ticks at
    1, 2, 5 × 10ⁿ over up to three decades, at the decades beyond.

    Parameters
    ----------
    axis : matplotlib.axis.Axis
        ``ax.xaxis``, ``ax.yaxis`` or ``colorbar.ax.yaxis``, its limits set.
    """
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    if axis.get_scale() == "log":
        axis.axes.autoscale_view()
        low, high = sorted(axis.get_view_interval())
        decades = np.log10(high / low) if low > 0 else np.inf
        axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0) if decades <= 3 else (1.0,),
                                          numticks=8))
        axis.set_minor_formatter(NullFormatter())
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))


def rpm_axis(ax, label: str = "input speed [rpm]"):
    """A secondary x axis on top in rpm for an x axis in rad/s.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Axes whose x is an input speed in rad/s.
    label : str
        Label of the rpm axis.

    Returns
    -------
    matplotlib.axes.Axes
        The secondary axis.
    """
    scale = 60.0 / (2.0 * np.pi)
    top = ax.secondary_xaxis("top", functions=(lambda w: w * scale, lambda n: n / scale))
    top.set_xlabel(label, fontsize=8)
    top.tick_params(labelsize=7)
    return top


def overview_figure(paths: list[str], png: str | Path, svg: str | Path | None = None) -> None:
    """Peak input torque (and peak stress where present) against speed, one column a family.

    One colour a material; cases with status ok filled, flagged ones hollow (failed cases,
    with no values, are left out). On the stress panels, dashed in the material's colour: its
    yield strength over the study's stress safety factor (the allowable peak stress).

    Parameters
    ----------
    paths : list of str
        Family summary files (``maps/<family>.nc``).
    png : str or Path
        The PNG file written.
    svg : str or Path, optional
        The SVG file written (default: ``png`` with ``.svg``).
    """
    datasets = [open_dataset(p) for p in paths]
    has_stress = any("peak_stress" in ds for ds in datasets)
    rows = 2 if has_stress else 1
    materials = list(dict.fromkeys(m for ds in datasets for m in ds.material.values.tolist()))
    colour = {m: f"C{i}" for i, m in enumerate(materials)}
    fig, axes = plt.subplots(rows, len(datasets), figsize=(3.4 * len(datasets), 3.2 * rows),
                             squeeze=False, constrained_layout=True)
    for col, ds in enumerate(datasets):
        family = str(ds.family.values[0])
        ok = (np.nan_to_num(ds.status.values) == 0) if "status" in ds else np.ones(
            ds.sizes["case"], bool)
        panels = [(ds.peak_input_torque, "peak input torque [N m]")]
        if has_stress and "peak_stress" in ds:
            panels.append((ds.peak_stress.max("link") / 1e6, "peak stress [MPa]"))
        for row, (values, label) in enumerate(panels):
            ax = axes[row, col]
            finite = _finite(values)
            for m in materials:
                mine = finite & (ds.material == m).values
                ax.scatter(ds.speed[mine & ok], values[mine & ok], s=7, alpha=0.6,
                           color=colour[m], label=f"{m}, ok ({int((mine & ok).sum())})")
                ax.scatter(ds.speed[mine & ~ok], values[mine & ~ok], s=7, alpha=0.5,
                           facecolors="none", edgecolors=colour[m], lw=0.6,
                           label=f"{m}, flagged ({int((mine & ~ok).sum())})")
                if row == 1:
                    _allowable_line(ax, ds, m, colour[m])
            ax.set_xlabel("speed [rad/s]")
            ax.set_ylabel(label)
            _log_if_positive(ax, values[finite])
            _clip_flagged(ax, values.values, finite & ok, finite & ~ok,
                          _allowable(ds, materials) if row == 1 else None)
            plain_ticks(ax.yaxis)
        rpm_axis(axes[0, col], "speed [rpm]")
        axes[0, col].set_title(f"{family} ({ds.sizes['case']} cases)", fontsize=9)
        ds.close()
    labels = {}
    for ax in axes.flat:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            labels.setdefault(label.split(" (")[0] if "yield" not in label else label, handle)
    fig.legend(labels.values(), labels.keys(), loc="outside lower center",
               ncols=min(4, len(labels)), fontsize=7, markerscale=2)
    save(fig, png, svg)


def _clip_flagged(ax, values: np.ndarray, ok: np.ndarray, flagged: np.ndarray,
                  allowable: float | None = None) -> None:
    """Keep the axis within a hundred times the unflagged cases' largest value (and ten times
    the allowable stress): only blown-up responses (an unstable case at 1e8 MPa) are left
    above, and counted, so that they do not squeeze the rest — resonance peaks stay drawn.
    Where every case is flagged (a family of change points, all near-singular) the flagged
    cases' median stands for the unflagged ones' largest value: their bulk stays drawn and
    the blown-up ones (1e13 MPa at the change point itself) are counted above."""
    if ax.get_yscale() != "log" or not (ok.any() or flagged.any()):
        return
    bulk = np.nanmax(values[ok]) if ok.any() else np.nanmedian(values[flagged])
    top = max(100.0 * float(bulk), 10.0 * (allowable or 0.0))
    above = int((flagged & (values > top)).sum())
    if above:
        ax.set_ylim(top=top)
        ax.text(0.98, 0.98, f"▲ {above} flagged above", transform=ax.transAxes, fontsize=6,
                ha="right", va="top", color="0.3")


def _allowable(ds: xr.Dataset, materials: list[str]) -> float | None:
    """The largest allowable stress (yield / stress safety factor) of the materials, MPa."""
    values = [_allowable_stress(ds, m) for m in materials]
    values = [v for v in values if v]
    return max(values) if values else None


def _allowable_stress(ds: xr.Dataset, material: str) -> float | None:
    """Yield strength / stress safety factor of ``material``, MPa, where known."""
    from ..problem.errors import SceneError
    from ..problem.materials import resolve_material

    factor = (ds.stress_utilisation.attrs.get("stress_safety_factor")
              if "stress_utilisation" in ds else None)
    try:
        strength = resolve_material(material)["yield_strength"]
    except SceneError:  # an inline material: not in the library
        strength = None
    return strength / factor / 1e6 if factor and strength else None


def _allowable_line(ax, ds: xr.Dataset, material: str, colour: str) -> None:
    """Yield strength / stress safety factor of ``material``, dashed, where known."""
    allowable = _allowable_stress(ds, material)
    if allowable:
        factor = ds.stress_utilisation.attrs["stress_safety_factor"]
        ax.axhline(allowable, color=colour, ls="--", lw=0.9,
                   label=f"{material}: yield / {factor:g} = {allowable:.4g} MPa")


#: Error estimates marked on :func:`estimate_figure` (relative).
ESTIMATE_MARKS = (0.01, 0.02, 0.05)


def estimate_figure(paths: list[str], png: str | Path, svg: str | Path | None = None) -> None:
    """How accurate the study is, by its own estimate: the cumulative distribution of
    ``error_estimate`` over the cases with status ok, one curve a family and one for all; the
    title gives the share within each of :data:`ESTIMATE_MARKS`, and how many of the estimates
    a case took from its neighbours in speed (``error_estimate_source``: a start transient's
    sweep, :mod:`ced.auto.sweep_estimate`), which are looser than a case's own.

    Flagged cases are left out: their flag, not the estimate, decides whether to trust them.
    """
    fig, ax = plt.subplots(figsize=(7.5, 4.0), constrained_layout=True)
    everything, shared = [], 0
    for i, path in enumerate(paths):
        with open_dataset(path) as ds:
            if "error_estimate" not in ds:
                continue
            ok = np.nan_to_num(ds.status.values) == 0
            values = ds.error_estimate.values[ok]
            if "error_estimate_source" in ds:
                source = ds.error_estimate_source.values[ok][np.isfinite(values)]
                shared += int((source == ESTIMATE_SOURCES["sweep_neighbours"]).sum())
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
        title = f"error estimate of the {len(total)} unflagged cases: {shares}"
        if shared:
            title += (f"\n{shared} of them from the case's neighbours in speed "
                      "(error_estimate_source: looser than a case's own)")
        ax.set_title(title, fontsize=9)
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
    with open_dataset(path) as ds:
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
    fig, axes = plt.subplots(1, len(materials), figsize=(5.0 * len(materials) + 2.2, 4.4),
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
        below = [k for k in HARMONICS if k * omega[-1] / (2.0 * np.pi) < ylow]
        if below:  # not drawn inside the axes: say so rather than leave them silently absent
            ks = f"{below[0]}…{below[-1]}" if len(below) > 1 else f"{below[0]}"
            ax.text(0.02, 0.02, f"harmonics k = {ks} below the axis "
                    f"(≤ {below[-1] * omega[-1] / (2.0 * np.pi):.3g} Hz)", fontsize=7,
                    transform=ax.transAxes, color="0.3")
        ax.set_yscale("log")
        ax.set_ylim(ylow, yhigh)
        plain_ticks(ax.yaxis)
        ax.set_xlim(0.0, omega[-1] * 1.08)
        ax.set_xlabel("input speed Ω [rad/s]")
        rpm_axis(ax)
        ax.set_title(f"{material}", fontsize=9)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
    axes[0, 0].set_ylabel("natural frequency [Hz]")
    # outside the data: inside, it covered the first mode's band
    axes[0, -1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    shown = _geometry_text(geometry, per_line=4)
    fig.suptitle(f"Campbell diagram, {family} — coloured: {shown}; dashed: k·Ω/2π, "
                 f"k = {HARMONICS[0]}…{HARMONICS[-1]}", fontsize=9)
    save(fig, png, svg)


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


def worst_cases(summary: xr.Dataset, error_tolerance: float = 0.05) -> dict[str, int]:
    """Case ids of a family's worst credible case and its worst flagged one.

    Worst: the largest peak stress (max over links). Credible: not flagged by any of
    :data:`ced.study.safe_speed.NOT_CREDIBLE` and an error estimate within
    ``error_tolerance`` (:func:`ced.study.safe_speed.credibility`); flagged: every other case
    with a finite peak stress (a resonant or large-deflection case can show GPa: no design
    answer, but a warning the designer must see).

    Parameters
    ----------
    summary : xarray.Dataset
        A family summary (``maps/<family>.nc``).
    error_tolerance : float
        Largest credible error estimate (dimensionless).

    Returns
    -------
    dict
        ``{"credible": id, "flagged": id}``, each key only where such a case exists.
    """
    stress = summary.peak_stress.max("link").values
    n = len(stress)
    reasons = credibility(summary.status.values if "status" in summary else np.zeros(n),
                          summary.error_estimate.values if "error_estimate" in summary
                          else np.full(n, np.nan), error_tolerance)
    credible = np.array([not r for r in reasons])
    out = {}
    for key, mask in (("credible", credible), ("flagged", ~credible)):
        mask = mask & np.isfinite(stress)
        if mask.any():
            out[key] = int(summary.case.values[np.flatnonzero(mask)[np.argmax(stress[mask])]])
    return out


def _case_row(fig, grid, row: int, ds: xr.Dataset, kind: str, why: str) -> None:
    """One case: the stress history at its critical point (both fibres) and the linkage at
    the instant of the history's peak."""
    links = [str(n) for n in ds.link.values]
    peak = abs(ds.stress).max(["step", "fibre"])  # (link, station)
    where = np.unravel_index(int(np.nanargmax(peak.values)), peak.shape)
    link, station = links[where[0]], float(ds.station.values[where[1]])
    history = ds.stress.sel(link=link, station=station) / 1e6  # (step, fibre), MPa
    worst = int(abs(history).max("fibre").argmax("step"))
    drawn_peak = float(abs(history).max())
    angle = np.unwrap(ds.crank_angle.values)
    angle = np.degrees(angle - angle[0])
    ax = fig.add_subplot(grid[row, 0])
    for fibre, style in zip(history.fibre.values, ("-", "--")):
        ax.plot(angle, history.sel(fibre=fibre), color="C3", ls=style,
                label=f"fibre y/h = {fibre:+g}")
    ax.axvline(angle[worst], color="0.4", lw=0.8, ls=":", label="instant drawn right")
    ax.axhline(0.0, color="0.6", lw=0.5)
    ax.set_ylabel(f"stress, {link} at\nstation {station:g} [MPa]")
    plain_ticks(ax.yaxis)  # no "1e8" offset above the axis: a blown-up case reads as such
    ax.set_xlabel("crank angle from start of the cycle [deg]")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    geometry = _geometry_text({k: float(ds[k]) for k in _LENGTHS
                               if k in ds.coords and ds[k].ndim == 0})
    speed = float(ds.speed)
    ax.set_title(f"{kind} case {int(ds.case)}: {geometry}, {ds.material.item()}, "
                 f"Ω = {speed:g} rad/s ({speed * 60 / (2 * np.pi):.0f} rpm)\n"
                 f"peak of the curve {drawn_peak:.4g} MPa; {why}", fontsize=8, loc="left")
    ax = fig.add_subplot(grid[row, 1])
    _linkage(ax, ds, worst, links)


def _linkage(ax, ds: xr.Dataset, step: int, links: list[str]) -> None:
    """The linkage at ``step``: rigid (grey) and with the deflection magnified (red), in m."""
    topo = topology(json.loads(ds.attrs["scenes"])[0]["mechanism"] if "scenes" in ds.attrs
                    else "slider_crank" if "rod" in links else "four_bar")
    pos = ds.joint_position.isel(step=step)
    xy = ds.joint_position.values
    size = max(float(np.ptp(xy[..., 0])), float(np.ptp(xy[..., 1]))) + 1e-9
    w = ds.deflection.isel(step=step)
    factor = magnification(float(abs(ds.deflection).max()), size)
    s = ds.station.values
    for name in links:
        a, b = (pos.sel(joint=j).values for j in topo.links[name])
        ax.plot([a[0], b[0]], [a[1], b[1]], color="0.6", lw=3, solid_capstyle="round",
                label="rigid" if name == links[0] else None)
        chord = b - a
        normal = np.array([-chord[1], chord[0]]) / (np.hypot(*chord) or 1.0)
        line = a + np.outer(s, chord) + factor * np.outer(w.sel(link=name).values, normal)
        ax.plot(line[:, 0], line[:, 1], color="C3", lw=1.5,
                label=f"deflection ×{factor:g}" if name == links[0] else None)
    for point, host in topo.points.items():  # a rigid ternary link's arm to its point
        a, b = pos.sel(joint=topo.links[host][0]).values, pos.sel(joint=point).values
        ax.plot([a[0], b[0]], [a[1], b[1]], color="0.6", lw=3, solid_capstyle="round")
    ax.plot(pos.values[:, 0], pos.values[:, 1], "ko", ms=4)
    for j, (px, py) in zip(pos.joint.values, pos.values):
        ax.annotate(str(j), (px, py), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    ax.set_title(f"linkage at {np.degrees(float(ds.crank_angle[step])) % 360:.0f}° crank angle",
                 fontsize=8)


def worst_case_figure(summary_path: str | Path, chunk_paths: list[str], png: str | Path,
                      svg: str | Path | None = None, error_tolerance: float = 0.05) -> None:
    """A family's worst credible case and, below it, its worst flagged case
    (:func:`worst_cases`).

    Each row: left, the stress at both outer fibres of the case's critical point (the link
    and station of its largest absolute stress) over one cycle of the crank; the title's peak
    is that curve's. Right: the linkage, in metres, at the instant of that peak, rigid (grey)
    and with the elastic deflection magnified by the round factor in its legend.

    Parameters
    ----------
    summary_path : str or Path
        The family summary file.
    chunk_paths : list of str
        The family's chunk files (the time histories are read from the cases' chunks).
    png : str or Path
        The PNG file written.
    svg : str or Path, optional
        The SVG file written (default: ``png`` with ``.svg``).
    error_tolerance : float
        Largest credible error estimate (dimensionless), as in the safe-speed table.
    """
    with open_dataset(summary_path) as summary:
        summary = summary.load()
    family = str(summary.family.values[0]) if "family" in summary.coords else "family"
    cases = worst_cases(summary, error_tolerance) if "peak_stress" in summary else {}
    if not cases:
        fig, ax = plt.subplots(figsize=(5, 3))
        ax.text(0.5, 0.5, f"{family}: no elastic result to show", ha="center", va="center",
                transform=ax.transAxes)
        ax.set_axis_off()
        save(fig, png, svg)
        return
    data = {}
    for path in chunk_paths:
        with open_dataset(path) as chunk:
            for kind, case in cases.items():
                if case in chunk.case.values:
                    data[kind] = chunk.sel(case=case).load()
    missing = set(cases) - set(data)
    if missing:
        raise ValueError(f"worst_case_figure: case(s) {[cases[k] for k in missing]} are in "
                         "none of the chunk files")
    kinds = [k for k in ("credible", "flagged") if k in data]
    fig = plt.figure(figsize=(11, 4.0 * len(kinds) + 0.4), constrained_layout=True)
    grid = fig.add_gridspec(len(kinds), 2, width_ratios=(1.25, 1))
    for row, kind in enumerate(kinds):
        ds = data[kind]
        status = int(np.nan_to_num(ds.status.item())) if "status" in ds else 0
        error = float(ds.error_estimate) if "error_estimate" in ds else float("nan")
        if kind == "credible":
            why = "status: " + ", ".join(status_names(status))
        else:
            why = "NOT a design answer: " + credibility([status], [error], error_tolerance)[0]
        _case_row(fig, grid, row, ds, f"worst {kind}", why)
    absent = [f"no {k} case in this family" for k in ("credible", "flagged") if k not in data]
    fig.suptitle(f"{family}: the worst credible and the worst flagged case by peak stress"
                 f"{' (' + '; '.join(absent) + ')' if absent else ''}\ncredible: none of "
                 f"{', '.join(NOT_CREDIBLE)}, error estimate ≤ {100 * error_tolerance:g} %",
                 fontsize=9)
    save(fig, png, svg)
