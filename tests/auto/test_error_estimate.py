"""Error estimates: companions, the a-priori time term, and the estimate against true errors."""
import copy

import numpy as np
import pytest
import yaml

from ced.auto.error_estimate import (MIN_COARSENING, SAFETY, SAFETY_PERIODIC,
                                     algorithmic_damping, coarser_steps,
                                     combine, companions)
from ced.problem.scene import SPECTRAL_TAIL, load_scene
from ced.simulation.simulate import simulate


def _scene(ne: int, spr: int, **time) -> dict:
    raw = yaml.safe_load(open("config/scenes/reference_four_bar.yaml"))
    raw.pop("modal")
    raw["discretization"] = {"elements_per_link": ne}
    raw["time"].update(steps_per_revolution=spr, **time)
    return raw


def test_one_companion_halves_the_steps_and_grows_the_space_error_alike():
    (companion,) = companions(load_scene(_scene(8, 256)), omega1_h=0.2)
    # Order 2 in space: 8 → 4 elements grows the error 4×, like halving the step.
    assert companion.scene["discretization"]["elements_per_link"] == 4
    assert companion.scene["time"]["steps_per_revolution"] == 128
    assert companion.scene["modal"] is None
    # Growth 4 (the smaller): Richardson's error is |Δ|/3, the estimate SAFETY_PERIODIC times
    # that (a periodic start).
    assert companion.factor == pytest.approx(SAFETY_PERIODIC / 3.0)


def test_a_shot_spectral_case_has_shot_companions_with_no_series_keys():
    # A spectral scene whose case was shot (no collocation points): its companion is shot and
    # carries no key of the series (a tail bound set by discretization: auto included); a
    # series case's companion is solved at the case's fixed points, with no tail to stop at.
    scene = load_scene(_scene(8, 256, periodic_solver="spectral", spectral_tail=1e-4))
    (companion,) = companions(scene, omega1_h=0.2)
    assert companion.scene["time"]["periodic_solver"] == "shooting"
    assert load_scene(companion.scene)["time"]["spectral_tail"] == SPECTRAL_TAIL
    (series,) = companions(scene, omega1_h=0.2, collocation_points=64)
    assert load_scene(series.scene)["time"]["collocation_points"] == 64


@pytest.mark.parametrize("steps, omega1_h", [(64, 0.2), (256, 0.85), (256, 1.5)])
def test_steps_are_refined_where_coarsening_leaves_the_asymptotic_range(steps, omega1_h):
    # Fewer than 64 steps in the companion, or ω₁h above 1 there after coarsening by at least
    # MIN_COARSENING while below π here.
    assert coarser_steps(steps, 1, omega1_h) is None
    # From the undeformed start the first mode rings: its ω₁h counts.
    space, time = companions(load_scene(_scene(8, steps, start="undeformed")), omega1_h)
    assert space.scene["discretization"]["elements_per_link"] == 4
    assert space.scene["time"]["steps_per_revolution"] == steps
    assert time.scene["discretization"]["elements_per_link"] == 8
    assert time.scene["time"]["steps_per_revolution"] == 2 * steps
    assert time.factor == pytest.approx(SAFETY / (1.0 - 1.0 / 4.0))


def test_stiff_first_mode_allows_halving():
    # ω₁h ≥ π at both step sizes: the mode responds quasi-statically either way.
    assert coarser_steps(256, 1, 3.5) == 128
    assert coarser_steps(256, 1, 0.4) == 128 and coarser_steps(256, 1, 0.5) == 128


