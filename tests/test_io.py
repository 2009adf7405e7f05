"""The output dataset contract (DESIGN §5): CF attributes, units, flags, atomic writes."""
import json
import os

import numpy as np
import pytest
import xarray as xr

from ced.problem.status import STATUS_FLAGS, status_code, status_names
from ced.simulation.dataset import VARIABLES
from ced.io import write_dataset
from ced.simulation.simulate import simulate

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
    with xr.open_dataset(path, engine="netcdf4") as ds:
        return ds.load()


@pytest.fixture(scope="module")
def rigid(tmp_path_factory):
    return _written(tmp_path_factory, SCENE)


@pytest.fixture(scope="module")
def elastic(tmp_path_factory):
    return _written(tmp_path_factory, ELASTIC)


def test_global_attributes(rigid):
    attrs = rigid.attrs
    assert attrs["Conventions"] == "CF-1.12"
    for key in ("title", "institution", "source", "history", "references"):
        assert attrs[key]
    assert attrs["source"].startswith("ced ") and "git" in attrs["source"]
    scenes = json.loads(attrs["scenes"])
    assert scenes[0]["mechanism"]["ground"] == 0.254
    assert attrs["effects"] == "inertia gravity"


@pytest.mark.parametrize("name", ["rigid", "elastic"])
def test_every_variable_has_units_and_long_name(name, request):
    ds = request.getfixturevalue(name)
    for var_name, var in {**ds.data_vars, **ds.coords}.items():
        assert var.attrs.get("long_name"), var_name
        if var.dtype.kind == "f":
            assert "units" in var.attrs, var_name
    for var_name in ds.data_vars:
        assert ds[var_name].dims == VARIABLES[var_name][0], var_name


def test_rigid_dataset_has_only_rigid_variables(rigid):
    assert set(rigid.data_vars) == {
        "time", "crank_angle", "joint_position", "link_angle", "link_angular_velocity",
        "link_angular_acceleration", "joint_force", "input_torque", "solve_time", "status",
        "message"}
    assert rigid.sizes["case"] == 1
    assert list(rigid.joint.values) == ["A", "B", "C", "D"]
    assert list(rigid.link.values) == ["crank", "coupler", "rocker"]
    assert str(rigid.family.values[0]) == "crank_rocker"


def test_elastic_dataset_variables_and_coordinates(elastic):
    for name in ("deflection", "stress", "natural_frequency", "peak_stress",
                 "dynamic_amplification", "floquet_multiplier_max"):
        assert name in elastic
    assert elastic.station.values[5] == 0.5
    assert np.allclose(elastic.modal_angle.values, 2 * np.pi * np.arange(6) / 6)
    assert list(elastic.mode.values) == [1, 2, 3]
    assert elastic.natural_frequency.attrs["units"] == "Hz"


def test_status_flags_are_cf(rigid):
    attrs = rigid.status.attrs
    meanings = attrs["flag_meanings"].split()
    assert meanings[0] == "ok" and set(meanings[1:]) == set(STATUS_FLAGS)
    assert len(attrs["flag_masks"]) == len(attrs["flag_values"]) == len(meanings)
    assert status_names(0) == ["ok"]
    code = status_code(["resonant", "near_singular"])
    assert status_names(code) == ["near_singular", "resonant"]


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


def test_effects_auto_is_resolved_and_recorded():
    scene = {**ELASTIC, "effects": "auto", "time": {**ELASTIC["time"], "start": "undeformed"}}
    ds = simulate(scene)
    report = json.loads(str(ds.effects_auto.values[0]))
    chosen = json.loads(ds.attrs["scenes"])[0]["effects"]
    assert isinstance(chosen, list) and "inertia" in chosen
    for effect, entry in report.items():
        assert entry["included"] == (effect in chosen)
        assert np.isfinite(entry["estimate"]) and entry["reason"]
    assert ds.attrs["effects"].split() == chosen


def test_written_file_is_readable_by_others_per_umask(tmp_path, rigid):
    old = os.umask(0o022)
    try:
        path = write_dataset(rigid, tmp_path / "perm.nc")
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == 0o644
