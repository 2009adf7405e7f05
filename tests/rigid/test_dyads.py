"""Linkages of dyads: the general closed form against the four-bar and slider-crank, loop
closure, finite differences and the power balance of six-bars with ternary links."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.problem.linkage import describe
from ced.problem.mechanism import topology
from ced.problem.scene import load_scene
from ced.response.batch import make_batch
from ced.rigid import dyads
from ced.rigid import kinematics as kin
from ced.rigid.inverse_dynamics import BodyProperties, inverse_dynamics, kinetic_energy_rate
from tests.conftest import check_derivatives, drive_of, four_bars

RIGID = {"discretization": {"formulation": "rigid"}}

WATT_II = {"type": "watt_ii", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35,
           "rocker_arm": 0.25, "rocker_arm_angle": 2.5, "coupler2": 0.4, "rocker2": 0.3,
           "pivot2_x": 0.2, "pivot2_y": -0.3}
STEPHENSON_III = {"type": "stephenson_iii", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                  "rocker": 0.35, "coupler_arm": 0.3, "coupler_arm_angle": 0.6,
                  "coupler2": 0.4, "rocker2": 0.3, "pivot2_x": 0.4, "pivot2_y": 0.55}
#: A four-bar driving a press ram through an inclined guide (RRP) from a point of its rocker.
PRESS = {"type": "linkage", "ground": {"A": [0.0, 0.0], "D": [0.5, 0.0]},
         "input": {"link": "crank", "pivot": "A", "tip": "B", "length": 0.1},
         "points": {"E": {"link": "rocker", "at": [0.2, -0.15]}},
         "dyads": [{"kind": "RRR", "links": ["coupler", "rocker"], "joints": ["B", "C", "D"],
                    "lengths": [0.45, 0.35]},
                   {"kind": "RRP", "links": ["rod", "ram"], "joints": ["E", "F"],
                    "lengths": [0.5], "guide": {"point": [0.9, -0.05], "angle": 0.3},
                    "slider_mass": 1.5, "branch": "crossed"}]}
#: Whitworth's quick return as a crank shaper: the crank A→B carries the block (an RPR
#: sleeve) that slides along the slotted lever O→C, whose end C drives the ram through a rod
#: (RRP). The lever oscillates (crank 0.1 m < |AO| 0.25 m).
SHAPER = {"type": "linkage", "ground": {"A": [0.0, 0.0], "O": [0.0, -0.25]},
          "input": {"link": "crank", "pivot": "A", "tip": "B", "length": 0.1},
          "dyads": [{"kind": "RPR", "links": ["lever", "block"], "joints": ["O", "C", "B"],
                     "lengths": [0.45], "sleeve_mass": 0.4, "sleeve_inertia": 3e-4},
                    {"kind": "RRP", "links": ["rod", "ram"], "joints": ["C", "F"],
                     "lengths": [0.15], "guide": {"point": [0.0, 0.22], "angle": 0.0},
                     "slider_mass": 2.0}]}
#: An oscillating cylinder: the piston rod pinned to the crank at B slides through a cylinder
#: (the sleeve) swivelling about the ground pivot O, off the rod's axis by 0.03 m; the rod's
#: end C is free.
CYLINDER = {"type": "linkage", "ground": {"A": [0.0, 0.0], "O": [0.3, 0.05]},
            "input": {"link": "crank", "pivot": "A", "tip": "B", "length": 0.1},
            "dyads": [{"kind": "RPR", "links": ["rod", "cylinder"], "joints": ["B", "C", "O"],
                       "lengths": [0.45], "offset": -0.03, "sleeve_mass": 0.8,
                       "sleeve_inertia": 2e-3}]}
MECHANISMS = {"watt_ii": WATT_II, "stephenson_iii": STEPHENSON_III, "press": PRESS,
              "shaper": SHAPER, "cylinder": CYLINDER}
POINT_MASSES = {"C": 0.2, "E": 0.1, "F": 0.3}


def _scene(mechanism, **extra):
    """The rigid scene with gravity and the point masses of :data:`POINT_MASSES` at the
    joints the mechanism has."""
    joints = topology(load_scene({**RIGID, "mechanism": mechanism})["mechanism"]).joint_names
    return load_scene({**RIGID, "mechanism": mechanism, "gravity": [0.3, -9.81],
                       "effects": ["inertia", "gravity"],
                       "point_masses": {j: m for j, m in POINT_MASSES.items() if j in joints},
                       **extra})


def _motion(scene, times):
    batch = make_batch([scene])
    return batch, batch.rigid_motion(times)


def _four_bar_cycle(linkage, samples: int):
    """The four-bar's description and its input motion over one cycle at 7 rad/s."""
    g, a, b, c, branch = linkage
    theta0, amp = drive_of(g, a, b, c)
    times = np.linspace(0.0, 2 * np.pi / 7.0, samples)[None]
    motion = kin.input_motion(times, np.array([7.0]), np.array([theta0]), np.array([amp]))
    mech = {"type": "four_bar", "ground": g, "crank": a, "coupler": b, "rocker": c,
            "branch": "open" if branch > 0 else "crossed"}
    return mech, motion


