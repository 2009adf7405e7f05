"""Figures and summary of the convergence study (ced.study.convergence_figures) on synthetic datasets
with the schema of ced.study.convergence.run_family: they render, have the expected panels and
markers on log axes, and survive NaN (no setting meeting a tolerance, unresolved errors)."""
import json

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
import xarray as xr

from ced.study.convergence_figures import (QUANTITIES, accuracy_markdown, estimate_figure,
                                           group_label, pareto_figure, pareto_front,
                                           write_accuracy_summary, write_pareto_figure)
from ced.study.convergence import UNRESOLVED

GROUPS = [("euler_bernoulli", 0, "newmark"), ("euler_bernoulli", 4, "generalized_alpha"),
          ("timoshenko", 0, "generalized_alpha")]
ELEMENTS = (2, 4, 8)
STEPS = (32, 64, 128)
TOLERANCES = (1e-2, 1e-3, 1e-4)


def synthetic(family: str = "crank_rocker", seed: int = 0, no_cheapest: bool = False,
              zero_error: bool = False) -> xr.Dataset:
    """A dataset shaped like ced.study.convergence.run_family's: errors ~ h² + dt², time ~ n·steps."""
    rng = np.random.default_rng(seed)
    rows = [(f, m, i, e, s) for f, m, i in GROUPS for e in ELEMENTS for s in STEPS]
    formulation, modes, integrator, elements, steps = (np.array(c) for c in zip(*rows))
    err = 0.05 / elements**2 + 20.0 / steps**2  # reaches 1e-2 but not 1e-3
    err = err * rng.uniform(0.8, 1.2, err.size)
    time = 1e-4 * elements * steps * (1 + modes) * rng.uniform(0.9, 1.1, err.size)
    labels = [group_label(f, m, i) for f, m, i, e, s in rows]  # the group, as run_family's
    full = [f"{label}, {e} el, {s} steps" for label, (*_, e, s) in zip(labels, rows)]
    if zero_error:
        err[0] = 0.0
        err[1] = np.nan
    cheapest_time = np.array([time[err < t].min() if (err < t).any() else np.nan
                              for t in TOLERANCES])
    cheapest_label = [full[int(np.flatnonzero(time == t)[0])] if np.isfinite(t) else ""
                      for t in cheapest_time]
    if no_cheapest:
        cheapest_time[:] = np.nan
        cheapest_label = ["", "", ""]
    ds = xr.Dataset(
        {
            "peak_stress": ("setting", 1e8 * (1 + err)),
            "peak_deflection": ("setting", 1e-3 * (1 + err)),
            "first_frequency": ("setting", 50.0 * (1 - err / 3)),
            "error_peak_stress": ("setting", err),
            "error_peak_deflection": ("setting", 1.3 * err),
            "error_first_frequency": ("setting", err / 3),
            "error_estimate": ("setting", 3 * err),
            "solve_time": ("setting", time),
            "auto_elements_per_link": ("tolerance", np.array([2, 4, 8])),
            "auto_steps_per_revolution": ("tolerance", np.array([64, 128, 256])),
            "auto_error": ("tolerance", np.array([4e-3, 6e-4, np.nan])),
            "auto_error_estimate": ("tolerance", np.array([9e-3, 9e-4, 9e-5])),
            "auto_solve_time": ("tolerance", np.array([0.01, 0.04, 0.2])),
            "cheapest_solve_time": ("tolerance", cheapest_time),
            "cheapest_label": ("tolerance", np.array(cheapest_label, dtype=object)),
            "reference_peak_stress": ((), 1e8, {"uncertainty": 2e-4}),
            "reference_peak_deflection": ((), 1e-3, {"uncertainty": 3e-4}),
            "reference_first_frequency": ((), 50.0, {"uncertainty": 1e-5}),
        },
        coords={
            "setting": np.arange(len(rows)),
            "label": ("setting", np.array(labels, dtype=object)),
            "formulation": ("setting", formulation.astype(object)),
            "modes_per_link": ("setting", modes.astype(int)),
            "elements_per_link": ("setting", elements.astype(int)),
            "steps_per_revolution": ("setting", steps.astype(int)),
            "integrator": ("setting", integrator.astype(object)),
            "tolerance": np.array(TOLERANCES),
        },
        attrs={"family": family, "scene": json.dumps({"family": family})},
    )
    return ds


def by_gid(ax, prefix: str) -> list:
    return [a for a in ax.get_children() if (a.get_gid() or "").startswith(prefix)]


def n_points(artists) -> int:
    return sum(len(a.get_offsets()) for a in artists)


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def test_pareto_front():
    time = np.array([5.0, 1.0, 2.0, 3.0, np.nan, 4.0])
    error = np.array([1e-4, 1e-1, 1e-1, 1e-2, 1e-9, 0.0])
    assert pareto_front(time, error).tolist() == [1, 3, 0]  # NaN time and zero error left out


