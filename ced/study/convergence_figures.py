"""Figures and summary of the convergence study: what accuracy costs in time.

Input: per-family datasets of :func:`ced.study.convergence.run_family` (dimension ``setting`` with
the errors of each discretization setting against a Richardson-extrapolated reference and its
measured solve time per case; dimension ``tolerance`` with the automatic discretization).

* :func:`pareto_figure`: error against solve time per case, one panel per quantity (peak
  stress, peak deflection, first natural frequency), with the Pareto front.
* :func:`estimate_figure`: true error of peak stress against ced's own error estimate.
* :func:`write_pareto_figure`: one family's Pareto figure (rule ``pareto_figure``).
* :func:`write_accuracy_summary`: the table "to reach 10 %, 1 %, 0.1 % use … at … ms per case"
  as CSV and markdown, and the estimate figure (rule ``convergence_summary``).

Same style as :mod:`ced.study.figures` (Agg back end, PNG and SVG through
:func:`ced.study.figures.save`).
"""
from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from ..io import open_dataset  # noqa: E402
from .convergence import UNRESOLVED  # noqa: E402
from .figures import plain_ticks, save  # noqa: E402

__all__ = ["QUANTITIES", "group_label", "pareto_front", "pareto_figure", "estimate_figure",
           "accuracy_markdown", "write_pareto_figure", "write_accuracy_summary"]

#: Panels of :func:`pareto_figure`: (error variable, reference variable, title, unit, scale).
QUANTITIES = (
    ("error_peak_stress", "reference_peak_stress", "peak stress", "MPa", 1e-6),
    ("error_peak_deflection", "reference_peak_deflection", "peak deflection", "mm", 1e3),
    ("error_first_frequency", "reference_first_frequency", "first natural frequency", "Hz", 1.0),
)

_MARKERS = "osD^vP<>Xph*"


def group_label(formulation: str, modes_per_link: int, integrator: str) -> str:
    """Legend label of a (formulation, modes per link, integrator) group of settings.

    Parameters
    ----------
    formulation : str
        ``discretization.formulation``.
    modes_per_link : int
        ``discretization.modes_per_link`` (0: full FE model).
    integrator : str
        ``time.integrator``.

    Returns
    -------
    str
    """
    model = str(formulation)
    if int(modes_per_link) > 0:
        model += f" reduced {int(modes_per_link)} modes"
    return f"{model}, {integrator}"


def _group_keys(ds: xr.Dataset) -> list[str]:
    """Group of each setting: the (formulation, modes, integrator) label of the dataset (its
    ``label`` coordinate), or :func:`group_label` where it has none."""
    own = [group_label(f, m, i) for f, m, i in zip(ds.formulation.values,
                                                    ds.modes_per_link.values,
                                                    ds.integrator.values)]
    if "label" not in ds.coords:
        return own
    labels = [str(v) for v in ds.label.values]
    # one label per (formulation, modes, integrator), else the label is not a group name
    pairs = set(zip(labels, own))
    return labels if len(pairs) == len(set(labels)) == len(set(own)) else own


def _groups(ds: xr.Dataset) -> dict[str, np.ndarray]:
    """Setting indices of each (formulation, modes, integrator) group, in order of appearance."""
    keys = _group_keys(ds)
    out: dict[str, list[int]] = {}
    for n, key in enumerate(keys):
        out.setdefault(key, []).append(n)
    return {k: np.asarray(v) for k, v in out.items()}


def _usable(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Points that can be drawn on log-log axes (finite and positive)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    with np.errstate(invalid="ignore"):
        return np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)


