"""Figures of a study (docs/guide/first_study.md): each writes a PNG and an SVG from the tiny test study."""
from pathlib import Path

import numpy as np
import pytest
import yaml

from ced.study.figures import (campbell_figure, magnification, map_slice, overview_figure,
                               resonance_map, worst_case_figure)
from ced.study.maps import reduce_family
from ced.study.safe_speed import write_safe_speed_table
from ced.study.cases import chunks
from ced.study.chunk_job import run_chunk
from ced.io import open_dataset

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
def test_resonance_map(maps, family):
    directory, out = maps
    png = directory / "resonance" / f"{family}.png"
    resonance_map(out[family][1], png, material="steel")
    assert written(png)


def test_map_slice_picks_the_varied_length(maps):
    _, out = maps
    with open_dataset(out["crank_rocker"][1]) as grid:
        sl, y, fixed = map_slice(grid.load())
    # crank_rocker of the test study: crank 0.05, coupler 0.2, rocker 0.15 / 0.2
    assert y == "rocker" and fixed["material"] == "aluminium"
    assert fixed["crank"] == 0.05 and fixed["coupler"] == 0.2
    assert set(sl.dims) >= {"rocker", "speed"} and "crank" not in sl.dims


@pytest.mark.parametrize("family", ["crank_rocker", "slider_crank"])
def test_worst_case_figure(maps, family):
    directory, out = maps
    summary, _, paths = out[family]
    png = directory / "worst" / f"{family}.png"
    worst_case_figure(summary, paths, png)
    assert written(png)
    text = png.with_suffix(".svg").read_text()
    assert "magnified" in text or "×" in text


def test_worst_case_is_largest_design_case(maps):
    # Failed (16), resonant (4), parametrically unstable (8) and large-deflection (1) cases
    # are not design answers.
    from ced.study.figures import _worst_case

    _, out = maps
    with open_dataset(out["crank_rocker"][0]) as ds:
        ds = ds.load()
    stress = ds.peak_stress.max("link").values.copy()
    stress[(ds.status.values.astype(int) & (1 | 4 | 8 | 16)) != 0] = -np.inf
    top = int(np.argmax(stress))
    assert _worst_case(ds) == int(ds.case[top])
    ds["status"] = ds.status.copy(data=np.where(np.arange(ds.sizes["case"]) == top, 16,
                                                ds.status.values).astype(ds.status.dtype))
    stress[top] = -np.inf
    assert _worst_case(ds) == int(ds.case[int(np.argmax(stress))])


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
