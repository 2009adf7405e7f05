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
