"""Change-point linkages (S + L = P + Q) driven through their singular configuration.

Branch rule (documented in :func:`ced.rigid.kinematics._track_branch`): the branch is chosen once,
from ``mechanism.branch`` at t = 0, and kept; only where the two assembly solutions touch (a
change point) is the candidate nearest to the linear extrapolation of the last two steps
taken, so the motion passes straight through the collinear configuration instead of
reflecting off it — a parallelogram stays a parallelogram. Deterministic: the same scene gives
bitwise the same motion.
"""
import numpy as np
import pytest

from ced.fem.eigenproblem import natural_frequencies
from ced.problem.mechanism import dyad_sine_min
from ced.problem.scene import load_scene
from ced.response.batch import make_batch
from ced.response.frequencies import cycle_frequencies, modal_phases
from ced.response.integrators import integrator_for
from ced.response.marching import Marcher
from ced.response.model import build_model, terms_at
from ced.response.period_terms import period_terms
from ced.response.periodic import INSTABILITY_MARGIN, monodromy
from ced.simulation.simulate import _peaks, simulate
from tests.hard_cases.helpers import assert_finite, flags

PARALLELOGRAM = {"type": "four_bar", "ground": 0.3, "crank": 0.1, "coupler": 0.3, "rocker": 0.1}
# S + L = 0.1 + 0.4 = P + Q = 0.35 + 0.15: all four joints collinear at θ = π.
CHANGE_POINT = {"type": "four_bar", "ground": 0.4, "crank": 0.1, "coupler": 0.35, "rocker": 0.15}
# S + L = 0.25 + 0.4 = P + Q = 0.3 + 0.35, the ground shortest: a double crank whose branches
# meet once a turn, at θ = 0 (the default study's change_point case 1691).
DOUBLE_CRANK = {"type": "four_bar", "ground": 0.25, "crank": 0.3, "coupler": 0.4, "rocker": 0.35}


def scene(mechanism, initial_angle=0.0, **time):
    return {"mechanism": mechanism,
            "links": {"default": {"section": {"shape": "rectangle", "height": 0.01,
                                              "width": 0.01}}},
            "drive": {"speed": 20.0, "initial_angle": initial_angle},
            "discretization": {"elements_per_link": 2},
            "time": {"revolutions": 1, "steps_per_revolution": 64, "start": "periodic", **time},
            "modal": {"modes": 3, "angles": 8},
            "outputs": {"stations": 3}}


@pytest.mark.parametrize("mechanism", [PARALLELOGRAM, CHANGE_POINT], ids=["parallelogram",
                                                                          "change_point"])
@pytest.mark.parametrize("initial_angle", [0.0, 0.013])
def test_change_point_is_finite_and_near_singular(mechanism, initial_angle):
    # θ0 = 0 puts a step exactly on the collinear configuration (the rigid analysis flags it);
    # θ0 = 0.013 steps over it, and the elastic check must still see that the structure is a
    # mechanism there (sin μ = 0 exactly, whatever the grid).
    ds = simulate(scene(mechanism, initial_angle))
    assert str(ds.family.values[0]) == "change_point"
    assert_finite(ds)
    assert "near_singular" in flags(ds)
    batch = make_batch([load_scene(scene(mechanism))])
    L = batch.lengths
    sine = dyad_sine_min(L["ground"], L["crank"], L["coupler"], L["rocker"],
                         batch.initial_angle, batch.amplitude)
    assert sine[0] == pytest.approx(0.0, abs=1e-7)
    # The smooth branch: the parallelogram's coupler stays parallel to the ground.
    if mechanism is PARALLELOGRAM:
        coupler = np.angle(np.exp(1j * ds.link_angle.sel(link="coupler").values[0]))
        assert np.abs(coupler).max() < 1e-6


@pytest.mark.parametrize("coupler", [0.1, 0.3])
def test_kite_whose_crank_pin_passes_over_the_rocker_pivot_is_solved(coupler):
    """Crank = ground, coupler = rocker: B lies on D at θ = 0, the folded position the
    default study's kites rock through; they all failed (NaN motion) before."""
    kite = {"type": "four_bar", "ground": 0.3, "crank": 0.3, "coupler": coupler,
            "rocker": coupler}
    ds = simulate({**scene(kite), "drive": {"speed": 20.0, "initial_angle": 0.0,
                                            "amplitude": 0.8}})
    assert str(ds.family.values[0]) == "change_point"
    assert_finite(ds)
    assert "near_singular" in flags(ds) and "failed" not in flags(ds)
    assert float(ds.peak_stress.max()) > 0