@given(four_bars())
@settings(max_examples=30, deadline=None)
def test_four_bar_preset_matches_the_closed_form(linkage):
    g, a, b, c, branch = linkage
    mech, motion = _four_bar_cycle(linkage, 241)
    ref = kin.four_bar(*(np.array([x]) for x in (g, a, b, c)), motion, np.array([branch]))
    got = dyads.linkage([describe(mech)], motion)
    scale = g + a + b + c
    assert got.topology == ref.topology
    assert np.abs(got.joint_position - ref.joint_position).max() < 1e-13 * scale
    for name in ("link_angular_velocity", "link_angular_acceleration", "joint_velocity",
                 "joint_acceleration"):
        value, expected = getattr(got, name), getattr(ref, name)
        assert np.abs(value - expected).max() < 1e-10 * (np.abs(expected).max() + 1.0), name


@pytest.mark.parametrize("offset", [0.0, 0.03, -0.05])
@pytest.mark.parametrize("branch", ["open", "crossed"])
def test_slider_crank_preset_matches_the_closed_form(offset, branch):
    mech = {"type": "slider_crank", "crank": 0.1, "rod": 0.3, "offset": offset,
            "slider_mass": 0.4, "branch": branch}
    times = np.linspace(0.0, 1.0, 301)[None]
    motion = kin.input_motion(times, np.array([9.0]), np.array([0.4]))
    ref = kin.slider_crank(np.array([0.1]), np.array([0.3]), np.array([offset]), motion,
                           np.array([1.0 if branch == "open" else -1.0]))
    got = dyads.linkage([describe(mech)], motion)
    for name in ("link_angle", "joint_position", "link_angular_velocity", "joint_velocity",
                 "link_angular_acceleration", "joint_acceleration"):
        value, expected = getattr(got, name), getattr(ref, name)
        assert np.abs(value - expected).max() < 1e-11 * (np.abs(expected).max() + 1.0), name
    assert float(got.guide_angle["slider"][0]) == 0.0


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_six_bar_loop_closure_to_round_off(name):
    scene = _scene(MECHANISMS[name])
    batch = make_batch([scene])
    motion = batch.rigid_motion(np.linspace(0.0, 2 * np.pi / batch.speed[0], 1441)[None])
    topo, position = motion.topology, motion.joint_position[0]
    at = {j: position[:, k] for k, j in enumerate(topo.joint_names)}
    description = describe(scene["mechanism"])
    for i, (link, (first, second)) in enumerate(topo.links.items()):
        length = np.linalg.norm(at[second] - at[first], axis=-1)
        assert np.abs(length - motion.lengths[0, i]).max() < 1e-14
        # Joint angles agree with the link angles.
        d = at[second] - at[first]
        angle = np.arctan2(d[:, 1], d[:, 0])
        assert np.abs(np.angle(np.exp(1j * (angle - motion.link_angle[0, :, i])))).max() < 1e-13
    for point, spec in description["points"].items():
        i = topo.link_names.index(spec["link"])
        th = motion.link_angle[0, :, i]
        r = at[point] - at[topo.links[spec["link"]][0]]
        local = np.stack([np.cos(th) * r[:, 0] + np.sin(th) * r[:, 1],
                          -np.sin(th) * r[:, 0] + np.cos(th) * r[:, 1]], axis=-1)
        assert np.abs(local - spec["at"]).max() < 1e-15
    for pivot, xy in description["ground"].items():
        assert np.abs(at[pivot] - xy).max() == 0.0
    # These geometries keep every dyad well away from a toggle; the RRP's is |cos(θ − φ)|.
    sines = dyads.dyad_sines(motion, description)[0]
    assert sines.shape == (1441, len(description["dyads"]))
    assert 0.3 < sines.min() and sines.max() <= 1.0
    for k, dyad in enumerate(description["dyads"]):
        P, M = (at[j] for j in dyad["joints"][:2])
        if dyad["kind"] == "RRP":
            u = (M - P) / np.linalg.norm(M - P, axis=-1)[:, None]
            guide = dyad["guide"]["angle"]
            assert np.allclose(sines[:, k], np.abs(u @ [math.cos(guide), math.sin(guide)]),
                               rtol=0, atol=1e-14)
        side = (M - P)
        if dyad["kind"] == "RPR":  # Q − P = s e + offset e⊥, the sleeve on the bar
            Q, i = at[dyad["joints"][2]], topo.link_names.index(dyad["links"][0])
            th, L = motion.link_angle[0, :, i], motion.lengths[0, i]
            e = np.stack([np.cos(th), np.sin(th)], -1)
            n = np.stack([-e[:, 1], e[:, 0]], -1)
            slide = motion.slide[dyad["links"][1]][0][0]
            assert np.abs(Q - P - slide[:, None] * e - dyad["offset"] * n).max() < 1e-15
            assert np.all((slide > 0) & (slide <= L))
            assert np.allclose(sines[:, k], slide / L, rtol=0, atol=1e-15)
        elif dyad["kind"] == "RRR":
            Q = at[dyad["joints"][2]]
            cross = (Q - P)[:, 0] * side[:, 1] - (Q - P)[:, 1] * side[:, 0]
            assert np.all(np.sign(cross) == (1 if dyad["branch"] == "open" else -1))
        else:  # M on the guide, on the chosen side of P
            u = np.array([math.cos(dyad["guide"]["angle"]), math.sin(dyad["guide"]["angle"])])
            normal = np.array([-u[1], u[0]])
            assert np.abs((M - dyad["guide"]["point"]) @ normal).max() < 1e-15
            assert np.all(np.sign(side @ u) == (1 if dyad["branch"] == "open" else -1))