@pytest.mark.parametrize("omega1_h", [0.55, 0.65, 0.78])
def test_coarsening_by_less_than_two_keeps_the_first_mode_resolved(omega1_h):
    steps = coarser_steps(256, 1, omega1_h)
    assert 256 / 2 < steps <= 256 / MIN_COARSENING
    assert omega1_h * 256 / steps <= 1.0 + 1e-12  # the companion's ω₁h
    # Houbolt damps the first mode at the halved step: the ω₁h rule holds.
    (companion,) = companions(load_scene(_scene(8, 256, integrator="houbolt")), omega1_h)
    assert companion.scene["time"]["steps_per_revolution"] == steps
    # The mesh coarsened so that the space error grows about as the time error does, and
    # Richardson's factor taken from the smaller growth.
    growth_t = (256 / steps) ** 2
    ne = companion.scene["discretization"]["elements_per_link"]
    growth = min((8 / ne) ** 2, growth_t)
    assert abs(np.log((8 / ne) ** 2 / growth_t)) < 0.4
    assert companion.factor == pytest.approx(SAFETY_PERIODIC / (growth - 1.0))


@pytest.mark.parametrize("start", ["undeformed", "quasi_static"])
@pytest.mark.parametrize("omega1_h", [0.0, 0.2, 1.5])
def test_start_transient_refines_the_steps(start, omega1_h):
    # Free vibrations accumulate phase error over the run: the time part always comes from a
    # finer companion on the scene's mesh, the space part from a coarser mesh at its steps.
    space, time = companions(load_scene(_scene(8, 256, start=start)), omega1_h)
    assert space.scene["discretization"]["elements_per_link"] == 4
    assert space.scene["time"]["steps_per_revolution"] == 256
    assert space.factor == pytest.approx(SAFETY / 3.0)
    assert time.scene["discretization"]["elements_per_link"] == 8
    assert time.scene["time"]["steps_per_revolution"] == 512
    assert time.factor == pytest.approx(SAFETY / (1.0 - 1.0 / 4.0))


@pytest.mark.parametrize("omega1_h", [0.85, 1.5, 2.5])
def test_periodic_start_halves_whatever_the_first_mode(omega1_h):
    # No free vibration in the periodic steady state: generalized-α (no damping of the first
    # mode at the companion's step) halves the steps even where ω₁h would forbid it.
    (companion,) = companions(load_scene(_scene(8, 256)), omega1_h)
    assert companion.scene["time"]["steps_per_revolution"] == 128
    assert companion.scene["discretization"]["elements_per_link"] == 4
    assert companion.factor == pytest.approx(SAFETY_PERIODIC / 3.0)


@pytest.mark.parametrize("integrator", ["houbolt", "hht"])
def test_periodic_start_keeps_the_rule_for_a_dissipative_scheme(integrator):
    # Houbolt and HHT damp the first mode at ω₁h = 3 (the companion's): two companions.
    scene = load_scene(_scene(8, 256, integrator=integrator))
    assert algorithmic_damping(scene["time"], 3.0) > 0.01
    space, time = companions(scene, omega1_h=1.5)
    assert space.scene["time"]["steps_per_revolution"] == 256
    assert time.scene["time"]["steps_per_revolution"] > 256


def test_coarser_steps_span_whole_revolutions():
    # 1.5 revolutions: the companion's steps times 1.5 must be a whole number.
    steps = coarser_steps(256, 1.5, 0.7)
    assert steps * 1.5 == int(steps * 1.5)


@pytest.mark.parametrize("elements", [1, 2, 4])
def test_small_meshes_are_refined_not_coarsened(elements):
    space, time = companions(load_scene(_scene(elements, 256)), omega1_h=0.2)
    assert space.scene["discretization"]["elements_per_link"] == 2 * elements
    assert space.factor == pytest.approx(SAFETY_PERIODIC / (1.0 - 1.0 / 4.0))
    assert time.scene["time"]["steps_per_revolution"] == 128
    assert time.factor == pytest.approx(SAFETY_PERIODIC / 3.0)




def test_combine_is_relative_and_adds_the_companions():
    est = combine(np.array([100.0, 0.0]), [np.array([90.0, 0.0])], [1.0])
    assert est == pytest.approx([0.1, 0.0])
    two = combine(np.array([100.0]), [np.array([90.0]), np.array([98.0])], [1.0, 4.0])
    assert two[0] == pytest.approx(0.1 + 0.08)