def pareto_front(time: np.ndarray, error: np.ndarray) -> np.ndarray:
    """Indices of the Pareto-optimal points (no other point is both faster and more accurate),
    sorted by time. Non-finite or non-positive values are left out.

    Parameters
    ----------
    time : ndarray
        Solve time of each point, s.
    error : ndarray
        Relative error of each point (dimensionless).

    Returns
    -------
    ndarray of int

    Examples
    --------
    >>> pareto_front(np.array([1.0, 2.0, 3.0, 4.0]), np.array([0.1, 0.2, 0.01, 0.01])).tolist()
    [0, 2]
    """
    time, error = np.asarray(time, float), np.asarray(error, float)
    candidates = np.flatnonzero(_usable(time, error))
    order = candidates[np.lexsort((error[candidates], time[candidates]))]
    front, best = [], math.inf
    for i in order:
        if error[i] < best:
            front.append(int(i))
            best = error[i]
    return np.asarray(front, dtype=int)


def _reference_text(ds: xr.Dataset, name: str, unit: str, scale: float) -> str:
    if name not in ds:
        return "reference n/a"
    value = float(ds[name].values) * scale
    unc = ds[name].attrs.get("uncertainty")
    text = f"ref. {value:.4g} {unit}"
    if unc is not None and np.isfinite(float(unc)):
        text += f" ± {100 * float(unc):.2g} %"
    return text


def pareto_figure(ds: xr.Dataset) -> plt.Figure:
    """Error against solve time per case for one family: three panels (peak stress, peak
    deflection, first natural frequency), both axes logarithmic.

    One colour and marker per (formulation, modes per link, integrator) group; thin lines join
    the settings of a group with equal elements per link as the steps per revolution grow; the
    black step line is the Pareto front over all settings, which stops at the grey band at the
    bottom, the reference's own relative uncertainty (errors below it are not resolved). On the
    peak-stress panel, stars are the automatic discretization for each tolerance (its true
    error of peak stress against its solve time; none where the reference is uncertain by 1 %
    or more, which the legend says), with the tolerance itself as a horizontal tick at the
    same time, and rings mark the cheapest sweep setting that meets each tolerance (none drawn
    where no setting does). Settings whose error is zero, negative or NaN (not drawable on a log
    axis) are counted in the panel's legend.

    Parameters
    ----------
    ds : xarray.Dataset
        One family's :func:`ced.study.convergence.run_family` result.

    Returns
    -------
    matplotlib.figure.Figure
    """
    family = ds.attrs.get("family", "")
    groups = _groups(ds)
    time_ms = np.asarray(ds.solve_time.values, float) * 1e3
    elements = np.asarray(ds.elements_per_link.values)
    steps = np.asarray(ds.steps_per_revolution.values)
    fig, axes = plt.subplots(1, len(QUANTITIES), figsize=(5.0 * len(QUANTITIES), 4.4),
                             constrained_layout=True)
    for ax, (var, ref, title, unit, scale) in zip(axes, QUANTITIES):
        error = np.abs(np.asarray(ds[var].values, float)) if var in ds else np.full(
            ds.sizes["setting"], np.nan)
        usable = _usable(time_ms, error)
        for g, (label, members) in enumerate(groups.items()):
            colour, marker = f"C{g % 10}", _MARKERS[g % len(_MARKERS)]
            shown = members[usable[members]]
            ax.scatter(time_ms[shown], error[shown], s=22, color=colour, marker=marker,
                       label=label, zorder=3, gid=f"setting:{label}")
            for n_el in np.unique(elements[shown]):
                line = shown[elements[shown] == n_el]
                line = line[np.argsort(steps[line], kind="stable")]
                if line.size > 1:
                    ax.plot(time_ms[line], error[line], color=colour, lw=0.7, alpha=0.6,
                            zorder=2, gid="refinement")
        # Below the reference's uncertainty errors are not resolved: the front does not go
        # there (it stops at the band, which says "no better known").
        front = pareto_front(time_ms, np.maximum(error, np.nan_to_num(_uncertainty(ds, ref))))
        if front.size:
            floor = np.nan_to_num(_uncertainty(ds, ref))
            ax.step(time_ms[front], np.maximum(error[front], floor), where="post", color="k",
                    lw=1.2, zorder=4, label="Pareto front", gid="pareto")
        hidden = int((~usable).sum())
        if hidden:
            ax.plot([], [], " ", label=f"{hidden} setting(s) with zero/NaN error not shown")
        if var == "error_peak_stress" and "tolerance" in ds.dims:
            _auto_markers(ax, ds, time_ms, error)
        if usable.any():
            ax.set_xscale("log")
            ax.set_yscale("log")
        else:
            ax.text(0.5, 0.5, "no drawable settings", ha="center", va="center",
                    transform=ax.transAxes)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlim(1e-1, 1e3)
            ax.set_ylim(1e-5, 1.0)
        _uncertainty_band(ax, ds, ref)
        plain_ticks(ax.xaxis)  # a time range under a decade labelled every minor tick, crowded
        ax.set_xlabel("solve time per case [ms]")
        ax.set_ylabel(f"relative error of {title}")
        ax.set_title(f"{title} — {_reference_text(ds, ref, unit, scale)}", fontsize=9)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
        ax.legend(fontsize=6, loc="best")
    fig.suptitle(f"What accuracy costs in time: {family} — error against the converged "
                 "(Richardson-extrapolated) reference", fontsize=10)
    return fig


