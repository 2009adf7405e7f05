import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.problem.mechanism import input_limits
from ced.rigid import kinematics as kin
from tests.conftest import FD8, check_derivatives, drive_of, four_bars


def _cross(u, v):
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _four_bar_at(times, g, a, b, c, branch, speed=7.0):
    theta0, amp = drive_of(g, a, b, c)
    motion = kin.input_motion(times, np.full(len(times), speed), np.full(len(times), theta0),
                              np.full(len(times), amp))
    n = len(times)
    return kin.four_bar(np.full(n, g), np.full(n, a), np.full(n, b), np.full(n, c), motion,
                        np.full(n, branch))


@given(four_bars())
@settings(max_examples=60, deadline=None)
def test_four_bar_loop_closure_whole_cycle(linkage):
    g, a, b, c, branch = linkage
    speed = 7.0
    t = np.linspace(0.0, 2 * np.pi / speed, 721)[None]
    r = _four_bar_at(t, g, a, b, c, branch, speed)
    A, B, C, D = (r.joint_position[0, :, k] for k in range(4))
    scale = g + a + b + c
    assert np.abs(np.linalg.norm(B - A, axis=-1) - a).max() < 1e-12 * scale
    assert np.abs(np.linalg.norm(C - B, axis=-1) - b).max() < 1e-12 * scale
    assert np.abs(np.linalg.norm(C - D, axis=-1) - c).max() < 1e-12 * scale
    assert np.allclose(D, [g, 0.0], atol=0)
    # The branch is kept: C stays on the chosen side of B→D over the whole cycle.
    side = np.sign(_cross(D - B, C - B))
    assert np.all(side == branch)


@given(four_bars(), st.floats(0.0, 1.0))
@settings(max_examples=60, deadline=None)
def test_four_bar_derivatives_match_finite_differences(linkage, phase):
    g, a, b, c, branch = linkage
    speed = 7.0
    t0 = phase * 2 * np.pi / speed
    dt = 1e-4 / speed
    times = (t0 + dt * np.arange(-4, 5))[None]
    r = _four_bar_at(times, g, a, b, c, branch, speed)
    check_derivatives(r, dt, speed, 1e-6)


@given(four_bars())
@settings(max_examples=60, deadline=None)
def test_freudenstein_equation(linkage):
    g, a, b, c, branch = linkage
    t = np.linspace(0.0, 1.0, 97)[None]
    r = _four_bar_at(t, g, a, b, c, branch)
    th2, th4 = r.link_angle[0, :, 0], r.link_angle[0, :, 2]
    # Freudenstein: K1 cos θ4 − K2 cos θ2 + K3 = cos(θ2 − θ4), K1 = g/a, K2 = g/c,
    # K3 = (a² − b² + c² + g²)/(2ac).
    k1, k2, k3 = g / a, g / c, (a * a - b * b + c * c + g * g) / (2 * a * c)
    residual = k1 * np.cos(th4) - k2 * np.cos(th2) + k3 - np.cos(th2 - th4)
    assert np.abs(residual).max() < 1e-10 * (1 + k1 + k2 + abs(k3))


def test_open_branch_puts_c_above_bd_for_crank_rocker():
    t = np.zeros((1, 1))
    r = _four_bar_at(t, 0.5, 0.1, 0.45, 0.35, 1.0)
    B, C = r.joint_position[0, 0, 1], r.joint_position[0, 0, 2]
    assert C[1] > 0 and _cross(np.array([0.5, 0]) - B, C - B) > 0
    crossed = _four_bar_at(t, 0.5, 0.1, 0.45, 0.35, -1.0)
    assert crossed.joint_position[0, 0, 2, 1] < 0


def test_parallelogram_tracks_through_change_point():
    # Parallelogram (g, a, b, c) = (1, 0.5, 1, 0.5): the smooth branch keeps the coupler
    # parallel to the ground through θ = π and 2π where the two branches touch.
    n = 1
    t = np.linspace(0.0, 2 * 2 * np.pi, 801)[None]  # speed 1 rad/s, θ hits 0, π exactly
    motion = kin.input_motion(t, np.ones(n), np.zeros(n))
    r = kin.four_bar(np.ones(n), np.full(n, 0.5), np.ones(n), np.full(n, 0.5), motion,
                     np.ones(n))
    assert np.all(np.isfinite(r.link_angular_velocity))
    assert np.all(np.isfinite(r.link_angular_acceleration))
    coupler = np.angle(np.exp(1j * r.link_angle[0, :, 1]))
    assert np.abs(coupler).max() < 1e-6
    assert np.abs(r.link_angular_velocity[0, :, 2] - 1.0).max() < 1e-6
    assert r.singular.any()


