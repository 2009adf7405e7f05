"""Scene parsing, validation and normalization (ced.problem.scene, docs/reference/scene.md)."""
from __future__ import annotations

import copy
import json
import math
import pickle
import re
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ced.problem.mechanism import assembly_error, topology
from ced.problem.scene import (DEFAULT_EFFECTS, EFFECTS, FORMULATIONS, INTEGRATORS, SCENE_KEYS,
                               SceneError, dump_scene, load_scene, scene_hash)
from tests.conftest import corpus_header, mutate_container

HERE = Path(__file__).resolve().parents[1]  # tests/
BAD_SCENES = sorted((HERE / "bad_scenes").glob("*.yaml"))
CONFIG_SCENES = sorted((HERE.parent / "config" / "scenes").glob("*.yaml"))

FOUR_BAR = {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45, "rocker": 0.35}


def minimal(**extra) -> dict:
    return {"mechanism": dict(FOUR_BAR), **extra}


def json_round_trip(obj):
    return json.loads(json.dumps(obj, allow_nan=False))


# ------------------------------------------------------------------------------ defaults
def test_minimal_four_bar_gets_documented_defaults():
    s = load_scene(minimal())
    assert list(s) == list(SCENE_KEYS)
    assert s["name"] == ""
    assert s["mechanism"] == {**FOUR_BAR, "branch": "open"}
    assert s["point_masses"] == {}
    assert s["drive"] == {"speed": 100.0, "initial_angle": 0.0, "amplitude": 0.8}
    assert s["effects"] == DEFAULT_EFFECTS == [
        "inertia", "elastic_inertia", "coriolis", "centrifugal", "axial_stiffening"]
    assert s["gravity"] == [0.0, -9.81]
    assert s["damping"] == {"model": "modal", "ratio": 0.0, "alpha": 0.0, "beta": 0.0}
    assert s["discretization"] == {"formulation": "euler_bernoulli", "elements_per_link": 8,
                                   "elements_across": 2, "modes_per_link": 0}
    assert s["time"] == {"revolutions": 2.0, "steps_per_revolution": 512,
                         "integrator": "generalized_alpha", "rho_inf": 0.9, "beta": 0.25,
                         "gamma": 0.5, "alpha": -0.05, "start": "undeformed",
                         "periodic_solver": "shooting", "collocation_points": "auto",
                         "spectral_tail": 5e-3}
    assert s["modal"] is None
    assert s["outputs"] == {"stations": 11, "every": 1, "error_estimate": True,
                            "error_estimate_sharing": True}
    assert s["tolerance"] == 1e-3
    assert set(s["links"]) == {"crank", "coupler", "rocker"}
    for link in s["links"].values():
        assert link["flexible"] is True
        assert link["material"]["name"] == "steel"
        sec = link["section"]
        assert (sec["shape"], sec["height"], sec["width"]) == ("rectangle", 0.005, 0.01)
        assert sec["area"] == pytest.approx(5e-5)
        assert sec["second_moment"] == pytest.approx(0.01 * 0.005**3 / 12)
        assert 0.8 < sec["shear_coefficient"] < 0.87


@pytest.mark.parametrize("mechanism, links, joints, extra", [
    ({"type": "slider_crank", "crank": 0.15, "rod": 0.3}, {"crank", "rod"}, ["A", "B", "C"],
     {"offset": 0.0, "slider_mass": 0.0, "branch": "open"}),
    ({"type": "single_link", "length": 0.5}, {"link"}, ["A", "B"], {}),
])
def test_other_mechanism_types(mechanism, links, joints, extra):
    s = load_scene({"mechanism": mechanism, "point_masses": {j: 0.01 for j in joints}})
    assert s["mechanism"] == {**mechanism, **extra}
    assert set(s["links"]) == links == set(topology(mechanism["type"]).link_names)
    assert s["point_masses"] == {j: 0.01 for j in joints}


def test_modal_block_defaults_and_null():
    assert load_scene(minimal(modal={}))["modal"] == {"modes": 6, "angles": 36,
                                                      "mode_shapes": False}
    assert load_scene(minimal(modal=None))["modal"] is None
    assert load_scene(minimal(modal={"modes": 3}))["modal"]["modes"] == 3


def test_null_blocks_mean_defaults_and_null_values_are_errors():
    assert load_scene(minimal(time=None, drive=None, links={"crank": None})) == \
        load_scene(minimal())
    with pytest.raises(SceneError) as err:
        load_scene(minimal(drive={"speed": None}))
    assert err.value.path == "drive.speed"


