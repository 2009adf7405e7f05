"""Models kept between the small batches of a call (ced.response.model_cache): a kept model
serves what a fresh build gives (bit for bit where, as here, no Craig–Bampton basis depends on
the batch's other cases), and only where the links and start configuration are the same."""
import dataclasses

import numpy as np
import pytest

from ced.problem.scene import load_scene
from ced.response import model_cache
from ced.response.batch import make_batch
from ced.response.model import build_model
from ced.simulation.simulate import simulate

FOUR_BAR = {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35}


def _scene(coupler=0.45, speed=100.0, steps=64, **extra):
    return load_scene({"mechanism": {**FOUR_BAR, "coupler": coupler},
                       "drive": {"speed": speed},
                       "discretization": {"elements_per_link": 4, "modes_per_link": 2},
                       "effects": ["inertia", "elastic_inertia", "coriolis", "centrifugal",
                                   "axial_stiffening", "damping"],
                       "damping": {"model": "modal", "ratio": 0.01},
                       "time": {"revolutions": 1, "steps_per_revolution": steps}, **extra})


def _arrays(model):
    """Every array of a model's fields but the batch, by path."""
    out = {}

    def walk(value, path):
        if isinstance(value, np.ndarray):
            out[path] = value
        elif isinstance(value, dict):
            for k, v in value.items():
                walk(v, f"{path}.{k}")
        elif dataclasses.is_dataclass(value) and not isinstance(value, type):
            for f in dataclasses.fields(value):
                walk(getattr(value, f.name), f"{path}.{f.name}")
    for f in dataclasses.fields(model):
        if f.name != "batch":
            walk(getattr(model, f.name), f.name)
    return out


@pytest.fixture(autouse=True)
def empty_cache():
    model_cache.clear()
    yield
    model_cache.clear()


def test_a_subset_of_a_kept_batch_gets_the_fresh_build_of_its_cases():
    # Three geometries kept; a batch of two of them (reversed, one twice, other speeds and
    # steps) must get bit for bit the arrays a fresh build of that batch has, but for the
    # modal damping's table, refined where any case of the kept batch needed it.
    kept = make_batch([_scene(c) for c in (0.45, 0.46, 0.47)])
    model_cache.model_for(kept)
    batch = make_batch([_scene(0.47, speed=80.0, steps=128), _scene(0.45, speed=120.0),
                        _scene(0.47, speed=90.0)])
    served, fresh = model_cache.model_for(batch), build_model(batch)
    assert served.batch is batch
    got, want = _arrays(served), _arrays(fresh)
    assert got.keys() == want.keys() and len(want) > 20
    for path, value in want.items():
        if not path.startswith("modal_damping."):
            np.testing.assert_array_equal(got[path], value, err_msg=path)
    assert served.layout == fresh.layout and served.effects == fresh.effects
    # The fresh grid is part of the served one (a kept batch halves an interval where any of
    # its cases needs it), and there the served table is the fresh one's to round-off: a
    # midpoint evaluated among other phases solves its motion in another batch of times.
    mine, theirs = fresh.modal_damping, served.modal_damping
    at = np.searchsorted(theirs.phase[0], mine.phase[0])
    np.testing.assert_array_equal(theirs.phase[:, at], mine.phase)
    np.testing.assert_allclose(theirs.matrix[:, at], mine.matrix, rtol=0,
                               atol=1e-9 * np.abs(mine.matrix).max())
    np.testing.assert_array_equal(theirs.turns, mine.turns)


def test_another_start_configuration_is_built_not_served():
    # Modal damping is tabulated over the phase from t = 0: another initial angle, another
    # table.
    first = model_cache.model_for(make_batch([_scene()]))
    turned = _scene()
    turned = load_scene({**turned, "drive": {**turned["drive"], "initial_angle": 1.0}})
    other = model_cache.model_for(make_batch([turned]))
    assert not np.array_equal(other.modal_damping.matrix[:, 0], first.modal_damping.matrix[:, 0])
    np.testing.assert_array_equal(other.modal_damping.matrix,
                                  build_model(make_batch([turned])).modal_damping.matrix)


