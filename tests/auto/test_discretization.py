"""discretization: auto — measured error ladders, the cheapest setting under the tolerance, and
the achieved error."""
import copy
import json
from collections import OrderedDict

import numpy as np
import pytest
import yaml
from hypothesis import given, settings, strategies as st

from ced.auto.discretization import (_ELEMENTS, FIRST_STEPS, INTERPOLATION_MARGIN,
                                     MAX_LADDER_STEPS, MODE_CHOICES, MODES,
                                     PERIODIC_STRIDE,
                                     RESONANT_HARMONICS, SAFETY, SERIES_FULL_POINTS,
                                     SERIES_SHARE, _full_cost, _reduced_cost, choose_shared,
                                     _pilot_key, sweep_key, bracket, choose, cost, interpolate,
                                     interpolated_error, ladder_errors, predicted_error,
                                     representatives,
                                     resolve_discretization, sweeps, unverified)
from ced.problem.scene import SPECTRAL_TAIL, load_scene
from ced.response.resonance import resonance_weight
from ced.simulation.simulate import simulate


def reference_raw(**changes) -> dict:
    raw = yaml.safe_load(open("config/scenes/reference_four_bar.yaml"))
    raw.pop("modal")
    raw.update(changes)
    return raw


def test_ladder_errors_extrapolated_to_zero_are_unbounded():
    # Asymptotic (changes −12, −3: order 2) towards a Richardson limit of zero.
    assert ladder_errors([16.0, 4.0, 1.0])[-1] == np.inf
    assert np.all(interpolate([32, 64, 128], ladder_errors([16.0, 4.0, 1.0]), [100, 256])
                  == np.inf)
    assert np.all(ladder_errors([0.0, 0.0, 0.0]) == 0.0)


def test_ladder_errors_are_exact_for_second_order_convergence():
    h = 1.0 / (32 * 2.0 ** np.arange(5))
    peaks = 7.0 * (1.0 + 3.0 * h**2)
    assert ladder_errors(peaks) == pytest.approx(3.0 * h**2 / 1.0, rel=1e-9)


@pytest.mark.parametrize("observed", [1.0, 2.0, 3.0, 3.5])
def test_ladder_errors_extrapolate_within_the_asymptotic_orders(observed):
    # Changes falling at an observed order from 1 to 3.5 earn Richardson's correction at
    # order 2: the last rung's error is a third of its change (or a twelfth of the one before).
    peaks = [1.01 + 0.01 * 2.0**observed, 1.01, 1.0]  # changes 0.01·2^q, then 0.01
    errors = ladder_errors(peaks)
    expected = max(0.01 / 3.0, 0.01 * 2.0**observed / 12.0)
    assert errors[-1] * abs(1.0 - 0.01 / 3.0) == pytest.approx(expected)


def test_a_ladder_out_of_its_asymptotic_range_earns_no_extrapolation():
    # Phase-wrapped rungs of a start transient: the peak moves erratically by about 1 %.
    peaks = [1.0, 1.012, 0.998, 1.006, 0.999]
    errors = ladder_errors(peaks)
    assert errors[-1] == pytest.approx(0.007 / 0.999)  # its own change, not a third of it
    # Every coarser rung errs by its distance to the last plus the last one's error.
    distance = np.abs(np.array(peaks) - peaks[-1]) / 0.999
    assert np.all(errors[:-1] >= distance[:-1] + errors[-1] - 1e-15)
    # A plateau (two rungs that happen to agree after a large change) is not converged.
    assert ladder_errors([1.05, 1.0, 1.0])[-1] == pytest.approx(0.05 / 4.0)


@given(st.lists(st.floats(0.5, 2.0), min_size=3, max_size=8))
@settings(max_examples=200, deadline=None)
def test_ladder_errors_never_grow_under_refinement(peaks):
    errors = ladder_errors(peaks)
    if errors[-1] == np.inf:  # extrapolated to zero: no relative error can be credited
        return
    assert np.all(np.diff(errors) <= 1e-15)
    # The last rung is never credited with less than its own Richardson correction,
    # relative to the extrapolated limit or (out of the asymptotic range) to the last rung.
    limit = peaks[-1] + (peaks[-1] - peaks[-2]) / 3.0
    assert (errors[-1] * max(abs(limit), abs(peaks[-1]))
            >= abs(peaks[-1] - peaks[-2]) / 3.0 * (1 - 1e-12))


def test_ladder_errors_distrust_a_rung_at_a_sign_change():
    # The 2nd rung happens to sit on the limit: it inherits the finer rung's larger error.
    errors = ladder_errors([1.1, 1.0, 1.0 + 4e-3, 1.0 + 1e-3])
    assert errors[1] >= errors[2] > 0.0


def test_interpolation_between_and_beyond_rungs():
    levels, errors = np.array([32.0, 64.0, 128.0]), np.array([4.5e-3, 1e-3, 2.5e-4])
    # On a rung, its error; beyond the finest, order 2 from it.
    assert interpolate(levels, errors, [64.0, 256.0]) == pytest.approx([1e-3, 2.5e-4 / 4])
    # Between rungs, the power law through the two (order log2(4.5) here).
    assert interpolate(levels, errors, [48.0])[0] == pytest.approx(1e-3 * 4.5**0.415, 1e-3)
    assert interpolate(levels, [1e-3, 1e-3, 1e-3], [40.0])[0] == pytest.approx(1e-3)
    assert np.isinf(interpolate(levels, errors, [16.0])[0])  # coarser than measured
    # A drop much steeper than the order (100× from 32 to 64 steps: a mode resolved in
    # between) is pre-asymptotic: the coarser rung's error holds up to the finer rung.
    steep = np.array([1e-1, 1e-3, 2.5e-4])
    assert interpolate(levels, steep, [40.0, 63.0]) == pytest.approx([1e-1, 1e-1])