@pytest.mark.parametrize("change, key, words", [
    ({"effects": ["inertia", "elastic_inertia", "elastic_axial_force"]}, "effects",
     "list axial_stiffening too"),
    ({"discretization": {"formulation": "plane_stress"}}, "discretization.formulation",
     "euler_bernoulli or timoshenko"),
    ({"time": {"start": "periodic", "periodic_solver": "spectral"}}, "time.periodic_solver",
     "use shooting"),
    ({"time": {"start": "periodic", "revolutions": 0.5}}, "time.revolutions", "at least 1"),
])
def test_elastic_axial_force_is_refused_where_it_cannot_be_solved(change, key, words):
    effects = ["inertia", "elastic_inertia", "axial_stiffening", "elastic_axial_force"]
    raw = minimal(**{"effects": effects, **change})
    with pytest.raises(SceneError) as err:
        load_scene(raw)
    assert err.value.path == key and words in err.value.message


def test_elastic_axial_force_is_accepted_with_its_conditions():
    effects = ["elastic_axial_force", "axial_stiffening", "inertia", "elastic_inertia"]
    s = load_scene(minimal(effects=effects, discretization={"formulation": "timoshenko"}))
    assert s["effects"] == ["inertia", "elastic_inertia", "axial_stiffening",
                            "elastic_axial_force"]


def test_effects_are_sorted_canonically_and_auto_is_kept():
    s = load_scene(minimal(effects=["damping", "gravity", "inertia"]))
    assert s["effects"] == ["inertia", "gravity", "damping"]
    assert load_scene(minimal(effects=[]))["effects"] == []
    assert load_scene(minimal(effects="auto"))["effects"] == "auto"
    assert load_scene(minimal(discretization="auto"))["discretization"] == "auto"


def test_numbers_ints_for_floats_and_integral_floats_for_ints():
    s = load_scene(minimal(drive={"speed": 50}, time={"steps_per_revolution": 256.0},
                           outputs={"stations": 21}))
    assert s["drive"]["speed"] == 50.0 and isinstance(s["drive"]["speed"], float)
    assert s["time"]["steps_per_revolution"] == 256
    assert isinstance(s["time"]["steps_per_revolution"], int)
    assert math.copysign(1.0, load_scene(minimal(drive={"initial_angle": -0.0}))
                         ["drive"]["initial_angle"]) == 1.0
    with pytest.raises(SceneError, match="drive.speed: must be a finite number > 0"):
        load_scene(minimal(drive={"speed": True}))


def test_numpy_scalars_are_accepted_and_converted():
    np = pytest.importorskip("numpy")
    s = load_scene({"mechanism": {**FOUR_BAR, "crank": np.float64(0.1)},
                    "time": {"steps_per_revolution": np.int64(64)}})
    assert type(s["mechanism"]["crank"]) is float
    assert type(s["time"]["steps_per_revolution"]) is int
    json.dumps(s)


# --------------------------------------------------------------------------------- links
def test_link_overrides_merge_key_by_key_and_section_as_a_whole():
    s = load_scene(minimal(links={
        "default": {"material": "aluminum", "section": {"shape": "circle", "diameter": 0.01}},
        "crank": {"flexible": False},
        "rocker": {"section": {"shape": "rectangle", "height": 0.004, "width": 0.02},
                   "material": {"E": 2.0e11, "rho": 7800, "nu": 0.29}},
    }))
    crank, coupler, rocker = (s["links"][n] for n in ("crank", "coupler", "rocker"))
    assert crank["flexible"] is False and coupler["flexible"] is True
    assert crank["material"]["name"] == "aluminium" and crank["section"]["shape"] == "circle"
    assert crank["section"]["height"] == 0.01
    assert coupler == {**crank, "flexible": True}
    assert rocker["section"] == {
        "shape": "rectangle", "height": 0.004, "width": 0.02, "area": pytest.approx(8e-5),
        "second_moment": pytest.approx(0.02 * 0.004**3 / 12),
        "shear_coefficient": pytest.approx(10 * 1.29 / (12 + 11 * 0.29))}
    assert rocker["material"]["E"] == 2.0e11 and rocker["material"]["yield_strength"] is None
    assert rocker["material"]["name"].startswith("inline")


def test_inherited_error_is_reported_where_it_was_written():
    with pytest.raises(SceneError) as err:
        load_scene(minimal(links={"default": {"section": {"shape": "rectangle", "height": -1,
                                                          "width": 0.01}}}))
    assert err.value.path == "links.default.section.height"


