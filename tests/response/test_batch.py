"""Batches of structurally identical scenes (ced.response.batch): the rigid motion on the step
grid is one continuous motion, whatever window of steps is asked for, and times off the grid
are on its branches, however they are sampled."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.problem.scene import load_scene
from ced.response.batch import make_batch
from ced.response.frequencies import modal_phases

#: S + L = 0.1 + 0.4 = P + Q = 0.35 + 0.15: the assembly's two branches meet at θ = π.
CHANGE_POINT = {"type": "four_bar", "ground": 0.4, "crank": 0.1, "coupler": 0.35, "rocker": 0.15}
CRANK_ROCKER = {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35}
#: S + L = 0.25 + 0.4 = P + Q = 0.3 + 0.35, the ground shortest: a double crank whose branches
#: meet once a turn, at θ = 0 (the default study's change_point case 1691).
DOUBLE_CRANK_CHANGE_POINT = {"type": "four_bar", "ground": 0.25, "crank": 0.3, "coupler": 0.4,
                             "rocker": 0.35}
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


def test_times_off_the_grid_of_a_batch_without_change_point_are_solved_as_given():
    batch = _batch(CRANK_ROCKER)
    times = batch.step_size[:, None] * np.array([0.5, 3.25, 7.0])[None, :]
    fresh = _batch(CRANK_ROCKER)._solve_motion(times)
    got = batch.rigid_motion(times)
    assert np.array_equal(got.link_angle, fresh.link_angle)
    assert np.array_equal(got.joint_acceleration, fresh.joint_acceleration)


def _wrapped(angle):
    return np.angle(np.exp(1j * angle))


def _assert_on_the_grid_motion(batch, times):
    """The motion at ``times`` (case, n) is the grid motion's: each link angle within the
    error of linear interpolation between the steps around it, h² |θ''|max / 8, taken as
    |Δ²θ|max / 4 (the second differences average θ'', which peaks between the steps just past
    the change point; a time on the other configuration is O(1) off), the same whether a time is asked for alone or in a
    sequence (the sampling does not choose the branch: the same to round-off, the angles
    unwrapped along different sequences)."""
    got = batch.rigid_motion(times)
    position = times / batch.step_size[:, None]  # within the two turns of 64 steps
    grid = _at(batch, np.arange(129))
    lower = np.floor(position).astype(int)
    rows = np.arange(batch.size)[:, None]
    fraction = (position - lower)[..., None]
    before, after = grid.link_angle[rows, lower], grid.link_angle[rows, lower + 1]
    interpolated = before + fraction * (after - before)
    curvature = np.abs(np.diff(grid.link_angle, 2, axis=1)).max(axis=1)[:, None]
    assert np.all(np.abs(_wrapped(got.link_angle - interpolated)) <= curvature / 4 + 1e-9)
    for j in range(times.shape[1]):
        alone = batch.rigid_motion(times[:, j:j + 1])
        assert np.abs(_wrapped(alone.link_angle[:, 0] - got.link_angle[:, j])).max() < 1e-12
        assert np.abs(alone.joint_position[:, 0] - got.joint_position[:, j]).max() < 1e-12


@pytest.mark.parametrize("mechanism", [DOUBLE_CRANK_CHANGE_POINT, CHANGE_POINT],
                         ids=["double_crank_change_point", "change_point"])
def test_modal_phases_are_on_the_grid_motions_branch(mechanism):
    # The modal analysis's 12 phases against 64 steps a turn: solved as a sequence of their
    # own, the double crank's phases 2 to 11 took the other branch past θ = 0 (its coupler up
    # to 2.1 rad off the continuous motion's), and a phase solved alone started again on the
    # scene's branch.
    batch = _batch(mechanism)
    times = modal_phases(12)[None, :] / batch.speed[:, None]
    _assert_on_the_grid_motion(batch, times)


@pytest.mark.parametrize("mechanism", [DOUBLE_CRANK_CHANGE_POINT, CHANGE_POINT],
                         ids=["double_crank_change_point", "change_point"])
@given(positions=st.lists(st.floats(0.0, 127.9), min_size=1, max_size=40, unique=True),
       fine=st.booleans())
@settings(max_examples=25, deadline=None)
def test_random_times_off_the_grid_are_on_the_grid_motions_branch(mechanism, positions, fine):
    # Any times in the two turns, in steps of the grid, coarse or fine (a dense run of 200
    # times after each drawn one), on the motion the grid takes there.
    batch = _batch(mechanism)
    positions = np.sort(positions)
    if fine:
        positions = np.unique(np.clip(positions[:, None] + np.linspace(0.0, 0.9, 5)[None, :],
                                      0.0, 127.9))
    _assert_on_the_grid_motion(batch, batch.step_size[:, None] * positions[None, :])


@pytest.mark.parametrize("mechanism", [CHANGE_POINT, CRANK_ROCKER, WATT_II],
                         ids=["change_point", "crank_rocker", "watt_ii"])
@pytest.mark.parametrize("inertia", [True, False])
def test_forces_at_steps_of_the_grid_are_those_solved_there(mechanism, inertia):
    # The rigid outputs solve the period's systems once (at unit speed, for the case's speed
    # family: ced.rigid.speed_family); the terms read the forces at their steps from them:
    # the forces inverse_dynamics gives on the motion at those steps, to round-off (the
    # change point's singular steps interpolated among the steps asked for; its systems
    # beside them ill-conditioned, round-off grows there).
    from ced.rigid.inverse_dynamics import inverse_dynamics

    batch = _batch(mechanism)
    gravity = np.tile([0.0, -9.81], (batch.size, 1))
    for steps in (np.arange(65), np.arange(0, 64, 4), np.arange(2, 64, 4), np.array([0]),
                  np.arange(70, 80), np.array([0.5, 3.25])):
        times = batch.step_size[:, None] * steps[None, :]
        got = batch.rigid_forces(times, inertia, gravity)
        want = inverse_dynamics(batch.rigid_motion(times), batch.bodies, gravity, inertia)
        for name in ("joint_force", "input_torque"):
            x, y = getattr(got, name), getattr(want, name)
            np.testing.assert_allclose(x, y, rtol=0, atol=1e-9 * np.abs(y).max(),
                                       err_msg=f"{steps} {name}")
    assert len(batch._forces_on_grid) == 1


#: Crank = rocker, ground = coupler: passes its change points (θ = 0 and π) twice a turn and
#: stays a parallelogram, back on its branch after every turn.
PARALLELOGRAM = {"type": "four_bar", "ground": 0.3, "crank": 0.1, "coupler": 0.3, "rocker": 0.1}
#: Crank = ground, coupler = rocker, the crank shortest: a rotating kite, whose crank pin
#: passes over the rocker pivot once a turn (ced.rigid.kinematics._over_pivot).
ROTATING_KITE = {"type": "four_bar", "ground": 0.2, "crank": 0.2, "coupler": 0.3, "rocker": 0.3}
#: CHANGE_POINT as a linkage of one RRR dyad: its solutions are tracked the same way.
CHANGE_POINT_DYADS = {"type": "linkage", "ground": {"A": [0.0, 0.0], "D": [0.4, 0.0]},
                      "input": {"link": "crank", "pivot": "A", "tip": "B", "length": 0.1},
                      "dyads": [{"kind": "RRR", "links": ["coupler", "rocker"],
                                 "joints": ["B", "C", "D"], "lengths": [0.35, 0.15]}]}


@pytest.mark.parametrize("mechanism, turns", [
    (CHANGE_POINT, 2), (DOUBLE_CRANK_CHANGE_POINT, 2), (ROTATING_KITE, 2),
    (CHANGE_POINT_DYADS, 2), (PARALLELOGRAM, 1), (CRANK_ROCKER, 1), (WATT_II, 1)],
    ids=["change_point", "double_crank_change_point", "rotating_kite", "change_point_dyads",
         "parallelogram", "crank_rocker", "watt_ii"])
def test_motion_turns_are_the_turns_after_which_the_motion_repeats(mechanism, turns):
    # The crank (ground) shortest: the change point is passed once a turn, straight through
    # onto the other branch, and the motion is back only after two turns. The double crank
    # starts on its change point (θ0 = 0): step N is step 0's configuration, step N + 1 is not.
    batch = _batch(mechanism)
    assert batch.motion_turns.tolist() == [turns, turns]
    assert batch.period_steps == 64 * turns
    motion = _at(batch, np.arange(2 * 64 + 1))
    gap = np.abs(np.angle(np.exp(1j * (motion.link_angle[:, 64:] - motion.link_angle[:, :65]))))
    assert (gap.max() > 0.1) == (turns == 2)  # one turn on: the other branch, or the same
    back = np.angle(np.exp(1j * (motion.link_angle[:, 128] - motion.link_angle[:, 0])))
    assert np.abs(back).max() < 1e-6


def test_the_repeat_test_s_motion_is_kept_only_where_it_is_the_one_turn_motion():
    # A six-bar whose dyads stay on their branches keeps the repeat test's motion (one turn and
    # a step) as its grid motion: over the turn, the same bits as the motion solved over it. A linkage
    # whose dyad passes a change point (two turns) solves its grid motion anew.
    batch = _batch(WATT_II)
    assert batch.motion_turns.tolist() == [1, 1]
    kept = batch._on_grid
    assert kept is not None and kept[0] == 65
    alone = _batch(WATT_II)._solve_motion(batch.step_size[:, None] * np.arange(65)[None, :])
    for name in ("link_angle", "link_angular_velocity", "link_angular_acceleration",
                 "joint_position", "joint_velocity", "joint_acceleration", "time", "singular"):
        assert np.array_equal(getattr(kept[1], name)[:, :65], getattr(alone, name)), name
    changing = _batch(CHANGE_POINT_DYADS)
    assert changing.motion_turns.tolist() == [2, 2]
    assert changing._on_grid is None


def test_a_batch_of_one_and_two_turn_cases_has_no_single_period():
    batch = make_batch([load_scene({"mechanism": m, "drive": {"speed": 20.0},
                                    "time": {"revolutions": 1, "steps_per_revolution": 64}})
                        for m in (CHANGE_POINT, PARALLELOGRAM)])
    assert batch.motion_turns.tolist() == [2, 1]
    with pytest.raises(ValueError, match="input turns"):
        batch.period_steps