def test_other_links_are_built_not_served():
    first = model_cache.model_for(make_batch([_scene(0.45)]))
    other = model_cache.model_for(make_batch([_scene(0.45, links={"coupler": {
        "section": {"shape": "rectangle", "height": 0.006, "width": 0.01}}})]))
    assert not np.array_equal(other.links["coupler"].stiffness, first.links["coupler"].stiffness)
    moved = model_cache.model_for(make_batch([_scene(0.46)]))
    assert not np.array_equal(moved.links["coupler"].mass, first.links["coupler"].mass)


def test_large_batches_are_not_kept(monkeypatch):
    monkeypatch.setattr(model_cache, "MAX_CASES", 1)
    model_cache.model_for(make_batch([_scene(), _scene(speed=90.0)]))
    assert not model_cache._MODELS


def test_a_simulation_is_the_same_with_kept_models(monkeypatch):
    # Within a call the error estimate's first frequencies reuse the solve's model; every
    # variable is the same bit for bit as with every model built afresh, with fewer builds.
    builds = []
    build = model_cache.build_model
    monkeypatch.setattr(model_cache, "build_model", lambda b: builds.append(b) or build(b))
    scenes = [_scene(0.45, speed=s, steps=128) for s in (90.0, 110.0)]
    kept = simulate(scenes)
    with_cache = len(builds)
    monkeypatch.setattr(model_cache, "MAX_CASES", 0)
    fresh = simulate(scenes)
    assert with_cache < len(builds) - with_cache
    for name in fresh.variables:
        if name != "solve_time":
            np.testing.assert_array_equal(kept[name].values, fresh[name].values, err_msg=name)


def test_a_call_starts_with_no_model_kept():
    before = model_cache.model_for(make_batch([_scene()]))
    simulate([_scene()])  # the same links: served, were the model still kept
    kept = [model for model, _ in model_cache._MODELS.values()]
    assert kept and all(model is not before for model in kept)


def _counted_evaluations(monkeypatch):
    """Case-phases evaluated by ced.response.period_terms._evaluate, as a list to sum."""
    from ced.response import period_terms
    counted, evaluate = [], period_terms._evaluate
    monkeypatch.setattr(period_terms, "_evaluate",
                        lambda model, times: counted.append(times.size) or evaluate(model, times))
    return counted, evaluate


def _ladder_rung(speeds, steps):
    """A batch at ``steps`` per revolution and the phases its period terms are evaluated at
    (every step up to 128, else 64 samples: ced.response.period_terms)."""
    batch = make_batch([_scene(speed=s, steps=steps) for s in speeds])
    phases = np.arange(steps, dtype=float) if steps <= 128 else np.arange(64) * (steps / 64)
    return batch, phases


def test_a_ladder_evaluates_each_phase_once_and_gets_fresh_terms(monkeypatch):
    from ced.response.period_terms import evaluate_terms
    counted, evaluate = _counted_evaluations(monkeypatch)
    speeds = (90.0, 100.0, 110.0)
    for steps, climbing, new in ((32, speeds, 3 * 32), (64, speeds[1:], 2 * 32),
                                 (128, speeds[1:], 2 * 64), (256, speeds[2:], 0),
                                 (1024, speeds[2:], 0)):
        batch, phases = _ladder_rung(climbing, steps)
        counted.clear()
        got = evaluate_terms(model_cache.model_for(batch), batch.step_size, phases)
        assert sum(counted) == new, steps
        fresh = build_model(batch)
        want = evaluate(fresh, batch.step_size[:, None] * phases[None, :])
        assert got.keys() == want.keys() and {"mass", "stiffness", "force"} <= got.keys()
        for name, value in want.items():
            np.testing.assert_array_equal(got[name], value, err_msg=f"{steps} {name}")


def test_terms_are_reused_at_the_same_times_of_the_same_speed_only(monkeypatch):
    from ced.response.period_terms import evaluate_terms
    counted, evaluate = _counted_evaluations(monkeypatch)
    batch, phases = _ladder_rung((100.0,), 64)
    evaluate_terms(model_cache.model_for(batch), batch.step_size, phases)
    kept = batch.step_size[0] * phases
    # another speed; other times, half of them equal; a grid 1.5 times finer, whose equal
    # times are not at the same phases to the bit ((2π/96)·3k against (2π/64)·2k)
    for speed, steps in ((101.0, 64), (100.0, 128), (100.0, 96)):
        batch, phases = _ladder_rung((speed,), steps)
        times = batch.step_size[0] * phases
        counted.clear()
        got = evaluate_terms(model_cache.model_for(batch), batch.step_size, phases)
        same = np.isin(times, kept) if steps == 128 else np.zeros(steps, bool)
        assert sum(counted) == steps - same.sum(), (speed, steps)
        want = evaluate(build_model(batch), times[None, :])
        for name, value in want.items():
            np.testing.assert_array_equal(got[name], value, err_msg=f"{speed} {steps} {name}")