def test_cost_model_prefers_the_cheaper_model():
    c, full = cost(np.array([2, 4, 8, 128]), 128, 1.0, 2)
    # The full mesh up to 4 elements, where a reduced link of 4 modes is no smaller.
    assert list(full) == [True, True, False, False]
    assert np.all(np.diff(c) > 0)
    # Steps dominate: doubling them costs more than quadrupling a fine mesh.
    assert cost(8, 256, 1.0, 1)[0] > cost(32, 128, 1.0, 1)[0]
    # More modes cost more per step; past 8 elements the reduced model is the cheaper one.
    assert cost(32, 1024, 1.0, 1, 8)[0] > cost(32, 1024, 1.0, 1, 4)[0]
    assert not cost(32, 1024, 1.0, 1, 8)[1]


ladders = st.lists(st.floats(1e-7, 1e-1), min_size=3, max_size=6).map(
    lambda e: np.sort(np.array(e))[::-1])


@given(space=ladders, time=ladders, tol=st.sampled_from([1e-2, 1e-3, 1e-4]),
       flexible=st.sampled_from([1, 2]),
       cut=st.tuples(st.floats(0.0, 1e-2), st.floats(0.0, 1e-3)))
@settings(max_examples=40, deadline=None)
def test_choice_meets_the_tolerance_at_least_cost(space, time, tol, flexible, cut):
    x = (2.0 * 2.0 ** np.arange(len(space)), space)
    t = (FIRST_STEPS * 2.0 ** np.arange(len(time)), time)
    truncation = dict(zip(MODE_CHOICES, cut))
    elements, steps, modes, predicted = choose(x, t, tol, 1.0, flexible, truncation)
    # Brute force over the same grid, within the ladders, over every model.
    ne, spr = np.meshgrid(_ELEMENTS[_ELEMENTS <= x[0][-1]],
                          np.arange(FIRST_STEPS, t[0][-1] + 1, 8), indexing="ij")
    grid_error = predicted_error(x, t, ne, spr)
    # The full mesh only where the space ladder measured it (up to 5 elements).
    costs = {m: np.where(grid_error + (truncation[m] if m else 0.0) <= tol / SAFETY,
                         _reduced_cost(ne, spr, 1.0, flexible, m) if m else
                         np.where(3 * ne - 3 <= MODES + 5, _full_cost(ne, spr, 1.0, flexible),
                                  np.inf), np.inf)
             for m in (0,) + MODE_CHOICES}
    best = min(float(c.min()) for c in costs.values())
    chosen = float(predicted_error(x, t, elements, steps)) + (truncation[modes] if modes
                                                               else 0.0)
    assert predicted == pytest.approx(chosen)
    if np.isfinite(best):  # nothing that meets the target is cheaper
        assert predicted <= tol / SAFETY
        model = (_reduced_cost(elements, steps, 1.0, flexible, modes) if modes else
                 _full_cost(elements, steps, 1.0, flexible))
        assert float(model) == pytest.approx(best)
    else:  # unreachable: the ladders' finest rungs, measured
        assert (elements, steps) == (int(x[0][-1]), int(t[0][-1]))


def test_a_truncated_model_is_chosen_only_where_its_truncation_fits():
    # Converged ladders: the reduced model of 4 modes is the cheapest, unless its measured
    # truncation exceeds the room the tolerance leaves; then 8 modes, then the full mesh
    # where the space ladder measured it.
    x = (np.array([2.0, 4.0, 8.0, 16.0]), np.array([5e-2, 2e-2, 4e-3, 1e-3]))
    t = (np.array([32.0, 64.0, 128.0]), np.array([1e-2, 1e-3, 1e-4]))
    assert choose(x, t, 1e-2, 1.0, 1, {4: 0.0, 8: 0.0})[2] == 4
    assert choose(x, t, 1e-2, 1.0, 1, {4: 8e-3, 8: 1e-3})[2] == 8
    # Neither fits, and the full mesh is measured only up to 5 elements, too coarse here: the
    # finest rungs, with the tolerance unmet.
    elements, steps, modes, predicted = choose(x, t, 1e-2, 1.0, 1, {4: 8e-3, 8: 8e-3})
    assert (elements, steps) == (16, 128) and modes in MODE_CHOICES
    assert predicted > 1e-2 / SAFETY
    # A ladder converged by 4 elements: there the full mesh was measured, and it is chosen.
    coarse = (x[0], np.array([5e-2, 3e-3, 1e-3, 2e-4]))
    elements, steps, modes, predicted = choose(coarse, t, 1e-2, 1.0, 1, {4: 8e-3, 8: 8e-3})
    assert modes == 0 and elements <= 5 and predicted <= 1e-2 / SAFETY


def fake_solver(peak, omega1=1e9, log=None):
    """A solve() for resolve_discretization: peak(elements, steps), a first frequency and the
    scene's speed."""
    def solve(scenes):
        out = {"peak": [], "omega1": [], "omega_top": [], "speed": []}
        for s in scenes:
            ne = s["discretization"]["elements_per_link"]
            spr = s["time"]["steps_per_revolution"]
            if log is not None:
                log.append((ne, spr))
            out["peak"].append(peak(ne, spr))
            out["omega1"].append(omega1 if s["modal"] else np.nan)
            out["omega_top"].append(omega1 if s["modal"] else np.nan)  # one mode
            out["speed"].append(s["drive"]["speed"])
        return {k: np.array(v) for k, v in out.items()}
    return solve


@pytest.mark.parametrize("tolerance", [1e-2, 1e-3, 1e-4])
def test_resolution_of_a_smooth_problem_meets_the_tolerance_cheaply(tolerance):
    # σ(n, s) = 1 + 0.3/n³ − 20/s²: space order 3, time order 2, errors of opposite sign.
    def true_error(ne, spr):
        return abs(0.3 / ne**3 - 20.0 / spr**2)

    scene = load_scene(reference_raw(discretization="auto", tolerance=tolerance))
    (chosen,), (report,) = resolve_discretization(
        [scene], fake_solver(lambda ne, spr: 1.0 + 0.3 / ne**3 - 20.0 / spr**2))
    ne = chosen["discretization"]["elements_per_link"]
    spr = chosen["time"]["steps_per_revolution"]
    assert true_error(ne, spr) < tolerance and report["tolerance_met"]
    assert report["predicted_error"] >= 0.3 / ne**3 + 20.0 / spr**2 - 1e-12  # a bound
    # Within 2× of the cheapest setting of the grid whose true error (with the lucky
    # cancellation of the two signs excluded) meets the tolerance.
    grid_ne, grid_spr = np.meshgrid(_ELEMENTS, np.arange(FIRST_STEPS, 1 << 16, 8),
                                    indexing="ij")
    best = cost(grid_ne, grid_spr, 1.0, 1)[0][
        0.3 / grid_ne**3 + 20.0 / grid_spr**2 < tolerance].min()
    assert float(cost(ne, spr, 1.0, 1)[0]) < 2.0 * best


