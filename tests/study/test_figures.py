"""Figures of a study (docs/guide/first_study.md): each writes a PNG and an SVG from the tiny test study."""
from pathlib import Path

import numpy as np
import pytest
import yaml

from ced.study.figures import campbell_figure, magnification, overview_figure, worst_case_figure
from ced.study.resonance_maps import map_slice, resonance_map
from ced.study.maps import reduce_family
from ced.study.safe_speed import write_safe_speed_table
from ced.study.cases import chunks
from ced.study.chunk_job import run_chunk
from ced.io import open_dataset
from ced.problem.errors import SceneError
from ced.problem.status import STATUS_FLAGS

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    """Test study, crank_rocker (two chunks) and slider_crank, simulated and reduced."""
    config = yaml.safe_load((ROOT / "config" / "studies" / "test.yaml").read_text())
    directory = tmp_path_factory.mktemp("plots")
    out = {}
    for family in ("crank_rocker", "slider_crank"):
        paths = [str(run_chunk(config, family, i, directory / f"{family}_{i}.nc"))
                 for i in range(chunks(config)[family])]
        reduce_family(paths, directory / f"{family}.nc", directory / f"{family}_grid.nc", 2.0)
        out[family] = (directory / f"{family}.nc", directory / f"{family}_grid.nc", paths)
    return directory, out


def written(png: Path) -> bool:
    svg = png.with_suffix(".svg")
    return (png.stat().st_size > 1000 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
            and svg.stat().st_size > 1000 and b"<svg" in svg.read_bytes()[:1000])


@pytest.mark.parametrize("family", ["crank_rocker", "slider_crank"])
def test_resonance_map_has_a_panel_per_material(maps, family):
    directory, out = maps
    png = directory / "resonance" / f"{family}.png"
    resonance_map(out[family][1], png)
    assert written(png)
    text = png.with_suffix(".svg").read_text()
    for material in ("steel", "aluminium"):  # both halves of the study
        assert material in text
    assert "rpm" in text
    # the harmonic speeds beyond the grid are named, not silently absent
    assert "above the speed range" in text or "k=" in text


def test_map_slice_picks_the_varied_length(maps):
    _, out = maps
    with open_dataset(out["crank_rocker"][1]) as grid:
        grid = grid.load()
    sl, y, fixed = map_slice(grid)
    # crank_rocker of the test study: crank 0.05, coupler 0.2, rocker 0.15 / 0.2
    assert y == "rocker" and fixed["material"] == "aluminium"
    assert fixed["crank"] == 0.05 and fixed["coupler"] == 0.2
    assert set(sl.dims) >= {"rocker", "speed"} and "crank" not in sl.dims
    # the config's slice: y and fixed values; a value off the grid is refused by name
    sl, y, fixed = map_slice(grid, "steel", 0, y="coupler", fixed={"rocker": 0.15})
    assert y == "coupler" and fixed["rocker"] == 0.15 and fixed["material"] == "steel"
    with pytest.raises(SceneError, match="resonance_map.fixed.rocker") as err:
        map_slice(grid, fixed={"rocker": 0.17})
    assert "0.15, 0.2" in err.value.message


def test_one_dimensional_sweep_is_drawn_as_lines(maps):
    directory, out = maps
    # slider_crank of the test study: one geometry, two speeds -> a sweep, not a 1-row map
    png = directory / "resonance" / "sweep.png"
    resonance_map(out["slider_crank"][1], png)
    text = png.with_suffix(".svg").read_text()
    assert "peak stress (dot: a case)" in text


def test_harmonic_speeds():
    from ced.study.resonance_maps import harmonic_speeds
    omega = harmonic_speeds(np.array([10.0, -1.0]))
    assert omega[0, 0] == pytest.approx(2 * np.pi * 10) and np.isnan(omega[:, 1]).all()
    assert omega[4, 0] == pytest.approx(2 * np.pi * 10 / 5)