def test_terms_beyond_the_bytes_allowed_are_not_kept(monkeypatch):
    from ced.response.period_terms import evaluate_terms
    monkeypatch.setattr(model_cache, "MAX_TERM_BYTES", 0)
    counted, _ = _counted_evaluations(monkeypatch)
    for _ in range(2):
        batch, phases = _ladder_rung((100.0,), 64)
        evaluate_terms(model_cache.model_for(batch), batch.step_size, phases)
    assert sum(counted) == 2 * 64 and not any(model_cache._TERMS.values())


def _family_terms(monkeypatch, kept, speed, spoil=None):
    """Terms of one case at ``speed`` after those of the ``kept`` speeds were evaluated in one
    batch (64 steps per revolution), against a direct evaluation: (case-phases evaluated for
    it, its largest misfit relative to each term's largest entry)."""
    from ced.response.period_terms import evaluate_terms
    counted, evaluate = _counted_evaluations(monkeypatch)
    batch, phases = _ladder_rung(kept, 64)
    evaluate_terms(model_cache.model_for(batch), batch.step_size, phases)
    if spoil is not None:
        spoil(next(e for entries in model_cache._TERMS.values() for e in entries))
    batch, phases = _ladder_rung((speed,), 64)
    counted.clear()
    got = evaluate_terms(model_cache.model_for(batch), batch.step_size, phases)
    want = evaluate(build_model(batch), batch.step_size[:, None] * phases[None, :])
    assert got.keys() == want.keys()
    misfit = max(np.abs(got[k] - want[k]).max() / np.abs(want[k]).max() for k in want)
    return sum(counted), misfit


def test_terms_at_another_speed_of_the_family_are_its_kept_speeds_quadratic(monkeypatch):
    # Four kept speeds: the slowest, middle and fastest fix T0 + Ω T1 + Ω² T2, the fourth
    # checks it; nothing is evaluated, and a direct evaluation agrees to round-off.
    evaluated, misfit = _family_terms(monkeypatch, (90.0, 97.0, 103.0, 110.0), 101.3)
    assert evaluated == 0 and misfit < 1e-12
    # a case's terms are the same bits whatever else its batch holds
    from ced.response.period_terms import evaluate_terms
    alone, phases = _ladder_rung((101.3,), 64)
    among, _ = _ladder_rung((95.0, 101.3, 97.0, 108.0), 64)
    got = [evaluate_terms(model_cache.model_for(b), b.step_size, phases) for b in (alone, among)]
    for name in got[0]:
        np.testing.assert_array_equal(got[0][name][0], got[1][name][1], err_msg=name)
    model_cache.clear()  # also a little outside them
    evaluated, misfit = _family_terms(monkeypatch, (90.0, 97.0, 103.0, 110.0), 118.0)
    assert evaluated == 0 and misfit < 1e-12


def test_terms_are_evaluated_where_the_family_cannot_give_them(monkeypatch):
    # three kept speeds leave nothing to check the quadratic with
    assert _family_terms(monkeypatch, (90.0, 100.0, 110.0), 95.0) == (64, 0.0)
    model_cache.clear()
    # far outside the kept speeds the interpolation would magnify their round-off
    assert _family_terms(monkeypatch, (90.0, 97.0, 103.0, 110.0), 400.0) == (64, 0.0)
    model_cache.clear()

    def cubic(entry):  # a term not quadratic in the speed: the check at the fourth fails
        row = entry.cases[(0, 97.0)]
        entry.values["stiffness"][row] *= 1.0 + 1e-6

    assert _family_terms(monkeypatch, (90.0, 97.0, 103.0, 110.0), 101.3, cubic) == (64, 0.0)