def test_unreachable_tolerance_is_reported_with_the_finest_rungs():
    rng = np.random.default_rng(0)
    scene = load_scene(reference_raw(discretization="auto", tolerance=1e-4))
    (chosen,), (report,) = resolve_discretization(
        [scene], fake_solver(lambda ne, spr: 1.0 + 0.1 * rng.standard_normal()))
    assert not report["tolerance_met"]
    assert chosen["time"]["steps_per_revolution"] == MAX_LADDER_STEPS
    assert report["time_ladder"][-1][0] == MAX_LADDER_STEPS


def test_unmet_tolerance_is_flagged_in_status():
    # The change point: its peak stress grows as a step nears the singular position, so no
    # ladder converges to 1e-4; the case is flagged, with its estimate, never NaN.
    raw = reference_raw(discretization="auto", tolerance=1e-4,
                        mechanism={"type": "four_bar", "ground": 0.25, "crank": 0.05,
                                   "coupler": 0.2, "rocker": 0.1})
    raw["drive"] = {"speed": 200.0}
    raw["links"] = {"default": {"material": "steel",
                                "section": {"shape": "rectangle", "height": 0.02,
                                            "width": 0.01}},
                    "crank": {"flexible": False}}
    ds = simulate(raw)
    report = json.loads(str(ds.discretization_auto.values[0]))
    assert not report["tolerance_met"]
    assert "tolerance_unmet" in str(ds.status.attrs["flag_meanings"])
    assert int(ds.status[0]) & 128 and float(ds.error_estimate[0]) > 1e-4
    assert np.isfinite(ds.peak_stress.values).all()


@pytest.mark.parametrize("harmonic, finest", [(10, 128), (15, 256), (20, 128)])
def test_an_excitable_mode_is_resolved_by_the_time_ladder(harmonic, finest):
    # Peaks independent of the step converge at once (3 rungs, up to 128 steps), unless a mode
    # the crank harmonics can excite (below the 16th) needs more to reach ω₁h ≤ 1/2: at the
    # 15th harmonic 4π·15 = 188 steps, so the ladder climbs to 256.
    speed = 100.0
    scene = load_scene(reference_raw(discretization="auto", drive={"speed": speed}))
    assert harmonic < RESONANT_HARMONICS or harmonic == 20
    log = []
    resolve_discretization([scene], fake_solver(lambda ne, spr: 1.0, harmonic * speed, log))
    assert max(s for _, s in log) == finest


def model_solver(peak, omega_top, log):
    """A solve() whose peak(elements, steps, modes) sees the model (0: the full mesh), with a
    first frequency far above the crank harmonics and the highest at ``omega_top`` (rad/s);
    ``log`` gets (elements, steps, modes) per pilot and the modes each modal analysis asked."""
    def solve(scenes):
        out = {"peak": [], "omega1": [], "omega_top": [], "speed": []}
        for s in scenes:
            d = s["discretization"]
            key = (d["elements_per_link"], s["time"]["steps_per_revolution"],
                   d["modes_per_link"])
            log.append(key + ((s["modal"]["modes"],) if s["modal"] else ()))
            out["peak"].append(peak(*key))
            out["omega1"].append(1e9 if s["modal"] else np.nan)
            out["omega_top"].append(omega_top if s["modal"] else np.nan)
            out["speed"].append(s["drive"]["speed"])
        return {k: np.array(v) for k, v in out.items()}
    return solve


@pytest.mark.parametrize("start, finest", [("periodic", 128), ("undeformed", 256)])
def test_a_start_transient_resolves_every_mode_of_the_ladders_model(start, finest):
    # Peaks independent of the step converge at once (3 rungs, up to 128 steps). From a start
    # transient every mode of the ladders' model rings, so the ladder climbs until the highest
    # (here at 15× the crank speed: 4π·15 = 188 steps) is resolved; in a periodic state a mode
    # that far above the first one cannot be excited, and the first is above the harmonics.
    speed = 100.0
    raw = reference_raw(discretization="auto", drive={"speed": speed})
    raw["time"] = {**raw["time"], "start": start}
    log = []
    resolve_discretization([load_scene(raw)], model_solver(lambda *_: 1.0, 15 * speed, log))
    assert max(entry[1] for entry in log) == finest
    modal = [entry[3] for entry in log if len(entry) == 4]
    assert modal == [MODES if start == "undeformed" else 1]  # one flexible link


@pytest.mark.parametrize("cut_4, cut_8, chosen", [(1e-2, 1e-3, 8), (0.0, 0.0, 4),
                                                  (1e-2, 1e-2, None)])
def test_the_model_is_chosen_for_its_measured_truncation(cut_4, cut_8, chosen):
    # Converged ladders; the reduced models' peaks are off the full mesh's by cut_4 and cut_8.
    # Four modes are kept only where their truncation fits the tolerance's room, else eight;
    # the truncation is measured at the ladders' mesh and finest steps. The full mesh would
    # need about 27 elements, where the space ladder ran reduced models: it is not chosen,
    # and where neither reduced model fits, the tolerance is not met.
    def peak(elements, steps, modes):
        return 1.0 + 3.0 / elements**2 + {0: 0.0, 4: cut_4, 8: cut_8}[modes]

    log = []
    (scene,), (report,) = resolve_discretization(
        [load_scene(reference_raw(discretization="auto", tolerance=1e-2))],
        model_solver(peak, 1.0, log))
    modes = scene["discretization"]["modes_per_link"]
    assert modes == report["modes_per_link"] and modes in MODE_CHOICES
    assert report["tolerance_met"] == (chosen is not None)
    if chosen is not None:
        assert modes == chosen
    full = peak(8, 0, 0)  # relative to the full mesh at the ladders' 8 elements
    assert report["truncation"] == {"4": pytest.approx(cut_4 / full),
                                    "8": pytest.approx(cut_8 / full)}
    top = max(entry[1] for entry in log)
    assert {(8, top, 0), (8, top, 4), (8, top, 8)} <= set(log)
    assert (report["predicted_error"] <= 1e-2 / SAFETY) == report["tolerance_met"]