def test_branch_choice_is_deterministic():
    a, b = simulate(scene(CHANGE_POINT)), simulate(scene(CHANGE_POINT))
    assert np.array_equal(a.link_angle.values, b.link_angle.values)
    assert np.array_equal(a.deflection.values, b.deflection.values)


def test_structure_loses_stiffness_at_the_change_point():
    # Without motion-induced terms, the frozen elastic structure of the parallelogram at
    # θ = 0 (all joints on the x axis) is a mechanism: joint C can swing across the line, held
    # by nothing, so its lowest frequency is 0 (to round-off of the eigensolver) while a quarter
    # turn later it is tens of Hz.
    s = scene(PARALLELOGRAM)
    s["effects"] = ["inertia", "elastic_inertia"]
    s["modal"] = {"modes": 1, "angles": 8}
    ds = simulate(s)
    f1 = ds.natural_frequency.values[0, :, 0]
    assert abs(f1[0]) < 1e-3 * f1.max()
    assert f1[2] > 10.0
    assert_finite(ds)


def test_change_point_instability_is_real_not_a_step_artefact():
    # Each passage through the collinear configuration kicks the mode that goes soft there;
    # whether the kicks add up depends on the phase that mode accumulates over the cycle. At
    # 1000 rad/s (2 % of the elements' axial frequency per period) the Floquet multiplier is
    # ≈ 1.03 per revolution and stays so as the step shrinks fourfold (measured 1.034 at 4096
    # steps, 1.031 at 16384, 1.034 at 65536; the peak stress 7.48, 7.53 and 7.53 GPa): the
    # parallelogram is parametrically unstable, mildly. (Until the period's terms followed the
    # one continuous motion, those evaluated past the change point in a window of their own
    # were on the other branch: 2.17 at 16384 steps, a step artefact.)
    multipliers = []
    for steps in (4096, 16384):
        s = scene(PARALLELOGRAM, steps_per_revolution=steps, integrator="newmark")
        s["drive"]["speed"] = 1000.0
        s["discretization"]["elements_per_link"] = 1
        s.pop("modal")
        ds = simulate(s)
        assert_finite(ds)
        assert {"near_singular", "parametrically_unstable"} <= flags(ds)
        multipliers.append(float(ds.floquet_multiplier_max.values[0]))
    assert all(1.02 < mu < 1.05 for mu in multipliers)
    assert multipliers[1] == pytest.approx(multipliers[0], rel=0.01)


def test_modal_frequencies_are_those_of_the_grid_motion():
    # The modal phases are off the step grid (12 against 64 steps a turn). Solved as a
    # sequence of their own, the double crank's phases past θ = 0 took the other branch, and
    # their frequencies were the other configuration's (the cycle mirrored: at phase 3, on
    # step 16, 60.6 / 147.6 / 202.1 Hz against the step's 49.7 / 129.3 / 255.1). Now each
    # phase's frozen frequencies are the grid motion's: at the phases on a step (16, 32, 48)
    # those of the step, and every phase's within the range of the four steps around it, to
    # 1e-3 of their largest (the frequencies turn sharply just past the change point, where
    # modes cross: linear interpolation would not do). Phase 0 is left out: it sits on the
    # change point, where the velocities are interpolated across the times solved together.
    # Its motion repeats only every two turns: the phases span both (phase φ at Ωt = 2φ), and
    # phase 6 is on the change point again, one turn on: left out as phase 0.
    s = scene(DOUBLE_CRANK)
    s["drive"]["speed"] = 300.0
    s["modal"] = {"modes": 3, "angles": 12}
    model = build_model(make_batch([load_scene(s)]))
    batch = model.batch
    turns = int(batch.motion_turns[0])
    assert turns == 2
    phases = modal_phases(12)
    frequency = cycle_frequencies(model, phases, 3)[0]
    grid = batch.step_size[:, None] * np.arange(64 * turns + 2)[None, :]
    terms, _ = terms_at(model, grid, model.effects - {"damping"}, frozenset({"elastic_mass"}))
    on_grid = natural_frequencies(terms.stiffness, terms.elastic_mass, 3)[0]
    position = turns * phases / batch.speed[0] / batch.step_size[0]
    lower = np.floor(position).astype(int)
    for j in [j for j in range(1, 12) if j != 6]:
        around = on_grid[lower[j] - 1:lower[j] + 3]
        slack = 1e-3 * np.abs(around).max(axis=0)  # a peak between two steps
        assert np.all(around.min(axis=0) - slack <= frequency[j]), j
        assert np.all(frequency[j] <= around.max(axis=0) + slack), j
    on_step = np.flatnonzero(position - lower < 1e-9)[1:]
    assert list(on_step) == [3, 6, 9]
    on_step = on_step[on_step != 6]
    assert np.allclose(frequency[on_step], on_grid[lower[on_step]], rtol=1e-9, atol=0.0)