def _auto_markers(ax, ds: xr.Dataset, time_ms: np.ndarray, error: np.ndarray) -> None:
    """Stars (automatic discretization), tolerance ticks and rings (cheapest sweep setting)."""
    tolerances = np.asarray(ds.tolerance.values, float)
    auto_t = np.asarray(ds.auto_solve_time.values, float) * 1e3 if "auto_solve_time" in ds \
        else np.full(tolerances.shape, np.nan)
    auto_e = np.abs(np.asarray(ds.auto_error.values, float)) if "auto_error" in ds \
        else np.full(tolerances.shape, np.nan)
    ok = _usable(auto_t, auto_e)
    uncertainty = _uncertainty(ds, "reference_peak_stress")
    if uncertainty >= 1e-2:  # as the accuracy table: its true error is not known
        ok[:] = False
        ax.plot([], [], " ", label=f"auto: true error unknown (reference ± "
                                   f"{100 * uncertainty:.2g} %)")
    ax.scatter(auto_t[ok], auto_e[ok], marker="*", s=140, color="gold", edgecolor="k",
               linewidth=0.6, zorder=6, label="auto discretization (tolerance →)", gid="auto")
    tick = _usable(auto_t, tolerances)
    ax.scatter(auto_t[tick], tolerances[tick], marker="_", s=220, color="k", linewidth=1.5,
               zorder=6, label="tolerance asked for", gid="tolerance")
    labels: dict[tuple[float, float], list[str]] = {}
    for t, e, tol in zip(auto_t[ok], auto_e[ok], tolerances[ok]):  # one label a star drawn
        labels.setdefault((float(t), float(e)), []).append(f"{100 * tol:g} %")
    for (t, e), text in labels.items():
        ax.annotate(", ".join(text), (t, e), textcoords="offset points", xytext=(6, -3),
                    fontsize=6)
    if "cheapest_solve_time" not in ds:
        return
    xs, ys = [], []
    for t, name in zip(np.asarray(ds.cheapest_solve_time.values, float),
                       _cheapest_names(ds)):
        i = _find_setting(ds, name, t)
        if i is not None and _usable(time_ms[i:i + 1], error[i:i + 1])[0]:
            xs.append(time_ms[i])
            ys.append(error[i])
    ax.scatter(xs, ys, s=110, facecolor="none", edgecolor="C3", linewidth=1.2, zorder=5,
               label="cheapest setting meeting a tolerance", gid="cheapest")


def _cheapest_names(ds: xr.Dataset) -> list[str]:
    n = ds.sizes["tolerance"]
    return [str(v) for v in ds.cheapest_label.values] if "cheapest_label" in ds else [""] * n