@pytest.mark.parametrize("tolerance", [1e-2, 1e-3])
def test_reference_four_bar_meets_the_tolerance(reference_four_bar_peak, tolerance):
    ds = simulate(reference_raw(discretization="auto", tolerance=tolerance))
    choice = json.loads(str(ds.discretization_auto.values[0]))
    assert choice["modes_per_link"] in (0,) + MODE_CHOICES and choice["tolerance"] == tolerance
    true = abs(float(ds.peak_stress.max()) - reference_four_bar_peak) / reference_four_bar_peak
    assert true < tolerance
    assert true <= choice["predicted_error"] <= tolerance / SAFETY
    # The per-case estimate (conservative by design) stays within a small factor of it.
    assert float(ds.error_estimate[0]) < 3.0 * tolerance
    assert ds.discretization_auto.attrs["long_name"].startswith("discretization chosen")


def test_scene_without_auto_reports_nothing():
    raw = reference_raw(discretization={"elements_per_link": 2})
    raw["time"]["steps_per_revolution"] = 32
    assert "discretization_auto" not in simulate(raw)


def test_several_auto_scenes_share_one_discretization_that_meets_both():
    raw = reference_raw(discretization="auto")
    fast = {**raw, "drive": {"speed": 150.0}}
    ds = simulate([raw, fast])
    choices = [json.loads(str(v)) for v in ds.discretization_auto.values]
    keys = ("elements_per_link", "steps_per_revolution", "modes_per_link")
    shared = [choices[0][k] for k in keys]
    assert shared == [choices[1][k] for k in keys]
    for choice in choices:  # each meets its tolerance there, by its own ladders
        assert choice["predicted_error"] <= choice["tolerance"] / SAFETY
    # At least each case's own choice, and no costlier than the finest of each
    # (elements, steps) of the two own choices, reduced to 8 modes or full, the cheaper.
    own = [c["own_choice"] for c in choices]
    model = cost(shared[0], shared[1], 1.0, 1, shared[2] or MODES)
    assert float(model[0]) >= max(float(cost(e, s, 1.0, 1, m or MODES)[0]) for e, s, m in own)
    assert float(model[0]) <= float(cost(max(e for e, _, _ in own), max(s for _, s, _ in own),
                                         1.0, 1)[0]) * (1 + 1e-12)


def test_identical_scenes_share_their_pilots():
    # A batch of cases that differ only in name climbs one ladder; each case gets the same
    # choice and report as it would alone, and a different case still climbs its own.
    def peak(ne, spr):
        return 1.0 + 0.3 / ne**3 - 20.0 / spr**2

    def raw(tolerance, **changes):
        return load_scene(reference_raw(discretization="auto", tolerance=tolerance, **changes))

    alone_log, copies_log, mixed_log, other_log = [], [], [], []
    (alone,), (alone_report,) = resolve_discretization([raw(1e-3)],
                                                       fake_solver(peak, log=alone_log))
    copies = [raw(1e-3, name=f"copy {k}") for k in range(4)]
    chosen, reports = resolve_discretization(copies, fake_solver(peak, log=copies_log))
    assert copies_log == alone_log
    for scene, report in zip(chosen, reports):
        assert report == alone_report
        assert scene["discretization"] == alone["discretization"]
        assert scene["time"]["steps_per_revolution"] == alone["time"]["steps_per_revolution"]
    assert [s["name"] for s in chosen] == [f"copy {k}" for k in range(4)]
    resolve_discretization([raw(1e-2)], fake_solver(peak, log=other_log))
    resolve_discretization(copies + [raw(1e-2)], fake_solver(peak, log=mixed_log))
    assert sorted(mixed_log) == sorted(alone_log + other_log)


# Sweeps in speed share their ladders (module docstring, stage 5).

def sweep_solver(peak, omega1=lambda speed: 1e9, log=None):
    """A solve() whose peak(elements, steps, speed) and first frequency (rad/s) depend on the
    speed; ``log`` gets (speed, elements, steps) per pilot."""
    def solve(scenes):
        out = {"peak": [], "omega1": [], "omega_top": [], "speed": []}
        for s in scenes:
            ne = s["discretization"]["elements_per_link"]
            spr = s["time"]["steps_per_revolution"]
            speed = s["drive"]["speed"]
            if log is not None:
                log.append((speed, ne, spr))
            out["peak"].append(peak(ne, spr, speed))
            out["omega1"].append(omega1(speed) if s["modal"] else np.nan)
            out["omega_top"].append(omega1(speed) if s["modal"] else np.nan)  # one mode
            out["speed"].append(speed)
        return {k: np.array(v) for k, v in out.items()}
    return solve


def speed_sweep(speeds, tolerance=1e-2):
    return [load_scene(reference_raw(discretization="auto", tolerance=tolerance,
                                     drive={"speed": float(v)}, name=f"{v:g} rad/s"))
            for v in speeds]


def test_sweeps_group_cases_that_differ_only_in_speed():
    scenes = speed_sweep([120.0, 100.0, 110.0]) + speed_sweep([100.0], tolerance=1e-3)
    longer = reference_raw(discretization="auto", tolerance=1e-2)
    longer["mechanism"] = {**longer["mechanism"], "coupler": 0.46}
    scenes.append(load_scene(longer))
    groups = sweeps([sweep_key(s) for s in scenes], [s["drive"]["speed"] for s in scenes])
    assert [g.tolist() for g in groups] == [[1, 2, 0], [3], [4]]


