"""The output dataset contract (ced.simulation.dataset): CF attributes, units, flags, what is
present."""
import json

import numpy as np
import pytest

from ced.problem.status import STATUS_FLAGS, status_code, status_names
from ced.problem.scene import load_scene
from ced.simulation.dataset import VARIABLES, _scenes_json
from ced.simulation.simulate import simulate
from tests.test_io import ELASTIC, elastic, rigid  # noqa: F401 (fixtures: datasets written and read back)


def test_global_attributes(rigid):
    attrs = rigid.attrs
    assert attrs["Conventions"] == "CF-1.12"
    for key in ("title", "institution", "source", "history", "references"):
        assert attrs[key]
    assert attrs["source"].startswith("ced ") and "git" in attrs["source"]
    scenes = json.loads(attrs["scenes"])
    assert scenes[0]["mechanism"]["ground"] == 0.254
    assert attrs["effects"] == "inertia gravity"


def test_scenes_attribute_is_the_json_of_the_scenes_text_for_text():
    # Each distinct block written once (known again by marshal's bytes): the same text as
    # the encoder's of the whole list, whatever repeats, differs only in type or sign, or
    # cannot be marshalled.
    four_bar = {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                "rocker": 0.35}
    scenes = [load_scene({"mechanism": four_bar, "drive": {"speed": w}})
              for w in (10.0, 20.0, 10.0)]
    scenes += [load_scene({"mechanism": {**four_bar, "coupler": 0.46}}),
               {"a": 1, "b": 1.0, "c": True, "d": [0.0, -0.0], "é": "ü"},
               {"b": 1.0, "a": 1.0, "c": 1, "d": (0.0, 0.0)},
               {"x": np.float64(0.25), "y": float("nan"), "z": {2: None}},
               {"x": 0.25, "y": [np.arange(2).tolist()], "z": {"2": None}}, [1, {"k": 2}]]
    assert _scenes_json(scenes) == json.dumps(scenes, sort_keys=True, separators=(",", ":"))
    assert _scenes_json([]) == "[]" and _scenes_json([{}]) == "[{}]"
    with pytest.raises(TypeError):
        _scenes_json([{"v": np.arange(2)}])


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
        "link_angular_acceleration", "joint_force", "input_torque", "motion_turns",
        "solve_time", "status", "message"}
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
