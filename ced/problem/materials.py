"""Material library and cross-section properties.

Materials come from the packaged library ``ced/problem/data/materials.yaml`` (handbook values, each
with its ``source``) or are given inline in a scene as ``{E, rho, nu[, yield_strength, name,
source]}``. :func:`resolve_material` returns a plain dict with the elastic constants and the
derived quantities used by the elements:

- shear modulus G = E / (2(1 + ν)), which is also Lamé's μ;
- Lamé's λ = E ν / ((1 + ν)(1 − 2ν));
- dilatational and shear wave speeds c1 = √((λ + 2μ)/ρ), c2 = √(μ/ρ) (thesis III.3.1.a).

Sections (:func:`section_properties`): ``rectangle`` {height (in-plane bending depth), width
(out of plane)} and ``circle`` {diameter}. The Timoshenko shear coefficient is Cowper's (1966)
Poisson-dependent value for both shapes: k = 10(1 + ν)/(12 + 11ν) for the rectangle,
k = 6(1 + ν)/(7 + 6ν) for the solid circle (→ 5/6 and 6/7 as ν → 0).

Resolved dicts are valid input again: a resolved material is accepted as an inline material
and a computed section as a section, provided the derived/computed entries agree with the
values recomputed from the primary ones (relative tolerance 1e-9) — so an edited E with a stale
G is an error, not silently overwritten.
"""
from __future__ import annotations

import copy
import functools
import math
from collections.abc import Mapping
from importlib import resources
from typing import Any

import yaml

from .errors import Choice, Real, SceneError, Text, check_keys, join

__all__ = [
    "SceneError",
    "SECTION_SHAPES",
    "library",
    "material_names",
    "material_aliases",
    "resolve_material",
    "section_properties",
    "cowper_shear_coefficient",
]

#: Primary keys of an inline material (E, rho, nu required).
MATERIAL_KEYS = ("name", "source", "E", "rho", "nu", "yield_strength", "ultimate_strength",
                 "endurance_limit")
#: Keys computed by :func:`resolve_material`, accepted (and checked) on input.
DERIVED_MATERIAL_KEYS = ("G", "lame_lambda", "lame_mu", "c1", "c2")

#: Section shapes with their size keys; ``height`` of a circle is computed (= diameter).
SECTION_SHAPES: dict[str, tuple[str, ...]] = {
    "rectangle": ("height", "width"),
    "circle": ("diameter",),
}
#: Keys computed by :func:`section_properties`, accepted (and checked) on input.
COMPUTED_SECTION_KEYS = ("area", "second_moment", "shear_coefficient")

_RTOL = 1e-9


_E = Real(low=0.0, low_open=True, unit="Pa")
_RHO = Real(low=0.0, low_open=True, unit="kg/m^3")
_NU = Real(low=-1.0, high=0.5, low_open=True, high_open=True)
_YIELD = Real(low=0.0, low_open=True, unit="Pa")
_SIZE = Real(low=0.0, low_open=True, unit="m")

#: Inline-material keys: (check, default, one line of meaning), for the generated scene
#: reference (:mod:`ced.problem.reference`); the checks are the ones :func:`resolve_material`
#: applies.
MATERIAL_FIELDS = {
    "name": (Text(nonempty=True), "inline(E=…,rho=…,nu=…)",
             "label of the material (the case coordinate material)"),
    "source": (Text(), None, "where the values come from (free text)"),
    "E": (_E, "required", "Young's modulus"),
    "rho": (_RHO, "required", "density"),
    "nu": (_NU, "required", "Poisson's ratio"),
    "yield_strength": (_YIELD, None, "yield strength, for the study's stress utilisation"),
    "ultimate_strength": (_YIELD, None, "tensile strength, for the fatigue check's Goodman "
                                        "mean-stress correction"),
    "endurance_limit": (_YIELD, None, "fully reversed endurance limit (or the fatigue strength "
                                      "at the longest tested life), for the fatigue check"),
}
#: Section keys: (check, default, one line of meaning), as :func:`section_properties` checks.
SECTION_FIELDS = {
    "shape": (Choice(tuple(SECTION_SHAPES)), "required", "decides which sizes are needed"),
    "height": (_SIZE, "required for a rectangle", "rectangle: in-plane size, the bending depth"),
    "width": (_SIZE, "required for a rectangle", "rectangle: out-of-plane size"),
    "diameter": (_SIZE, "required for a circle", "circle: diameter of the solid round section"),
}


# --------------------------------------------------------------------------------- library
@functools.lru_cache(maxsize=1)
def _raw_library() -> tuple[dict[str, dict], dict[str, str]]:
    text = (resources.files("ced.problem") / "data" / "materials.yaml").read_text(encoding="utf-8")
    data = yaml.safe_load(text)
    entries = {
        name: _inline(entry, f"materials.yaml:{name}", default_name=name)
        for name, entry in data["materials"].items()
    }
    aliases = dict(data.get("aliases") or {})
    for alias, target in aliases.items():
        if target not in entries:
            raise SceneError(f"materials.yaml:aliases.{alias}", f"unknown material {target!r}")
    return entries, aliases


