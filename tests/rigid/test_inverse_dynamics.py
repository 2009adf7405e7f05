import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.rigid import kinematics as kin
from ced.rigid.inverse_dynamics import BodyProperties, inverse_dynamics, kinetic_energy_rate
from tests.conftest import drive_of, four_bars

GRAVITY = np.array([0.3, -9.81])


def _bodies(lengths, rho_area=0.4, point=(0.0, 0.05, 0.08, 0.0), slider=0.0):
    mass = rho_area * np.asarray(lengths, float)[None]
    inertia = mass * np.asarray(lengths, float)[None] ** 2 / 12 + 1e-6
    return BodyProperties(mass, inertia, np.asarray(point, float)[None], np.array([slider]))


def _four_bar(g, a, b, c, branch, speed=30.0, steps=400):
    t = np.linspace(0, 2 * np.pi / speed, steps)[None]
    theta0, amp = drive_of(g, a, b, c)
    m = kin.input_motion(t, [speed], [theta0], [amp])
    return kin.four_bar([g], [a], [b], [c], m, [branch])


def _power_balance_error(motion, bodies, gravity):
    res = inverse_dynamics(motion, bodies, gravity)
    power = res.input_torque * motion.link_angular_velocity[..., 0]
    rate = kinetic_energy_rate(motion, bodies, gravity)
    return np.abs(power - rate).max() / (np.abs(power).max() + np.abs(rate).max())


@given(four_bars())
@settings(max_examples=40, deadline=None)
def test_four_bar_power_balance(linkage):
    # Input power = d(kinetic energy)/dt + power against gravity, at every step (1e-9 rel.).
    g, a, b, c, branch = linkage
    motion = _four_bar(g, a, b, c, branch)
    assert _power_balance_error(motion, _bodies([a, b, c]), GRAVITY) < 1e-9


@pytest.mark.parametrize("offset", [0.0, 0.04, -0.03])
def test_slider_crank_power_balance_and_guide(offset):
    speed = 150.0
    t = np.linspace(0, 2 * np.pi / speed, 300)[None]
    motion = kin.slider_crank([0.15], [0.30], [offset], kin.input_motion(t, [speed], [0.0]),
                              [1.0])
    bodies = _bodies([0.15, 0.30], point=(0.0, 0.02, 0.01), slider=0.075552)
    assert _power_balance_error(motion, bodies, GRAVITY) < 1e-9
    res = inverse_dynamics(motion, bodies, GRAVITY)
    # The slider's y balance: rod force + guide force + weight = 0 (no y acceleration).
    slider_mass = 0.075552 + 0.01
    residual = res.joint_force[0, :, 2, 1] + res.guide_force[0] + slider_mass * GRAVITY[1]
    assert np.abs(residual).max() < 1e-9 * np.abs(res.joint_force).max()


def test_single_link_torque_closed_form():
    # Uniform link pivoted at one end, θ = Ω t + A sin: T = I_A α − m g·(L/2) e⊥ moment.
    L, m = 0.5, 0.8
    t = np.linspace(0, 1, 50)[None]
    motion = kin.single_link([L], kin.input_motion(t, [4.0], [0.2], [0.3]))
    bodies = BodyProperties(np.array([[m]]), np.array([[m * L * L / 12]]),
                            np.zeros((1, 2)), np.zeros(1))
    res = inverse_dynamics(motion, bodies, (0.0, -9.81))
    th, al = motion.link_angle[0, :, 0], motion.link_angular_acceleration[0, :, 0]
    expected = m * L * L / 3 * al + m * 9.81 * L / 2 * np.cos(th)
    assert np.allclose(res.input_torque[0], expected, rtol=1e-12, atol=1e-12)