@pytest.mark.parametrize("name", sorted(MECHANISMS))
@pytest.mark.parametrize("phase", [0.0, 0.37, 0.81])
def test_six_bar_derivatives_match_finite_differences(name, phase):
    scene = _scene(MECHANISMS[name])
    speed = 100.0
    dt = 1e-4 / speed
    times = (phase * 2 * np.pi / speed + dt * np.arange(-4, 5))[None]
    _, r = _motion(scene, times)
    check_derivatives(r, dt, speed, 1e-7)


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_six_bar_power_balance(name):
    """Input power = d(T + V)/dt with ternary links, point masses, gravity, a slider and the
    sleeves of RPR dyads (their frictionless slide does no work)."""
    # 2048 steps: the central difference below stays within 2e-4 on the shaper's quick return.
    scene = _scene(MECHANISMS[name], time={"revolutions": 1, "steps_per_revolution": 2048})
    batch = make_batch([scene])
    motion = batch.rigid_motion()
    forces = inverse_dynamics(motion, batch.bodies, batch.gravity)
    power = forces.input_torque * motion.link_angular_velocity[..., 0]
    rate = kinetic_energy_rate(motion, batch.bodies, batch.gravity)
    assert np.abs(power - rate).max() < 1e-9 * np.abs(rate).max()
    # The rate itself is checked against a finite difference of T + V along the motion.
    energy = _energy(motion, batch.bodies, batch.gravity)
    h = batch.step_size[0]
    fd = (energy[0, 2:] - energy[0, :-2]) / (2 * h)
    assert np.abs(fd - rate[0, 1:-1]).max() < 2e-4 * np.abs(rate).max()


