"""Error estimates shared along a speed sweep: who solves companions, what the others get."""
import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.auto.discretization import representatives
from ced.auto.sweep_estimate import (MARGIN, MAX_GAP, MIN_CASES, STRIDE, stride,
                                      sweep_estimates)
from ced.problem.scene import MEANINGS, load_scene
from ced.problem.status import STATUS_FLAGS
from ced.simulation.dataset import ESTIMATE_SOURCES
from ced.simulation.simulate import simulate


def _scenes(speeds, start: str = "undeformed", **outputs) -> list[dict]:
    raw = yaml.safe_load(open("config/scenes/reference_four_bar.yaml"))
    raw.pop("modal")
    raw["time"].update(start=start, revolutions=2, steps_per_revolution=64)
    raw["discretization"] = {"elements_per_link": 4}
    raw["outputs"] = {**raw.get("outputs", {}), **outputs}
    return [load_scene({**raw, "drive": {"speed": float(v)}}) for v in speeds]


class Companions:
    """A stand-in for ``error_estimates``: each case's own estimate from a table, and which
    cases it was asked to solve."""

    def __init__(self, own):
        self.own, self.solved = np.asarray(own, float), set()

    def __call__(self, known):
        new = set(range(len(self.own))) - set(known)
        assert not new & self.solved, "a case's companions were solved twice"
        self.solved |= new
        return np.array([known.get(i, self.own[i]) for i in range(len(self.own))])


def _run(scenes, own, status=None, known=None):
    companions = Companions(own)
    status = np.zeros(len(scenes), int) if status is None else np.asarray(status)
    out, interpolated = sweep_estimates(scenes, status, dict(known or {}), companions)
    return out, interpolated, companions.solved


def test_every_stride_th_speed_solves_companions_and_the_rest_are_bounded_by_them():
    speeds = np.linspace(90.0, 110.0, 40)
    own = 0.01 + 0.001 * np.sin(speeds)
    out, interpolated, solved = _run(_scenes(speeds), own)
    climbers = representatives(40, stride(40))
    assert solved == set(climbers.tolist()) and not interpolated[climbers].any()
    np.testing.assert_array_equal(out[climbers], own[climbers])
    for p in np.flatnonzero(interpolated):
        low, high = climbers[climbers < p].max(), climbers[climbers > p].min()
        assert out[p] == MARGIN * max(own[low], own[high])
    assert interpolated.sum() == 40 - len(climbers)