def _kite(coupler, branch, steps, speed=50.0):
    """A kite (crank = ground = 0.25 m, coupler = rocker) rocking 0.8 of its half-range
    about θ = 0, where its crank pin B lies on the rocker pivot D: ``steps`` a period."""
    g = a = 0.25
    lim = input_limits(g, a, coupler, coupler)
    t = (2 * np.pi / speed) * np.arange(steps + 1)[None] / steps
    motion = kin.input_motion(t, [speed], [lim.mid], [0.8 * lim.half_range])
    return kin.four_bar([g], [a], [coupler], [coupler], motion, [branch])


@pytest.mark.parametrize("branch", [1.0, -1.0])
@pytest.mark.parametrize("coupler", [0.05, 0.25, 0.45])
def test_kite_passes_over_the_rocker_pivot(coupler, branch):
    """B on D (θ = 0, every half period) left B→D undefined: the motion was NaN there and
    every case failed (144 of the default study's change points). Now it is finite, closed,
    continuous, and the same however it is sampled."""
    fine, coarse = _kite(coupler, branch, 1024), _kite(coupler, branch, 64)
    assert fine.singular[0, [0, 512, 1024]].all()  # coupler folded on the rocker
    for r in (fine, coarse):
        for value in (r.link_angle, r.link_angular_velocity, r.link_angular_acceleration,
                      r.joint_position, r.joint_velocity, r.joint_acceleration):
            assert np.isfinite(value).all()
        A, B, C, D = (r.joint_position[0, :, k] for k in range(4))
        assert np.abs(np.linalg.norm(C - B, axis=-1) - coupler).max() < 1e-14
        assert np.abs(np.linalg.norm(C - D, axis=-1) - coupler).max() < 1e-14
    # Continuous: no step turns a link by more than its fastest rate allows.
    step = (2 * np.pi / 50.0) / 1024
    rate = np.abs(fine.link_angular_velocity[0]).max(axis=0)
    assert np.all(np.abs(np.diff(fine.link_angle[0], axis=0)).max(axis=0) <= 1.01 * rate * step + 1e-12)
    assert np.abs(coarse.link_angle[0] - fine.link_angle[0, ::16]).max() < 1e-12
    # Rates and accelerations are the motion's, away from the fold.
    dt = 1e-4 / 50.0
    t0 = 0.2 * 2 * np.pi / 50.0
    lim = input_limits(0.25, 0.25, coupler, coupler)
    motion = kin.input_motion((t0 + dt * np.arange(-4, 5))[None], [50.0], [lim.mid],
                              [0.8 * lim.half_range])
    check_derivatives(kin.four_bar([0.25], [0.25], [coupler], [coupler], motion, [branch]),
                      dt, 50.0, 1e-6)


def test_rhombus_keeps_its_mode_over_the_pivot_and_through_collinearity():
    """A rhombus turning fully passes B over D at θ = 0 and lies collinear at θ = π: open
    stays the parallelogram (coupler parallel to the ground, rocker turning with the crank),
    crossed the folded kite (C on A, rocker at π)."""
    t = np.linspace(0.0, 2 * 2 * np.pi, 801)[None]  # 1 rad/s: θ hits 0, π, 2π exactly
    motion = kin.input_motion(t, [1.0], [0.0])
    opened = kin.four_bar([0.3], [0.3], [0.3], [0.3], motion, [1.0])
    assert np.abs(opened.link_angle[0, :, 1]).max() < 1e-12
    assert np.abs(opened.link_angle[0, :, 2] - t[0]).max() < 1e-12
    crossed = kin.four_bar([0.3], [0.3], [0.3], [0.3], motion, [-1.0])
    assert np.abs(crossed.joint_position[0, :, 2]).max() < 1e-12
    rocker = crossed.link_angle[0, :, 2]
    assert np.abs(np.sin(rocker)).max() < 1e-12 and np.all(np.cos(rocker) < 0)


# Change points (S + L = P + Q) of each kind: collinear at θ = π (g + a = b + c), at θ = 0
# (|g − a| = |b − c|, the ground shortest: a double crank), at both (a parallelogram).
CHANGE_POINTS = {"half_turn": (0.4, 0.1, 0.35, 0.15), "zero": (0.25, 0.3, 0.4, 0.35),
                 "both": (0.3, 0.1, 0.3, 0.1)}