def _energy(motion, bodies, gravity):
    """T + V of every body from positions and velocities only (central differences check)."""
    from ced.rigid.dyads import point_motion

    total = np.zeros(motion.time.shape)
    g = gravity[:, None, :]
    topo = motion.topology
    for i, link in enumerate(topo.link_names):
        k = topo.joint_names.index(topo.links[link][0])
        base = tuple(x[:, :, k] for x in (motion.joint_position, motion.joint_velocity,
                                          motion.joint_acceleration))
        x, v, _ = point_motion(base, motion.link_angle[..., i],
                               motion.link_angular_velocity[..., i],
                               motion.link_angular_acceleration[..., i], bodies.centre[:, i])
        m = bodies.mass[:, i][:, None]
        w = motion.link_angular_velocity[..., i]
        total += 0.5 * m * np.sum(v * v, -1) + 0.5 * bodies.inertia[:, i][:, None] * w * w
        total -= m * np.sum(x * g, -1)
    masses = bodies.point_mass.copy()
    for s, slider in enumerate(topo.sliders):
        masses[:, topo.joint_names.index(topo.sliders[slider])] += bodies.slider_mass[:, s]
    for s, (pivot, bar) in enumerate(topo.sleeves.values()):  # mass at the pivot, turning
        masses[:, topo.joint_names.index(pivot)] += bodies.sleeve_mass[:, s]
        w = motion.link_angular_velocity[..., topo.link_names.index(bar)]
        total += 0.5 * bodies.sleeve_inertia[:, s][:, None] * w * w
    for k in range(len(topo.joint_names)):
        x, v = motion.joint_position[:, :, k], motion.joint_velocity[:, :, k]
        total += masses[:, k][:, None] * (0.5 * np.sum(v * v, -1) - np.sum(x * g, -1))
    return total


def test_ternary_mass_properties_of_a_bell_crank():
    """Rocker of the Watt II: bars D→C (0.35 m) and D→E (0.25 m at 2.5 rad), welded at D."""
    scene = _scene(WATT_II)
    bodies = make_batch([scene]).bodies
    i = list(scene["links"]).index("rocker")
    link = scene["links"]["rocker"]
    rho_a = link["material"]["rho"] * link["section"]["area"]
    rho_i = link["material"]["rho"] * link["section"]["second_moment"]
    m1, m2 = rho_a * 0.35, rho_a * 0.25
    c1, c2 = np.array([0.175, 0.0]), 0.125 * np.array([math.cos(2.5), math.sin(2.5)])
    centre = (m1 * c1 + m2 * c2) / (m1 + m2)
    # Inertia about D: Σ ρAℓ³/3 + ρIℓ; then about the centre by the parallel-axis theorem.
    about_d = rho_a * (0.35**3 + 0.25**3) / 3 + rho_i * (0.35 + 0.25)
    assert bodies.mass[0, i] == pytest.approx(m1 + m2, rel=1e-14)
    assert np.allclose(bodies.centre[0, i], centre, rtol=1e-14, atol=0)
    assert bodies.inertia[0, i] == pytest.approx(about_d - (m1 + m2) * centre @ centre,
                                                 rel=1e-12)


@pytest.mark.parametrize("kind", ["watt_ii", "stephenson_iii"])
def test_massless_second_loop_leaves_the_four_bar_torque(kind):
    """Exact limit: a second dyad of vanishing density adds nothing to the first loop, whose
    input torque is then the four-bar's with the ternary link's own mass properties."""
    light = {"material": {"E": 2.1e11, "rho": 1e-9, "nu": 0.3}, "flexible": False}
    six = load_scene({**RIGID, "mechanism": MECHANISMS[kind], "effects": ["inertia", "gravity"],
                      "links": {"coupler2": light, "rocker2": light}})
    loop = {k: MECHANISMS[kind][k] for k in ("ground", "crank", "coupler", "rocker")}
    four = load_scene({**RIGID, "mechanism": {"type": "four_bar", **loop},
                       "effects": ["inertia", "gravity"]})
    b6, b4 = make_batch([six]), make_batch([four])
    # The four-bar's links with the six-bar's mass properties (the ternary link's arm counts).
    n = len(b4.topology.links)
    bodies = BodyProperties(b6.bodies.mass[:, :n], b6.bodies.inertia[:, :n],
                            b4.bodies.point_mass, b4.bodies.slider_mass, b6.bodies.centre[:, :n])
    arm = "rocker" if kind == "watt_ii" else "coupler"
    i = b4.topology.link_names.index(arm)
    assert bodies.mass[0, i] > 1.5 * b4.bodies.mass[0, i]  # the arm is really there
    t6 = inverse_dynamics(b6.rigid_motion(), b6.bodies, b6.gravity).input_torque
    t4 = inverse_dynamics(b4.rigid_motion(), bodies, b4.gravity).input_torque
    assert np.abs(t6 - t4).max() < 1e-8 * np.abs(t4).max()