def _find_setting(ds: xr.Dataset, name: str, solve_time: float) -> int | None:
    """The setting a ``cheapest_label`` names (``label`` alone, or ``"<label>, <n> el, <m>
    steps"``), else the one whose solve time is ``solve_time``; None if NaN or not found."""
    if not np.isfinite(solve_time):
        return None  # no sweep setting meets this tolerance
    labels = [str(v) for v in ds.label.values] if "label" in ds.coords else []
    for i, label in enumerate(labels):
        full = (f"{label}, {int(ds.elements_per_link.values[i])} el, "
                f"{int(ds.steps_per_revolution.values[i])} steps")
        if name in (label, full) and (name == full or labels.count(label) == 1):
            return i
    times = np.asarray(ds.solve_time.values, float)
    match = np.flatnonzero(np.isclose(times, solve_time, rtol=1e-9, atol=0.0))
    return int(match[0]) if match.size else None


def _uncertainty(ds: xr.Dataset, ref: str) -> float:
    """Relative uncertainty of a reference value (NaN if not stated)."""
    return float(ds[ref].attrs.get("uncertainty", np.nan)) if ref in ds else np.nan


def _uncertainty_band(ax, ds: xr.Dataset, ref: str) -> None:
    """Shade from the bottom of the axis up to the reference's relative uncertainty."""
    unc = _uncertainty(ds, ref)
    if not (np.isfinite(unc) and unc > 0):
        return
    low, high = ax.get_ylim()
    bottom = min(low, unc / 3.0)
    ax.axhspan(bottom, unc, color="0.5", alpha=0.2, lw=0, zorder=1,
               label=f"reference uncertainty {100 * unc:.2g} %", gid="uncertainty")
    ax.set_ylim(bottom, max(high, unc * 3.0))