@given(four_bars())
@settings(max_examples=30, deadline=None)
def test_newton_euler_per_link_and_shaking_force(linkage):
    g, a, b, c, branch = linkage
    motion = _four_bar(g, a, b, c, branch, steps=50)
    bodies = _bodies([a, b, c])
    res = inverse_dynamics(motion, bodies, GRAVITY)
    F = res.joint_force[0]  # (step, joint, 2): A, B, C, D
    P = motion.joint_position[0]
    acc_pm = motion.joint_acceleration[0]
    # Forces on each link: crank gets F_A − F_B, coupler F_B − F_C, rocker F_C + F_D.
    on_link = {"crank": [(0, 1.0), (1, -1.0)], "coupler": [(1, 1.0), (2, -1.0)],
               "rocker": [(2, 1.0), (3, 1.0)]}
    carried = {"coupler": 1, "rocker": 2}  # point masses at B, C ride on coupler, rocker
    scale = np.abs(F).max()
    for i, link in enumerate(["crank", "coupler", "rocker"]):
        L = motion.lengths[0, i]
        G = motion.link_point(link, L / 2)[0]
        aG = motion.link_point(link, L / 2, order=2)[0]
        m, I = bodies.mass[0, i], bodies.inertia[0, i]
        total = sum(sign * F[:, k] for k, sign in on_link[link])
        expected = m * (aG - GRAVITY)
        moment = sum(
            sign * ((P[:, k, 0] - G[:, 0]) * F[:, k, 1] - (P[:, k, 1] - G[:, 1]) * F[:, k, 0])
            for k, sign in on_link[link])
        expected_moment = I * motion.link_angular_acceleration[0, :, i]
        if link == "crank":
            moment = moment + res.input_torque[0]
        if link in carried:
            k = carried[link]
            mp = bodies.point_mass[0, k]
            fp = mp * (acc_pm[:, k] - GRAVITY)
            expected = expected + fp
            arm = P[:, k] - G
            expected_moment = expected_moment + arm[:, 0] * fp[:, 1] - arm[:, 1] * fp[:, 0]
        assert np.abs(total - expected).max() < 1e-10 * scale
        assert np.abs(moment - expected_moment).max() < 1e-10 * scale * (a + b + c)
    # Shaking force: ground reactions plus total weight = Σ m a_G (links and point masses).
    ma = sum(bodies.mass[0, i] * motion.link_point(l, motion.lengths[0, i] / 2, order=2)[0]
             for i, l in enumerate(["crank", "coupler", "rocker"]))
    ma = ma + sum(bodies.point_mass[0, k] * acc_pm[:, k] for k in range(4))
    total_mass = bodies.mass.sum() + bodies.point_mass.sum()
    assert np.abs(F[:, 0] + F[:, 3] + total_mass * GRAVITY - ma).max() < 1e-10 * scale


def test_static_analysis_without_inertia_effect():
    # Without the inertia effect only gravity loads the linkage: torque = static moment.
    motion = _four_bar(0.5, 0.1, 0.45, 0.35, 1.0, speed=300.0, steps=40)
    bodies = _bodies([0.1, 0.45, 0.35])
    quasi = inverse_dynamics(motion, bodies, (0.0, -9.81), inertia=False)
    full = inverse_dynamics(motion, bodies, (0.0, -9.81))
    slow = _four_bar(0.5, 0.1, 0.45, 0.35, 1.0, speed=1e-6, steps=40)
    static = inverse_dynamics(slow, bodies, (0.0, -9.81))
    assert np.allclose(quasi.input_torque, static.input_torque, rtol=1e-6, atol=1e-12)
    assert not np.allclose(full.input_torque, quasi.input_torque, rtol=1e-2)