@given(four_bars())
@settings(max_examples=30, deadline=None)
def test_dyad_sines_of_a_four_bar_reach_the_exact_minimum(linkage):
    """The sampled transmission of the one RRR dyad against the four-bar's exact minimum."""
    from ced.problem.mechanism import dyad_sine_min

    g, a, b, c, branch = linkage
    mech, motion = _four_bar_cycle(linkage, 4001)
    sines = dyads.dyad_sines(dyads.linkage([describe(mech)], motion), describe(mech))
    exact = float(dyad_sine_min(g, a, b, c, *drive_of(g, a, b, c)))
    assert sines.shape == (1, 4001, 1)
    # Never below the exact minimum; the sampled minimum is within a step of it.
    assert sines.min() >= exact - 1e-12
    assert sines.min() - exact < 1e-3 + 2e-5 / max(exact, 1e-3)


def _inverted_slider_crank(d, a, offset=0.0, length=None, speed=7.0, samples=721):
    """Crank A→B (a) about A = (0, 0), RPR lever about O = (d, 0) through the block at B."""
    dist_max = math.sqrt((d + a) ** 2 - offset**2)
    mech = {"type": "linkage", "ground": {"A": [0.0, 0.0], "O": [d, 0.0]},
            "input": {"link": "crank", "pivot": "A", "tip": "B", "length": a},
            "dyads": [{"kind": "RPR", "links": ["lever", "block"], "joints": ["O", "T", "B"],
                       "lengths": [length or 1.2 * dist_max], "offset": offset}]}
    times = np.linspace(0.0, 2 * np.pi / speed, samples)[None]
    motion = kin.input_motion(times, np.array([speed]), np.array([0.0]))
    return mech, dyads.linkage([describe(load_scene({**RIGID, "mechanism": mech})["mechanism"])],
                               motion)


@pytest.mark.parametrize("d, a", [(0.25, 0.1), (0.1, 0.25)])
def test_rpr_inverted_slider_crank_matches_the_textbook_closed_form(d, a):
    """The centred inverted slider-crank (crank shaper for a < d, Whitworth's rotating lever
    for a > d): with B − O = (a cos θ2 − d, a sin θ2), the lever's angle is
    θ4 = atan2(a sin θ2, a cos θ2 − d), the block's distance from O b² = a² + d² − 2ad cos θ2,
    and differentiating tan θ4 at constant crank speed ω2,
    ω4 = ω2 a (a − d cos θ2)/b², α4 = ω2² a d (d² − a²) sin θ2 / b⁴, ḃ = ω2 a d sin θ2 / b."""
    w2 = 7.0
    _, r = _inverted_slider_crank(d, a, speed=w2)
    th2 = r.link_angle[0, :, 0]
    b2 = a * a + d * d - 2 * a * d * np.cos(th2)
    th4 = np.arctan2(a * np.sin(th2), a * np.cos(th2) - d)
    lever = r.link_angle[0, :, 1]
    assert np.abs(np.angle(np.exp(1j * (lever - th4)))).max() < 1e-14
    s, ds, _ = (x[0] for x in r.slide["block"])
    assert np.abs(s - np.sqrt(b2)).max() < 1e-15
    assert np.abs(ds - w2 * a * d * np.sin(th2) / np.sqrt(b2)).max() < 1e-14
    w4 = w2 * a * (a - d * np.cos(th2)) / b2
    assert np.abs(r.link_angular_velocity[0, :, 1] - w4).max() < 1e-13 * np.abs(w4).max()
    al4 = w2**2 * a * d * (d * d - a * a) * np.sin(th2) / b2**2
    assert np.abs(r.link_angular_acceleration[0, :, 1] - al4).max() < 1e-12 * np.abs(al4).max()


