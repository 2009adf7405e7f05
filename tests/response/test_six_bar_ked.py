"""KED of six-bars (linkages of dyads): exact limits against the four-bar and the beam, the
near_singular flag at a toggle of the second dyad, periodic start, Floquet and convergence."""
import math

import numpy as np
import pytest

from ced.fem.eigenproblem import natural_frequencies
from ced.problem.scene import load_scene
from ced.response.batch import make_batch
from ced.response.model import build_model, terms_at
from ced.simulation.simulate import simulate

FOUR_BAR = {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35}
#: A Watt II whose point E lies on the rocker's bar (no arm: the rocker's body is the
#: four-bar's) and whose second loop D–E–F–G assembles over the whole cycle.
WATT_ON_BAR = {**FOUR_BAR, "type": "watt_ii", "rocker_arm": 0.25, "rocker_arm_angle": 0.0,
               "coupler2": 0.4, "rocker2": 0.3, "pivot2_x": 0.2, "pivot2_y": -0.3}
#: Featherweight (1e-9 of steel's density), stiff (1000 × steel) material of the second dyad;
#: a flexible second dyad takes 1e-3 of steel's density (a lighter, stiffer beam only tests
#: the round-off of eigen-solves whose frequencies span eight decades).
GHOST = {"E": 2.1e14, "rho": 7.85e-6, "nu": 0.3}
GHOST_BEAM = {"E": 2.1e14, "rho": 7.85, "nu": 0.3}
ALL_EFFECTS = ["inertia", "elastic_inertia", "coriolis", "centrifugal", "axial_stiffening",
               "gravity"]


def _scene(mechanism, links, **extra):
    scene = {"mechanism": mechanism,
             "links": {"default": {"section": {"shape": "rectangle", "height": 0.008,
                                               "width": 0.008}},
                       "crank": {"flexible": False}, "rocker": {"flexible": False}, **links},
             "drive": {"speed": 60.0}, "effects": ALL_EFFECTS, "gravity": [0.0, -9.81],
             "discretization": {"formulation": "euler_bernoulli", "elements_per_link": 6},
             "time": {"revolutions": 1, "steps_per_revolution": 256, "start": "periodic"},
             "modal": {"modes": 3, "angles": 8}}
    scene.update(extra)
    return scene


@pytest.mark.parametrize("second_dyad_flexible", [False, True])
def test_watt_ii_with_a_massless_stiff_second_dyad_is_the_four_bar(second_dyad_flexible):
    """The first loop's elastic coupler of a Watt II whose second dyad weighs nothing and does
    not deform responds as the four-bar's: the rigid ternary rocker carries E on its bar,
    its loads are resultants (not the bar's distributed loads), and its axial stiffening is
    Σ F·r (not ∫N ds) — equal in this limit."""
    ghost = {"material": GHOST_BEAM if second_dyad_flexible else GHOST,
             "flexible": second_dyad_flexible}
    four = simulate([_scene(FOUR_BAR, {})])
    watt = simulate([_scene(WATT_ON_BAR, {"coupler2": ghost, "rocker2": ghost})])
    # The flexible ghost dyad's frequencies span eight decades: its result carries the
    # round-off of P amplified (one-ulp random perturbations of P moved the stress by
    # 1.8e-4 to 3.4e-4, measured), so its bound is 1e-3, not the rigid limit's 1e-9.
    tol = 1e-9 if not second_dyad_flexible else 1e-3
    for name in ("peak_deflection", "peak_stress"):
        a = four[name].sel(link="coupler").values
        b = watt[name].sel(link="coupler").values
        assert abs(b - a) <= tol * abs(a), (name, a, b)
    a = four.deflection.sel(link="coupler").values
    b = watt.deflection.sel(link="coupler").values
    assert np.abs(b - a).max() <= tol * np.abs(a).max()
    if not second_dyad_flexible:  # the stiff dyad's own modes are far above
        assert np.allclose(watt.natural_frequency.values, four.natural_frequency.values,
                           rtol=1e-9)


#: The Watt II of the rigid tests: the rocker a ternary link with an arm, both couplers of
#: interest flexible.
WATT_II = {"type": "watt_ii", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35,
           "rocker_arm": 0.25, "rocker_arm_angle": 2.5, "coupler2": 0.4, "rocker2": 0.3,
           "pivot2_x": 0.2, "pivot2_y": -0.3}


