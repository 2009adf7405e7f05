"""Six-bars and linkages of dyads through simulate: rigid and elastic datasets, documented
coordinates."""
import numpy as np
import pytest

from ced.io import write_dataset
from ced.problem.scene import SceneError
from ced.response.batch import make_batch
from ced.rigid.inverse_dynamics import inverse_dynamics
from ced.problem.scene import load_scene
from ced.simulation.dataset import CASE_COORDINATES
from ced.simulation.simulate import simulate
from tests.rigid.test_dyads import PRESS, STEPHENSON_III, WATT_II

RIGID = {"discretization": {"formulation": "rigid"},
         "time": {"revolutions": 1, "steps_per_revolution": 32}}


@pytest.mark.parametrize("mechanism", [WATT_II, STEPHENSON_III, PRESS])
def test_rigid_dataset_of_a_six_bar(mechanism, tmp_path):
    scenes = [{"mechanism": mechanism, **RIGID}, {"mechanism": mechanism, **RIGID,
                                                  "drive": {"speed": 40.0}}]
    ds = simulate(scenes)
    batch = make_batch([load_scene(s) for s in scenes])
    motion = batch.rigid_motion()
    forces = inverse_dynamics(motion, batch.bodies, batch.gravity)
    assert list(ds.link.values) == batch.topology.link_names
    assert list(ds.joint.values) == batch.topology.joint_names
    # to round-off: the dataset's are P + Ω² Q of the case's speed family (unit speed)
    for name in ("input_torque", "joint_force"):
        want = getattr(forces, name)
        np.testing.assert_allclose(ds[name].values, want, rtol=0,
                                   atol=1e-12 * np.abs(want).max(), err_msg=name)
    assert ("guide_force" in ds) == (mechanism is PRESS)
    for name, coord in ds.coords.items():
        if coord.dims == ("case",) and name != "case":
            assert name in CASE_COORDINATES, name
            assert coord.attrs.get("units", "") == CASE_COORDINATES[name][0], name
    write_dataset(ds, tmp_path / "six.nc")


@pytest.mark.parametrize("mechanism", [WATT_II, STEPHENSON_III, PRESS])
@pytest.mark.parametrize("discretization", [None, "auto"])
def test_elastic_dataset_of_a_six_bar(mechanism, discretization, tmp_path):
    """Binary links flexible (the default), ternary links rigid: every elastic variable is
    finite, a rigid link carries no strain."""
    scene = {"mechanism": mechanism, "time": {"revolutions": 1, "steps_per_revolution": 64}}
    if discretization is not None:
        scene["discretization"] = discretization
    ds = simulate([scene])
    normalized = load_scene(scene)
    for link in ds.link.values:
        stress = ds.peak_stress.sel(link=link).values
        assert np.all(np.isfinite(stress))
        assert (stress > 0).all() == normalized["links"][link]["flexible"], link
    write_dataset(ds, tmp_path / "six_elastic.nc")