@pytest.mark.parametrize("ne, spr, integrator", [
    (4, 64, "generalized_alpha"), (8, 128, "generalized_alpha"), (16, 256, "newmark"),
    (8, 128, "houbolt"), (8, 32, "houbolt"), (2, 32, "hht")])
def test_estimate_brackets_the_true_error(reference_four_bar_peak, ne, spr, integrator):
    ds = simulate(_scene(ne, spr, integrator=integrator))
    true = abs(float(ds.peak_stress.max()) - reference_four_bar_peak) / reference_four_bar_peak
    estimate = float(ds.error_estimate[0])
    assert true <= estimate <= 10.0 * true  # the band issue 6 asks for on 90 % of settings
    assert ds.error_estimate.attrs["units"] == "1"


def test_no_estimate_when_not_asked_or_rigid():
    raw = _scene(4, 32)
    raw["outputs"] = {"error_estimate": False}
    assert "error_estimate" not in simulate(raw)
    rigid = copy.deepcopy(_scene(4, 32))
    rigid["discretization"] = {"formulation": "rigid"}
    assert "error_estimate" not in simulate(rigid)


def test_dissipative_scheme_refines_until_the_first_mode_is_resolved():
    hb = load_scene(_scene(8, 64, integrator="houbolt"))
    ga = load_scene(_scene(8, 64))
    # Houbolt damps ω₁h = 3.2 heavily; its companion goes to 8× the steps (ω₁h = 0.4).
    assert algorithmic_damping(hb["time"], 1.6) > 0.1 > algorithmic_damping(ga["time"], 1.6)
    assert companions(hb, omega1_h=3.2)[1].scene["time"]["steps_per_revolution"] == 512
    assert companions(hb, omega1_h=3.2)[1].factor == pytest.approx(SAFETY_PERIODIC / (1.0 - 1.0 / 64.0))
    assert companions(ga, omega1_h=3.2)[1].scene["time"]["steps_per_revolution"] == 128


def test_failing_companion_leaves_the_case_and_no_estimate(monkeypatch):
    import ced.simulation.simulate as simulation

    real = simulation.solve_batch

    def failing_companions(batch, peaks_only=False, allocate=None, guesses=None):
        if "companion" in batch.scenes[0].get("name", ""):
            raise FloatingPointError("injected")
        return real(batch, peaks_only, allocate, guesses)

    monkeypatch.setattr(simulation, "solve_batch", failing_companions)
    ds = simulate(_scene(4, 128))
    assert np.isnan(ds.error_estimate[0]) and np.isfinite(ds.peak_stress).all()
    assert int(ds.status[0]) & 16 == 0  # the case itself did not fail


def test_a_series_case_hands_its_guess_to_its_mesh_companion_alone():
    # The scene's series starts its mesh companion's GMRES (same points, ced.response.
    # warm_start); a shot case's companions are shot and take none.
    from ced.auto.error_estimate import error_estimates
    scenes = [load_scene(_scene(8, 256)) for _ in range(2)]
    given = []

    def solve(companion_scenes, guesses):
        given.append(guesses)
        return np.full(len(companion_scenes), 99.0)
    guess = np.ones((32, 3))
    estimate = error_estimates(scenes, np.array([100.0, 100.0]), np.zeros(2, bool),
                               lambda: np.full(2, 100.0), np.full(2, 1e-3), solve,
                               spectral_tail=np.array([1e-4, np.nan]),
                               collocation_points=np.array([32, 0]),
                               guesses=[guess, np.ones((32, 3))])
    assert len(given) == 1 and given[0][0] is guess and given[0][1] is None
    assert np.all(np.isfinite(estimate))
    # Without guesses the solve is told so.
    given.clear()
    error_estimates(scenes, np.array([100.0, 100.0]), np.zeros(2, bool),
                    lambda: np.full(2, 100.0), np.full(2, 1e-3), solve)
    assert given == [None]