def test_pilot_keys_ignore_the_name_and_tell_speeds_and_values_apart():
    a, b, c = speed_sweep([100.0, 100.0, 110.0])
    b = {**b, "name": "another"}
    assert _pilot_key(a) == _pilot_key(b)
    assert sweep_key(a) == sweep_key(c) and _pilot_key(a) != _pilot_key(c)
    stiffer = copy.deepcopy(a)
    stiffer["links"]["coupler"]["material"]["E"] *= 1.0 + 1e-15
    assert sweep_key(stiffer) != sweep_key(a)
    # A value marshal does not write (a dict subclass) is keyed by its canonical JSON: equal
    # scenes still share a key.
    odd = {**a, "drive": OrderedDict(a["drive"])}
    assert _pilot_key(odd) == _pilot_key({**b, "drive": OrderedDict(b["drive"])})
    assert sweep_key(odd) != sweep_key(stiffer)


@given(n=st.integers(1, 300), stride=st.integers(1, 40))
def test_representatives_bracket_every_case(n, stride):
    climbed = representatives(n, stride)
    assert climbed[0] == 0 and climbed[-1] == n - 1 and np.all(np.diff(climbed) > 0)
    assert np.all(np.diff(climbed) <= stride)
    below, above = bracket(climbed, n)
    assert np.all(below <= np.arange(n)) and np.all(np.arange(n) <= above)
    # The two are neighbouring climbers (no climber strictly between them).
    inside = (climbed[None, :] > below[:, None]) & (climbed[None, :] < above[:, None])
    assert not inside.any()


@given(data=st.data(), n=st.integers(2, 60), stride=st.integers(1, 12),
       bar=st.floats(1e-4, 1e-1))
@settings(max_examples=200, deadline=None)
def test_a_sweep_left_unverified_has_only_checked_predictions(data, n, stride, bar):
    climbed = representatives(n, stride)
    errors = np.array(data.draw(st.lists(st.floats(0.0, 0.2), min_size=len(climbed),
                                         max_size=len(climbed))))
    top = np.array(data.draw(st.lists(st.sampled_from([128, 256, 512]),
                                      min_size=len(climbed), max_size=len(climbed))))
    need = np.array(data.draw(st.lists(st.sampled_from([0.0, 100.0, 300.0, 600.0]),
                                       min_size=n, max_size=n)))
    weight = data.draw(st.none() | st.lists(st.floats(0.0, 1e4), min_size=n, max_size=n))
    more = unverified(climbed, errors, top, need, bar, resonance=weight)
    assert not set(more.tolist()) & set(climbed.tolist())
    assert np.all((more > 0) & (more < n - 1))
    if len(more):
        return
    # Nothing left to climb: every case between climbers is bounded within the bar, the rule
    # held at every climber, and its first mode needs no finer steps than theirs reached.
    m = INTERPOLATION_MARGIN
    for k, (low, high) in enumerate(zip(climbed[:-1], climbed[1:])):
        if high - low < 2:
            continue
        assert m * max(errors[k], errors[k + 1]) <= bar
        assert np.all(need[low + 1:high] <= max(top[k], top[k + 1]))
        if weight is not None:  # the resonance-scaled prediction holds inside the gap
            assert np.all(interpolated_error(errors[[k, k + 1]], np.array(weight)[[low, high]],
                                             np.array(weight)[low + 1:high]) <= bar)
        for c in (k, k + 1):
            if 0 < c < len(climbed) - 1:
                neighbours = np.array(weight)[climbed[[c - 1, c + 1]]] if weight else None
                assert errors[c] <= interpolated_error(
                    errors[[c - 1, c + 1]], neighbours,
                    None if weight is None else weight[climbed[c]])


def climbers(log, first_steps=FIRST_STEPS):
    """Speeds whose pilots went beyond the first rung."""
    return {speed for speed, ne, spr in log if (ne, spr) != (8, first_steps)}


def test_a_sweep_climbs_from_representatives_and_shares_their_ladders():
    # The time error grows steeply with speed and the space error is negligible: the fastest
    # case sets the steps and most others are far enough below the bar for their climbing
    # neighbours to bound them. (Where all need about the same, all climb: module docstring.)
    speeds = np.linspace(90.0, 110.0, 33)

    def peak(ne, spr, speed):
        return 1.0 + 1e-5 / ne**3 - 20.0 * (speed / 110.0) ** 12 / spr**2

    log = []
    chosen, reports = resolve_discretization(speed_sweep(speeds), sweep_solver(peak, log=log))
    own = {float(s["drive"]["speed"]) for s, r in zip(chosen, reports) if r["ladder"] == "own"}
    assert own == climbers(log) and len(own) < len(speeds)
    assert set(speeds[representatives(len(speeds))]) <= own
    spr = chosen[0]["time"]["steps_per_revolution"]
    ne = chosen[0]["discretization"]["elements_per_link"]
    for scene, report in zip(chosen, reports):
        speed = scene["drive"]["speed"]
        # Every case: one first rung of its own; the others' ladders are not climbed again.
        assert sum(1 for s, *_ in log if s == speed and (_[0], _[1]) == (8, FIRST_STEPS)) == 1
        true = abs(1e-5 / ne**3 - 20.0 * (speed / 110.0) ** 12 / spr**2)
        assert true <= report["predicted_error"] <= 1e-2 and report["tolerance_met"]
        if report["ladder"] == "interpolated":
            low, high = report["ladder_cases"]
            assert chosen[low]["drive"]["speed"] < speed < chosen[high]["drive"]["speed"]
            assert reports[low]["ladder"] == reports[high]["ladder"] == "own"
            assert report["predicted_error"] == pytest.approx(INTERPOLATION_MARGIN * max(
                reports[low]["predicted_error"], reports[high]["predicted_error"]))