def test_rpr_crank_shaper_quick_return():
    """The crank shaper's lever stops where it is tangent to the crank circle (OB ⟂ AB,
    cos θ2 = a/d), its swing there ±asin(a/d) about the line of centres, and the crank turns
    2 arccos(a/d) on one stroke and 2π − 2 arccos(a/d) on the other: the time ratio of the
    quick return."""
    d, a = 0.25, 0.1
    stop = math.acos(a / d)
    mech, _ = _inverted_slider_crank(d, a)
    motion = kin.input_motion(np.array([[0.0, stop / 7.0, (2 * np.pi - stop) / 7.0]]),
                              np.array([7.0]), np.array([0.0]))
    r = dyads.linkage([describe(load_scene({**RIGID, "mechanism": mech})["mechanism"])], motion)
    assert np.abs(r.link_angular_velocity[0, 1:, 1]).max() < 1e-15
    swing = np.angle(np.exp(1j * (r.link_angle[0, 1:, 1] - math.pi)))  # from the line O→A
    assert np.allclose(swing, [-math.asin(a / d), math.asin(a / d)], rtol=0, atol=1e-15)
    # Between the stops the lever turns one way only: sampled on a fine grid.
    _, fine = _inverted_slider_crank(d, a, samples=36001)
    th2 = fine.link_angle[0, :, 0]
    forward = fine.link_angular_velocity[0, :, 1] > 0  # ω4 ∝ a − d cos θ2
    inside = (th2 > stop + 1e-3) & (th2 < 2 * np.pi - stop - 1e-3)
    outside = (th2 < stop - 1e-3) | (th2 > 2 * np.pi - stop + 1e-3)
    assert forward[inside].all() and not forward[outside].any()
    ratio = (2 * np.pi - 2 * stop) / (2 * stop)
    assert inside.sum() / outside.sum() == pytest.approx(ratio, rel=2e-3)


@given(d=st.floats(0.1, 0.6), crank=st.floats(0.05, 0.9), offset=st.floats(-0.9, 0.9),
       extra=st.floats(1.0, 2.0), phase=st.floats(0.0, 1.0))
