"""``ced.simulate`` (ced.simulation.simulate): failing cases are isolated and recorded, and no
case carries a non-finite value unless it is failed, with the cause in its message."""
import json

import numpy as np
import pytest

from ced.problem.errors import SceneError
from ced.problem.status import STATUS_FLAGS
from ced.simulation.simulate import simulate

BASE = {"mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                      "rocker": 0.35},
        "links": {"crank": {"flexible": False}, "rocker": {"flexible": False}},
        "discretization": {"elements_per_link": 4},
        "outputs": {"error_estimate": False}}
#: Central differences (Newmark β = 0, γ = ½): stable for ω h ≤ 2. The highest frequency of
#: this 4-element coupler is 21.04 kHz (ω = 1.322e5 rad/s), so at Ω = 100 rad/s a revolution
#: needs 2π/(Ω h) ≥ π ω/Ω = 4153.7, i.e. 4154 steps.
EXPLICIT = {**BASE, "time": {"revolutions": 1, "steps_per_revolution": 4200,
                             "integrator": "newmark", "beta": 0.0, "gamma": 0.5}}


def failed(ds) -> np.ndarray:
    return (ds.status.values & STATUS_FLAGS["failed"]) > 0


def finite_unless_failed(ds) -> None:
    for name, var in ds.data_vars.items():
        if var.dtype.kind == "f" and "case" in var.dims:
            values = var.transpose("case", ...).values.reshape(ds.sizes["case"], -1)
            assert np.isfinite(values[~failed(ds)]).all(), name


def test_explicit_scheme_beyond_its_stability_limit_is_refused():
    with pytest.raises(SceneError) as err:
        simulate({**EXPLICIT, "time": {**EXPLICIT["time"], "steps_per_revolution": 256}})
    assert err.value.path == "time.steps_per_revolution"
    assert "stability limit is ω h ≤ 2" in err.value.message
    assert "use at least 4154 steps per revolution" in err.value.message


def test_explicit_scheme_fails_only_the_cases_beyond_the_limit():
    # At 40 rad/s the same 4200 steps per revolution are 2.5 times longer: ω h = 4.9 > 2.
    ds = simulate([EXPLICIT, {**EXPLICIT, "drive": {"speed": 40.0}}])
    assert failed(ds).tolist() == [False, True]
    assert "ω h = 4.945" in str(ds.message.values[1])
    finite_unless_failed(ds)
    # Within the limit, central differences agree with the default scheme to the step's order.
    reference = simulate({**BASE, "time": {"revolutions": 1, "steps_per_revolution": 4200}})
    np.testing.assert_allclose(ds.peak_stress.values[0, 1],
                               reference.peak_stress.values[0, 1], rtol=2e-2)


def test_overflowing_input_fails_the_case_and_says_so():
    heavy = {**BASE, "effects": ["inertia", "elastic_inertia", "gravity"],
             "gravity": [0.0, -1e300], "time": {"revolutions": 1, "steps_per_revolution": 64}}
    light = {**heavy, "gravity": [0.0, -9.81]}
    with np.errstate(over="ignore", invalid="ignore"):
        ds = simulate([light, heavy])
    assert failed(ds).tolist() == [False, True]
    assert "an input overflows" in str(ds.message.values[1])
    assert "stress" in str(ds.message.values[1])
    finite_unless_failed(ds)


def test_a_batch_solved_in_parts_equals_one_batch(monkeypatch):
    # A batch beyond cases_per_solve is solved in parts: the same results, in the same order,
    # and a failing case is isolated within its part.
    import ced.simulation.simulate as sim
    scenes = [{**BASE, "drive": {"speed": s}, "time": {"revolutions": 1,
                                                       "steps_per_revolution": 256}}
              for s in (60.0, 80.0, 100.0, 120.0, 140.0)]
    whole = simulate(scenes)
    monkeypatch.setattr(sim, "cases_per_solve", lambda scene: 2)
    parts = simulate(scenes)
    for name in ("stress", "joint_force", "peak_stress", "status"):
        assert np.array_equal(parts[name].values, whole[name].values), name
    from ced.problem.scene import load_scene
    from ced.response.batch import make_batch
    batch = make_batch([load_scene(s) for s in scenes])
    out = sim.solve_batch(batch)
    # its parts write their station fields into the batch's arrays (nothing copied) and
    # copy the rest
    for name in ("peak_stress", "stress", "deflection", "axial_strain", "joint_force"):
        assert np.array_equal(out[name], whole[name].values), name