def test_a_case_between_representatives_that_they_do_not_predict_climbs_its_own():
    # 17 speeds, climbers at 0, 8 and 16 first, whose errors are small enough to bound the
    # others. Case 5 has a first mode at 15× its speed, which its time ladder would resolve to
    # 256 steps while the others stop at 128: it climbs itself, and its large time error sets
    # the steps for all.
    speeds = np.arange(90.0, 107.0)
    odd = speeds[5]

    def peak(ne, spr, speed):
        return 1.0 + 1e-5 / ne**3 - (400.0 if speed == odd else 0.05) / spr**2

    log = []
    chosen, reports = resolve_discretization(
        speed_sweep(speeds), sweep_solver(peak, lambda v: 15.0 * v if v == odd else 1e9, log))
    assert reports[5]["ladder"] == "own" and max(s for v, _, s in log if v == odd) >= 256
    assert not any(s > 128 for v, _, s in log if v != odd)
    spr = chosen[5]["time"]["steps_per_revolution"]
    assert spr >= reports[5]["own_choice"][1] and 400.0 / spr**2 < 1e-2
    # A smooth bump between the first climbers fails their bound: the gap is bisected until
    # the bump's case has climbed and set the steps.
    log = []

    def bump(ne, spr, speed):
        return 1.0 + 0.3 / ne**3 - 5.0 * (1 + 40.0 * np.exp(-(speed - 94.0) ** 2)) / spr**2

    chosen, reports = resolve_discretization(speed_sweep(speeds), sweep_solver(bump, log=log))
    assert reports[4]["ladder"] == "own" and 94.0 in climbers(log)
    spr, ne = (chosen[0]["time"]["steps_per_revolution"],
               chosen[0]["discretization"]["elements_per_link"])
    for speed, report in zip(speeds, reports):
        true = abs(0.3 / ne**3 - 5.0 * (1 + 40.0 * np.exp(-(speed - 94.0) ** 2)) / spr**2)
        assert true <= report["predicted_error"] <= 1e-2


@given(errors=st.lists(st.floats(0.0, 1.0), min_size=2, max_size=2),
       weights=st.lists(st.floats(1e-3, 1e4), min_size=2, max_size=2),
       weight=st.lists(st.floats(0.0, 1e5), min_size=1, max_size=20))
def test_interpolated_error_scales_each_climber_by_how_much_more_the_case_resonates(
        errors, weights, weight):
    plain = INTERPOLATION_MARGIN * max(errors)
    assert interpolated_error(errors) == plain
    predicted = interpolated_error(errors, weights, weight)
    weight = np.array(weight)
    # never below the plain bound, equal to it where the case resonates no more than either
    # climber, and growing with the case's weight
    assert np.all(predicted >= plain)
    calm = weight <= min(weights)
    np.testing.assert_allclose(predicted[calm], plain)
    order = np.argsort(weight)
    assert np.all(np.diff(predicted[order]) >= -1e-12 * predicted[order][1:])
    expected = INTERPOLATION_MARGIN * np.max(
        np.array(errors) * np.maximum(1.0, weight[:, None] / np.array(weights)), axis=1)
    np.testing.assert_allclose(predicted, expected, rtol=1e-12)


def test_a_resonance_between_climbers_is_found_from_the_frozen_spectra():
    # A periodic sweep whose space error a narrow 4:1 resonance at 91.05 rad/s (between two
    # speeds of the sweep, away from its first climbers and the middles of their gaps)
    # multiplies by the resonance weight, as on the reference four-bar. Searched from the
    # frozen spectra (one mode, ω̄ = 4 × 91.05 rad/s, 0.02 % of its load at k = 4, nearly
    # undamped), the speed where the weight peaks climbs, and every case's prediction bounds
    # its error. Without the search, at the same spacing, the climbers' errors bound a
    # resonance they do not see: the cases near it are under-predicted (6.8× here).
    speeds = np.round(np.arange(90.0, 110.01, 0.2), 2)
    share = np.zeros((17, 1))
    share[1, 0], share[4, 0] = 0.9998, 2e-4
    spectrum = (np.array([4 * 91.05]), share, np.array([1e-4]))

    def weight(speed):
        return resonance_weight([speed], spectrum[0][None], share[None], spectrum[2][None])[0]

    def error(ne, speed):
        return 0.3 / ne**3 * weight(speed) / weight(90.0)

    def peak(ne, spr, speed):
        return 1.0 + error(ne, speed)

    def spectra(scenes):
        return [spectrum for _ in scenes]

    log = []
    chosen, reports = resolve_discretization(speed_sweep(speeds), sweep_solver(peak, log=log),
                                             spectra=spectra)
    assert 91.0 in climbers(log)
    assert len(climbers(log)) < len(speeds) / 4
    ne = chosen[0]["discretization"]["elements_per_link"]
    for speed, report in zip(speeds, reports):
        assert error(ne, speed) <= report["predicted_error"] <= 1e-2 / SAFETY
        assert report["resonance_weight"] == pytest.approx(weight(speed))
    chosen, reports = resolve_discretization(speed_sweep(speeds), sweep_solver(peak),
                                             stride=PERIODIC_STRIDE)
    assert not any("resonance_weight" in report for report in reports)
    ne = chosen[0]["discretization"]["elements_per_link"]
    assert any(error(ne, speed) > report["predicted_error"]
               for speed, report in zip(speeds, reports))


def test_the_reference_four_bars_resonance_is_found_in_a_sweep_of_its_steady_states():
    # 41 speeds across the undamped 4:1 resonance (ω̄₁/4 ≈ 90.9 rad/s) as Fourier series at
    # 1 %: the first climbers (89 and 97 rad/s, every 33rd case and the last) are far from it;
    # the search puts climbers on it, and every case is within its estimate against 32
    # elements and 8 modes (within 1e-5 of every FE DOF at 256 points on these speeds).
    raw = reference_raw(tolerance=1e-2, discretization="auto",
                        time={"revolutions": 1, "steps_per_revolution": 128,
                              "start": "periodic", "periodic_solver": "spectral"},
                        outputs={"error_estimate": True})
    speeds = np.round(np.linspace(89.0, 97.0, 41), 2)
    scenes = [{**raw, "drive": {"speed": float(v)}} for v in speeds]
    ds = simulate(scenes)
    reports = [json.loads(str(r)) for r in ds.discretization_auto.values]
    own = {float(v) for v, r in zip(speeds, reports) if r["ladder"] == "own"}
    assert {90.8, 91.0} <= own and len(own) < len(speeds) / 2
    weight = np.array([r["resonance_weight"] for r in reports])
    assert speeds[np.argmax(weight)] in (90.8, 91.0)
    reference = simulate([{**s, "discretization": {"elements_per_link": 32,
                                                   "modes_per_link": 8}} for s in scenes])
    true = np.abs(ds.peak_stress.max("link").values
                  / reference.peak_stress.max("link").values - 1.0)
    assert np.all(true <= 1e-2) and np.all(true <= ds.error_estimate.values + 1e-5)
    assert true.max() > 1e-4  # the resonance's error is there to be bounded