def _turning(lengths, theta0, steps, branch=1.0, turns=2, speed=10.0):
    g, a, b, c = lengths
    t = (2 * np.pi / speed) * np.arange(turns * steps + 1)[None] / steps
    motion = kin.input_motion(t, [speed], [theta0])
    return kin.four_bar([g], [a], [b], [c], motion, [branch])


@pytest.mark.parametrize("kind", sorted(CHANGE_POINTS))
@given(offset=st.floats(0.0, 1.0), branch=st.sampled_from([1.0, -1.0]))
@settings(max_examples=25, deadline=None)
def test_change_point_motion_does_not_depend_on_the_steps(kind, offset, branch):
    """The motion passes straight through the change point however the steps sample it: on
    64 steps a turn, with the touching angle anywhere between two steps, it is the motion on
    1024 steps at the same instants. Tracking the nearest solution step by step (before
    2026-11-27) saw the two touch only where a step fell within 0.01 rad of them: with the
    change point mid-step, 64 and 128 steps reflected the motion off it (the coupler's
    velocity jumping by 5.2 rad/s, twice itself), while 256 passed through."""
    lengths = CHANGE_POINTS[kind]
    theta0 = np.pi - (10 + offset) * 2 * np.pi / 64
    coarse, fine = _turning(lengths, theta0, 64, branch), _turning(lengths, theta0, 1024, branch)
    assert np.abs(np.angle(np.exp(1j * (coarse.link_angle[0]
                                        - fine.link_angle[0, ::16])))).max() < 1e-6
    regular = ~coarse.singular[0] & ~fine.singular[0, ::16]
    assert np.abs(coarse.link_angular_velocity[0][regular]
                  - fine.link_angular_velocity[0, ::16][regular]).max() < 1e-6
    # Smooth: no step changes a link's rate by more than its fastest acceleration allows.
    step = (2 * np.pi / 10.0) / 1024
    jump = np.abs(np.diff(fine.link_angular_velocity[0], axis=0)).max(axis=0)
    assert np.all(jump <= 1.01 * np.abs(fine.link_angular_acceleration[0]).max(axis=0) * step
                  + 1e-9)


def test_change_point_labels_flip_once_per_crossing():
    """The solution's label (left or right of B→D) changes at each crossing of the touching
    angle and only there: once a turn at π, twice at both 0 and π (the parallelogram stays a
    parallelogram: coupler parallel to the ground), and a rocking input that swings across π
    and back crosses it twice a period."""
    for kind, per_turn in (("half_turn", 1), ("zero", 1), ("both", 2)):
        r = _turning(CHANGE_POINTS[kind], 0.3, 128)
        assert np.abs(np.diff(r.branch["coupler"][0])).sum() == 2 * per_turn
    parallelogram = _turning(CHANGE_POINTS["both"], 0.3, 128)
    assert np.abs(np.angle(np.exp(1j * parallelogram.link_angle[0, :, 1]))).max() < 1e-12
    g, a, b, c = CHANGE_POINTS["half_turn"]
    t = (2 * np.pi / 10.0) * np.arange(129)[None] / 128
    rocking = kin.four_bar([g], [a], [b], [c], kin.input_motion(t, [10.0], [np.pi + 0.1], [0.5]),
                           [1.0])
    assert np.abs(np.diff(rocking.branch["coupler"][0])).sum() == 2
    assert np.abs(rocking.link_angle[0, -1] - rocking.link_angle[0, 0]).max() < 1e-9


def test_change_point_crossing_parity_on_and_off_the_level():
    """A step exactly on the touching angle keeps the previous step's count (both solutions
    are one there); a start on it counts from the side the motion moves to."""
    angle = np.array([[np.pi, 3.5, 4.0, 2 * np.pi + np.pi, 9.5],
                      [np.pi, 3.0, 2.5, np.pi, 3.5],
                      [3.0, np.pi, 3.5, 3.0, 2.9]])
    assert kin._crossing_parity(angle, np.pi).tolist() == [[0, 0, 0, 0, 1], [0, 0, 0, 0, 1],
                                                           [0, 0, 1, 0, 0]]