@pytest.mark.parametrize("family", ["crank_rocker", "slider_crank"])
def test_worst_case_figure(maps, family):
    directory, out = maps
    summary, _, paths = out[family]
    png = directory / "worst" / f"{family}.png"
    worst_case_figure(summary, paths, png)
    assert written(png)
    text = png.with_suffix(".svg").read_text()
    assert "deflection ×" in text and "worst" in text


def test_worst_cases_are_the_largest_credible_and_flagged(maps):
    # credible: no flag of NOT_CREDIBLE and an error estimate within the tolerance
    from ced.study.figures import worst_cases

    _, out = maps
    with open_dataset(out["crank_rocker"][0]) as ds:
        ds = ds.load()
    stress = ds.peak_stress.max("link").values
    ds["error_estimate"][:] = 0.01
    ds["status"][:] = 0
    top = int(np.argmax(stress))
    assert worst_cases(ds) == {"credible": int(ds.case[top])}
    ds["status"][top] = STATUS_FLAGS["large_deflection"]
    second = int(np.argsort(stress)[-2])
    assert worst_cases(ds) == {"credible": int(ds.case[second]), "flagged": int(ds.case[top])}
    ds["error_estimate"][second] = 0.2  # above the tolerance: flagged too
    third = int(np.argsort(stress)[-3])
    assert worst_cases(ds, 0.05) == {"credible": int(ds.case[third]),
                                     "flagged": int(ds.case[top])}
    assert worst_cases(ds, 0.5)["credible"] == int(ds.case[second])


def test_worst_case_title_peak_is_the_drawn_curve_peak(maps):
    directory, out = maps
    summary, _, paths = out["crank_rocker"]
    png = directory / "worst" / "peaks.png"
    worst_case_figure(summary, paths, png, error_tolerance=1.0)  # every unflagged case
    text = png.with_suffix(".svg").read_text()
    from ced.study.figures import worst_cases
    with open_dataset(summary) as s:
        case = worst_cases(s.load(), 1.0)["credible"]
    for path in paths:
        with open_dataset(path) as chunk:
            if case in chunk.case.values:
                drawn = float(abs(chunk.stress.sel(case=case)).max()) / 1e6
    assert f"peak of the curve {drawn:.4g} MPa" in text
    assert "x [m]" in text and "y [m]" in text


def test_magnification_is_round():
    assert magnification(1e-3, 0.5) == 50.0
    assert magnification(1e-4, 0.3) == 200.0
    assert magnification(10.0, 0.5) == 0.005   # a diverged response is drawn reduced
    assert magnification(0.0, 0.5) == 1.0


def test_other_figures_and_table(maps):
    directory, out = maps
    families = [str(out[f][0]) for f in out]
    overview_figure(families, directory / "overview.png")
    assert written(directory / "overview.png")
    campbell_figure(out["crank_rocker"][0], directory / "campbell.png")
    assert written(directory / "campbell.png")
    write_safe_speed_table(families, directory / "safe.csv", directory / "safe.md", 2.0)
    lines = (directory / "safe.csv").read_text().splitlines()
    assert len(lines) == 1 + 2 * 2 + 1 * 2  # (2 crank_rocker + 1 slider) geometries x 2 materials


def test_estimate_figure_counts_the_unflagged_cases(maps):
    from ced.study.figures import estimate_figure
    directory, out = maps
    paths = [str(out[f][0]) for f in ("crank_rocker", "slider_crank")]
    png = directory / "estimate.png"
    estimate_figure(paths, png, png.with_suffix(".svg"))
    assert written(png)
    unflagged = 0
    for p in paths:
        with open_dataset(p) as ds:
            ok = ds.status.values == 0
            unflagged += int(np.isfinite(ds.error_estimate.values[ok]).sum())
    assert f"the {unflagged} unflagged cases" in png.with_suffix(".svg").read_text()
    assert "neighbours in speed" not in png.with_suffix(".svg").read_text()  # all own here


