"""Modal damping over the cycle (ced.response.modal_damping): every mode of the linkage gets ζ
at every instant, the damping never feeds energy in, and it does not depend on how many stiff
modes the model has (the frozen C of t = 0 did, by 11 % at a change point)."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.fem.eigenproblem import natural_frequencies
from ced.problem.scene import load_scene
from ced.response import modal_damping
from ced.response.batch import make_batch
from ced.response.model import build_model, terms_at
from ced.simulation.simulate import simulate

RATIO = 0.01
# The convergence study's change-point four-bar (config/studies/convergence.yaml): crank 0.05,
# rocker 0.1, coupler 0.2 over a 0.25 ground, S + L = P + Q; 20 mm deep links, 200 rad/s.
CHANGE_POINT = {
    "mechanism": {"type": "four_bar", "ground": 0.25, "crank": 0.05, "coupler": 0.2,
                  "rocker": 0.1},
    "links": {"default": {"material": "steel",
                          "section": {"shape": "rectangle", "height": 0.02, "width": 0.01}},
              "crank": {"flexible": False}},
    "drive": {"speed": 200.0},
    "effects": ["inertia", "elastic_inertia", "coriolis", "centrifugal", "axial_stiffening",
                "damping"],
    "damping": {"model": "modal", "ratio": RATIO},
    "time": {"revolutions": 1, "steps_per_revolution": 256, "start": "periodic"},
    "outputs": {"stations": 11},
}


def _scene(elements=8, modes=0, **changes):
    return load_scene({**CHANGE_POINT, "discretization": {"elements_per_link": elements,
                                                          "modes_per_link": modes}, **changes})


def _modal(M, K, C):
    """The frozen modes' damping Φᵀ C Φ (mass-normalised Φ) and their ω, rad/s."""
    f, phi = natural_frequencies(K, M, K.shape[-1], shapes=True)
    return np.swapaxes(phi, -1, -2) @ C @ phi, 2 * math.pi * np.abs(f)


@settings(max_examples=25, deadline=None)
@given(n=st.integers(2, 9), seed=st.integers(0, 2**31 - 1),
       ratio=st.floats(1e-4, 0.5))
def test_damping_matrix_is_diagonal_in_the_modes_with_2_zeta_omega(n, seed, ratio):
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(2, n, n))
    M, K = a @ a.T + n * np.eye(n), b @ b.T + 0.1 * np.eye(n)
    C, omega, phi = modal_damping.damping_matrix(M, K, ratio)
    np.testing.assert_allclose(C, C.T, rtol=0, atol=1e-12 * np.abs(C).max())
    modal = phi.T @ C @ phi
    np.testing.assert_allclose(modal, np.diag(2 * ratio * omega), rtol=0,
                               atol=1e-9 * 2 * ratio * omega.max())
    np.testing.assert_allclose(omega**2, np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real),
                               rtol=1e-8)


def test_a_fast_turning_structure_is_tabulated_to_the_tolerance():
    # A two-DOF structure whose stiff direction turns twice a period, stiffness ratio 10⁴:
    # the frozen damping of one phase would give its soft mode 100ζ half a turn later. The
    # table's midpoints between every pair of samples hold every mode's damping to TOLERANCE.
    ratio = 0.02

    def turning(times):  # (case, n) → M, K (case, n, 2, 2); period 1 s
        th = 2 * np.pi * 2 * times
        c, s = np.cos(th), np.sin(th)
        R = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
        K = R @ np.diag([1e4, 1.0]) @ np.swapaxes(R, -1, -2)
        return np.broadcast_to(np.eye(2), K.shape), K

    table = modal_damping.tabulate(turning, np.array([1.0]), np.array([1]), ratio)
    grid = table.phase[0]
    assert len(grid) > modal_damping.INITIAL_SAMPLES + 1
    middle = 0.5 * (grid[:-1] + grid[1:]) + modal_damping.OFFSET
    M, K = turning(middle[None, :])
    modal, omega = _modal(M, K, table.at(middle[None, :], np.array([2 * np.pi])))
    scale = 2 * ratio * np.sqrt(omega[..., :, None] * omega[..., None, :])
    assert np.abs(modal / scale - np.eye(2)).max() < 2 * modal_damping.TOLERANCE
    # and it is periodic, the same a period on
    np.testing.assert_allclose(table.at(middle[None, :] + 1.0, np.array([2 * np.pi])),
                               table.at(middle[None, :], np.array([2 * np.pi])), atol=1e-9)