def test_every_case_climbing_gives_each_case_its_own_ladders():
    # stride=1 is the resolution without sharing: each case's report is the one it gets alone
    # (a batch of identical cases likewise, test_identical_scenes_share_their_pilots).
    speeds = [95.0, 100.0, 105.0]

    def peak(ne, spr, speed):
        return 1.0 + 0.3 / ne**3 - 20.0 * speed / 100.0 / spr**2

    _, together = resolve_discretization(speed_sweep(speeds), sweep_solver(peak), stride=1)
    for scene, report in zip(speed_sweep(speeds), together):
        _, (alone,) = resolve_discretization([scene], sweep_solver(peak))
        for key in ("own_choice", "own_predicted_error", "time_ladder", "space_ladder"):
            assert report[key] == alone[key]
        assert report["ladder"] == "own"


def series_sweep(speeds, tolerance=1e-2, steps=256):
    return [load_scene(reference_raw(
        discretization="auto", tolerance=tolerance, drive={"speed": float(v)},
        name=f"{v:g} rad/s", time={"revolutions": 1, "steps_per_revolution": steps,
                                   "start": "periodic", "periodic_solver": "spectral"}))
        for v in speeds]


def series_solver(space_error, shot=lambda speed, pilot: False, log=None):
    """A solve() of spectral pilots: a series (tail 1e-7, peak 1 + space_error(elements,
    speed), no time error) where ``shot(speed, pilot)`` is false, else marched (tail NaN, a
    time error 20/s² added); ``log`` gets (speed, elements, steps, spectral_tail) per pilot
    and, with ``log.points``, (speed, elements, modes, collocation_points)."""
    def solve(scenes):
        out = {k: [] for k in ("peak", "omega1", "omega_top", "speed", "tail")}
        for s in scenes:
            ne = s["discretization"]["elements_per_link"]
            spr = s["time"]["steps_per_revolution"]
            speed = s["drive"]["speed"]
            if log is not None:
                log.append((speed, ne, spr, s["time"]["spectral_tail"]))
                if hasattr(log, "points"):
                    log.points.append((speed, ne, s["discretization"]["modes_per_link"],
                                       s["time"]["collocation_points"]))
            marched = s["time"]["periodic_solver"] != "spectral" or shot(speed, s)
            out["peak"].append(1.0 + space_error(ne, speed) - (20.0 / spr**2 if marched else 0))
            out["tail"].append(np.nan if marched else 1e-7)
            out["omega1"].append(1e9 if s["modal"] else np.nan)
            out["omega_top"].append(1e9 if s["modal"] else np.nan)
            out["speed"].append(speed)
        return {k: np.array(v) for k, v in out.items()}
    return solve


def test_a_series_climbs_no_time_ladder_and_keeps_its_tail_within_its_share():
    # With periodic_solver: spectral the time error is the series' tail, which its adaptive
    # points keep below SERIES_SHARE of the budget: no pilot leaves the scene's own steps, the
    # space ladder and the truncation are climbed as usual, and the prediction carries the
    # tail's bound on top of the space error, which grows steeply with speed (the fastest case
    # sets the mesh and bounds the others, test_a_sweep_climbs_from_representatives...).
    speeds = np.linspace(90.0, 110.0, 17)

    def space(ne, speed):
        return 0.3 * (speed / 110.0) ** 12 / ne**3

    log = []
    chosen, reports = resolve_discretization(series_sweep(speeds), series_solver(space, log=log))
    bound = SERIES_SHARE * 1e-2 / SAFETY
    assert {spr for *_, spr, _ in log} == {256}
    # Every series pilot stops at the bound but the full mesh's truncation pilot, at fixed
    # points (SERIES_FULL_POINTS) where no tail is to stop at.
    assert {tail for *_, tail in log} == {bound, SPECTRAL_TAIL}
    assert {ne for _, ne, _, tail in log if tail == SPECTRAL_TAIL} == {8}
    own = {speed for speed, *_ in log}
    assert set(speeds[representatives(len(speeds))]) <= own and len(own) < len(speeds)
    ne = chosen[0]["discretization"]["elements_per_link"]
    for scene, report in zip(chosen, reports):
        assert scene["time"] == {**scene["time"], "periodic_solver": "spectral",
                                 "collocation_points": "auto", "steps_per_revolution": 256,
                                 "spectral_tail": bound}
        assert report["time_error"] == "spectral_tail" and report["spectral_tail_bound"] == bound
        true = space(ne, scene["drive"]["speed"])
        assert true + bound <= report["predicted_error"] <= 1e-2 / SAFETY
        assert report["tolerance_met"] and report["first_frequency"] is None
        if report["ladder"] == "own":
            assert report["time_ladder"] == []
        else:  # the margin is on the interpolated part, not on the bound each case keeps
            low, high = report["ladder_cases"]
            assert report["predicted_error"] == pytest.approx(INTERPOLATION_MARGIN * max(
                reports[low]["predicted_error"] - bound,
                reports[high]["predicted_error"] - bound) + bound)


def test_a_series_shot_at_its_first_rung_climbs_the_marched_ladders():
    # The sweep's middle representative does not come out a series (its GMRES did not
    # converge, or it is near a change point): it climbs the time ladder from the first rung,
    # with its modal analysis, and the shared steps meet its marched time error.
    speeds = np.linspace(90.0, 110.0, 17)
    odd = speeds[8]
    log = []
    chosen, reports = resolve_discretization(
        series_sweep(speeds), series_solver(lambda ne, speed: 0.3 / ne**3,
                                            shot=lambda speed, pilot: speed == odd, log=log))
    assert {spr for speed, _, spr, _ in log if speed != odd} == {256}
    assert min(spr for speed, _, spr, _ in log if speed == odd) == FIRST_STEPS
    assert "time_error" not in reports[8] and len(reports[8]["time_ladder"]) >= 3
    spr = chosen[0]["time"]["steps_per_revolution"]
    ne = chosen[0]["discretization"]["elements_per_link"]
    assert 0.3 / ne**3 + 20.0 / spr**2 <= reports[8]["predicted_error"] <= 1e-2 / SAFETY


