"""A whole study as one lazily loaded dataset (ced.open_study, ced.study.browse)."""
from pathlib import Path

import dask.array
import numpy as np
import pytest
import yaml

import ced
from ced.io import open_dataset
from ced.study.cases import chunks
from ced.study.chunk_job import run_chunk
from ced.study.maps import reduce_family

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """The test study (16 cases, 3 families) laid out as the pipeline writes it."""
    config = yaml.safe_load((ROOT / "config" / "studies" / "test.yaml").read_text())
    root = tmp_path_factory.mktemp("study")
    for family, n in chunks(config).items():
        paths = [run_chunk(config, family, i, root / "chunks" / family / f"{i}.nc")
                 for i in range(n)]
        reduce_family(paths, root / "maps" / f"{family}.nc", None, 2.0)
    return root


def test_every_case_lazily_with_its_family_and_grid_coordinates(study):
    ds = ced.open_study(study)
    assert ds.sizes["case"] == 16
    assert sorted(set(ds.family.values.tolist())) == ["change_point", "crank_rocker",
                                                       "slider_crank"]
    assert isinstance(ds.stress.data, dask.array.Array)         # nothing read yet
    assert isinstance(ds.fatigue_safety_factor.data, dask.array.Array)  # from the maps
    assert ds.link.values.tolist() == ["crank", "coupler", "rocker", "rod"]
    assert ds.joint.values.tolist() == ["A", "B", "C", "D"]
    slider = ds.family == "slider_crank"
    assert np.isnan(ds.ground.values[slider.values]).all()      # not a slider-crank length
    assert (ds.rod.values[slider.values] == 0.2).all()


def test_selection_reads_the_same_values_as_the_files(study):
    ds = ced.open_study(study)
    pick = ds.case[(ds.family == "crank_rocker") & (ds.case_id == 5)].item()
    chosen = ds.sel(case=pick)
    with open_dataset(study / "chunks" / "crank_rocker" / "1.nc") as chunk:
        expect = chunk.stress.sel(case=5, link="coupler").values
    assert np.array_equal(chosen.stress.sel(link="coupler").values, expect)
    with open_dataset(study / "maps" / "crank_rocker.nc") as summary:
        expect = summary.fatigue_safety_factor.sel(case=5).values
    assert np.array_equal(chosen.fatigue_safety_factor.sel(link=["crank", "coupler",
                                                                 "rocker"]).values, expect)
    # a link the family lacks is NaN, not an error
    assert np.isnan(chosen.stress.sel(link="rod").values).all()


def test_no_chunks_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="results directory"):
        ced.open_study(tmp_path)