def test_shear_coefficient_follows_the_link_material():
    s = load_scene(minimal(links={"default": {"material": "steel"},
                                  "coupler": {"material": "titanium"}}))
    k = {n: s["links"][n]["section"]["shear_coefficient"] for n in s["links"]}
    assert k["crank"] == pytest.approx(10 * 1.3 / (12 + 11 * 0.3))
    assert k["coupler"] == pytest.approx(10 * 1.342 / (12 + 11 * 0.342))


# --------------------------------------------------------------------- rules and options
def test_newmark_and_hht_parameters():
    s = load_scene(minimal(time={"integrator": "newmark", "beta": 0.3025, "gamma": 0.6}))
    assert (s["time"]["beta"], s["time"]["gamma"]) == (0.3025, 0.6)
    assert load_scene(minimal(time={"integrator": "hht", "alpha": -0.1}))["time"]["alpha"] == -0.1
    with pytest.raises(SceneError) as err:
        load_scene(minimal(time={"integrator": "newmark", "gamma": 0.4}))
    assert err.value.path == "time.gamma" and ">= 0.5" in err.value.message
    with pytest.raises(SceneError) as err:
        load_scene(minimal(time={"integrator": "hht", "rho_inf": 0.5}))
    assert err.value.path == "time.rho_inf" and "generalized_alpha" in err.value.message


def test_rayleigh_damping():
    s = load_scene(minimal(effects=["inertia", "elastic_inertia", "damping"],
                           damping={"model": "rayleigh", "alpha": 1.0, "beta": 1e-5}))
    assert s["damping"] == {"model": "rayleigh", "ratio": 0.0, "alpha": 1.0, "beta": 1e-5}
    with pytest.raises(SceneError, match="damping.ratio: is only used with model modal"):
        load_scene(minimal(damping={"model": "rayleigh", "ratio": 0.02}))


def test_assembly_uses_mechanism_assembly_error():
    bad = {"type": "four_bar", "ground": 1.0, "crank": 0.1, "coupler": 0.1, "rocker": 0.1}
    with pytest.raises(SceneError) as err:
        load_scene({"mechanism": bad})
    assert err.value.path == "mechanism"
    assert err.value.message == assembly_error({**bad, "branch": "open"})


def test_scene_error_format_and_type():
    err = SceneError("links.coupler.section.height", "must be > 0")
    assert str(err) == "links.coupler.section.height: must be > 0"
    assert isinstance(err, ValueError)
    again = pickle.loads(pickle.dumps(err))
    assert (again.path, again.message) == (err.path, err.message)


# ---------------------------------------------------------------------------- YAML input
def test_yaml_file_with_yaml12_numbers(tmp_path):
    path = tmp_path / "scene.yaml"
    path.write_text("mechanism: {type: single_link, length: 5e-1}\n"
                    "links: {default: {material: {E: 2.1e11, rho: 7850, nu: 0.3}}}\n"
                    "tolerance: 1e-4\n")
    s = load_scene(path)
    assert s["mechanism"]["length"] == 0.5 and s["tolerance"] == 1e-4
    assert s["links"]["link"]["material"]["E"] == 2.1e11
    assert load_scene(str(path)) == s


def test_yaml_text_is_not_a_path():
    with pytest.raises(SceneError) as err:
        load_scene("mechanism: {type: single_link, length: 0.5}")
    assert err.value.path == "<scene>" and "YAML text is not accepted" in err.value.message
    with pytest.raises(SceneError):
        load_scene(42)


@pytest.mark.parametrize("path", CONFIG_SCENES, ids=lambda p: p.name)
def test_config_scenes_are_valid_and_idempotent(path):
    s = load_scene(path)
    assert load_scene(s) == s == load_scene(json_round_trip(s))


# --------------------------------------------------------------------------- bad scenes
def test_there_are_enough_bad_scenes():
    assert len(BAD_SCENES) >= 20
    for path in BAD_SCENES:
        assert path.read_text().startswith("# expect: ")


@pytest.mark.parametrize("path", BAD_SCENES, ids=lambda p: p.stem)
def test_bad_scene(path):
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert err.value.path == corpus_header(path, "expect"), str(err.value)
    assert corpus_header(path, "mentions") in err.value.message, str(err.value)
    assert str(err.value) == f"{err.value.path}: {err.value.message}"


# ------------------------------------------------------------- valid scenes (hypothesis)
finite = st.floats(allow_nan=False, allow_infinity=False)