def test_pinned_pinned_second_coupler_has_the_beams_frequencies():
    """Everything rigid but the second coupler, the rocker of the second dyad 1e6 times as
    dense: E (on the rigid first loop) and F (held by the heavy rocker's inertia) stand still
    for the coupler's bending modes, which are then a pinned-pinned beam's,
    f_n = (nπ)²/(2πL²) √(EI/ρA), frozen at any instant of a slow motion."""
    heavy = {"material": {"E": 2.1e11, "rho": 7.85e9, "nu": 0.3}, "flexible": False}
    scene = load_scene(_scene(
        WATT_II, {"coupler": {"flexible": False}, "coupler2": {"flexible": True},
                  "rocker2": heavy},
        effects=["inertia", "elastic_inertia"], drive={"speed": 1.0},
        discretization={"formulation": "euler_bernoulli", "elements_per_link": 16}))
    batch = make_batch([scene])
    model = build_model(batch)
    terms, _ = terms_at(model, np.array([[0.0, 1.3]]), extras=frozenset({"elastic_mass"}))
    freq = natural_frequencies(terms.stiffness, terms.elastic_mass, 4)
    E, rho = (batch.link_property("coupler2", "material", k)[0] for k in ("E", "rho"))
    I, A = (batch.link_property("coupler2", "section", k)[0] for k in ("second_moment", "area"))
    L = 0.4
    exact = [(n * math.pi) ** 2 / (2 * math.pi * L * L) * math.sqrt(E * I / (rho * A))
             for n in (1, 2, 3)]
    # Mode 0: the heavy rocker swinging on the coupler's axial stiffness (far below).
    assert np.all(np.abs(freq[..., 0]) < 0.05 * exact[0])
    # Hermite cubics: the error grows as n⁴ (1.3e-6, 1.7e-5, 8.3e-5 at 16 elements).
    assert np.allclose(freq[..., 1], exact[0], rtol=2e-6)
    assert np.allclose(freq[..., 1:], exact, rtol=1.5e-4)


def _second_toggle(margin):
    """A Watt II whose second dyad (coupler2 0.2 m) stretches to (1 − margin) of its full
    length at the farthest E–G distance of the cycle: there sin²μ ≈ 8.3 margin."""
    scene = load_scene(_scene(WATT_II, {}, discretization={"formulation": "rigid"}))
    motion = make_batch([scene]).rigid_motion()
    names = motion.topology.joint_names
    E = motion.joint_position[0, :, names.index("E")]
    far = np.hypot(E[:, 0] - 0.2, E[:, 1] + 0.3).max()
    return {**WATT_II, "coupler2": 0.2, "rocker2": far / (1 - margin) - 0.2}


@pytest.mark.parametrize("margin, flagged", [(2e-4, True), (5e-4, True), (0.1, False)])
def test_near_singular_flagged_near_a_toggle_of_the_second_dyad(margin, flagged):
    """The second dyad's transmission sine falls below 0.1 near its toggle: flagged (the
    first loop alone is far from one: sin μ ≥ 0.85), and the flag is not set far from it."""
    mech = _second_toggle(margin)
    scene = _scene(mech, {}, time={"revolutions": 1, "steps_per_revolution": 128,
                                   "start": "quasi_static"})
    scene.pop("modal")
    ds = simulate([scene])
    assert bool(ds.status.values[0] & 2) == flagged


def test_periodic_start_floquet_and_error_estimate_of_a_watt_ii_batch():
    """Two Watt II cases (two speeds) with flexible couplers: periodic steady state with its
    Floquet multiplier, the cycle's frequencies and the error estimate, all finite; and the
    peak deflection converges at second order in the step (Newmark)."""
    links = {"coupler": {"flexible": True}, "coupler2": {"flexible": True}}
    scenes = [_scene(WATT_II, links, drive={"speed": w},
                     outputs={"error_estimate": True}) for w in (40.0, 60.0)]
    ds = simulate(scenes)
    for name in ("peak_deflection", "peak_stress", "natural_frequency",
                 "floquet_multiplier_max", "error_estimate"):
        assert np.all(np.isfinite(ds[name].values)), name
    assert np.all(ds.floquet_multiplier_max.values <= 1.0 + 1e-6)
    assert np.all(ds.error_estimate.values < 0.05)

    def end(spr):  # from rest, at the end of the revolution (a peak is sampled on the grid)
        one = _scene(WATT_II, links, time={"revolutions": 1, "steps_per_revolution": spr,
                                           "start": "undeformed", "integrator": "newmark"})
        one.pop("modal")
        return simulate([one]).deflection.sel(link="coupler2").values[0, -1]
    ref = end(4096)
    errs = [np.abs(end(n) - ref).max() for n in (256, 512)]
    assert 1.7 < math.log2(errs[0] / errs[1]) < 2.5


