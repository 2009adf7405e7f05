"""Solving in parts with progress gives the dataset of one call, and says how far it is."""
import io

import numpy as np
import pytest

import ced
from ced.problem.scene import load_scene
from ced.study import progress
from ced.study.progress import eta_text, simulate_in_parts, split

SCENE = {"mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                       "rocker": 0.35},
         "discretization": {"elements_per_link": 2},
         "time": {"revolutions": 1, "steps_per_revolution": 16},
         "modal": {"modes": 2, "angles": 4}}


def scenes(n):
    return [{**SCENE, "drive": {"speed": 50.0 + 10.0 * i}} for i in range(n)]


def test_parts_are_large_and_few():
    one = load_scene(SCENE)
    assert split([one] * (2 * progress.MIN_PART - 1)) == [slice(0, 2 * progress.MIN_PART - 1)]
    parts = split([one] * 1000)
    assert len(parts) == progress.MAX_PARTS
    assert parts[0].start == 0 and parts[-1].stop == 1000
    assert all(a.stop == b.start for a, b in zip(parts, parts[1:]))


def test_scenes_that_cannot_share_parts_are_solved_in_one():
    elastic = load_scene(SCENE)
    rigid = load_scene({**SCENE, "discretization": {"formulation": "rigid"}})
    auto = load_scene({**SCENE, "discretization": "auto"})
    assert len(split([elastic] * 100 + [rigid] * 100)) == 1
    assert len(split([auto] * 200)) == 1


def test_parts_join_to_the_dataset_of_one_call(monkeypatch):
    monkeypatch.setattr(progress, "MIN_PART", 3)
    lines = []
    parts = simulate_in_parts(scenes(8), desc="family/0", log=lines.append)
    whole = ced.simulate(scenes(8))
    assert len(lines) == 2 and lines[0].startswith("family/0: 4/8 cases in ")
    assert "s left" in lines[0] and lines[-1].startswith("family/0: 8/8 cases in ")
    assert set(parts.data_vars) == set(whole.data_vars)
    for name in whole.data_vars:
        if name != "solve_time":
            np.testing.assert_array_equal(parts[name].values, whole[name].values)
            assert parts[name].dims == whole[name].dims
            assert parts[name].attrs.keys() == whole[name].attrs.keys()
    for name in whole.coords:
        np.testing.assert_array_equal(parts[name].values, whole[name].values)
        assert parts[name].attrs == whole[name].attrs
    for key in ("scenes", "effects", "references", "Conventions"):
        assert parts.attrs[key] == whole.attrs[key]


def test_no_bar_when_not_a_terminal(monkeypatch):
    monkeypatch.setattr(progress, "MIN_PART", 2)
    stream = io.StringIO()  # not a terminal
    simulate_in_parts(scenes(4), stream=stream)
    assert stream.getvalue() == ""


@pytest.mark.parametrize("done, total, elapsed, text", [
    (1, 4, 2.0, "1/4 cases in 2 s, about 6 s left"),
    (4, 4, 8.0, "4/4 cases in 8 s"),
])
def test_eta_text(done, total, elapsed, text):
    assert eta_text(done, total, elapsed) == text