def _opt(**fields):
    return st.fixed_dictionaries({}, optional=fields)


@st.composite
def mechanisms(draw):
    kind = draw(st.sampled_from(["four_bar", "slider_crank", "single_link"]))
    length = st.floats(0.02, 1.0)
    if kind == "four_bar":
        mech = {"type": kind, **{k: draw(length) for k in ("ground", "crank", "coupler",
                                                            "rocker")}}
        names = ("ground", "crank", "coupler", "rocker")
        while True:  # shrink the longest link until the linkage closes with some margin
            longest = max(names, key=mech.__getitem__)
            others = sum(mech[k] for k in names) - mech[longest]
            if mech[longest] < 0.99 * others:
                break
            mech[longest] = 0.9 * others
        mech.update(draw(_opt(branch=st.sampled_from(["open", "crossed"]))))
    elif kind == "slider_crank":
        crank, offset = draw(length), draw(st.floats(-0.2, 0.2))
        mech = {"type": kind, "crank": crank, "rod": crank + abs(offset) + draw(length)}
        mech.update(draw(_opt(offset=st.just(offset), slider_mass=st.floats(0, 1),
                              branch=st.sampled_from(["open", "crossed"]))))
    else:
        mech = {"type": kind, "length": draw(length)}
    assert assembly_error({"offset": 0.0, **mech}) is None
    return mech


materials = st.one_of(
    st.sampled_from(["steel", "aluminium", "aluminum", "titanium", "brass", "Steel",
                     "sung_thompson_aluminium"]),
    st.fixed_dictionaries({"E": st.floats(1e9, 5e11), "rho": st.floats(1e3, 2e4),
                           "nu": st.floats(-0.5, 0.49)},
                          optional={"yield_strength": st.floats(1e7, 2e9),
                                    "name": st.text(min_size=1, max_size=8)}),
)
sections = st.one_of(
    st.fixed_dictionaries({"shape": st.just("rectangle"), "height": st.floats(1e-4, 0.1),
                           "width": st.floats(1e-4, 0.1)}),
    st.fixed_dictionaries({"shape": st.just("circle"), "diameter": st.floats(1e-4, 0.1)}),
)
link_entries = _opt(material=materials, section=sections, flexible=st.booleans())


@st.composite
def time_blocks(draw):
    integrator = draw(st.sampled_from(INTEGRATORS))
    params = {"newmark": {"beta": st.floats(0, 0.5), "gamma": st.floats(0.5, 1)},
              "hht": {"alpha": st.floats(-1 / 3, 0)},
              "generalized_alpha": {"rho_inf": st.floats(0, 1)},
              "houbolt": {}}[integrator]
    block = draw(_opt(revolutions=st.floats(0.5, 5), steps_per_revolution=st.integers(8, 4096),
                      start=st.sampled_from(["undeformed", "quasi_static", "periodic"]),
                      **params))
    return {"integrator": integrator, **block} if draw(st.booleans()) or params else block


@st.composite
def valid_scenes(draw):
    mech = draw(mechanisms())
    topo = topology(mech["type"])
    links = draw(st.dictionaries(st.sampled_from(["default", *topo.link_names]), link_entries,
                                 max_size=3))
    damping = draw(st.one_of(
        _opt(model=st.just("modal"), ratio=st.floats(0, 0.2)),
        st.fixed_dictionaries({"model": st.just("rayleigh")},
                              optional={"alpha": st.floats(0, 10), "beta": st.floats(0, 1e-3)})))
    scene = {"mechanism": mech}
    scene.update(draw(_opt(
        name=st.text(max_size=10),
        links=st.just(links),
        point_masses=st.dictionaries(st.sampled_from(topo.joint_names), st.floats(0, 1)),
        drive=_opt(speed=st.floats(1, 1000), initial_angle=st.floats(-7, 7),
                   amplitude=st.floats(0.01, 1)),
        # elastic_axial_force has conditions of its own on other keys: tested apart.
        effects=st.one_of(st.just("auto"), st.lists(
            st.sampled_from([e for e in EFFECTS if e != "elastic_axial_force"]), unique=True)),
        gravity=st.lists(st.floats(-20, 20), min_size=2, max_size=2),
        damping=st.just(damping),
        discretization=st.one_of(st.just("auto"), _opt(
            formulation=st.sampled_from(FORMULATIONS), elements_per_link=st.integers(1, 512),
            elements_across=st.integers(1, 64))),
        time=time_blocks(),
        modal=st.one_of(st.none(), _opt(modes=st.integers(1, 20), angles=st.integers(1, 72),
                                        mode_shapes=st.booleans())),
        outputs=_opt(stations=st.integers(1, 50).map(lambda n: 2 * n + 1),
                     every=st.integers(1, 16)),
        tolerance=st.floats(1e-8, 0.5),
    )))
    return scene


