"""Figures of a study (matplotlib; every figure is written as PNG and SVG)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

__all__ = ["overview_figure", "campbell_figure", "representative_geometry", "save",
           "HARMONICS"]

#: Crank harmonics k·Ω/2π drawn on Campbell diagrams.
HARMONICS = tuple(range(1, 11))

#: Lengths that identify a geometry, by mechanism type.
_LENGTHS = ("ground", "crank", "coupler", "rocker", "rod", "offset")


def save(fig, png: str | Path, svg: str | Path | None = None) -> None:
    """Save ``fig`` as ``png`` and as ``svg`` (default: the same name with .svg)."""
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
    one whose lowest natural frequency (median over its cases) is the median."""
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
    effective stiffness, stored as −√|λ|/2π by :func:`ced.modal.natural_frequencies`; bands
    are clipped at the bottom edge). Dashed lines: crank harmonics k·Ω/2π, k = 1…10 — a mode
    band crossing a harmonic line is a candidate resonance.
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
    shown = ", ".join(f"{k} {v:g}" for k, v in geometry.items())
    fig.suptitle(f"Campbell diagram, {family} — coloured: {shown} m; dashed: k·Ω/2π, "
                 f"k = {HARMONICS[0]}…{HARMONICS[-1]}", fontsize=9)
    save(fig, png, svg)