def two_turn_scene(revolutions):
    """The crank-shortest change point (its branches meet at θ = π, passed once a turn):
    its motion repeats only every two turns. Stable at 20 rad/s (multiplier ≈ 0.4 a turn)."""
    s = scene(CHANGE_POINT, revolutions=revolutions)
    s["links"]["default"]["section"]["height"] = 0.02
    s.pop("modal")
    return s


def test_rigid_outputs_of_a_two_turn_change_point_repeat_every_two_turns():
    # Later turns were copied from the first: the second turn was the first turn's branch
    # again, up to π off in the link angles of the motion solved through.
    ds = simulate(two_turn_scene(3))
    angle = ds.link_angle.values[0]
    gap = np.abs(np.angle(np.exp(1j * (angle[64:] - angle[:-64]))))  # one turn on
    assert gap.max() > 1.0
    assert np.abs(np.angle(np.exp(1j * (angle[128:] - angle[:-128])))).max() < 1e-9
    assert ds.joint_force.values[0, 64:].max() != ds.joint_force.values[0, :65].max()


def test_periodic_state_of_a_two_turn_change_point_returns_after_two_turns():
    # The periodic start solved over one turn joined the end of a turn to a start on the
    # other branch: marched two turns from it, the response did not come back.
    ds = simulate(two_turn_scene(2))
    deflection = ds.deflection.values[0].astype(float)  # (step, link, station), stored float32
    scale = np.abs(deflection).max()
    assert np.abs(deflection[128] - deflection[0]).max() < 1e-5 * scale
    assert np.abs(deflection[64] - deflection[0]).max() > 0.1 * scale  # not a one-turn period


def test_two_turn_change_point_peaks_cover_both_turns():
    # One revolution asked: the outputs cover it, the peaks the whole two-turn period.
    one, two = simulate(two_turn_scene(1)), simulate(two_turn_scene(2))
    assert one.sizes["step"] == 65
    np.testing.assert_allclose(one.peak_stress.values, two.peak_stress.values, rtol=1e-9)
    np.testing.assert_allclose(one.dynamic_amplification.values,
                               two.dynamic_amplification.values, rtol=1e-9)
    stress = np.abs(two.stress.values[0]).max(axis=(2, 3))  # (step, link)
    peak = two.peak_stress.values[0]
    flexible = peak > 0
    # The second turn holds the crank's peak: the first turn's largest stress is well below.
    assert np.any(stress[:65, flexible].max(axis=0) < 0.9 * peak[flexible])
    assert np.allclose(stress[:, flexible].max(axis=0), peak[flexible], rtol=1e-2)


def test_two_turn_change_point_multiplier_is_per_turn():
    # The multipliers of the two-turn monodromy are those of one turn squared: the reported
    # one is its square root, comparable with one-turn cases' and with the same threshold.
    s = two_turn_scene(1)
    ds = simulate(s)
    batch = make_batch([load_scene(s)])
    model = build_model(batch)
    h = batch.step_size
    terms = period_terms(model, h, 128, exact=True)
    scheme = integrator_for(load_scene(s)["time"])
    two_turns = monodromy(scheme, Marcher(scheme, terms, h), h, 128, model.layout.ny, 1)
    largest = np.abs(np.linalg.eigvals(two_turns.Phi)).max()
    reported = float(ds.floquet_multiplier_max.values[0])
    assert reported == pytest.approx(np.sqrt(largest), rel=1e-9)
    assert ("parametrically_unstable" in flags(ds)) == (reported > 1.0 + INSTABILITY_MARGIN)


def test_two_turn_change_point_peaks_only_solve_agrees():
    # A pilot's or an error estimate's companion solve (peaks only) takes the same two-turn
    # period and peaks as the full solve.
    s = two_turn_scene(1)
    full = simulate(s)
    peaks = _peaks([load_scene(s)])
    assert peaks["peak"][0] == pytest.approx(float(full.peak_stress.max()), rel=1e-12)
