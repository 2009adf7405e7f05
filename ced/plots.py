"""Figures of a study (matplotlib, saved as PNG and SVG side by side)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import xarray as xr  # noqa: E402

__all__ = ["overview_figure", "save"]


def save(fig, output: str | Path) -> None:
    """Save ``fig`` as ``output`` (PNG) and the same name with .svg."""
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output, dpi=120, bbox_inches="tight")
    fig.savefig(output.with_suffix(".svg"), bbox_inches="tight")
    plt.close(fig)


def overview_figure(paths: list[str], output: str | Path) -> None:
    """Peak input torque (and peak stress where present) against speed, one panel a family."""
    datasets = [xr.open_dataset(p, engine="netcdf4") for p in paths]
    has_stress = any("peak_stress" in ds for ds in datasets)
    rows = 2 if has_stress else 1
    fig, axes = plt.subplots(rows, len(datasets), figsize=(3.2 * len(datasets), 3.0 * rows),
                             squeeze=False, constrained_layout=True)
    for col, ds in enumerate(datasets):
        family = str(ds.family.values[0])
        ax = axes[0, col]
        ax.scatter(ds.speed, ds.peak_input_torque, s=6, alpha=0.5)
        ax.set_title(f"{family} ({ds.sizes['case']} cases)", fontsize=9)
        ax.set_xlabel("speed [rad/s]")
        ax.set_ylabel("peak input torque [N m]")
        ax.set_yscale("log")
        if has_stress and "peak_stress" in ds:
            ax = axes[1, col]
            ax.scatter(ds.speed, ds.peak_stress.max("link") / 1e6, s=6, alpha=0.5, color="C3")
            ax.set_xlabel("speed [rad/s]")
            ax.set_ylabel("peak stress [MPa]")
            ax.set_yscale("log")
        ds.close()
    save(fig, output)