# ------------------------------------------------------------------------- RPR dyads
def _inverted_slider_crank(d, a, lever, offset=0.0, sleeve=(0.05, 4e-4), **extra):
    """A flexible crank A→B (clamped at A) carrying the block of an RPR dyad whose rigid
    lever turns about the ground pivot O = (d, 0); the lever's end T is free."""
    mech = {"type": "linkage", "ground": {"A": [0.0, 0.0], "O": [d, 0.0]},
            "input": {"link": "crank", "pivot": "A", "tip": "B", "length": a},
            "dyads": [{"kind": "RPR", "links": ["lever", "block"], "joints": ["O", "T", "B"],
                       "lengths": [lever], "offset": offset, "sleeve_mass": sleeve[0],
                       "sleeve_inertia": sleeve[1]}]}
    scene = {"mechanism": mech, "drive": {"speed": 1.0},
             "links": {"default": {"section": {"shape": "rectangle", "height": 0.01,
                                               "width": 0.01}}},
             "effects": ["inertia", "elastic_inertia"],
             "discretization": {"formulation": "euler_bernoulli", "elements_per_link": 16}}
    scene.update(extra)
    return load_scene(scene)


def _cantilever_with_tip_mass(batch, link, tip_mass):
    """First frequency (Hz) of a clamped-free Euler–Bernoulli beam with a tip mass M:
    1 + cos λ cosh λ + μλ (cos λ sinh λ − sin λ cosh λ) = 0, μ = M/(ρAL),
    ω = λ² √(EI/(ρA L⁴)) (Blevins, Formulas for natural frequency and mode shape, table 8-8)."""
    from scipy.optimize import brentq

    E, rho = (batch.link_property(link, "material", k)[0] for k in ("E", "rho"))
    A, I = (batch.link_property(link, "section", k)[0] for k in ("area", "second_moment"))
    L = batch.link_lengths[0, batch.topology.link_names.index(link)]
    mu = tip_mass / (rho * A * L)
    lam = brentq(lambda x: 1 + math.cos(x) * math.cosh(x)
                 + mu * x * (math.cos(x) * math.sinh(x) - math.sin(x) * math.cosh(x)),
                 1e-3, 1.8751040687)
    return lam * lam * math.sqrt(E * I / (rho * A * L**4)) / (2 * math.pi)


def test_rpr_sleeve_and_lever_weigh_on_the_crank_tip_as_the_textbook_tip_mass():
    """Frozen, the block at the flexible crank's tip B turns the rigid lever by
    φ = e⊥·U_B/s (s = |OB|): the crank's bending mode carries the block's mass plus
    (J_block + I_O,lever) cos²(θ_lever − θ_crank)/s², the lever's and block's rotary inertia
    felt across the lever. Crank and lever in line (θ2 = 0): all of it; lever square to the
    crank (the quick-return stop, cos θ2 = a/d): the block's mass only. Both against the
    cantilever with a tip mass."""
    from ced.fem.eigenproblem import natural_frequencies

    d, a, lever = 0.5, 0.2, 0.8
    m_s, J_s = 0.05, 4e-4
    batch = make_batch([_inverted_slider_crank(d, a, lever, sleeve=(m_s, J_s))])
    terms, _ = terms_at(build_model(batch), np.array([[0.0, math.acos(a / d)]]),
                        extras=frozenset({"elastic_mass"}))
    freq = natural_frequencies(terms.stiffness, terms.elastic_mass, 2)[0, :, 0]
    rho, A, I = (batch.link_property("lever", g, k)[0] for g, k in (
        ("material", "rho"), ("section", "area"), ("section", "second_moment")))
    about_o = rho * A * lever**3 / 3 + rho * I * lever
    in_line = _cantilever_with_tip_mass(batch, "crank", m_s + (J_s + about_o) / (d - a) ** 2)
    square = _cantilever_with_tip_mass(batch, "crank", m_s)
    assert in_line < 0.3 * square  # the lever's inertia is really felt
    # Hermite cubics, 16 elements: ~1e-8.
    assert freq[0] == pytest.approx(in_line, rel=1e-7)
    assert freq[1] == pytest.approx(square, rel=1e-7)


