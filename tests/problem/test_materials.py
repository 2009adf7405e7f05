"""Material library and cross-section properties (ced.problem.materials)."""
from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.problem.materials import (cowper_shear_coefficient, library, material_aliases,
                                   material_names, resolve_material, section_properties)
from ced.problem.scene import SceneError

KEYS = {"name", "source", "E", "rho", "nu", "yield_strength", "ultimate_strength",
        "endurance_limit", "G", "lame_lambda", "lame_mu", "c1", "c2"}


# -------------------------------------------------------------------------------- library
def test_library_has_the_required_materials_with_sources():
    names = material_names()
    for name in ("steel", "aluminium", "titanium", "brass", "sung_thompson_aluminium"):
        assert name in names
    for name, m in library().items():
        assert set(m) == KEYS
        assert m["name"] == name
        assert isinstance(m["source"], str) and len(m["source"]) > 20
        assert 1e10 < m["E"] < 3e11
        assert 1000 < m["rho"] < 10000
        assert 0.2 < m["nu"] < 0.4
        assert 5e7 < m["yield_strength"] < 2e9
        # fatigue data, where given, is ordered as for every metal: S_e < S_y-ish < S_u
        if m["endurance_limit"] is not None:
            assert m["endurance_limit"] < m["ultimate_strength"]
            assert m["yield_strength"] < m["ultimate_strength"]
            assert "endurance limit" in m["source"] or "fatigue strength" in m["source"]


@pytest.mark.parametrize("name, ultimate, endurance", [
    ("steel", 360e6, 180e6),              # S235 minimum S_u; Shigley S'e = 0.5 S_u
    ("aluminium", 310e6, 96.5e6),         # 6061-T6, R. R. Moore at 5e8 cycles
    ("titanium", 950e6, 510e6),           # Ti-6Al-4V unnotched at 1e7 cycles
    ("brass", None, None),                # nothing we could cite: no fatigue result
])
def test_library_fatigue_data(name, ultimate, endurance):
    m = resolve_material(name)
    assert m["ultimate_strength"] == ultimate and m["endurance_limit"] == endurance


def test_inline_endurance_limit_must_be_below_the_tensile_strength():
    with pytest.raises(SceneError, match="endurance_limit") as err:
        resolve_material({"E": 2e11, "rho": 7800, "nu": 0.3, "ultimate_strength": 4e8,
                          "endurance_limit": 5e8})
    assert "ultimate_strength" in err.value.message


@pytest.mark.parametrize("name, E, rho, nu, yield_strength, source_words", [
    ("steel", 2.1e11, 7850, 0.3, 2.35e8, "S235"),
    ("aluminium", 6.89e10, 2700, 0.33, 2.76e8, "6061-T6"),
    ("titanium", 1.138e11, 4430, 0.342, 8.8e8, "Ti-6Al-4V"),
    ("brass", 9.7e10, 8500, 0.31, 3.1e8, "C36000"),
    ("sung_thompson_aluminium", 7.1e10, 2714, 0.33, 2.76e8, "Sung"),
])
def test_library_values(name, E, rho, nu, yield_strength, source_words):
    m = resolve_material(name)
    assert (m["E"], m["rho"], m["nu"], m["yield_strength"]) == (E, rho, nu, yield_strength)
    assert source_words in m["source"]


def test_aliases_and_case():
    assert material_aliases()["aluminum"] == "aluminium"
    assert resolve_material("aluminum") == resolve_material("aluminium")
    assert resolve_material(" Steel ")["name"] == "steel"


def test_library_is_a_copy():
    m = resolve_material("steel")
    m["E"] = 1.0
    library()["steel"]["E"] = 1.0
    assert resolve_material("steel")["E"] == 2.1e11


# ------------------------------------------------------------------------- derived values
@settings(max_examples=100, deadline=None)
@given(E=st.floats(1e8, 1e12), rho=st.floats(10, 3e4), nu=st.floats(-0.9, 0.49))
def test_lame_constants_and_wave_speeds(E, rho, nu):
    m = resolve_material({"E": E, "rho": rho, "nu": nu})
    G = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    assert m["G"] == pytest.approx(G) and m["lame_mu"] == pytest.approx(G)
    assert m["lame_lambda"] == pytest.approx(lam)
    # independent forms: c1² = E(1 − ν)/(ρ(1 + ν)(1 − 2ν)), c2² = G/ρ (thesis III.3.1.a)
    assert m["c1"] == pytest.approx(math.sqrt(E * (1 - nu) / (rho * (1 + nu) * (1 - 2 * nu))))
    assert m["c2"] == pytest.approx(math.sqrt(G / rho))
    assert m["c1"] > m["c2"]
    assert resolve_material(m) == m  # a resolved material is valid inline input


def test_steel_wave_speeds_are_the_textbook_ones():
    m = resolve_material("steel")
    assert m["c1"] == pytest.approx(6020, rel=0.01)  # dilatational, m/s
    assert m["c2"] == pytest.approx(3220, rel=0.01)  # shear, m/s