def test_pareto_figure_panels_markers_log_axes():
    ds = synthetic()
    fig = pareto_figure(ds)
    axes = fig.axes
    assert len(axes) == len(QUANTITIES) == 3
    n = ds.sizes["setting"]
    for ax, (var, ref, title, *_) in zip(axes, QUANTITIES):
        assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
        assert title in ax.get_title() and "ref." in ax.get_title()
        groups = by_gid(ax, "setting:")
        assert len(groups) == len(GROUPS)  # one marker set per (formulation, modes, integrator)
        assert n_points(groups) == n
        assert len({a.get_facecolor()[0].tobytes() for a in groups}) == len(GROUPS)
        # one line per (group, elements per link), each through the steps of that mesh
        lines = by_gid(ax, "refinement")
        assert len(lines) == len(GROUPS) * len(ELEMENTS)
        assert all(len(line.get_xdata()) == len(STEPS) for line in lines)
        front = by_gid(ax, "pareto")
        assert len(front) == 1
        x, y = front[0].get_xdata(), front[0].get_ydata()
        assert np.all(np.diff(x) > 0) and np.all(np.diff(y) < 0)
        expected = pareto_front(ds.solve_time.values * 1e3, ds[var].values)
        assert len(x) == len(expected)
        band = by_gid(ax, "uncertainty")  # reference uncertainty: floor band up to it
        assert len(band) == 1
        unc = ds[ref].attrs["uncertainty"]
        assert np.isclose(band[0].get_extents().transformed(ax.transData.inverted()).y1, unc,
                          rtol=1e-6)
        assert ax.get_ylim()[0] < unc
    stress = axes[0]
    finite = np.isfinite(ds.auto_error.values).sum()
    assert n_points(by_gid(stress, "auto")) == finite == 2  # stars where the auto error exists
    assert n_points(by_gid(stress, "tolerance")) == len(TOLERANCES)  # a tick per tolerance
    ticks = by_gid(stress, "tolerance")[0].get_offsets()
    assert np.allclose(np.sort(ticks[:, 1]), np.sort(TOLERANCES))
    assert n_points(by_gid(stress, "cheapest")) == np.isfinite(
        ds.cheapest_solve_time.values).sum() > 0
    for ax in axes[1:]:
        assert not by_gid(ax, "auto")
    assert "crank_rocker" in fig._suptitle.get_text()
    fig.canvas.draw()  # renders


def test_pareto_figure_nan_cheapest_and_unresolved_errors(tmp_path):
    """No sweep setting meets any tolerance (cheapest_solve_time all NaN), one error exactly 0
    and one NaN: the figure renders and leaves those points out, saying so in the legend."""
    ds = synthetic(no_cheapest=True, zero_error=True)
    fig = pareto_figure(ds)
    stress = fig.axes[0]
    assert n_points(by_gid(stress, "cheapest")) == 0
    assert n_points(by_gid(stress, "setting:")) == ds.sizes["setting"] - 2
    legend = [t.get_text() for t in stress.get_legend().get_texts()]
    assert any("2 setting(s)" in t for t in legend)
    fig.savefig(tmp_path / "pareto.png")
    assert (tmp_path / "pareto.png").stat().st_size > 1000


def test_pareto_figure_all_nan_errors():
    ds = synthetic()
    for var, *_ in QUANTITIES:
        ds[var][:] = np.nan
    ds["auto_error"][:] = np.nan
    fig = pareto_figure(ds)
    assert all(ax.get_yscale() == "log" for ax in fig.axes)
    fig.canvas.draw()


def test_estimate_figure():
    datasets = {f: synthetic(f, seed=k) for k, f in enumerate(("crank_rocker", "slider_crank"))}
    fig = estimate_figure(datasets)
    (ax,) = fig.axes
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    total = 0
    for family, ds in datasets.items():
        floor = UNRESOLVED * ds.reference_peak_stress.attrs["uncertainty"]
        resolved = int((ds.error_peak_stress > floor).sum())
        assert n_points(by_gid(ax, f"estimate:{family}")) == resolved
        assert n_points(by_gid(ax, f"unresolved:{family}")) == ds.sizes["setting"] - resolved
        assert n_points(by_gid(ax, f"auto:{family}")) == 2
        total += resolved
    # synthetic estimates are 3x the true error: all resolved ones inside [estimate/10, estimate]
    assert f"{total} of {total} in band, {total} with true ≤ estimate" in ax.get_title()
    fig.canvas.draw()


def test_accuracy_markdown_references_and_validation():
    datasets = {"crank_rocker": synthetic()}
    table = pd.DataFrame({"family": ["crank_rocker"] * 3, "target": ["10 %", "1 %", "0.1 %"],
                          "setting": ["a", "b", "c"], "ms_per_case": [0.1, 1.0, np.nan]})
    text = accuracy_markdown(datasets, table, {"upper_bound": 0.95, "within": 0.9,
                                               "min_ratio": 1.5, "settings": 20})
    assert text.startswith("# What accuracy costs in time")
    assert "| crank_rocker | 0.1 % | c | — |" in text
    assert "of the 20 settings" in text and "ratio is 1.5" in text
    assert "at most the estimate for 95.0 %" in text and "estimate for 90 %" in text
    numeric = table.assign(target=[0.1, 0.01, 0.001])  # ced.study.convergence.accuracy_table's
    assert "| crank_rocker | 0.1 % | c | — |" in accuracy_markdown(datasets, numeric, {})
    assert "| crank_rocker | 100 ± 0.02 % | 1 ± 0.03 % | 50 ± 0.001 % |" in text