@pytest.mark.parametrize("revolutions", [0.5, 1.0, 2.5])
def test_rigid_results_repeated_over_periods_equal_the_direct_ones(revolutions):
    # The rigid motion is solved over one period and repeated: the link angles keep turning
    # (the crank gains 2π per revolution, the last step included) and every result equals the
    # kinematics evaluated at each step directly.
    from ced.problem.scene import load_scene
    from ced.response.batch import make_batch
    from ced.rigid.inverse_dynamics import inverse_dynamics
    from ced.simulation.simulate import _rigid_outputs
    scene = load_scene({**BASE, "discretization": {"formulation": "rigid"},
                        "time": {"revolutions": revolutions, "steps_per_revolution": 16}})
    batch = make_batch([scene])
    out, _ = _rigid_outputs(batch, inertia=True)
    motion = batch.rigid_motion()
    forces = inverse_dynamics(motion, batch.bodies, batch.gravity, inertia=True)
    assert np.allclose(out["link_angle"], motion.link_angle, atol=1e-12)
    assert np.allclose(out["joint_force"], forces.joint_force, rtol=1e-10,
                       atol=1e-10 * np.abs(forces.joint_force).max())
    assert np.allclose(out["time"], motion.time)


def test_cases_of_interleaved_structures_come_back_in_the_callers_order():
    # Two structures (4 and 2 elements) interleaved: solved as two batches, returned in order.
    scenes = [{**BASE, "drive": {"speed": speed},
               "discretization": {"elements_per_link": ne},
               "time": {"revolutions": 1, "steps_per_revolution": 64}}
              for speed, ne in ((50.0, 4), (60.0, 2), (70.0, 4), (80.0, 2))]
    together = simulate(scenes)
    for i, scene in enumerate(scenes):
        alone = simulate(scene)
        assert float(together.speed[i]) == scene["drive"]["speed"]
        np.testing.assert_array_equal(together.stress.isel(case=i).values,
                                      alone.stress.isel(case=0).values)


def test_auto_estimates_are_the_predictions_with_the_series_own_tail():
    # discretization: auto's prediction is a case's estimate; a case predicted as a series
    # adds what its own tail exceeds the bound it was refined to, and one that was shot in the
    # end is left to the error estimate's companions.
    # A case bounded by its neighbours but flagged resonant or unstable gets companions too,
    # its prediction a floor under theirs.
    from ced.simulation.simulate import _auto_estimates
    series = {"predicted_error": 4e-3, "time_error": "spectral_tail",
              "spectral_tail_bound": 1e-3, "ladder": "own"}
    reports = [{}, {"predicted_error": 5e-3, "ladder": "interpolated"}, series, series, series,
               {**series, "ladder": "interpolated"}, {"predicted_error": 5e-3, "ladder": "own"}]
    tail = np.array([np.nan, np.nan, 2e-7, 3e-3, np.nan, 2e-7, np.nan])
    quiet = np.zeros(len(reports), np.int64)
    assert _auto_estimates(reports, tail, quiet) == (
        {1: 5e-3, 2: 4e-3, 3: pytest.approx(6e-3), 5: 4e-3, 6: 5e-3}, {})
    assert _auto_estimates(reports, None, quiet) == ({1: 5e-3, 6: 5e-3}, {})
    flagged = quiet + np.array([0, 4, 4, 0, 0, 8, 4])
    assert _auto_estimates(reports, tail, flagged) == (
        {2: 4e-3, 3: pytest.approx(6e-3), 6: 5e-3}, {1: 5e-3, 5: 4e-3})
    # a flagged interpolated series shot in the end: no prediction to floor it
    assert _auto_estimates(reports, None, flagged) == ({6: 5e-3}, {1: 5e-3})