@pytest.mark.parametrize("offset, branch", [(0.0, 1.0), (0.05, 1.0), (-0.04, -1.0)])
def test_slider_crank_geometry_and_derivatives(offset, branch):
    speed, a, b = 150.0, 0.15, 0.30
    dt = 1e-4 / speed
    for t0 in np.linspace(0, 2 * np.pi / speed, 7):
        times = (t0 + dt * np.arange(-4, 5))[None]
        motion = kin.input_motion(times, [speed], [0.0])
        r = kin.slider_crank([a], [b], [offset], motion, [branch])
        B, C = r.joint_position[0, :, 1], r.joint_position[0, :, 2]
        assert np.allclose(C[:, 1], offset, atol=1e-15)
        assert np.allclose(np.linalg.norm(C - B, axis=-1), b, rtol=1e-14)
        assert np.all(np.sign(C[:, 0] - B[:, 0]) == branch)
        for value, derivative in (
            (r.link_angle[0], r.link_angular_velocity[0, 4]),
            (r.link_angular_velocity[0], r.link_angular_acceleration[0, 4]),
            (r.joint_velocity[0], r.joint_acceleration[0, 4]),
        ):
            fd = np.tensordot(FD8, value, axes=(0, 0)) / dt
            assert np.abs(fd - derivative).max() < 1e-6 * (np.abs(derivative).max() + 1)


def test_oscillating_input():
    t = np.linspace(0, 1, 11)[None]
    m = kin.input_motion(t, [3.0], [0.4], [0.2])
    assert np.allclose(m.angle, 0.4 + 0.2 * np.sin(3 * t))
    assert np.allclose(m.velocity, 0.6 * np.cos(3 * t))
    assert np.allclose(m.acceleration, -1.8 * np.sin(3 * t))


def test_single_link_tip_motion():
    t = np.linspace(0, 1, 5)[None]
    r = kin.single_link([0.5], kin.input_motion(t, [2.0], [0.0]))
    tip = r.joint_position[0, :, 1]
    assert np.allclose(tip, 0.5 * np.stack([np.cos(2 * t[0]), np.sin(2 * t[0])], -1))
    # Centripetal acceleration of a uniformly turning tip: L Ω² towards the pivot.
    assert np.allclose(r.joint_acceleration[0, :, 1], -4.0 * tip)


def test_link_point_matches_joints():
    t = np.linspace(0, 0.3, 7)[None]
    r = _four_bar_at(t, 0.5, 0.1, 0.45, 0.35, 1.0)
    for order, arr in enumerate((r.joint_position, r.joint_velocity, r.joint_acceleration)):
        assert np.allclose(r.link_point("coupler", 0.45, order), arr[:, :, 2])
        assert np.allclose(r.link_point("rocker", 0.35, order), arr[:, :, 2])


@pytest.mark.filterwarnings("ignore:invalid value encountered")
def test_compiled_unwrap_is_numpys_bit_for_bit():
    """Random walks with jumps of any size, the wrapped output of arctan2, jumps of exactly
    ±π and just past it, signed zeros, NaN and inf, a single step and none."""
    rng = np.random.default_rng(3)
    pi = np.pi
    for p in (rng.uniform(-20, 20, (7, 500)), np.cumsum(rng.uniform(-4, 4, (5, 300)), axis=1),
              np.angle(np.exp(1j * np.cumsum(rng.uniform(-0.5, 0.5, (4, 1000)), axis=1))),
              np.array([[0.0, pi, 0.0, -pi, 0.0, 2 * pi, -0.0, np.nan, 1.0, 3 * pi, -3 * pi,
                         np.inf, 0.0]]),
              np.array([[-0.0, -0.0, pi, 2 * pi, 0.0, pi + 1e-16, 0.0, -(pi + 4e-16), 0.0]]),
              np.zeros((3, 1)), np.zeros((2, 0))):
        expected, got = np.unwrap(p, axis=1), kin.unwrap(p)
        assert np.array_equal(got, expected, equal_nan=True)
        assert np.array_equal(np.signbit(got), np.signbit(expected))


@pytest.mark.filterwarnings("ignore:invalid value encountered")
def test_branches_meet_decides_as_the_exact_gap():
    """The remainder-wrapped gap decides as numpy's exact |angle(exp(i d))| < 0.01, also for
    minima at the threshold to the last bit, at ±2πm from it, and for NaN, inf and huge d."""
    from ced.rigid.kinematics import _branches_meet

    rng = np.random.default_rng(5)
    near = [1e-2, -1e-2, np.nextafter(1e-2, 0), np.nextafter(1e-2, 1), 1e-2 + 2e-9,
            1e-2 - 2e-9, 5e-3, 0.0]
    odd = [np.nan, 1e6, -np.inf, np.pi, -np.pi]
    for _ in range(300):
        d = rng.uniform(-20, 20, (4, int(rng.integers(3, 40))))
        d[0, 0] = 2 * np.pi * rng.integers(-3, 4) + rng.choice(near)
        d[1, -1] = rng.choice(odd)
        exact = np.abs(np.angle(np.exp(1j * d))).min(axis=1) < 1e-2
        assert np.array_equal(_branches_meet(d), exact)
