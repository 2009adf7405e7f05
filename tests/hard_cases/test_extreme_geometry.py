"""Link-length ratio 1:100, very soft and very stiff materials, deflections beyond 1 %."""
import numpy as np
import pytest

from ced.problem.mechanism import NEAR_SINGULAR_SIN
from ced.response.elastic import LARGE_DEFLECTION
from ced.simulation.simulate import simulate
from tests.hard_cases.helpers import assert_finite, flags

L, H, W = 0.5, 0.005, 0.01


def test_length_ratio_one_to_hundred():
    # Crank 0.01 m against a 1 m coupler and ground: a crank-rocker whose coupler barely
    # swings (the transmission angle stays within ±0.6° of its mean, far from a toggle).
    ds = simulate({"mechanism": {"type": "four_bar", "ground": 1.0, "crank": 0.01,
                                 "coupler": 1.0, "rocker": 0.5},
                   "drive": {"speed": 20.0},
                   "discretization": {"elements_per_link": 2},
                   "time": {"revolutions": 1, "steps_per_revolution": 64, "start": "periodic"},
                   "modal": {"modes": 3, "angles": 8}, "outputs": {"stations": 3}})
    assert str(ds.family.values[0]) == "crank_rocker"
    assert_finite(ds)
    B, C = ds.joint_position.values[0, :, 1], ds.joint_position.values[0, :, 2]
    assert np.abs(np.linalg.norm(C - B, axis=-1) - 1.0).max() < 1e-12
    angle = ds.link_angle.values[0]
    assert np.abs(np.sin(angle[:, 1] - angle[:, 2])).min() > NEAR_SINGULAR_SIN
    # Never near_singular etc.; the 10 mm crank is only two 5 mm section depths long, so it
    # is no beam (thick_link, docs/fidelity.md).
    assert flags(ds) <= {"parametrically_unstable", "resonant", "thick_link"}
    assert "thick_link" in flags(ds)
    assert float(ds.natural_frequency.min()) > 0


def cantilever(material):
    # A cantilever turning slowly (0.5 rad/s) in the vertical plane: quasi-static under its
    # own weight. Horizontal (step 0), uniform load q = ρAg downwards: w(x) = −q x²(6L² − 4Lx +
    # x²)/(24EI), so mid-span sits at −17qL⁴/384EI, above the chord's midpoint at
    # w(L)/2 = −24qL⁴/384EI: the deflection from the chord is +7qL⁴/(384 EI) (link y up).
    return {"mechanism": {"type": "single_link", "length": L},
            "links": {"default": {"material": material,
                                  "section": {"shape": "rectangle", "height": H, "width": W}}},
            "drive": {"speed": 0.5},
            "effects": ["inertia", "elastic_inertia", "gravity", "coriolis", "centrifugal",
                        "axial_stiffening"],
            "discretization": {"elements_per_link": 4},
            "time": {"revolutions": 1, "steps_per_revolution": 64, "start": "periodic"},
            "modal": {"modes": 2, "angles": 4}, "outputs": {"stations": 3}}


@pytest.mark.parametrize("E, rho, large", [(1.0e9, 1150.0, True),    # soft polymer
                                           (1.0e12, 3500.0, False)])  # diamond-like
def test_soft_link_is_flagged_large_deflection_and_stiff_link_is_not(E, rho, large):
    ds = simulate(cantilever({"E": E, "rho": rho, "nu": 0.3}))
    assert_finite(ds)
    q, EI = rho * H * W * 9.81, E * W * H**3 / 12
    exact = 7 * q * L**4 / (384 * EI)
    assert ds.deflection.values[0, 0, 0, 1] == pytest.approx(exact, rel=0.02)
    peak = float(ds.peak_deflection.values[0, 0])
    assert (peak / L > LARGE_DEFLECTION) == large
    assert flags(ds) == ({"large_deflection"} if large else set())


def test_more_modes_than_the_model_has_is_a_scene_error_not_nan():
    # One element, clamped: 3 DOFs, so 3 modes exist. Asking for 6 used to pad with NaN; it
    # is an impossible value of modal.modes (docs/reference/scene.md), named with the available count.
    scene = cantilever("steel")
    scene["discretization"]["elements_per_link"] = 1
    scene["modal"] = {"modes": 3, "angles": 2}
    ds = simulate(scene)
    assert ds.sizes["mode"] == 3
    assert_finite(ds)
    scene["modal"]["modes"] = 6
    with pytest.raises(Exception, match=r"modal\.modes: 6 modes asked for.*only 3 degrees"):
        simulate(scene)