@settings(max_examples=40, deadline=None)
def test_rpr_closure_derivatives_and_power_balance(d, crank, offset, extra, phase):
    """Any assemblable inverted slider-crank (crank a = crank·d, |offset| a fraction of the
    smallest |OB| = d − a): Q − P = s e + offset e⊥ to round-off, rates and accelerations
    against finite differences, and input power = d(T + V)/dt with the block's mass and
    inertia and gravity."""
    a = crank * d
    e = offset * (d - a)
    length = extra * math.sqrt((d + a) ** 2 - e * e)
    mech = {"type": "linkage", "ground": {"A": [0.0, 0.0], "O": [d, 0.0]},
            "input": {"link": "crank", "pivot": "A", "tip": "B", "length": a},
            "dyads": [{"kind": "RPR", "links": ["lever", "block"], "joints": ["O", "T", "B"],
                       "lengths": [length], "offset": e, "sleeve_mass": 0.3,
                       "sleeve_inertia": 1e-3}]}
    scene = _scene(mech)
    speed = 100.0
    dt = 1e-4 / speed
    times = (phase * 2 * np.pi / speed + dt * np.arange(-4, 5))[None]
    batch, r = _motion(scene, times)
    check_derivatives(r, dt, speed, 1e-6)
    th = r.link_angle[0, :, 1]
    P, Q = r.joint_position[0, :, 1], r.joint_position[0, :, 3]
    s = r.slide["block"][0][0]
    closure = Q - P - s[:, None] * np.stack([np.cos(th), np.sin(th)], -1) \
        - e * np.stack([-np.sin(th), np.cos(th)], -1)
    assert np.abs(closure).max() < 1e-15 * 4
    forces = inverse_dynamics(r, batch.bodies, batch.gravity)
    power = forces.input_torque * r.link_angular_velocity[..., 0]
    rate = kinetic_energy_rate(r, batch.bodies, batch.gravity)
    assert np.abs(power - rate).max() < 1e-9 * (np.abs(rate).max() + np.abs(power).max())


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_transmission_from_positions_is_the_rigid_motions(name):
    """The near_singular check's measures (positions only, the assembly check's placement,
    ced.problem.linkage.transmission) equal dyad_sines of the tracked rigid motion."""
    from ced.problem.linkage import transmission

    scene = _scene(MECHANISMS[name])
    batch = make_batch([scene])
    motion = batch.rigid_motion(np.linspace(0.0, 2 * np.pi / batch.speed[0], 721)[None])
    description = describe(scene["mechanism"])
    expected = dyads.dyad_sines(motion, description)[0]
    got = transmission(description, motion.link_angle[0, :, 0])
    assert got.shape == expected.shape
    assert np.abs(got - expected).max() < 1e-12


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_compiled_point_placement_is_the_numpy_one_bit_for_bit(monkeypatch, name):
    """The joints placed from a link's frame (a dyad's middle joint, a point of a link) and
    an RRR dyad's rates and accelerations by the compiled loops, as by numpy's expressions
    (CED_KERNEL=numpy)."""
    scenes = [_scene(MECHANISMS[name], drive={"speed": w}) for w in (7.0, 23.0)]
    batch = make_batch(scenes)
    times = batch.step_size[:, None] * np.arange(0.0, 70.0, 1.3)[None]
    out = []
    for compiled in (True, False):
        monkeypatch.setattr(kin, "COMPILED", compiled)
        out.append(make_batch(scenes)._solve_motion(times))
    for field in ("joint_position", "joint_velocity", "joint_acceleration", "link_angle",
                  "link_angular_velocity", "link_angular_acceleration"):
        assert np.array_equal(getattr(out[0], field), getattr(out[1], field)), field


#: A linkage of one RRR dyad that passes its change points (crank + ground = coupler + rocker,
#: 0.1 + 0.4 = 0.35 + 0.15), started on one (θ0 = 0 and π) and off them.
_CHANGE_POINT_DYAD = {"type": "linkage", "ground": {"A": [0.0, 0.0], "D": [0.4, 0.0]},
                      "input": {"link": "crank", "pivot": "A", "tip": "B", "length": 0.1},
                      "dyads": [{"kind": "RRR", "links": ["coupler", "rocker"],
                                 "joints": ["B", "C", "D"], "lengths": [0.35, 0.15]}]}


@pytest.mark.parametrize("start", [0.0, math.pi, 0.3])
def test_compiled_rrr_placement_is_the_numpy_one_through_change_points(monkeypatch, start):
    """dyads._rrr_compiled as _rrr's numpy expressions bit for bit where the dyad's solutions
    meet: the branch tracked along the grid through its singular steps (their rates
    interpolated), and followed off the grid."""
    scenes = [load_scene({**RIGID, "mechanism": _CHANGE_POINT_DYAD,
                          "drive": {"speed": w, "initial_angle": start},
                          "time": {"revolutions": 2, "steps_per_revolution": 64}})
              for w in (10.0, 37.0)]
    out = []
    for compiled in (True, False):
        monkeypatch.setattr(kin, "COMPILED", compiled)
        batch = make_batch(scenes)
        grid = batch.rigid_motion(batch.step_size[:, None] * np.arange(129)[None])
        off = batch.rigid_motion(batch.step_size[:, None] * (3.3 * np.arange(37) + 0.25)[None])
        out.append((grid, off))
    assert out[0][0].singular.any() == (start != 0.3)
    for got, want in zip(*out):
        for field in ("joint_position", "joint_velocity", "joint_acceleration", "link_angle",
                      "link_angular_velocity", "link_angular_acceleration", "singular"):
            assert np.array_equal(getattr(got, field), getattr(want, field)), field
        assert np.array_equal(got.branch["coupler"], want.branch["coupler"])