def test_write_accuracy_summary(tmp_path):
    """The rules' entry points: CSV and markdown (ced.study.convergence.accuracy_table and
    estimate_validation) and the estimate figure; each family's Pareto figure on its own, from
    family files written by ced.io."""
    from ced.io import write_dataset

    paths, figures = [], {}
    for k, family in enumerate(("crank_rocker", "slider_crank")):
        paths.append(str(write_dataset(synthetic(family, seed=k),
                                       tmp_path / "convergence" / f"{family}.nc")))
        figures[family] = (str(tmp_path / f"{family}.png"), str(tmp_path / f"{family}.svg"))
        write_pareto_figure(paths[-1], *figures[family])
    estimate = (str(tmp_path / "estimate.png"), str(tmp_path / "estimate.svg"))
    write_accuracy_summary(paths, tmp_path / "t" / "accuracy.csv", tmp_path / "t" / "accuracy.md",
                           estimate)
    csv = pd.read_csv(tmp_path / "t" / "accuracy.csv")
    assert sorted(set(csv.family)) == ["crank_rocker", "slider_crank"]
    assert len(csv) == 2 * 3  # a row per (family, target 10 %, 1 %, 0.1 %)
    md = (tmp_path / "t" / "accuracy.md").read_text()
    assert "| slider_crank | 0.1 % | none in the sweep |" in md  # synthetic errors stop ~2e-3
    # estimates are 3x the true error: every one an upper bound, inside the band
    assert "at most the estimate for 100.0 % and" in md and "estimate for 100 %;" in md
    assert "## References" in md and "± 0.02 %" in md
    for png, svg in [*figures.values(), estimate]:
        assert (tmp_path / png).stat().st_size > 1000 and (tmp_path / svg).stat().st_size > 1000


def test_an_uncertain_reference_claims_no_error_it_cannot_see():
    """A family whose reference is uncertain by 9 % (the change point's, whose peak still
    moves with the step): the accuracy table verifies only 10 %, with the uncertainty added
    to each setting's error, and says so for 1 % and 0.1 %; the auto table shows no number
    for its true error."""
    from ced.study.convergence import accuracy_table

    uncertain = synthetic("change_point")
    uncertain["reference_peak_stress"].attrs["uncertainty"] = 0.09
    table = accuracy_table({"change_point": uncertain}).set_index("target")
    errors = uncertain.error_peak_stress.values
    meeting = errors + 0.09 < 0.1
    assert 0 < meeting.sum() < (errors < 0.1).sum()  # the uncertainty changed the choice
    best = int(np.flatnonzero(meeting)[np.argmin(uncertain.solve_time.values[meeting])])
    assert table.loc[0.1, "ms_per_case"] == pytest.approx(1e3 * uncertain.solve_time.values[best])
    for target in (0.01, 0.001):
        assert table.loc[target, "setting"] == "not verifiable: reference uncertain by 9 %"
        assert np.isnan(table.loc[target, "error"])
    text = accuracy_markdown({"change_point": uncertain, "crank_rocker": synthetic()},
                             accuracy_table({"change_point": uncertain}), {})
    auto = text[text.index("## `discretization: auto`"):text.index("## References")]
    rows = [line for line in auto.splitlines() if line.startswith("| change_point")]
    assert len(rows) == 3 and all("unknown (reference uncertain)" in r for r in rows)
    known = [line for line in auto.splitlines() if line.startswith("| crank_rocker | 0.01 |")]
    assert "| 0.004 |" in known[0]  # a family known to 1 % keeps its true error


def test_pareto_figure_claims_nothing_below_the_reference_uncertainty():
    """With the reference uncertain by 9 % (the change point's): the front stops at the band
    (nothing is known to be better), no auto star is drawn at an error that reference cannot
    see, and the legend says why; stars at the same point share one label."""
    ds = synthetic("change_point")
    ds["reference_peak_stress"].attrs["uncertainty"] = 0.09
    stress = pareto_figure(ds).axes[0]
    front = by_gid(stress, "pareto")[0]
    assert min(front.get_ydata()) == pytest.approx(0.09)
    assert np.all(np.diff(front.get_xdata()) > 0)
    assert n_points(by_gid(stress, "auto")) == 0
    assert any("true error unknown (reference ± 9 %)" in t.get_text()
               for t in stress.get_legend().get_texts())
    assert n_points(by_gid(stress, "tolerance")) == len(TOLERANCES)  # where auto's time is
    known = synthetic()
    known["auto_error"] = ("tolerance", np.array([4e-3, 4e-3, 4e-3]))
    known["auto_solve_time"] = ("tolerance", np.array([0.02, 0.02, 0.02]))
    stress = pareto_figure(known).axes[0]
    assert [t.get_text() for t in stress.texts] == ["1 %, 0.1 %, 0.01 %"]
