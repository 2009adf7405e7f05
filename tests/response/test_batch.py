"""Batches of structurally identical scenes (ced.response.batch): the rigid motion on the step
grid is one continuous motion, whatever window of steps is asked for."""
import numpy as np
import pytest

from ced.problem.scene import load_scene
from ced.response.batch import make_batch

#: S + L = 0.1 + 0.4 = P + Q = 0.35 + 0.15: the assembly's two branches meet at θ = π.
CHANGE_POINT = {"type": "four_bar", "ground": 0.4, "crank": 0.1, "coupler": 0.35, "rocker": 0.15}
CRANK_ROCKER = {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35}
WATT_II = {"type": "watt_ii", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35,
           "rocker_arm": 0.25, "rocker_arm_angle": 2.5, "coupler2": 0.4, "rocker2": 0.3,
           "pivot2_x": 0.2, "pivot2_y": -0.3}


def _batch(mechanism, speeds=(20.0, 35.0)):
    return make_batch([load_scene({"mechanism": mechanism, "drive": {"speed": s},
                                   "time": {"revolutions": 2, "steps_per_revolution": 64}})
                       for s in speeds])


def _at(batch, steps):
    return batch.rigid_motion(batch.step_size[:, None] * np.asarray(steps)[None, :])


@pytest.mark.parametrize("mechanism", [CHANGE_POINT, CRANK_ROCKER, WATT_II],
                         ids=["change_point", "crank_rocker", "watt_ii"])
def test_windows_of_the_step_grid_are_the_one_continuous_motion(mechanism):
    # The period's terms are evaluated window by window (and sampled at every fourth step):
    # each window is the motion of the whole grid at those steps, to the bit. Solved on its
    # own, a window past the change point started again on the scene's branch, up to π off.
    whole = _at(_batch(mechanism), np.arange(129))
    batch = _batch(mechanism)
    for window in (np.arange(70, 80), np.arange(0, 128, 4), np.arange(100, 129)):
        part = _at(batch, window)
        for name in ("link_angle", "link_angular_velocity", "joint_position",
                     "joint_acceleration", "singular", "time"):
            assert np.array_equal(getattr(part, name), getattr(whole, name)[:, window]), name
    if mechanism is CHANGE_POINT:  # ... which a window solved alone is not
        alone = batch._solve_motion(batch.step_size[:, None] * np.arange(70, 80)[None, :])
        gap = np.angle(np.exp(1j * (alone.link_angle - whole.link_angle[:, 70:80])))
        assert np.abs(gap).max() > 1.0


def test_times_off_the_grid_are_solved_as_given():
    batch = _batch(CRANK_ROCKER)
    times = batch.step_size[:, None] * np.array([0.5, 3.25, 7.0])[None, :]
    fresh = _batch(CRANK_ROCKER)._solve_motion(times)
    assert np.array_equal(batch.rigid_motion(times).link_angle, fresh.link_angle)


@pytest.mark.parametrize("mechanism", [CHANGE_POINT, CRANK_ROCKER, WATT_II],
                         ids=["change_point", "crank_rocker", "watt_ii"])
@pytest.mark.parametrize("inertia", [True, False])
def test_forces_at_steps_of_the_grid_are_those_solved_there(mechanism, inertia):
    # The rigid outputs solve the period's systems once; the terms read the forces at their
    # steps from them: the forces inverse_dynamics gives on the motion at those steps, the
    # same bits (the change point's singular steps interpolated among the steps asked for).
    from ced.rigid.inverse_dynamics import inverse_dynamics

    batch = _batch(mechanism)
    gravity = np.tile([0.0, -9.81], (batch.size, 1))
    for steps in (np.arange(65), np.arange(0, 64, 4), np.arange(2, 64, 4), np.array([0]),
                  np.arange(70, 80), np.array([0.5, 3.25])):
        times = batch.step_size[:, None] * steps[None, :]
        got = batch.rigid_forces(times, inertia, gravity)
        want = inverse_dynamics(batch.rigid_motion(times), batch.bodies, gravity, inertia)
        for name in ("joint_force", "input_torque"):
            assert np.array_equal(getattr(got, name), getattr(want, name)), (steps, name)
    assert len(batch._forces_on_grid) == 1
