"""Cases that differ in speed alone share one rigid solution: scaled and interpolated, their
motion and forces are each case's own to round-off."""
import numpy as np
import pytest

from ced.problem.scene import load_scene
from ced.response.batch import make_batch
from ced.rigid import speed_family
from tests.rigid.test_dyads import MECHANISMS, _scene

SPEEDS = [40.0, 55.0, 61.0, 90.0, 123.0]
FOUR_BAR = {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35}
SLIDER = {"type": "slider_crank", "crank": 0.1, "rod": 0.4, "offset": 0.03}
PARALLELOGRAM = {"type": "four_bar", "ground": 0.3, "crank": 0.1, "coupler": 0.3,
                 "rocker": 0.1}
CASES = {"four_bar": (FOUR_BAR, {}), "slider_crank": (SLIDER, {}),
         "change_point": (PARALLELOGRAM, {}),
         "rocker_input": ({"type": "four_bar", "ground": 0.5, "crank": 0.35, "coupler": 0.1,
                           "rocker": 0.45}, {"amplitude": 0.9}),
         **{name: (m, {}) for name, m in MECHANISMS.items()}}


def _scenes(mechanism, drive, speeds, steps=96):
    return [_scene(mechanism, drive={**drive, "speed": s},
                   time={"steps_per_revolution": steps, "revolutions": 2}) for s in speeds]


def _alone(scenes, steps):
    """Each case solved in a batch of its own: (motion, forces) per case."""
    out = []
    for s in scenes:
        batch = make_batch([s])
        times = batch.step_size[:, None] * steps[None, :]
        motion = batch.rigid_motion(times)
        out.append((motion, batch.rigid_forces(times, motion=motion)))
    return out


def _close(x, y, name, floor=1e-300, tolerance=1e-11):
    """x = y to ``tolerance`` of the larger of y's magnitude and ``floor`` (a quantity that
    is zero by geometry, a parallelogram's coupler rate, is round-off of its scale)."""
    scale = max(np.abs(y).max(), floor)
    np.testing.assert_allclose(x, y, rtol=0, atol=tolerance * scale, err_msg=name)


@pytest.mark.parametrize("kind", sorted(CASES))
def test_family_motion_and_forces_are_each_case_solved_alone(kind):
    mechanism, drive = CASES[kind]
    scenes = _scenes(mechanism, drive, SPEEDS)
    batch = make_batch(scenes)
    families = batch._speed_families()
    assert families.nodes.tolist() == [0] and families.family.tolist() == [0] * len(SPEEDS)
    steps = np.arange(batch.n_steps + 1)
    times = batch.step_size[:, None] * steps[None, :]
    motion = batch.rigid_motion(times)
    forces = batch.rigid_forces(times, motion=motion)
    for c, (one, its) in enumerate(_alone(scenes, steps)):
        for order, name in enumerate(("link_angle", "link_angular_velocity",
                                      "link_angular_acceleration")):
            _close(getattr(motion, name)[c], getattr(one, name)[0], f"{kind} {name} {c}",
                   SPEEDS[c] ** order)
        for order, name in enumerate(("joint_position", "joint_velocity",
                                      "joint_acceleration")):
            _close(getattr(motion, name)[c], getattr(one, name)[0], f"{kind} {name} {c}",
                   0.1 * SPEEDS[c] ** order)
        assert np.array_equal(motion.singular[c], one.singular[0])
        for name in ("joint_force", "input_torque", "guide_force", "sleeve_force"):
            if getattr(its, name) is not None:  # beside a change point the Newton–Euler
                # systems are ill-conditioned (Hadamard ratio ~1e-5): round-off grows there
                _close(getattr(forces, name)[c], getattr(its, name)[0], f"{kind} {name} {c}",
                       tolerance=1e-9)


def test_cases_that_differ_in_more_than_speed_are_not_one_family():
    """Two geometries × three speeds and a case with another gravity: three families."""
    longer = {**FOUR_BAR, "coupler": 0.46}
    scenes = (_scenes(FOUR_BAR, {}, [40.0, 50.0, 60.0]) + _scenes(longer, {}, [40.0, 50.0, 60.0])
              + [_scene(FOUR_BAR, drive={"speed": 45.0}, gravity=[0.0, -1.0],
                        time={"steps_per_revolution": 96, "revolutions": 2})])
    families = make_batch(scenes)._speed_families()
    assert families.nodes.tolist() == [0, 3, 6]
    assert families.family.tolist() == [0, 0, 0, 1, 1, 1, 2]


