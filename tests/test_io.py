"""netCDF files (ced.io): atomic writes, permissions, a dataset read back as written."""
import os

import pytest
import xarray as xr

from ced.io import write_dataset
from ced.simulation.simulate import simulate
from ced.io import open_dataset

SCENE = "config/scenes/sung_thompson_rigid.yaml"
ELASTIC = {
    "mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                  "rocker": 0.35},
    "links": {"crank": {"flexible": False}, "rocker": {"flexible": False}},
    "discretization": {"elements_per_link": 4},
    "time": {"revolutions": 1, "steps_per_revolution": 64, "start": "periodic"},
    "modal": {"modes": 3, "angles": 6},
}


def _written(tmp_path_factory, scene):
    """The dataset of ``scene`` after a write and a read back."""
    path = tmp_path_factory.mktemp("io") / "out.nc"
    write_dataset(simulate(scene), path)
    with open_dataset(path) as ds:
        return ds.load()


@pytest.fixture(scope="module")
def rigid(tmp_path_factory):
    return _written(tmp_path_factory, SCENE)


@pytest.fixture(scope="module")
def elastic(tmp_path_factory):
    return _written(tmp_path_factory, ELASTIC)


def test_write_is_atomic_and_leaves_no_temporary(tmp_path, rigid, monkeypatch):
    path = tmp_path / "out.nc"
    write_dataset(rigid, path)
    before = path.read_bytes()

    def boom(*args, **kwargs):
        raise RuntimeError("disk full")
    monkeypatch.setattr(xr.Dataset, "to_netcdf", boom)
    with pytest.raises(RuntimeError):
        write_dataset(rigid, path)
    assert path.read_bytes() == before  # the old file is intact
    assert os.listdir(tmp_path) == ["out.nc"]  # and no temporary is left behind


def test_written_file_is_readable_by_others_per_umask(tmp_path, rigid):
    old = os.umask(0o022)
    try:
        path = write_dataset(rigid, tmp_path / "perm.nc")
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == 0o644