def test_rpr_geometric_stiffness_is_the_hessian_of_the_dyads_weight():
    """Static (gravity, no inertia), at the instant the lever (offset 0.04 m from B) lies along
    the crank with gravity square to both, the crank carries no axial force: the stiffness
    that gravity adds (axial_stiffening) is the RPR's alone, the lever's ∫N ds and the
    sleeve's normal force on the closure's second order. It must be the Hessian of the
    lever's potential −m g·x_G in the crank tip's translation U_B, the lever placed exactly
    (θ = angle(B + U_B − O) − atan2(offset, s)), by central differences."""
    from scipy.optimize import brentq

    d, a, lever, offset = 0.5, 0.2, 0.8, 0.04
    O = np.array([d, 0.0])

    def lever_angle(B):
        D = B - O
        s = math.sqrt(D @ D - offset**2)
        return math.atan2(D[1], D[0]) - math.atan2(offset, s)

    def tip(theta):
        return a * np.array([math.cos(theta), math.sin(theta)])

    theta = brentq(lambda t: math.sin(lever_angle(tip(t)) - t), -0.1, -0.05)
    g = -9.81 * np.array([-math.sin(theta), math.cos(theta)])
    scene = _inverted_slider_crank(d, a, lever, offset, drive={"speed": 1.0,
                                                               "initial_angle": theta},
                                   gravity=list(g), effects=["gravity", "axial_stiffening"],
                                   discretization={"formulation": "euler_bernoulli",
                                                   "elements_per_link": 4})
    batch = make_batch([scene])
    model = build_model(batch)
    t = np.zeros((1, 1))
    loaded, P = terms_at(model, t)
    unloaded, _ = terms_at(model, t, effects={"axial_stiffening"})
    added = (loaded.stiffness - unloaded.stiffness)[0, 0]
    nf = P.shape[-1]
    # Only U_B's coordinates: the crank's interior DOFs take no stiffness (round-off only).
    assert np.abs(added[nf:]).max() < 1e-12 and np.abs(added[:, nf:]).max() < 1e-12
    i = batch.topology.link_names.index("lever")
    m, centre = batch.bodies.mass[0, i], batch.bodies.centre[0, i]

    def potential(U):
        th = lever_angle(tip(theta) + U)
        R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        return -m * g @ (O + R @ centre)

    h, eye = 1e-4, np.eye(2)
    hessian = np.array([[(potential(h * (eye[i] + eye[j])) - potential(h * (eye[i] - eye[j]))
                          - potential(h * (eye[j] - eye[i])) + potential(-h * (eye[i] + eye[j])))
                         / (4 * h * h) for j in range(2)] for i in range(2)])
    off = model.layout.joint_offsets["B"]
    PB = P[0, 0, off:off + 2]
    expected = PB.T @ hessian @ PB
    assert np.abs(hessian).max() > 1.0  # N/m: the lever's weight is really felt
    assert np.abs(added[:nf, :nf] - expected).max() < 1e-6 * np.abs(expected).max()