def test_a_periodic_sweep_as_series_meets_its_tolerance():
    # The reference four-bar's steady state at three speeds, as Fourier series chosen for 1 %,
    # against 32 elements of every DOF at 256 points: within the tolerance and the estimate,
    # which is the prediction (the series' own tails are far below their bound).
    speeds = [90.0, 100.0, 110.0]
    raw = [reference_raw(discretization="auto", tolerance=1e-2, drive={"speed": v},
                         time={"revolutions": 1, "steps_per_revolution": 128,
                               "start": "periodic", "periodic_solver": "spectral"})
           for v in speeds]
    ds = simulate(raw)
    reports = [json.loads(str(r)) for r in ds.discretization_auto.values]
    converged = simulate([{**r, "discretization": {"elements_per_link": 32},
                           "time": {**r["time"], "collocation_points": 256}} for r in raw])
    true = np.abs(ds.peak_stress.max("link").values / converged.peak_stress.max("link").values
                  - 1.0)
    assert np.all(true <= 1e-2) and np.all(true <= ds.error_estimate.values)
    assert np.all(ds.spectral_tail.values <= reports[0]["spectral_tail_bound"])
    assert ds.error_estimate.values == pytest.approx([r["predicted_error"] for r in reports])
    assert all(r["time_error"] == "spectral_tail" for r in reports)


class _Log(list):
    points: list


def test_a_series_whose_pilot_is_shot_climbs_marched_and_its_full_mesh_is_patient():
    # The full mesh's series is solved at SERIES_FULL_POINTS fixed points (its GMRES may
    # iterate longer there). Where it is shot all the same, at the output steps, its peak
    # carries a time error no ladder measured: that case climbs the marched ladders.
    speeds = np.linspace(90.0, 110.0, 17)
    odd = speeds[8]
    log = _Log()
    log.points = []

    def shot(speed, pilot):
        return speed == odd and pilot["discretization"]["modes_per_link"] == 0 \
            and pilot["discretization"]["elements_per_link"] == 8

    chosen, reports = resolve_discretization(
        series_sweep(speeds), series_solver(lambda ne, speed: 0.3 / ne**3, shot, log))
    full = {(speed, points) for speed, ne, modes, points in log.points if (ne, modes) == (8, 0)}
    assert {points for speed, points in full if speed != odd} == {SERIES_FULL_POINTS}
    assert "time_error" not in reports[8] and len(reports[8]["time_ladder"]) >= 3
    assert min(spr for speed, _, spr, _ in log if speed == odd) == FIRST_STEPS
    assert all(r["time_error"] == "spectral_tail" for k, r in enumerate(reports) if k != 8)
    spr = chosen[0]["time"]["steps_per_revolution"]
    assert 20.0 / spr**2 <= reports[8]["predicted_error"] <= 1e-2 / SAFETY


def test_with_a_series_the_full_mesh_is_chosen_only_where_no_reduced_model_exists():
    # The reduced models truncate too much, so a marched call takes the full mesh at 5
    # elements, where a 4-mode model also exists; a series' GMRES crawls on that full mesh
    # (and would be shot unmeasured), so a call with a series (a floor) does not take it.
    space = (np.array([2.0, 4.0, 8.0, 16.0]), np.array([4e-2, 5e-3, 6e-4, 8e-5]))
    time = (np.array([128.0]), np.zeros(1))
    cut = {4: 5e-3, 8: 5e-3}
    assert choose_shared([(space, time, cut)], 5e-3, 1.0, 1)[:3] == (5, 128, 0)
    elements, _, modes, predicted = choose_shared([(space, time, cut, 3e-4)], 5e-3, 1.0, 1)
    assert modes in MODE_CHOICES and predicted > 5e-3 / SAFETY  # unmet, and said so
    # Where the full mesh is the only model (4 elements or fewer) a series may take it.
    assert choose_shared([(space, time, {4: 1.0, 8: 1.0}, 3e-4)], 1e-2, 1.0, 1)[:3] == \
        (4, 128, 0)


def test_series_of_the_convergence_study_references_meet_their_tolerance():
    # The rocker-crank and the triple rocker of the convergence study (1 % modal damping,
    # 200 rad/s; their full meshes' series need over 100 GMRES iterations, the case that once
    # let a shot full mesh pass for a truncation of 0.8 %), as series chosen for 1e-3,
    # against 32 elements and 8 modes shot at 4096 steps per revolution: within the
    # prediction, which is within the tolerance.
    conv = yaml.safe_load(open("config/studies/convergence.yaml"))["convergence"]
    for family in ("rocker_crank", "triple_rocker"):
        raw = {**conv["base_scene"], **conv["families"][family], "modal": None}
        raw["links"] = {**conv["base_scene"]["links"], **conv["families"][family].get("links", {})}
        raw["time"] = {"revolutions": 1, "steps_per_revolution": 128, "start": "periodic"}
        reference = simulate({**raw, "discretization": {"elements_per_link": 32,
                                                        "modes_per_link": 8},
                              "time": {**raw["time"], "steps_per_revolution": 4096}})
        ds = simulate({**raw, "discretization": "auto", "tolerance": 1e-3,
                       "time": {**raw["time"], "periodic_solver": "spectral"}})
        report = json.loads(str(ds.discretization_auto.values[0]))
        true = abs(float(ds.peak_stress.max()) / float(reference.peak_stress.max()) - 1.0)
        assert report["time_error"] == "spectral_tail" and report["tolerance_met"]
        assert true <= report["predicted_error"] == pytest.approx(float(ds.error_estimate[0]))
        # a series' full mesh only where no reduced model exists (4 elements or fewer)
        assert report["modes_per_link"] in MODE_CHOICES or report["elements_per_link"] <= 4