def estimate_figure(datasets: dict[str, xr.Dataset]) -> plt.Figure:
    """True relative error of peak stress against ced's own estimate, every setting of every
    family (dots, one colour a family) and the automatic discretization (stars).

    The shaded band is [estimate/10, estimate]: an estimate that is safe (not below the true
    error) and not more than ten times pessimistic. Above the diagonal the estimate is
    optimistic. The title gives the number of points inside the band and at or below the
    diagonal (true ≤ estimate), counted as
    :func:`ced.study.convergence.estimate_validation` does: settings whose true error is below
    ``UNRESOLVED`` times the reference's uncertainty, or whose reference is uncertain by more
    than 1 % (not resolved), are drawn hollow and not counted.

    Parameters
    ----------
    datasets : dict of str to xarray.Dataset
        Family -> its :func:`ced.study.convergence.run_family` result.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = plt.subplots(figsize=(5.6, 5.0), constrained_layout=True)
    inside = total = bounded = 0
    xs_all = []
    for k, (family, ds) in enumerate(datasets.items()):
        est = np.abs(np.asarray(ds.error_estimate.values, float))
        true = np.abs(np.asarray(ds.error_peak_stress.values, float))
        uncertainty = _uncertainty(ds, "reference_peak_stress")
        floor = UNRESOLVED * uncertainty if not uncertainty >= 1e-2 else np.inf
        ok = _usable(est, true)
        resolved = ok & ~(true <= floor)  # NaN floor: every point resolved
        ax.scatter(est[resolved], true[resolved], s=14, color=f"C{k % 10}", label=family,
                   zorder=3, gid=f"estimate:{family}")
        ax.scatter(est[ok & ~resolved], true[ok & ~resolved], s=14, facecolor="none",
                   edgecolor=f"C{k % 10}", zorder=3, gid=f"unresolved:{family}")
        inside += int(((true[resolved] <= est[resolved])
                       & (true[resolved] >= est[resolved] / 10.0)).sum())
        bounded += int((true[resolved] <= est[resolved]).sum())
        total += int(resolved.sum())
        xs_all.append(est[ok])
        if "auto_error_estimate" in ds and "auto_error" in ds:
            a_est = np.abs(np.asarray(ds.auto_error_estimate.values, float))
            a_true = np.abs(np.asarray(ds.auto_error.values, float))
            a_ok = _usable(a_est, a_true)
            ax.scatter(a_est[a_ok], a_true[a_ok], marker="*", s=90, color=f"C{k % 10}",
                       edgecolor="k", linewidth=0.5, zorder=4, gid=f"auto:{family}")
    xs = np.concatenate(xs_all) if xs_all else np.array([])
    low = float(xs.min()) / 30.0 if xs.size else 1e-6
    high = float(xs.max()) * 3.0 if xs.size else 1.0
    grid = np.geomspace(low, high, 50)
    ax.fill_between(grid, grid / 10.0, grid, color="C2", alpha=0.15, lw=0,
                    label="estimate/10 ≤ true ≤ estimate")
    ax.plot(grid, grid, color="k", lw=0.8)
    ax.plot(grid, grid / 10.0, color="k", lw=0.5, ls="--")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(low, high)
    ax.set_xlabel("estimated relative error of peak stress (ced)")
    ax.set_ylabel("true relative error of peak stress (vs reference)")
    share = (f"{inside} of {total} in band, {bounded} with true ≤ estimate" if total
             else "no settings")
    ax.set_title(f"Error estimate against true error — {share}\n(stars: auto; hollow: true "
                 f"error below {UNRESOLVED:g}× the reference uncertainty, or a reference "
                 "uncertain by > 1 %: not counted)", fontsize=9)
    ax.grid(True, which="both", lw=0.3, alpha=0.5)
    ax.legend(fontsize=7, loc="upper left")
    return fig


# ------------------------------------------------------------------------------ summary table
def _cell(value) -> str:
    if isinstance(value, (float, np.floating)):
        return "—" if not np.isfinite(value) else f"{value:.4g}"
    return str(value)


def _table_markdown(table) -> str:
    frame = table.reset_index() if any(n is not None for n in table.index.names) else table
    columns = [str(c) for c in frame.columns]
    out = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    out += ["| " + " | ".join(_cell(v) for v in row) + " |"
            for row in frame.itertuples(index=False)]
    return "\n".join(out)


def _validation_line(validation: dict) -> str:
    """One sentence on :func:`ced.study.convergence.estimate_validation`'s result."""
    if {"within", "min_ratio", "settings"} <= set(validation):
        within, ratio = float(validation["within"]), float(validation["min_ratio"])
        share = f"{100 * within:.0f} %" if np.isfinite(within) else "—"
        bound = float(validation.get("upper_bound", np.nan))
        upper = (f"the true error is at most the estimate for {100 * bound:.1f} % and "
                 if np.isfinite(bound) else "")
        return (f"Error estimate: of the {int(validation['settings'])} settings whose true "
                f"error of peak stress is resolved (above {UNRESOLVED:g}× the reference's "
                f"uncertainty, itself below 1 %), {upper}estimate/10 ≤ true error ≤ "
                f"estimate for {share}; the smallest "
                f"estimate/true ratio is {_cell(ratio)} (below 1: an optimistic estimate).")
    parts = [f"{key} = {_cell(value)}" for key, value in validation.items()]
    return ("Error estimate validation (true error of peak stress within [estimate/10, "
            "estimate]): " + "; ".join(parts) + ".")


def _percent_targets(table):
    """The table with a numeric ``target`` column written as percentages (0.01 → "1 %")."""
    if "target" not in getattr(table, "columns", ()) or table["target"].dtype.kind not in "fi":
        return table
    table = table.copy()
    table["target"] = [f"{100 * float(t):g} %" for t in table["target"]]
    return table


def _auto_lines(datasets: dict[str, xr.Dataset]) -> list[str]:
    """The ``discretization: auto`` section: :func:`ced.study.convergence.auto_table` and a
    count."""
    from .convergence import auto_table

    table = auto_table(datasets)
    if not len(table):
        return []
    met = table[table.resolved]
    compared = table[np.isfinite(table.cost_ratio)]
    lines = ["## `discretization: auto`", "",
             f"Achieved error below the tolerance in {int((met.error < met.tolerance).sum())} "
             f"of {len(met)} cases (families whose reference is known to 1 %); chosen setting "
             f"within 2× of the cheapest sweep setting meeting the tolerance in "
             f"{int((compared.cost_ratio <= 2.0).sum())} of {len(compared)} (solve times "
             "measured side by side).", ""]
    # Where the reference is uncertain by more than 1 % the true error is not known: no
    # number is shown for it (a figure against that reference would read as a true error).
    error = [_cell(e) if ok else "unknown (reference uncertain)"
             for e, ok in zip(table.error, table.resolved)]
    shown = table.assign(tolerance=[f"{t:g}" for t in table.tolerance],
                         error=error).drop(columns="resolved")
    return lines + [_table_markdown(shown), ""]