def library() -> dict[str, dict]:
    """Every library material, resolved (see :func:`resolve_material`), by canonical name."""
    return copy.deepcopy(_raw_library()[0])


def material_names() -> list[str]:
    """Canonical names of the library materials, sorted."""
    return sorted(_raw_library()[0])


def material_aliases() -> dict[str, str]:
    """Accepted alternative spellings → canonical names (e.g. ``aluminum`` → ``aluminium``)."""
    return dict(_raw_library()[1])


# ------------------------------------------------------------------------------- materials
def resolve_material(spec: Any, path: str = "links.default.material") -> dict:
    """Resolve a material given by library name or inline.

    Parameters
    ----------
    spec : str or mapping
        A library name (case-insensitive; aliases such as ``aluminum`` accepted) or an inline
        mapping ``{E, rho, nu[, yield_strength, ultimate_strength, endurance_limit, name,
        source]}`` in SI units. A dict returned
        by this function is accepted too (its derived entries must be consistent).
    path : str
        Dotted key path used in error messages.

    Returns
    -------
    dict
        ``name``, ``source`` (str or None), ``E`` (Pa), ``rho`` (kg/m³), ``nu``,
        ``yield_strength``, ``ultimate_strength``, ``endurance_limit`` (Pa, None if not
        given), ``G`` (Pa), ``lame_lambda``,
        ``lame_mu`` (Pa), ``c1``, ``c2`` (m/s).

    Raises
    ------
    SceneError
        Unknown name, unknown key, missing E/rho/nu, out-of-range value (E, rho > 0,
        −1 < ν < 0.5, yield_strength > 0), or inconsistent derived entries.

    Examples
    --------
    >>> m = resolve_material("aluminum")
    >>> m["name"], m["E"]
    ('aluminium', 68900000000.0)
    >>> round(resolve_material({"E": 2.1e11, "rho": 7850, "nu": 0.3})["c2"])
    3208
    """
    entries, aliases = _raw_library()
    if isinstance(spec, str):
        key = spec.strip().lower()
        key = aliases.get(key, key)
        if key in entries:
            return copy.deepcopy(entries[key])
        raise SceneError(path, f"unknown material {spec!r}; allowed: {_allowed_materials()}")
    if isinstance(spec, Mapping):
        return _inline(spec, path)
    raise SceneError(path, f"must be a material name or an inline mapping; allowed: "
                           f"{_allowed_materials()}; got {spec!r:.60}")


def _allowed_materials() -> str:
    entries, aliases = _raw_library()
    alias_text = f" (aliases: {join(sorted(aliases))})" if aliases else ""
    return (f"a library name from {join(sorted(entries))}{alias_text}, or an inline mapping "
            f"{{E, rho, nu[, yield_strength, ultimate_strength, endurance_limit, name, "
            f"source]}}")


def _inline(spec: Mapping, path: str, default_name: str | None = None) -> dict:
    check_keys(spec, path, MATERIAL_KEYS + DERIVED_MATERIAL_KEYS)
    for key in ("E", "rho", "nu"):
        if spec.get(key) is None:
            raise SceneError(f"{path}.{key}", "missing; an inline material needs E (Pa), "
                                              "rho (kg/m^3) and nu")
    E = _E(spec["E"], f"{path}.E")
    rho = _RHO(spec["rho"], f"{path}.rho")
    nu = _NU(spec["nu"], f"{path}.nu")
    ys, uts, se = (None if spec.get(key) is None else _YIELD(spec[key], f"{path}.{key}")
                   for key in ("yield_strength", "ultimate_strength", "endurance_limit"))
    if se is not None and uts is not None and se >= uts:
        raise SceneError(f"{path}.endurance_limit", f"{se!r} Pa must be below the "
                                                    f"ultimate_strength {uts!r} Pa")
    if spec.get("name") is not None:
        name = Text(nonempty=True)(spec["name"], f"{path}.name")
    else:
        name = default_name or f"inline(E={E:.6g},rho={rho:.6g},nu={nu:.6g})"
    source = spec.get("source")
    source = None if source is None else Text()(source, f"{path}.source")

    mu = E / (2.0 * (1.0 + nu))
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    derived = {
        "G": mu,
        "lame_lambda": lam,
        "lame_mu": mu,
        "c1": math.sqrt((lam + 2.0 * mu) / rho),
        "c2": math.sqrt(mu / rho),
    }
    for key, value in derived.items():
        if not math.isfinite(value) or (key != "lame_lambda" and value <= 0.0):
            raise SceneError(path, f"derived {key} = {value!r} is not a finite positive number; "
                                   f"E, rho and nu must be physically reasonable")
    _check_consistent(spec, derived, path, "E, rho and nu")
    return {"name": name, "source": source, "E": E, "rho": rho, "nu": nu,
            "yield_strength": ys, "ultimate_strength": uts, "endurance_limit": se, **derived}