def test_a_flagged_case_between_climbers_is_estimated_no_lower_than_its_prediction():
    # The reference four-bar's undamped periodic sweep: its slower speeds are flagged
    # resonant, so those between climbers are estimated by companions, each raised to its
    # prediction where the companions' is lower.
    base = {"mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                          "rocker": 0.35},
            "links": {"default": {"material": "steel",
                                  "section": {"shape": "rectangle", "height": 0.005,
                                              "width": 0.01}},
                      "crank": {"flexible": False}, "rocker": {"flexible": False}},
            "time": {"revolutions": 1, "start": "periodic", "periodic_solver": "spectral",
                     "steps_per_revolution": 128},
            "discretization": "auto", "tolerance": 1e-2,
            "outputs": {"stations": 21, "error_estimate": True, "every": 128}}
    ds = simulate([{**base, "drive": {"speed": float(s)}} for s in np.linspace(90, 110, 12)])
    reports = [json.loads(str(r)) for r in ds.discretization_auto.values]
    sharp = (ds.status.values & (STATUS_FLAGS["resonant"]
                                 | STATUS_FLAGS["parametrically_unstable"])) > 0
    between = [i for i, r in enumerate(reports) if r["ladder"] == "interpolated" and sharp[i]]
    assert between  # the sweep has such cases
    estimate = ds.error_estimate.values
    for i in between:
        assert estimate[i] >= reports[i]["predicted_error"]
    # the companions' own estimate was lower at some: the floor is what they report
    assert any(estimate[i] == reports[i]["predicted_error"] for i in between)


def test_the_resonance_search_knows_the_spectra_of_one_turn_motions_only():
    # The spectra injected into discretization: auto: a crank-rocker's (its motion repeats every
    # turn) in the order given, none for a four-bar that passes its change point once a turn
    # (its motion repeats every two, and its load's harmonics are not the crank's).
    from ced.problem.scene import load_scene
    from ced.simulation.simulate import _spectra

    links = {"default": {"material": "steel",  # the reference four-bar's
                         "section": {"shape": "rectangle", "height": 0.005, "width": 0.01}},
             "crank": {"flexible": False}, "rocker": {"flexible": False}}

    def scene(mechanism, speed):
        return load_scene({"mechanism": mechanism, "drive": {"speed": speed}, "links": links,
                           "discretization": {"elements_per_link": 8, "modes_per_link": 8},
                           "time": {"revolutions": 1, "steps_per_revolution": 64,
                                    "start": "periodic"}})

    crank_rocker = {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                    "rocker": 0.35}
    change_point = {"type": "four_bar", "ground": 0.4, "crank": 0.1, "coupler": 0.35,
                    "rocker": 0.15}
    spectra = _spectra([scene(crank_rocker, 90.0), scene(change_point, 90.0),
                        scene(crank_rocker, 110.0)])
    assert spectra[1] is None
    for spectrum in (spectra[0], spectra[2]):
        frequency, share, zeta = spectrum
        assert frequency.shape == zeta.shape == (4,) and share.shape == (17, 4)
        assert np.all(np.diff(frequency) > 0) and np.all(zeta == 0.0)
        np.testing.assert_allclose(share.sum(axis=0), 1.0)
    # the mean frozen frequencies barely move with speed; the first is the 4:1 resonance's
    np.testing.assert_allclose(spectra[0][0], spectra[2][0], rtol=2e-3)
    assert 4 * 90.0 < spectra[0][0][0] < 4 * 92.0


def test_the_estimate_source_names_where_each_estimate_came_from():
    from ced.simulation.dataset import ESTIMATE_SOURCES
    from ced.simulation.simulate import _estimate_source
    estimate = np.array([0.01, np.nan, 0.02, 0.03, np.nan])
    source = _estimate_source(estimate, {2: 0.02, 4: np.nan},
                              np.array([False, False, False, True, False]))
    assert [list(ESTIMATE_SOURCES)[s] for s in source] == [
        "companions", "none", "discretization_auto", "sweep_neighbours", "none"]