def accuracy_markdown(datasets: dict[str, xr.Dataset], table, validation: dict) -> str:
    """Markdown page of the study: the accuracy table, one line on the error estimate's
    validation and the reference values with their relative uncertainties.

    Parameters
    ----------
    datasets : dict of str to xarray.Dataset
        Family -> its :func:`ced.study.convergence.run_family` result.
    table : pandas.DataFrame
        :func:`ced.study.convergence.accuracy_table` of them.
    validation : dict
        :func:`ced.study.convergence.estimate_validation` of them.

    Returns
    -------
    str
    """
    lines = ["# What accuracy costs in time", "",
             "Cheapest sweep setting that reaches each target relative error on peak stress "
             "(its error against the Richardson-extrapolated reference plus that reference's "
             "own uncertainty below the target), and its solve time per case measured in a "
             "batch.", "", _table_markdown(_percent_targets(table)), ""]
    if validation:
        lines += [_validation_line(validation), ""]
    lines += _auto_lines(datasets)
    lines += ["## References (Richardson-extrapolated)", "",
              "| family | peak stress [MPa] | peak deflection [mm] | first frequency [Hz] |",
              "|---|---|---|---|"]
    for family, ds in datasets.items():
        cells = []
        for _, ref, _, _, scale in QUANTITIES:
            if ref not in ds:
                cells.append("—")
                continue
            unc = float(ds[ref].attrs.get("uncertainty", np.nan))
            text = _cell(float(ds[ref].values) * scale)
            if np.isfinite(unc):
                text += f" ± {100 * unc:.2g} %"
            cells.append(text)
        lines.append(f"| {family} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def write_pareto_figure(path: str | Path, png: str | Path, svg: str | Path) -> None:
    """Rule ``pareto_figure``: one family's convergence file (from
    :func:`ced.study.convergence.run_family`) → its :func:`pareto_figure` as ``png`` and ``svg``.

    Parameters
    ----------
    path : str or Path
        The family's convergence file.
    png, svg : str or Path
        The figure files written.
    """
    with open_dataset(path) as ds:
        ds = ds.load()
    save(pareto_figure(ds), png, svg)


def write_accuracy_summary(paths: list[str], csv: str | Path, markdown: str | Path,
                           estimate: tuple[str, str] | None = None) -> None:
    """Rule ``convergence_summary``: the family files ``paths`` (from
    :func:`ced.study.convergence.run_family`) → :func:`ced.study.convergence.accuracy_table`
    as ``csv`` and, with :func:`ced.study.convergence.estimate_validation` and the references,
    as ``markdown``; :func:`estimate_figure` into ``estimate`` if given. The families' Pareto
    figures are their own rule (:func:`write_pareto_figure`), so that each is drawn as soon as
    its family is done rather than all at the end.

    Parameters
    ----------
    paths : list of str
        The families' convergence files.
    csv, markdown : str or Path
        The table files written.
    estimate : (str, str), optional
        PNG and SVG of the estimate figure.
    """
    from .convergence import accuracy_table, estimate_validation

    datasets = {}
    for path in paths:
        with open_dataset(path) as ds:
            ds = ds.load()
        datasets[Path(path).stem] = ds  # results/<study>/convergence/<family>.nc
    table = accuracy_table(datasets)
    Path(csv).parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(csv, index=any(n is not None for n in table.index.names),
                 float_format="%.6g")
    Path(markdown).write_text(accuracy_markdown(datasets, table, estimate_validation(datasets)))
    if estimate is not None:
        save(estimate_figure(datasets), *estimate)