def test_rpr_loads_reach_the_flexible_crank_through_its_pin():
    """The rigid lever and block are in dynamic equilibrium under their d'Alembert and
    weight loads and the pin forces at O and B: over the small motion the elastic
    coordinates give them (their (u0, v0, φ) and U_B by the projection), their loads do the
    work of minus the pin force at B on U_B. So doubling their masses (lever density, block
    mass and inertia) adds to the load vector exactly −(∂U_B/∂y)ᵀ ΔF_B, ΔF_B the change of
    the rigid analysis's force on the block at B, and nothing on the crank's own DOFs."""
    from ced.rigid.inverse_dynamics import inverse_dynamics

    def loads(factor):
        steel = {"E": 2.1e11, "rho": 7850.0 * factor, "nu": 0.3}
        scene = _inverted_slider_crank(
            0.25, 0.1, 0.45, 0.02, sleeve=(0.4 * factor, 3e-4 * factor),
            drive={"speed": 30.0}, effects=["inertia", "gravity"], gravity=[0.3, -9.81],
            links={"default": {"section": {"shape": "rectangle", "height": 0.01,
                                           "width": 0.01}},
                   "lever": {"material": steel, "flexible": False}})
        batch = make_batch([scene])
        times = np.linspace(0.0, 2 * math.pi / 30.0, 17)[None, :-1]
        terms, P = terms_at(build_model(batch), times)
        rigid = inverse_dynamics(batch.rigid_motion(times), batch.bodies, batch.gravity)
        B = batch.topology.joint_names.index("B")
        return terms.force[0], P[0], rigid.joint_force[0, :, B], build_model(batch).layout

    F1, P, FB1, layout = loads(1.0)
    F2, _, FB2, _ = loads(2.0)
    nf = P.shape[-1]
    off = layout.joint_offsets["B"]
    expected = -np.einsum("saf,sa->sf", P[:, off:off + 2], FB2 - FB1)
    assert np.abs(expected).max() > 1.0
    assert np.abs((F2 - F1)[:, :nf] - expected).max() < 1e-10 * np.abs(expected).max()
    assert np.abs((F2 - F1)[:, nf:]).max() < 1e-10 * np.abs(expected).max()


#: Whitworth's shaper with a four-bar output: the crank drives the slotted lever through its
#: block (RPR); the lever's end C drives an RRR dyad (coupler C→F, rocker G→F).
SHAPER_RRR = {"type": "linkage", "ground": {"A": [0.0, 0.0], "O": [0.0, -0.25],
                                            "G": [0.35, 0.3]},
              "input": {"link": "crank", "pivot": "A", "tip": "B", "length": 0.1},
              "dyads": [{"kind": "RPR", "links": ["lever", "block"], "joints": ["O", "C", "B"],
                         "lengths": [0.45], "sleeve_mass": 0.4, "sleeve_inertia": 3e-4},
                        {"kind": "RRR", "links": ["coupler", "rocker"],
                         "joints": ["C", "F", "G"], "lengths": [0.3, 0.25]}]}


def test_shaper_with_a_flexible_output_dyad_runs_the_whole_ked():
    """Crank, RPR (rigid lever and block) and a flexible RRR dyad: periodic steady state and
    its Floquet multiplier, the cycle's frequencies and the error estimate, all finite; the
    flexible links deflect, the rigid lever does not."""
    scene = _scene(SHAPER_RRR, {"crank": {"flexible": True}, "rocker": {"flexible": True},
                                "coupler": {"flexible": True}},
                   drive={"speed": 30.0}, outputs={"error_estimate": True},
                   time={"revolutions": 1, "steps_per_revolution": 256, "start": "periodic"})
    ds = simulate([scene])
    assert list(ds.link.values) == ["crank", "lever", "coupler", "rocker"]
    for name in ("peak_deflection", "peak_stress", "natural_frequency",
                 "floquet_multiplier_max", "error_estimate"):
        assert np.all(np.isfinite(ds[name].values)), name
    assert np.all(ds.floquet_multiplier_max.values <= 1.0 + 1e-6)
    peak = ds.peak_deflection.sel(case=0)
    assert float(peak.sel(link="lever")) == 0.0
    assert all(float(peak.sel(link=n)) > 0.0 for n in ("crank", "coupler", "rocker"))
    assert not ds.status.values[0] & (2 | 16)  # neither near_singular nor failed


@pytest.mark.parametrize("crank, flagged", [(0.21, True), (0.1, False)])
def test_near_singular_flagged_as_the_block_nears_the_lever_pivot(crank, flagged):
    """The block comes within |AO| − crank of the lever's pivot: s/L = 0.04/0.5 < 0.1 is
    flagged, 0.15/0.5 is not."""
    mech = {"type": "linkage", "ground": {"A": [0.0, 0.0], "O": [0.0, -0.25]},
            "input": {"link": "crank", "pivot": "A", "tip": "B", "length": crank},
            "dyads": [{"kind": "RPR", "links": ["lever", "block"], "joints": ["O", "C", "B"],
                       "lengths": [0.5], "sleeve_mass": 0.1}]}
    scene = _scene(mech, {"crank": {"flexible": True}},
                   time={"revolutions": 1, "steps_per_revolution": 128,
                         "start": "quasi_static"})
    scene.pop("modal")
    scene["links"].pop("rocker")
    ds = simulate([scene])
    assert bool(ds.status.values[0] & 2) == flagged