def test_inline_material_defaults():
    m = resolve_material({"E": 2.1e11, "rho": 7850, "nu": 0.3})
    assert m["yield_strength"] is None and m["source"] is None
    assert m["name"].startswith("inline")
    assert isinstance(m["E"], float) and isinstance(m["rho"], float)
    assert resolve_material({"E": 1e11, "rho": 5e3, "nu": 0.3, "name": "x"})["name"] == "x"


@pytest.mark.parametrize("spec, path, words", [
    ("unobtainium", "m", "aluminium"),
    (3, "m", "library name"),
    ({"rho": 7850, "nu": 0.3}, "m.E", "needs E"),
    ({"E": 2e11, "rho": 7850, "nu": 0.5}, "m.nu", "< 0.5"),
    ({"E": 2e11, "rho": 7850, "nu": -1.0}, "m.nu", "> -1"),
    ({"E": 0, "rho": 7850, "nu": 0.3}, "m.E", "> 0 (Pa)"),
    ({"E": True, "rho": 7850, "nu": 0.3}, "m.E", "finite number"),
    ({"E": "2e11", "rho": 7850, "nu": 0.3}, "m.E", "finite number"),
    ({"E": 2e11, "rho": float("nan"), "nu": 0.3}, "m.rho", "finite number"),
    ({"E": 2e11, "rho": 7850, "nu": 0.3, "yield_strength": -1}, "m.yield_strength", "> 0"),
    ({"E": 2e11, "rho": 7850, "nu": 0.3, "colour": "grey"}, "m.colour", "allowed"),
    ({"E": 2e11, "rho": 7850, "nu": 0.3, "name": ""}, "m.name", "non-empty"),
    ({"E": 2e11, "rho": 7850, "nu": 0.3, "c2": 1.0}, "m.c2", "computed"),
    ({"E": 1e308, "rho": 1e-300, "nu": 0.3}, "m", "finite positive"),
])
def test_material_errors(spec, path, words):
    with pytest.raises(SceneError) as err:
        resolve_material(spec, "m")
    assert err.value.path == path
    assert words in err.value.message


# ------------------------------------------------------------------------------- sections
def test_rectangle():
    s = section_properties({"shape": "rectangle", "height": 0.01, "width": 0.02}, 0.3)
    assert s == {"shape": "rectangle", "height": 0.01, "width": 0.02,
                 "area": pytest.approx(2e-4), "second_moment": pytest.approx(0.02 * 1e-6 / 12),
                 "shear_coefficient": pytest.approx(13 / 15.3)}


def test_circle():
    s = section_properties({"shape": "circle", "diameter": 0.02}, 0.3)
    assert s == {"shape": "circle", "diameter": 0.02, "height": 0.02,
                 "area": pytest.approx(math.pi * 1e-4), "second_moment":
                     pytest.approx(math.pi * 0.02**4 / 64),
                 "shear_coefficient": pytest.approx(7.8 / 8.8)}


def test_cowper_limits():
    assert cowper_shear_coefficient("rectangle", 0.0) == pytest.approx(5 / 6)
    assert cowper_shear_coefficient("circle", 0.0) == pytest.approx(6 / 7)
    with pytest.raises(ValueError):
        cowper_shear_coefficient("hexagon", 0.3)


@settings(max_examples=100, deadline=None)
@given(h=st.floats(1e-5, 1.0), w=st.floats(1e-5, 1.0), nu=st.floats(-0.9, 0.49))
def test_section_identities_and_re_validation(h, w, nu):
    r = section_properties({"shape": "rectangle", "height": h, "width": w}, nu)
    assert r["second_moment"] == pytest.approx(r["area"] * h * h / 12)
    c = section_properties({"shape": "circle", "diameter": h}, nu)
    assert c["second_moment"] == pytest.approx(c["area"] * h * h / 16)
    assert section_properties(r, nu) == r and section_properties(c, nu) == c


@pytest.mark.parametrize("section, path, words", [
    ({"shape": "hexagon"}, "s.shape", "rectangle, circle"),
    ({"height": 0.01, "width": 0.01}, "s.shape", "rectangle, circle"),
    ("rectangle", "s", "mapping"),
    ({"shape": "rectangle", "height": 0.01}, "s.width", "needs height, width"),
    ({"shape": "rectangle", "height": 0.0, "width": 0.01}, "s.height", "> 0 (m)"),
    ({"shape": "rectangle", "height": 0.01, "width": 0.01, "diameter": 0.01}, "s.diameter",
     "allowed"),
    ({"shape": "circle", "diameter": 0.01, "width": 0.01}, "s.width", "allowed"),
    ({"shape": "circle", "diameter": 0.01, "height": 0.02}, "s.height", "computed"),
    ({"shape": "rectangle", "height": 0.01, "width": 0.01, "area": 1.0}, "s.area", "computed"),
    ({"shape": "rectangle", "height": 1e200, "width": 1e200}, "s", "finite positive"),
    ({"shape": "circle", "diameter": 1e-200}, "s", "finite positive"),
])
def test_section_errors(section, path, words):
    with pytest.raises(SceneError) as err:
        section_properties(section, 0.3, "s")
    assert err.value.path == path
    assert words in err.value.message
