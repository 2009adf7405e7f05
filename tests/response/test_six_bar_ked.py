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
    tol = 1e-9 if not second_dyad_flexible else 1e-4
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