def test_a_case_does_not_depend_on_the_others_of_its_batch():
    """Alone or with others of its family, a case gets the same bits: the family's motion
    and forces are solved at unit speed, not at one of its cases' speeds."""
    scenes = _scenes(MECHANISMS["watt_ii"], {}, SPEEDS)
    batch = make_batch(scenes)
    steps = np.arange(batch.n_steps + 1)
    motion = batch.rigid_motion(batch.step_size[:, None] * steps)
    forces = batch.rigid_forces(batch.step_size[:, None] * steps, motion=motion)
    for c, (one, its) in enumerate(_alone(scenes, steps)):
        assert np.array_equal(motion.joint_acceleration[c], one.joint_acceleration[0])
        assert np.array_equal(forces.joint_force[c], its.joint_force[0])


def test_forces_with_another_gravity_than_the_batch_are_solved_per_case():
    """A caller's gravity that differs within a family is not interpolated."""
    scenes = _scenes(FOUR_BAR, {}, SPEEDS)
    batch = make_batch(scenes)
    steps = np.arange(batch.n_steps + 1)
    times = batch.step_size[:, None] * steps[None, :]
    gravity = np.zeros((len(SPEEDS), 2))
    gravity[2, 1] = -9.81
    shared = batch.rigid_forces(times, gravity=gravity)
    for c, s in enumerate(scenes):
        alone = make_batch([s])
        its = alone.rigid_forces(alone.step_size[:, None] * steps[None, :],
                                 gravity=gravity[c:c + 1])
        _close(shared.joint_force[c], its.joint_force[0], f"case {c}")


def test_forces_are_gravity_plus_speed_squared_times_unit_inertia():
    """P + Ω² Q of each case's family, None parts left out."""
    from ced.rigid.inverse_dynamics import InverseDynamics
    speed = np.array([2.0, 3.0, 5.0])
    families = speed_family.SpeedFamilies(np.array([0, 2]), np.array([0, 0, 1]))
    P = np.array([[1.5, -2.0], [0.5, 1.0]])
    Q = np.array([[0.25, 4.0], [-1.0, 2.0]])

    def forces(x):
        return InverseDynamics(joint_force=x[:, None, :, None], input_torque=x[:, None, 0],
                               guide_force=None, sleeve_force=None)

    both = speed_family.combined_forces(forces(P), forces(Q), families, speed)
    want = P[[0, 0, 1]] + speed[:, None] ** 2 * Q[[0, 0, 1]]
    np.testing.assert_allclose(both.joint_force[:, 0, :, 0], want, rtol=1e-15)
    assert both.guide_force is None
    only_inertia = speed_family.combined_forces(None, forces(Q), families, speed)
    np.testing.assert_allclose(only_inertia.input_torque[:, 0],
                               speed**2 * Q[[0, 0, 1], 0], rtol=1e-15)
    only_gravity = speed_family.combined_forces(forces(P), None, families, speed)
    assert np.array_equal(only_gravity.input_torque[:, 0], P[[0, 0, 1], 0])


def test_a_speed_sweep_solves_its_elastic_cases_as_alone():
    """Through the KED solve: the peaks of a flexible four-bar's speed sweep are those of
    each case solved alone, to round-off."""
    from ced.simulation.simulate import simulate
    scenes = [{"mechanism": FOUR_BAR, "drive": {"speed": s}, "gravity": [0.0, -9.81],
               "effects": ["inertia", "elastic_inertia", "gravity", "coriolis", "centrifugal",
                           "axial_stiffening"],
               "discretization": {"elements_per_link": 3},
               "time": {"steps_per_revolution": 64, "revolutions": 1, "start": "undeformed"},
               "outputs": {"stations": 5, "error_estimate": False}} for s in SPEEDS]
    together = simulate(scenes)
    for c, s in enumerate(scenes):
        alone = simulate([s])
        for name in ("peak_stress", "joint_force", "input_torque"):
            x, y = together[name].values[c], alone[name].values[0]
            np.testing.assert_allclose(x, y, rtol=0, atol=1e-9 * np.abs(y).max(),
                                       err_msg=f"{name} case {c}")
    assert load_scene(scenes[0])["effects"]  # the scenes are valid as given