def test_parallelogram_through_change_point_stays_finite():
    # Parallelogram (1, 0.5, 1, 0.5) driven through θ = 0, π, where all links are collinear
    # and the Newton–Euler matrix is singular. Near there the rigid forces grow like
    # 1/(θ − θ*) (the linkage is instantaneously statically indeterminate) — physical for a
    # rigid model; at the singular steps themselves no solve exists and the forces are
    # interpolated between the neighbours instead of blowing up (~1e17) or raising.
    t = np.linspace(0.0, 2 * np.pi, 721)[None]  # hits θ = 0, π, 2π exactly (speed 1)
    motion = kin.four_bar([1.0], [0.5], [1.0], [0.5], kin.input_motion(t, [1.0], [0.0]),
                          [1.0])
    bodies = _bodies([0.5, 1.0, 0.5])
    res = inverse_dynamics(motion, bodies, GRAVITY)
    singular = np.flatnonzero(motion.singular[0])
    assert singular.size
    assert np.all(np.isfinite(res.joint_force)) and np.all(np.isfinite(res.input_torque))
    F = res.joint_force[0]
    for k in singular[(singular > 0) & (singular < F.shape[0] - 1)]:
        neighbours = np.abs(F[[k - 1, k + 1]]).max(axis=0)
        assert np.all(np.abs(F[k]) <= neighbours + 1e-12)
    regular = ~motion.singular[0]
    power = res.input_torque[0] * motion.link_angular_velocity[0, :, 0]
    rate = kinetic_energy_rate(motion, bodies, GRAVITY)[0]
    assert np.abs(power - rate)[regular].max() < 1e-6 * np.abs(rate).max()


def _cross(r, f):
    return r[..., 0] * f[..., 1] - r[..., 1] * f[..., 0]


def test_rpr_sleeve_and_guide_bar_newton_euler():
    """Whitworth's shaper (crank, RPR lever and block, RRP ram): the block turns about B with
    the lever, so Σ F = m_s (a_B − g) with the crank's pin force at B and the lever's normal
    force N e⊥ (no force along the frictionless slide), and Σ M_B = J_s α: the couple alone
    (N acts on the line through B). The lever: pin O, −N e⊥ at the block's point
    M = O + s e, −C and the rod's pin at C, against m a_G and I α about G."""
    from ced.problem.scene import load_scene
    from ced.response.batch import make_batch
    from tests.rigid.test_dyads import RIGID, SHAPER

    scene = load_scene({**RIGID, "mechanism": SHAPER, "gravity": list(GRAVITY),
                        "effects": ["inertia", "gravity"], "point_masses": {"C": 0.2}})
    batch = make_batch([scene])
    motion = batch.rigid_motion()
    res = inverse_dynamics(motion, batch.bodies, batch.gravity)
    topo = motion.topology
    assert topo.sleeves == {"block": ("B", "lever")}
    j = {name: k for k, name in enumerate(topo.joint_names)}
    F, X, acc = res.joint_force[0], motion.joint_position[0], motion.joint_acceleration[0]
    i = topo.link_names.index("lever")
    th, al = motion.link_angle[0, :, i], motion.link_angular_acceleration[0, :, i]
    e = np.stack([np.cos(th), np.sin(th)], -1)
    n = np.stack([-e[:, 1], e[:, 0]], -1)
    N, C = res.sleeve_force[0, :, 0, 0], res.sleeve_force[0, :, 0, 1]
    m_s, J_s = batch.bodies.sleeve_mass[0, 0], batch.bodies.sleeve_inertia[0, 0]
    assert (m_s, J_s) == (0.4, 3e-4)
    scale = np.abs(F).max()
    # The block.
    residual = F[:, j["B"]] + N[:, None] * n - m_s * (acc[:, j["B"]] - GRAVITY)
    assert np.abs(residual).max() < 1e-10 * scale
    assert np.abs(C - J_s * al).max() < 1e-10 * np.abs(C).max()
    # The lever: C joins lever (first) and rod (second), so the rod's pin pulls it with −F_C.
    m, I = batch.bodies.mass[0, i], batch.bodies.inertia[0, i]
    G = motion.link_point("lever", batch.bodies.centre[0, i, 0])[0]
    aG = motion.link_point("lever", batch.bodies.centre[0, i, 0], order=2)[0]
    assert np.allclose(batch.bodies.centre[0, i], [0.225, 0.0])
    M = X[:, j["O"]] + motion.slide["block"][0][0][:, None] * e
    forces = [(X[:, j["O"]], F[:, j["O"]]), (M, -N[:, None] * n), (X[:, j["C"]], -F[:, j["C"]])]
    total = sum(f for _, f in forces)
    assert np.abs(total - m * (aG - GRAVITY)).max() < 1e-10 * scale
    moment = sum(_cross(x - G, f) for x, f in forces) - C
    assert np.abs(moment - I * al).max() < 1e-10 * scale * 0.45