@pytest.fixture(scope="module")
def change_point_model():
    return build_model(make_batch([_scene()]))


def test_every_mode_gets_the_ratio_through_the_change_point(change_point_model):
    # At 40 instants over the motion's period (two turns: the change point is passed once a
    # turn), the slow mode included as the links align (its frequency falls to a third).
    model = change_point_model
    assert model.modal_damping.turns[0] == 2
    period = 2 * 2 * np.pi / 200.0
    times = (np.arange(40)[None, :] + 0.37) / 40 * period
    terms, _ = terms_at(model, times, model.effects, frozenset({"elastic_mass",
                                                                "elastic_stiffness"}))
    C = model.modal_damping.at(times, model.batch.speed)
    modal, omega = _modal(terms.elastic_mass, terms.elastic_stiffness, C)
    zeta = np.diagonal(modal, axis1=-2, axis2=-1) / (2 * omega)
    assert omega[0, :, 0].min() < 0.6 * omega[0, :, 0].max()  # the modes do turn
    np.testing.assert_allclose(zeta[..., :8], RATIO, rtol=modal_damping.TOLERANCE)


@settings(max_examples=20, deadline=None)
@given(time=st.floats(0.0, 1.0))
def test_the_interpolated_damping_never_feeds_energy(change_point_model, time):
    C = change_point_model.modal_damping.at(np.array([[time]]), np.array([200.0]))[0, 0]
    assert np.linalg.eigvalsh(0.5 * (C + C.T)).min() >= -1e-12 * np.abs(C).max()


def test_the_change_point_does_not_depend_on_the_stiff_modes_kept():
    # Every FE DOF against Craig–Bampton bases: complete (every interior mode: the same
    # space at each instant) and truncated to 4 modes a link. With C frozen at t = 0 the full
    # mesh was 26.1, the reduced models 29.1 MPa (8 elements, 512 steps per revolution): 11 %
    # apart. Now 5.3e-5, of the order of what separates them undamped (1.7e-5): the reduced
    # interior coordinates are relative to constraint modes that turn with the joints, so the
    # two march different coordinates of the same space, apart by O(h²) (the slider-crank from
    # rest, 2.8e-3, 2.3e-4, 2.1e-5 at 256, 1024, 4096 steps per revolution).
    full, complete, four = (float(simulate(_scene(modes=m)).peak_stress.max())
                            for m in (0, 23, 4))
    assert complete == pytest.approx(full, rel=2e-4)
    assert four == pytest.approx(complete, rel=1e-5)


def test_no_ratio_no_table():
    # ζ = 0: nothing tabulated, and C is the Coriolis terms' alone.
    model = build_model(make_batch([_scene(damping={"model": "modal", "ratio": 0.0})]))
    assert model.modal_damping is None
    times = np.array([[0.0, 0.01]])
    terms, _ = terms_at(model, times)
    undamped, _ = terms_at(model, times, model.effects - {"damping"})
    np.testing.assert_array_equal(terms.damping, undamped.damping)