@settings(max_examples=200, deadline=None)
@given(valid_scenes())
def test_valid_scenes_normalize_idempotently_and_round_trip_through_json(raw):
    before = copy.deepcopy(raw)
    s = load_scene(raw)
    assert raw == before, "load_scene must not modify its input"
    assert load_scene(s) == s
    text = dump_scene(s)
    assert json.loads(text) == s
    assert load_scene(json.loads(text)) == s
    assert dump_scene(load_scene(s)) == text
    assert re.fullmatch(r"[0-9a-f]{12}", scene_hash(s))
    assert scene_hash(load_scene(json.loads(text))) == scene_hash(s)


def test_scene_hash_and_dump_are_canonical():
    a = load_scene(minimal())
    b = load_scene({"tolerance": 1e-3, **minimal()})
    assert dump_scene(a) == dump_scene(b) and scene_hash(a) == scene_hash(b)
    assert scene_hash(load_scene(minimal(drive={"speed": 101.0}))) != scene_hash(a)
    text = dump_scene(a)
    assert text == json.dumps(json.loads(text), sort_keys=True, separators=(",", ":"),
                              ensure_ascii=False)


# -------------------------------------------------------------------------------- fuzzing
KEYS = list(SCENE_KEYS) + ["type", "ground", "crank", "coupler", "rocker", "rod", "length",
                           "material", "section", "shape", "height", "width", "diameter", "E",
                           "rho", "nu", "G", "default", "A", "B", "model", "integrator"]
WORDS = ["auto", "steel", "aluminum", "rectangle", "circle", "open", "four_bar",
         "slider_crank", "single_link", "newmark", "hht", "modal", "rayleigh", "inertia", "A"]
junk = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(), st.integers(-10**400, 10**400),
              st.floats(), st.floats(-1e-300, 1e-300), st.sampled_from([1e308, -1e308, 5e-324]),
              st.text(max_size=8), st.sampled_from(WORDS), st.sampled_from(KEYS)),
    lambda children: st.one_of(
        st.lists(children, max_size=4),
        st.dictionaries(st.one_of(st.sampled_from(KEYS), st.text(max_size=4), st.integers()),
                        children, max_size=4)),
    max_leaves=10,
)


def _containers(obj, out):
    if isinstance(obj, (dict, list)):
        out.append(obj)
        for child in (obj.values() if isinstance(obj, dict) else obj):
            _containers(child, out)
    return out


def _mutate(data, scene):
    for _ in range(data.draw(st.integers(1, 4), label="mutations")):
        containers = _containers(scene, [])
        target = data.draw(st.sampled_from(containers), label="target")
        mutate_container(data, target, junk, st.one_of(st.sampled_from(KEYS),
                                                       st.text(max_size=4)))
    return scene


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_fuzz_mutated_scenes_give_a_scene_or_a_scene_error(data):
    raw = data.draw(valid_scenes(), label="scene")
    if data.draw(st.booleans(), label="normalized first"):
        raw = json_round_trip(load_scene(raw))
    if data.draw(st.booleans(), label="replace whole"):
        raw = data.draw(junk) if data.draw(st.booleans()) else {**raw, **data.draw(
            st.dictionaries(st.sampled_from(list(SCENE_KEYS)), junk, max_size=3))}
    else:
        raw = _mutate(data, raw)
    try:
        s = load_scene(raw)
    except SceneError as err:
        assert isinstance(err.path, str) and err.path
        assert str(err).startswith(err.path + ": ")
        return
    assert isinstance(s, dict)
    assert load_scene(json.loads(dump_scene(s))) == s


@settings(max_examples=150, deadline=None)
@given(st.one_of(
    st.text(max_size=200),
    st.lists(st.sampled_from(["mechanism:", " {type: four_bar", ", ground: 0.5", "}", "\n",
                              "  ", "- ", "[", "]", ":", "&a ", "*a", "!!python/object ",
                              "'", '"', "#", "links:", "crank: .nan", "\t", "? "]),
             max_size=30).map("".join)))
def test_fuzz_yaml_text_gives_a_scene_or_a_scene_error(text):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scene.yaml"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        try:
            load_scene(path)
        except SceneError as err:
            assert err.path