def _both_paths(monkeypatch, motion, bodies, gravity, inertia=True):
    """inverse_dynamics with the systems assembled in the compiled loop and by numpy."""
    import ced.rigid.inverse_dynamics as module

    out = []
    for compiled in (True, False):
        monkeypatch.setattr(module, "COMPILED", compiled)
        out.append(inverse_dynamics(motion, bodies, gravity, inertia=inertia))
    return out


def _assert_same_bits(a, b):
    for name in ("joint_force", "input_torque", "guide_force", "sleeve_force"):
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None) == (y is None), name
        if x is not None:
            assert np.array_equal(x, y), name


@pytest.mark.parametrize("inertia, steps", [(True, 101), (False, 101), (True, 64), (True, 30)])
def test_compiled_assembly_is_the_numpy_one_bit_for_bit(monkeypatch, inertia, steps):
    """The compiled loop does the arithmetic of the numpy assembly operation for operation
    (no fastmath) and solves with the same LU: the same bits, for built-in mechanisms (centres
    at mid-length, a slider parallel to x, a change point) and linkages of dyads (centres off
    the links' axes, point masses, slider guides at an angle, RPR sleeves); steps that fill
    the compiled loop's chunks exactly, leave some over, or fill none."""
    from ced.response.batch import make_batch
    from tests.rigid.test_dyads import MECHANISMS, _scene

    parallelogram = _four_bar(0.4, 0.15, 0.4, 0.15, 1.0, steps=steps)
    slider = kin.slider_crank([0.1], [0.3], [0.02], kin.input_motion(
        np.linspace(0, 0.2, steps)[None], [30.0], [0.3]), [1.0])
    for motion, bodies in ((parallelogram, _bodies([0.15, 0.4, 0.15])),
                           (slider, _bodies([0.1, 0.3], point=(0.0, 0.05, 0.08), slider=0.3))):
        _assert_same_bits(*_both_paths(monkeypatch, motion, bodies, GRAVITY, inertia))
    for mechanism in MECHANISMS.values():
        batch = make_batch([_scene(mechanism), _scene(mechanism, drive={"speed": 40.0})])
        _assert_same_bits(*_both_paths(monkeypatch, batch.rigid_motion(), batch.bodies,
                                       batch.gravity, inertia))


def test_dyads_solved_in_closed_form_as_by_lu(monkeypatch):
    """Every RRR dyad's block of the Newton–Euler systems is found (one of a four-bar's, two of
    a Watt II's) and solved in closed form: the joint forces and torque of the LU on every
    block, to round-off; the numpy assembly uses the same solve (the same bits)."""
    import ced.rigid.inverse_dynamics as module
    from ced.response.batch import make_batch
    from ced.rigid.small_systems import lu_only
    from tests.rigid.test_dyads import MECHANISMS, _scene

    four_bar = _four_bar(0.5, 0.1, 0.45, 0.35, 1.0)
    batch = make_batch([_scene(MECHANISMS["watt_ii"]),
                        _scene(MECHANISMS["watt_ii"], drive={"speed": 40.0})])
    cases = ((four_bar, _bodies([0.1, 0.45, 0.35]), 1),
             (batch.rigid_motion(), batch.bodies, 2))
    with_dyads = module._with_dyads
    for motion, bodies, dyads in cases:
        found = []
        monkeypatch.setattr(module, "_with_dyads", lambda p, b: found.append(
            with_dyads(p, b)) or found[-1])
        closed = inverse_dynamics(motion, bodies, GRAVITY)
        assert (found[-1][3][:, 0] >= 0).sum() == dyads
        monkeypatch.setattr(module, "_with_dyads",
                            lambda p, b: (*b, lu_only(b[2])))
        lu = inverse_dynamics(motion, bodies, GRAVITY)
        for name in ("joint_force", "input_torque"):
            x, y = getattr(closed, name), getattr(lu, name)
            np.testing.assert_allclose(x, y, rtol=0, atol=1e-12 * np.abs(y).max())
        monkeypatch.undo()
        _assert_same_bits(*_both_paths(monkeypatch, motion, bodies, GRAVITY, True))