def test_a_speed_sweep_shares_one_table_the_same_bits_as_alone():
    # Tabulated at unit speed, once per distinct model: the speeds of a sweep share the
    # table, and it is the table of that geometry built alone at any speed.
    scenes = [_scene(drive={"speed": s}) for s in (150.0, 200.0, 250.0)]
    other = _scene(mechanism={**CHANGE_POINT["mechanism"], "coupler": 0.21})
    table = build_model(make_batch(scenes + [other])).modal_damping
    alone = build_model(make_batch([_scene(drive={"speed": 90.0})])).modal_damping
    for case in range(3):
        np.testing.assert_array_equal(table.matrix[case], alone.matrix[0])
    assert not np.array_equal(table.matrix[3], alone.matrix[0])


def test_a_structure_that_does_not_turn_keeps_the_damping_of_its_start():
    # A single rotating link: its elastic mass and stiffness in the link frame never change,
    # so every sample of the table is the frozen C of t = 0 (what ced used everywhere before)
    # to round-off, and the bisection stops at the first level.
    scene = load_scene({"mechanism": {"type": "single_link", "length": 0.5},
                        "drive": {"speed": 10.0},
                        "effects": ["inertia", "elastic_inertia", "damping"],
                        "damping": {"model": "modal", "ratio": 0.05},
                        "discretization": {"elements_per_link": 4},
                        "time": {"revolutions": 1, "steps_per_revolution": 64}})
    model = build_model(make_batch([scene]))
    table = model.modal_damping
    assert table.phase.shape[1] == 2 * modal_damping.INITIAL_SAMPLES + 1
    terms, _ = terms_at(model, np.zeros((1, 1)), set(), frozenset({"elastic_mass",
                                                                  "elastic_stiffness"}))
    start, _, _ = modal_damping.damping_matrix(terms.elastic_mass[:, 0],
                                               terms.elastic_stiffness[:, 0], 0.05)
    np.testing.assert_allclose(table.matrix[0], np.broadcast_to(start, table.matrix.shape[1:]),
                               rtol=0, atol=1e-9 * np.abs(start).max())


WATT_II = {"type": "watt_ii", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35,
           "rocker_arm": 0.25, "rocker_arm_angle": 2.5, "coupler2": 0.4, "rocker2": 0.3,
           "pivot2_x": 0.2, "pivot2_y": -0.3}
# A double rocker driven by its rocking input, θ = θ_mid + A sin(Ωt): the period is 2π/Ω.
DOUBLE_ROCKER = {"type": "four_bar", "ground": 0.5, "crank": 0.35, "coupler": 0.1,
                 "rocker": 0.45}


@pytest.mark.parametrize("mechanism, links, drive", [
    (WATT_II, {"crank": {"flexible": False}, "rocker": {"flexible": False}},
     {"speed": 60.0}),
    (DOUBLE_ROCKER, {"crank": {"flexible": False}}, {"speed": 40.0, "amplitude": 0.9}),
], ids=["watt_ii", "rocking_input"])
def test_every_mode_gets_the_ratio_in_a_six_bar_and_under_a_rocking_input(mechanism, links,
                                                                          drive):
    scene = load_scene({"mechanism": mechanism, "links": links, "drive": drive,
                        "effects": ["inertia", "elastic_inertia", "damping"],
                        "damping": {"model": "modal", "ratio": RATIO},
                        "discretization": {"elements_per_link": 4},
                        "time": {"revolutions": 1, "steps_per_revolution": 64}})
    model = build_model(make_batch([scene]))
    times = np.linspace(0.0, 2 * np.pi / drive["speed"], 13)[None, :] + 1e-3
    terms, _ = terms_at(model, times, model.effects, frozenset({"elastic_mass",
                                                                "elastic_stiffness"}))
    C = model.modal_damping.at(times, model.batch.speed)
    modal, omega = _modal(terms.elastic_mass, terms.elastic_stiffness, C)
    zeta = np.diagonal(modal, axis1=-2, axis2=-1) / (2 * omega)
    np.testing.assert_allclose(zeta[..., :6], RATIO, rtol=modal_damping.TOLERANCE)
    assert np.isfinite(simulate(scene).peak_stress).all()
