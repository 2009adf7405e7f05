"""Dyad descriptions: presets, topology, normalization and the refusals, each naming its key."""
import copy

import pytest

from ced.problem.linkage import describe, linkage_topology
from ced.problem.mechanism import topology
from ced.problem.scene import SceneError, load_scene
from tests.rigid.test_dyads import CYLINDER, PRESS, RIGID, SHAPER, STEPHENSON_III, WATT_II


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


def test_rpr_topology_sleeve_is_a_body_and_the_bar_end_a_joint():
    shaper = topology(load_scene({**RIGID, "mechanism": SHAPER})["mechanism"])
    assert shaper.link_names == ["crank", "lever", "rod"]
    assert shaper.sleeves == {"block": ("B", "lever")} and shaper.sliders == {"ram": "F"}
    assert shaper.joints["B"] == ("crank", "block") and shaper.joints["C"] == ("lever", "rod")
    assert shaper.links["lever"] == ("O", "C") and shaper.ground_joints == ("A", "O")
    # The bar's end C used by no dyad is a free tip; the sleeve turns on a ground pivot.
    cylinder = topology(load_scene({**RIGID, "mechanism": CYLINDER})["mechanism"])
    assert cylinder.joints["C"] == ("rod", "tip") and cylinder.joints["O"] == ("ground",
                                                                               "cylinder")
    assert cylinder.ground_joints == ("A", "O")
    dyad = describe(load_scene({**RIGID, "mechanism": SHAPER})["mechanism"])["dyads"][0]
    assert dyad == {"kind": "RPR", "links": ["lever", "block"], "joints": ["O", "C", "B"],
                    "lengths": [0.45], "offset": 0.0, "sleeve_mass": 0.4,
                    "sleeve_inertia": 3e-4}


@pytest.mark.parametrize("mechanism", [WATT_II, STEPHENSON_III, PRESS, SHAPER, CYLINDER])
def test_normalized_linkage_is_a_fixed_point(mechanism):
    scene = load_scene({**RIGID, "mechanism": mechanism})
    assert load_scene(scene) == scene


def test_ternary_link_is_rigid_and_flexible_true_is_refused_on_it():
    scene = load_scene({**RIGID, "mechanism": WATT_II})
    assert scene["links"]["rocker"]["flexible"] is False
    assert scene["links"]["coupler2"]["flexible"] is True
    err = _error(WATT_II, links={"rocker": {"flexible": True}})
    assert err.path == "links.rocker.flexible" and "ternary" in str(err)


def _press(base=PRESS, **change):
    mech = copy.deepcopy(base)
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


@pytest.mark.parametrize("change, path, words", [
    ({"dyads/0/branch": "open"}, "mechanism.dyads[0].branch", "one assembly"),
    ({"dyads/0/lengths": [0.45, 0.1]}, "mechanism.dyads[0].lengths", "1 link length"),
    ({"dyads/0/joints": ["O", "B"]}, "mechanism.dyads[0].joints", "3 joint names"),
    ({"dyads/0/guide": {"angle": 0.0}}, "mechanism.dyads[0].guide", "unknown"),
    ({"dyads/0/offset": "0.1"}, "mechanism.dyads[0].offset", "number"),
    ({"dyads/0/sleeve_mass": -0.1}, "mechanism.dyads[0].sleeve_mass", ">= 0"),
    ({"dyads/0/sleeve_inertia": -1e-3}, "mechanism.dyads[0].sleeve_inertia", ">= 0"),
    ({"dyads/0/joints/2": "Z"}, "mechanism.dyads[0].joints[2]", "attached to nothing"),
    ({"dyads/0/joints/1": "B"}, "mechanism.dyads[0].joints[1]", "already used"),
    ({"dyads/1/links/1": "block"}, "mechanism.dyads[1].links[1]", "used twice"),
    ({"points": {"E": {"link": "lever", "at": [0.1, 0.05]}}}, "mechanism.points.E",
     "carry no points"),
    ({"points": {"E": {"link": "block", "at": [0.1, 0.05]}}}, "mechanism.points.E",
     "carry no points"),
])
def test_bad_rpr_descriptions_are_refused_naming_the_key(change, path, words):
    err = _error(_press(SHAPER, **change))
    assert err.path == path, str(err)
    assert words in str(err)


def test_rpr_guide_bar_is_rigid_and_its_sleeve_is_no_link():
    """A sleeve sliding along a flexible bar is a load moving over it, which the linear
    floating-frame model cannot represent: flexible: true on the bar is refused, an inherited
    one ignored; the sleeve, a block, takes no link properties."""
    scene = load_scene({**RIGID, "mechanism": SHAPER})
    assert scene["links"]["lever"]["flexible"] is False
    assert scene["links"]["rod"]["flexible"] is True
    err = _error(SHAPER, links={"lever": {"flexible": True}})
    assert err.path == "links.lever.flexible"
    assert "RPR" in str(err) and "rigid" in str(err) and "moving" in str(err)
    err = _error(SHAPER, links={"block": {"flexible": False}})
    assert err.path == "links.block" and "sleeve" in str(err) and "not a link" in str(err)
    err = _error(SHAPER, links={"ram": {"flexible": False}})
    assert err.path == "links.ram" and "slider block" in str(err)


def test_rpr_that_cannot_assemble_somewhere_in_the_cycle_is_refused():
    # |OB| ranges over [0.15, 0.35] m: an offset of 0.2 m puts B inside the bar's reach circle.
    err = _error(_press(SHAPER, **{"dyads/0/offset": 0.2}))
    assert err.path == "mechanism" and "dyads[0]" in str(err)
    assert "|OB|" in str(err) and "offset" in str(err) and "pivot O" in str(err)
    # The block reaches 0.35 m along the lever: a 0.3 m lever is too short.
    err = _error(_press(SHAPER, **{"dyads/0/lengths": [0.3]}))
    assert err.path == "mechanism" and "runs off the end" in str(err) and "lever" in str(err)
    # The crank's tip passing through the lever's pivot (|AO| = crank): the block would sit
    # on the pivot.
    err = _error(_press(SHAPER, **{"ground/O": [0.0, -0.1]}))
    assert err.path == "mechanism" and "would sit on the bar's pivot" in str(err)


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
    assert len(blocks) == 7
    kinds = [load_scene(yaml.safe_load(block))["mechanism"]["type"] for block in blocks]
    assert kinds == ["linkage", "linkage", "watt_ii", "stephenson_iii", "linkage", "linkage",
                     "linkage"]