def test_a_climber_its_neighbours_do_not_bound_opens_both_its_gaps():
    speeds = np.linspace(90.0, 110.0, 40)
    own = np.full(40, 0.01)
    low, climber, high = representatives(40, stride(40))[:3]
    own[climber] = 0.05  # leave-one-out: 0.05 > 1.5 × 0.01
    _, interpolated, solved = _run(_scenes(speeds), own)
    middles = [(low + climber) // 2, (climber + high) // 2]
    assert set(middles) <= solved and not interpolated[middles + [climber]].any()


def test_cases_that_cannot_share_solve_their_own():
    speeds = np.linspace(90.0, 110.0, 40)
    own = np.full(40, 0.01)
    status = np.zeros(40, int)
    status[5] = STATUS_FLAGS["near_singular"]
    status[6] = STATUS_FLAGS["buckled"]
    status[7] = STATUS_FLAGS["resonant"]  # a start transient's resonance is broad: shares
    _, interpolated, solved = _run(_scenes(speeds), own, status)
    assert {5, 6} <= solved and 7 not in solved and interpolated[7]
    # Periodic starts, sweeps too small, repeated speeds, and auto's cases: every one its own.
    for scenes in (_scenes(speeds, start="periodic"), _scenes(speeds[:MIN_CASES - 1]),
                   _scenes(np.repeat(speeds[:20], 2)),
                   _scenes(speeds, error_estimate_sharing=False)):
        _, interpolated, solved = _run(scenes, np.full(len(scenes), 0.01))
        assert solved == set(range(len(scenes))) and not interpolated.any()
    known = {i: 0.02 for i in range(40)}
    out, interpolated, solved = _run(_scenes(speeds), own, known=known)
    assert not solved and not interpolated.any() and (out == 0.02).all()
    # auto's cases whose prediction is a floor under their companions: their own too
    companions = Companions(own)
    _, interpolated = sweep_estimates(_scenes(speeds), np.zeros(40, int), {}, companions,
                                      alone=range(40))
    assert companions.solved == set(range(40)) and not interpolated.any()


def test_cases_that_do_not_let_their_estimate_be_shared_are_no_part_of_the_sweep():
    """``outputs.error_estimate_sharing: false`` on some cases of a sweep: they solve their
    own, and the others still share among themselves (their key differs)."""
    speeds = np.linspace(90.0, 110.0, 40)
    scenes = _scenes(speeds)
    own_scenes = _scenes(speeds, error_estimate_sharing=False)
    mixed = [own_scenes[i] if i % 2 else scenes[i] for i in range(40)]
    _, interpolated, solved = _run(mixed, np.full(40, 0.01))
    assert set(range(1, 40, 2)) <= solved and not interpolated[1::2].any()
    assert interpolated[0::2].sum() == 20 - len(representatives(20, stride(20)))


def test_a_sweep_climbs_every_stride_th_case_and_at_least_three():
    assert stride(1000) == STRIDE and stride(2 * STRIDE + 1) == STRIDE
    for n in range(MIN_CASES, 3 * STRIDE):
        climbers = representatives(n, stride(n))
        assert len(climbers) >= 3 and np.diff(climbers).max() <= STRIDE


def test_gaps_wider_than_measured_are_bisected_until_no_case_is_left_in_them():
    speeds = 10.0 * (1.0 + 2.0 * MAX_GAP) ** np.arange(MIN_CASES)  # every gap too wide
    _, interpolated, solved = _run(_scenes(speeds), np.full(MIN_CASES, 0.01))
    assert solved == set(range(MIN_CASES)) and not interpolated.any()


def test_no_case_is_bounded_by_a_climber_without_an_estimate():
    speeds = np.linspace(90.0, 110.0, 40)
    own = np.full(40, 0.01)
    failed = representatives(40, stride(40))[1]
    own[failed] = np.nan  # its companions failed
    out, interpolated, solved = _run(_scenes(speeds), own)
    climbers = np.array(sorted(solved))
    for p in np.flatnonzero(interpolated):
        assert climbers[climbers < p].max() != failed and climbers[climbers > p].min() != failed
    assert np.isfinite(out[np.arange(40) != failed]).all() and failed in solved


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(1e-4, 1e-1), min_size=MIN_CASES, max_size=60))
def test_every_inner_climber_is_bounded_by_its_climbing_neighbours(own):
    """What the bisection guarantees: leave-one-out holds at every inner climber in the end,
    each case's estimate is its own or bounded by two such climbers."""
    n = len(own)
    own = np.asarray(own)
    out, interpolated, solved = _run(_scenes(np.linspace(90.0, 110.0, n)), own)
    climbers = np.array(sorted(solved))
    assert {0, n - 1} <= solved and (interpolated == ~np.isin(np.arange(n), climbers)).all()
    for a, c, b in zip(climbers[:-2], climbers[1:-1], climbers[2:]):
        assert own[c] <= MARGIN * max(own[a], own[b]) or (b - c < 2 and c - a < 2)
    assert (out >= own * ~interpolated).all()


def test_the_scene_reference_states_the_sweep_size():
    assert f"{MIN_CASES} or more" in MEANINGS["outputs.error_estimate"]
    sharing = MEANINGS["outputs.error_estimate_sharing"]
    assert f"every {STRIDE}th case" in sharing and f"{MARGIN} times" in sharing


def test_a_transient_sweep_through_simulate_reports_where_each_estimate_comes_from():
    speeds = np.linspace(90.0, 110.0, MIN_CASES)
    raw = yaml.safe_load(open("config/scenes/reference_four_bar.yaml"))
    raw.pop("modal")
    raw["time"].update(start="undeformed", revolutions=2, steps_per_revolution=128)
    raw["discretization"] = {"elements_per_link": 6, "modes_per_link": 4}
    scenes = [{**raw, "drive": {"speed": float(v)}} for v in speeds]
    shared = simulate(scenes)
    own = simulate([{**s, "outputs": {"error_estimate_sharing": False}} for s in scenes])
    assert (own.error_estimate_source.values == ESTIMATE_SOURCES["companions"]).all()
    own = own.error_estimate.values
    source = shared.error_estimate_source.values
    climbers = representatives(MIN_CASES, stride(MIN_CASES))
    assert stride(MIN_CASES) == 8 and list(climbers) == [0, 8, 16]
    assert (source[climbers] == ESTIMATE_SOURCES["companions"]).all()
    assert (np.delete(source, climbers) == ESTIMATE_SOURCES["sweep_neighbours"]).all()
    assert shared.error_estimate_source.attrs["flag_meanings"].split() == list(ESTIMATE_SOURCES)
    # A climber's estimate is its own companions', whichever cases are solved beside it.
    np.testing.assert_allclose(shared.error_estimate.values[climbers], own[climbers],
                               rtol=1e-12)
    assert (shared.error_estimate.values[8 + 1:16] == MARGIN * own[[8, 16]].max()).all()
