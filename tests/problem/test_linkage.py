"""Dyad descriptions: presets, topology, normalization and the refusals, each naming its key."""
import copy

import pytest

from ced.problem.linkage import describe, linkage_topology
from ced.problem.mechanism import topology
from ced.problem.scene import SceneError, load_scene
from tests.rigid.test_dyads import PRESS, RIGID, STEPHENSON_III, WATT_II


def _error(mechanism, **extra):
    with pytest.raises(SceneError) as info:
        load_scene({**RIGID, "mechanism": mechanism, **extra})
    return info.value


def test_presets_expand_to_the_built_in_topologies():
    four = {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35,
            "branch": "open"}
    slider = {"type": "slider_crank", "crank": 0.1, "rod": 0.3, "offset": 0.0,
              "slider_mass": 0.0, "branch": "open"}
    assert linkage_topology(describe(four)) == topology("four_bar")
    assert linkage_topology(describe(slider)) == topology("slider_crank")


def test_six_bar_topologies():
    watt = topology("watt_ii")
    assert watt.link_names == ["crank", "coupler", "rocker", "coupler2", "rocker2"]
    assert watt.joints["E"] == ("rocker", "coupler2") and watt.points == {"E": "rocker"}
    assert watt.ground_joints == ("A", "D", "G")
    steph = topology("stephenson_iii")
    assert steph.joints["E"] == ("coupler", "coupler2") and steph.points == {"E": "coupler"}
    press = topology(load_scene({**RIGID, "mechanism": PRESS})["mechanism"])
    assert press.sliders == {"ram": "F"} and "ram" not in press.links


@pytest.mark.parametrize("mechanism", [WATT_II, STEPHENSON_III, PRESS])
def test_normalized_linkage_is_a_fixed_point(mechanism):
    scene = load_scene({**RIGID, "mechanism": mechanism})
    assert load_scene(scene) == scene


def test_ternary_link_is_rigid_and_flexible_true_is_refused_on_it():
    scene = load_scene({**RIGID, "mechanism": WATT_II})
    assert scene["links"]["rocker"]["flexible"] is False
    assert scene["links"]["coupler2"]["flexible"] is True
    err = _error(WATT_II, links={"rocker": {"flexible": True}})
    assert err.path == "links.rocker.flexible" and "ternary" in str(err)


def _press(**change):
    mech = copy.deepcopy(PRESS)
    for path, value in change.items():
        target = mech
        keys = path.split("/")
        for key in keys[:-1]:
            target = target[int(key)] if key.isdigit() else target[key]
        target[int(keys[-1]) if keys[-1].isdigit() else keys[-1]] = value
    return mech


@pytest.mark.parametrize("change, path, words", [
    ({"dyads/1/links/0": "coupler"}, "mechanism.dyads[1].links[0]", "used twice"),
    ({"dyads/1/links/1": "crank"}, "mechanism.dyads[1].links[1]", "used twice"),
    ({"dyads/1/joints/0": "X"}, "mechanism.dyads[1].joints[0]", "attached to nothing"),
    ({"dyads/1/joints/0": "B"}, "mechanism.dyads[1].joints[0]", "already carries a joint"),
    ({"dyads/0/joints/2": "E"}, "mechanism.dyads[0].joints[2]", "attached to nothing"),
    ({"points/E/link": "rod"}, "mechanism.dyads[1].joints[0]", "attached to nothing"),
    ({"dyads/1/joints/1": "C"}, "mechanism.dyads[1].joints[1]", "already used"),
    ({"input/pivot": "Z"}, "mechanism.input.pivot", "not a ground pivot"),
    ({"dyads/0/kind": "PRP"}, "mechanism.dyads[0].kind", "allowed: RRR, RRP, RPR"),
    ({"dyads/0/lengths": [0.45]}, "mechanism.dyads[0].lengths", "2 link lengths"),
    ({"dyads/1/lengths/0": -1.0}, "mechanism.dyads[1].lengths[0]", "> 0"),
    ({"dyads/1/guide": {"angle": 0.3, "slope": 1}}, "mechanism.dyads[1].guide.slope", "unknown"),
    ({"ground/G": [1.0, 1.0]}, "mechanism.ground.G", "attached to nothing"),
    ({"points/H": {"link": "rocker", "at": [0.1, 0.1]}}, "mechanism.points.H",
     "attached to nothing"),
    ({"points/H": {"link": "nope", "at": [0.1, 0.1]}}, "mechanism.points.H.link",
     "unknown link"),
])
def test_bad_descriptions_are_refused_naming_the_key(change, path, words):
    err = _error(_press(**change))
    assert err.path == path, str(err)
    assert words in str(err)


def test_dyad_that_cannot_assemble_somewhere_in_the_cycle_is_refused():
    # The ram's rod is long enough at the start but not over the whole turn of the crank.
    err = _error(_press(**{"dyads/1/lengths/0": 0.36}))
    assert err.path == "mechanism"
    assert "dyads[1]" in str(err) and "cannot reach its guide" in str(err)
    watt = dict(WATT_II, rocker2=0.05)
    err = _error(watt)
    assert "dyads[1]" in str(err) and "coupler2" in str(err) and "input angle" in str(err)
    # The first loop of a six-bar is checked as a four-bar.
    err = _error(dict(STEPHENSON_III, coupler=2.0))
    assert "first loop" in str(err)


def test_rocker_input_six_bar_is_checked_over_its_oscillation_only():
    """A double-rocker first loop sweeps amplitude × its half-range: the second loop must
    assemble over that sweep, not the whole circle."""
    base = dict(WATT_II, ground=0.5, crank=0.35, coupler=0.1, rocker=0.45, coupler2=0.2,
                rocker2=0.15)
    scene = load_scene({**RIGID, "mechanism": base, "drive": {"amplitude": 0.5}})
    assert scene["mechanism"]["type"] == "watt_ii"
    err = _error(base, drive={"amplitude": 1.0})
    assert "dyads[1]" in str(err)


def test_every_scene_of_the_six_bar_guide_loads():
    """The guide's examples are real scenes (docs/guide/six_bars.md)."""
    import re
    from pathlib import Path

    import yaml

    text = (Path(__file__).resolve().parents[2] / "docs/guide/six_bars.md").read_text()
    blocks = re.findall(r"```yaml\n(.*?)```", text, re.S)
    assert len(blocks) == 5
    kinds = [load_scene(yaml.safe_load(block))["mechanism"]["type"] for block in blocks]
    assert kinds == ["linkage", "linkage", "watt_ii", "stephenson_iii", "linkage"]