def _check_consistent(spec: Mapping, computed: Mapping[str, float], path: str,
                      inputs: str) -> None:
    """Given derived entries must agree with the recomputed ones."""
    for key, value in computed.items():
        if key not in spec or spec[key] is None:
            continue
        given = Real()(spec[key], f"{path}.{key}")
        if abs(given - value) > _RTOL * max(abs(given), abs(value)):
            raise SceneError(
                f"{path}.{key}",
                f"{given!r} does not match the value {value!r} computed from {inputs}; "
                f"{key} is computed — omit it, or update it together with {inputs}")


# -------------------------------------------------------------------------------- sections
def cowper_shear_coefficient(shape: str, nu: float) -> float:
    """Cowper's (1966) Timoshenko shear coefficient of a rectangle or a solid circle.

    Parameters
    ----------
    shape : str
        ``rectangle`` or ``circle``.
    nu : float
        Poisson's ratio (dimensionless).

    Returns
    -------
    float
        The shear coefficient k (dimensionless): 10(1 + ν)/(12 + 11ν) for the rectangle,
        6(1 + ν)/(7 + 6ν) for the solid circle.

    Examples
    --------
    >>> round(cowper_shear_coefficient("rectangle", 0.0), 4)
    0.8333
    """
    if shape == "rectangle":
        return 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu)
    if shape == "circle":
        return 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu)
    raise ValueError(f"unknown section shape {shape!r}; allowed: {join(SECTION_SHAPES)}")


def section_properties(section: Any, nu: float, path: str = "links.default.section") -> dict:
    """Validate a cross-section and compute its properties.

    Parameters
    ----------
    section : mapping
        ``{shape: rectangle, height, width}`` (height = in-plane bending depth, width = out of
        plane) or ``{shape: circle, diameter}``, sizes in m. Computed keys (``area``,
        ``second_moment``, ``shear_coefficient``, and ``height`` of a circle) are accepted if
        consistent, so that a returned dict is valid input.
    nu : float
        Poisson's ratio of the link's material (for the shear coefficient).
    path : str
        Dotted key path used in error messages.

    Returns
    -------
    dict
        ``shape``, the sizes, ``height`` (bending depth, = diameter for a circle),
        ``area`` (m²), ``second_moment`` (in-plane, m⁴: w h³/12 or π d⁴/64) and
        ``shear_coefficient`` (Cowper).

    Examples
    --------
    >>> s = section_properties({"shape": "rectangle", "height": 0.01, "width": 0.02}, 0.3)
    >>> round(s["area"], 12), round(s["second_moment"] * 1e9, 6)
    (0.0002, 1.666667)
    """
    if not isinstance(section, Mapping):
        raise SceneError(path, f"must be a mapping {{shape: rectangle, height, width}} or "
                               f"{{shape: circle, diameter}}; got {section!r:.60}")
    if section.get("shape") is None:
        raise SceneError(f"{path}.shape", f"missing; allowed: {join(SECTION_SHAPES)}")
    shape = Choice(tuple(SECTION_SHAPES))(section["shape"], f"{path}.shape")
    sizes = SECTION_SHAPES[shape]
    extra = ("height",) if shape == "circle" else ()
    check_keys(section, path, ("shape",) + sizes + extra + COMPUTED_SECTION_KEYS)
    values = {}
    for key in sizes:
        if section.get(key) is None:
            raise SceneError(f"{path}.{key}", f"missing; a {shape} section needs "
                                              f"{join(sizes)}, each {_SIZE.describe()}")
        values[key] = _SIZE(section[key], f"{path}.{key}")

    if shape == "rectangle":
        h, w = values["height"], values["width"]
        area, second_moment = w * h, w * h * h * h / 12.0
    else:
        h = d = values["diameter"]
        area, second_moment = math.pi * d * d / 4.0, math.pi * d * d * d * d / 64.0
    computed = {"area": area, "second_moment": second_moment,
                "shear_coefficient": cowper_shear_coefficient(shape, nu)}
    for key, value in computed.items():
        if not (math.isfinite(value) and value > 0.0):
            raise SceneError(path, f"the sizes give {key} = {value!r}; sizes must give a finite "
                                   f"positive area and second moment")
    check = dict(computed, height=h) if shape == "circle" else computed
    _check_consistent(section, check, path, f"shape, {join(sizes)} and the material's nu")
    return {"shape": shape, **values, **({"height": h} if shape == "circle" else {}), **computed}