def test_estimate_figure_says_how_many_estimates_came_from_neighbours(maps, tmp_path):
    """A start transient's speed sweep shares its companions (ced.auto.sweep_estimate): the
    figure where the study's accuracy is judged says how many unflagged estimates are shared."""
    from ced.simulation.dataset import ESTIMATE_SOURCES
    from ced.study.figures import estimate_figure
    _, out = maps
    with open_dataset(out["crank_rocker"][0]) as ds:
        ds = ds.load()
    assert (ds.error_estimate_source.values == ESTIMATE_SOURCES["companions"]).all()
    ok = np.flatnonzero((ds.status.values == 0) & np.isfinite(ds.error_estimate.values))
    source = ds.error_estimate_source.values.copy()
    source[ok[::2]] = ESTIMATE_SOURCES["sweep_neighbours"]
    source[ds.status.values != 0] = ESTIMATE_SOURCES["sweep_neighbours"]  # flagged: not counted
    ds["error_estimate_source"] = ds.error_estimate_source.copy(data=source)
    path = tmp_path / "shared.nc"
    ds.to_netcdf(path)
    png = tmp_path / "estimate.png"
    estimate_figure([str(path)], png, png.with_suffix(".svg"))
    assert f"{len(ok[::2])} of them from the case's neighbours in speed" in (
        png.with_suffix(".svg").read_text())


def test_blown_up_flagged_cases_are_counted_above_the_axis():
    """The overview's log axes end at 100× the unflagged cases' largest value, or, in a family
    whose every case is flagged (the change points), at 100× the flagged cases' median: the
    1e13 MPa of a case on the change point itself is counted above, not drawn."""
    import matplotlib.pyplot as plt

    from ced.study.figures import _clip_flagged

    values = np.array([3.0, 10.0, 20.0, 8.0, 5e12, 1e13, 2e13])
    # unflagged 3, 10, 8: top 100 × 10; all flagged: 100 × their median, 20
    for ok, top in ((values < 15.0, 1e3), (np.zeros(7, bool), 2e3)):
        fig, ax = plt.subplots()
        ax.scatter(np.arange(7), values)
        ax.set_yscale("log")
        _clip_flagged(ax, values, ok, ~ok)
        assert ax.get_ylim()[1] == pytest.approx(top)
        assert [t.get_text() for t in ax.texts] == ["▲ 3 flagged above"]
        plt.close(fig)


def test_resonance_map_colours_are_not_squeezed_by_a_blown_up_case():
    """The colour scale ends at 100x the largest case not flagged resonant or unstable (every
    case flagged: their median), with an arrow for the cells above; without a blown-up case it
    spans the values."""
    import xarray as xr

    from ced.study.resonance_maps import _colour_norm

    stress = np.array([[1e6, 1e7, 5e7], [2e7, 3e7, 1e20]])  # Pa; one case at 1e14 MPa
    resonant = STATUS_FLAGS["resonant"]

    def slice_(status):
        return xr.Dataset({"peak_stress": (("speed", "coupler", "link"), stress[..., None]),
                           "status": (("speed", "coupler"), status),
                           "case": (("speed", "coupler"), np.arange(6.0).reshape(2, 3)),
                           "error_estimate": (("speed", "coupler"), np.full((2, 3), 1e-3))})

    some = np.array([[0, 0, 0], [0, 0, resonant]])
    norm, clipped = _colour_norm([slice_(some)], 0.02)
    assert clipped and norm.vmin == pytest.approx(1.0) and norm.vmax == pytest.approx(5e3)
    norm, clipped = _colour_norm([slice_(np.full((2, 3), resonant))], 0.02)
    assert clipped and norm.vmax == pytest.approx(100 * 25.0)  # median of 1 … 1e14 MPa: 25
    stress[1, 2] = 4e7
    norm, clipped = _colour_norm([slice_(some)], 0.02)
    assert not clipped and norm.vmax == pytest.approx(50.0)
