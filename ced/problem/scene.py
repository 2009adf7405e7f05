"""Scene files: parse, validate and normalize (docs/reference/scene.md is generated from here).

:func:`load_scene` turns a scene (a YAML file or a mapping) into a new plain nested dict with
every default filled in, every value checked and every derived quantity (resolved materials,
section properties) computed. The result holds only dict/list/str/float/int/bool/None, so it is
JSON-serializable (:func:`dump_scene`, :func:`scene_hash`), and it is valid input again:
``load_scene(load_scene(x)) == load_scene(x)``.

Any problem raises :class:`SceneError` with the dotted key path of the offending value
(``links.coupler.section.height``, ``effects[2]``, ``<scene>`` for the document) and a message
saying what is allowed.

Choices the design leaves open
------------------------------
- **YAML dialect.** Scalars are resolved as in YAML 1.2: ``2.1e11`` and ``1e-3`` are floats
  (PyYAML's YAML 1.1 rules would read them as strings), only ``true``/``false`` are booleans
  (``yes``/``no``/``on``/``off`` stay strings), no sexagesimal or octal integers. Duplicate
  keys in a mapping are an error; so are files, nesting and alias expansions beyond the limits
  of :mod:`ced.problem.yaml_files`, the reader shared with study configs.
- **Numbers.** ``bool`` is never a number; an ``int`` is accepted for a float; a float with an
  integral value (``512.0``) is accepted for an integer; NaN/inf are rejected (see
  :mod:`ced.problem.errors`).
- **null.** A null *block* (``time:`` with nothing under it, ``links: {crank: }``) means an
  empty one, i.e. all defaults; ``modal: null`` means no modal analysis; a null *value* where a
  number, string or list is expected is an error (a forgotten value is not silently replaced).
- **Unused parameters.** In ``damping`` and ``time``, a parameter that the chosen model or
  integrator does not use must stay at its default (``{model: modal, alpha: 0.1}`` is an error,
  it would otherwise silently mean "no Rayleigh damping"). ``drive`` and ``discretization``
  are lenient (``amplitude`` vs ``initial_angle`` depends on the family, ``elements_across``
  is only read by ``plane_stress``) so that one base scene serves a whole study.
- **Links.** The built-in default link is overridden key by key by ``links.default``, which in
  turn is overridden key by key by each named link; ``material`` and ``section`` are replaced as
  a whole. Errors in an inherited value are reported at the path where it was written
  (``links.default.section.height``). Derived material/section entries in the input (as in a
  normalized scene) must agree with the recomputed ones.
- **Limits.** elements_per_link ≤ 512, elements_across ≤ 64, steps_per_revolution ≤ 10⁶,
  at most 10⁹ steps in total, modal modes ≤ 1000 and angles ≤ 100000, output stations ≤ 10001.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Mapping
from typing import Any


from .errors import (AutoOr, Bool, Choice, Int, Real, SceneError, Text, check_keys, join,
                     shown)
from .linkage import LINKAGE_FIELDS, PRESET_FIELDS, check_description
from .materials import resolve_material, section_properties
from .yaml_files import check_structure, load_yaml

__all__ = [
    "SceneError",
    "load_scene",
    "check_elastic_axial_force",
    "dump_scene",
    "scene_hash",
    "EFFECTS",
    "DEFAULT_EFFECTS",
    "FORMULATIONS",
    "INTEGRATORS",
    "PERIODIC_SOLVERS",
    "MECHANISM_TYPES",
    "SCENE_KEYS",
]

# ------------------------------------------------------------------------------ vocabulary
#: Every effect, in canonical order (normalized ``effects`` lists follow it).
EFFECTS = ("inertia", "elastic_inertia", "gravity", "coriolis", "centrifugal",
           "axial_stiffening", "elastic_axial_force", "damping")
DEFAULT_EFFECTS = ["inertia", "elastic_inertia", "coriolis", "centrifugal", "axial_stiffening"]
FORMULATIONS = ("euler_bernoulli", "timoshenko", "seed_lame", "plane_stress", "rigid")
INTEGRATORS = ("newmark", "hht", "generalized_alpha", "houbolt")
STARTS = ("undeformed", "quasi_static", "periodic")
PERIODIC_SOLVERS = ("shooting", "spectral")
MECHANISM_TYPES = ("four_bar", "slider_crank", "single_link", "watt_ii", "stephenson_iii",
                   "linkage")
AUTO = "auto"
#: Default ``time.spectral_tail``: 0.5 % (ced.response.collocation, measured on the default
#: study: the adaptive series' largest true error was 0.83 %).
SPECTRAL_TAIL = 5e-3

#: Top-level keys, in the order of the normalized scene.
SCENE_KEYS = ("name", "mechanism", "links", "point_masses", "drive", "effects", "gravity",
              "damping", "discretization", "time", "modal", "outputs", "tolerance")

#: The link every scene starts from.
BUILTIN_LINK = {"material": "steel",
                "section": {"shape": "rectangle", "height": 0.005, "width": 0.01},
                "flexible": True}
LINK_KEYS = ("material", "section", "flexible")

MAX_TOTAL_STEPS = 10**9


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED = _Required()

# ------------------------------------------------------------------------- declarative spec
# A block is {key: (check, default)}; a check is a callable (value, path) -> normalized value
# with a describe() method for messages (see ced.problem.errors).
_LENGTH = Real(low=0.0, low_open=True, unit="m")
_BRANCH = Choice(("open", "crossed"))
_NONNEG = Real(low=0.0)

MECHANISM_FIELDS: dict[str, dict[str, tuple[Any, Any]]] = {
    "four_bar": {
        "ground": (_LENGTH, REQUIRED),
        "crank": (_LENGTH, REQUIRED),
        "coupler": (_LENGTH, REQUIRED),
        "rocker": (_LENGTH, REQUIRED),
        "branch": (_BRANCH, "open"),
    },
    "slider_crank": {
        "crank": (_LENGTH, REQUIRED),
        "rod": (_LENGTH, REQUIRED),
        "offset": (Real(unit="m"), 0.0),
        "slider_mass": (Real(low=0.0, unit="kg"), 0.0),
        "branch": (_BRANCH, "open"),
    },
    "single_link": {
        "length": (_LENGTH, REQUIRED),
    },
    **{kind: {key: (check, REQUIRED if default is None else default)
              for key, (check, default) in fields.items()}
       for kind, fields in PRESET_FIELDS.items()},
    "linkage": {"ground": (LINKAGE_FIELDS["ground"], REQUIRED),
                "input": (LINKAGE_FIELDS["input"], REQUIRED),
                "points": (LINKAGE_FIELDS["points"], {}),
                "dyads": (LINKAGE_FIELDS["dyads"], REQUIRED)},
}

BLOCKS: dict[str, dict[str, tuple[Any, Any]]] = {
    "drive": {
        "speed": (Real(low=0.0, low_open=True, unit="rad/s"), 100.0),
        "initial_angle": (Real(unit="rad"), 0.0),
        "amplitude": (Real(low=0.0, high=1.0, low_open=True,
                           unit="fraction of the input's feasible half-range"), 0.8),
    },
    "damping": {
        "model": (Choice(("modal", "rayleigh")), "modal"),
        "ratio": (Real(low=0.0, unit="fraction of critical damping"), 0.0),
        "alpha": (Real(low=0.0, unit="1/s, mass-proportional"), 0.0),
        "beta": (Real(low=0.0, unit="s, stiffness-proportional"), 0.0),
    },
    "discretization": {
        "formulation": (Choice(FORMULATIONS), "euler_bernoulli"),
        "elements_per_link": (Int(1, 512), 8),
        "elements_across": (Int(1, 64, hint="plane_stress only"), 2),
        "modes_per_link": (Int(0, 512, hint="0 keeps every FE DOF; n > 0 reduces each "
                               "flexible link to n fixed-interface modes plus static load "
                               "vectors"), 0),
    },
    "time": {
        "revolutions": (Real(low=0.0, low_open=True, unit="input periods"), 2.0),
        "steps_per_revolution": (Int(8, 1_000_000), 512),
        "integrator": (Choice(INTEGRATORS), "generalized_alpha"),
        "rho_inf": (Real(low=0.0, high=1.0), 0.9),
        "beta": (Real(low=0.0, high=0.5), 0.25),
        "gamma": (Real(low=0.5, high=1.0), 0.5),
        "alpha": (Real(low=-1.0 / 3.0, high=0.0), -0.05),
        "start": (Choice(STARTS), "undeformed"),
        "periodic_solver": (Choice(PERIODIC_SOLVERS), "shooting"),
        "collocation_points": (AutoOr(Int(8, 4096, even=True)), AUTO),
        "spectral_tail": (Real(low=0.0, high=1.0, low_open=True, high_open=True,
                               unit="relative to the peak stress"), SPECTRAL_TAIL),
    },
    "modal": {
        "modes": (Int(1, 1000), 6),
        "angles": (Int(1, 100_000), 36),
        "mode_shapes": (Bool(), False),
    },
    "outputs": {
        "stations": (Int(3, 10_001, odd=True, hint="odd so that 0.5 is a station"), 11),
        "every": (Int(1, None, hint="write every n-th step"), 1),
        "error_estimate": (Bool(), True),
        "error_estimate_sharing": (Bool(), True),
    },
}

#: Parameters used only by one choice of a selector key: block -> (selector, {choice: params}).
MODEL_PARAMETERS = {
    "damping": ("model", {"modal": ("ratio",), "rayleigh": ("alpha", "beta")}),
    "time": ("integrator", {"newmark": ("beta", "gamma"), "hht": ("alpha",),
                            "generalized_alpha": ("rho_inf",), "houbolt": ()}),
}

#: One line of meaning per scene key, by dotted path (``<link>`` and ``<joint>`` stand for any
#: link or joint name of the mechanism). The scene reference of the documentation
#: (:mod:`ced.problem.reference`) is generated from these and the spec above; a key of the spec
#: without a meaning here fails the build of that reference.
MEANINGS: dict[str, str] = {
    "name": "free label of the scene, stored as the case coordinate scene_name",
    "mechanism.type": "kind of linkage; the other mechanism keys depend on it",
    "mechanism.four_bar.ground": "distance between the ground pivots A and D",
    "mechanism.four_bar.crank": "length of the input link A→B",
    "mechanism.four_bar.coupler": "length of the coupler B→C",
    "mechanism.four_bar.rocker": "length of the output link D→C",
    "mechanism.four_bar.branch": "assembly branch: open puts C on the left of B→D at the start "
                                 "(a kite, crank = ground and coupler = rocker, whose B passes "
                                 "over D: on the left of (sin θ/2, −cos θ/2), which is B→D for "
                                 "0 < θ < 2π)",
    "mechanism.slider_crank.crank": "length of the crank A→B",
    "mechanism.slider_crank.rod": "length of the connecting rod B→C",
    "mechanism.slider_crank.offset": "signed distance of the slider's guide from the x-axis "
                                     "through A",
    "mechanism.slider_crank.slider_mass": "mass of the slider at C",
    "mechanism.slider_crank.branch": "assembly branch of the rod (open or crossed)",
    "mechanism.single_link.length": "length of the one link, driven about a ground pivot with "
                                    "a free tip (for verification)",
    **{f"mechanism.{kind}.{key}": meaning for kind in ("watt_ii", "stephenson_iii")
       for key, meaning in {
           "ground": "distance between the ground pivots A and D of the first four-bar",
           "crank": "length of the input link A→B",
           "coupler": "length of the first coupler B→C",
           "rocker": "length of the first rocker D→C",
           "branch": "assembly branch of the first loop: open puts C on the left of B→D",
           "rocker_arm": "distance from the rocker's pivot D to its third joint E (the rocker "
                         "is a ternary link)",
           "rocker_arm_angle": "angle of D→E from D→C, counter-clockwise",
           "coupler_arm": "distance from B to the coupler's third joint E (the coupler is a "
                          "ternary link)",
           "coupler_arm_angle": "angle of B→E from B→C, counter-clockwise",
           "coupler2": "length of the second coupler E→F",
           "rocker2": "length of the output rocker G→F",
           "pivot2_x": "x of the output rocker's ground pivot G",
           "pivot2_y": "y of the output rocker's ground pivot G",
           "branch2": "assembly branch of the second dyad: open puts F on the left of E→G",
       }.items() if key in MECHANISM_FIELDS[kind]},
    "mechanism.linkage.ground": "the ground pivots by name, with their positions",
    "mechanism.linkage.input": "the input link: its name, its ground pivot, the name of its tip "
                               "joint and its length; it turns fully at the drive speed",
    "mechanism.linkage.points": "third (fourth, …) joints of links, in the link's frame: x from "
                                "its first joint towards its second, y to the left; a link "
                                "with a point is a ternary link (rigid)",
    "mechanism.linkage.dyads": "dyads placed in order, each attached to two known points (RRR: "
                               "links [P→M, Q→M], joints [P, M, Q]) or to one point and a "
                               "fixed guide (RRP: links [rod, slider], joints [P, M], guide "
                               "{point, angle}); branch open puts M on the left of P→Q (RRR) "
                               "or ahead of P along the guide (RRP). RPR: links [guide, "
                               "sleeve], joints [P, T, Q], lengths [L]: a rigid guide bar "
                               "P→T turning about P, through a sleeve turning about Q at the "
                               "signed offset (m, default 0) to the left of the bar's line; "
                               "sleeve_mass (kg) at Q and sleeve_inertia (kg m², about Q), "
                               "default 0; one assembly (no branch); T may stay free",
    "links.default": "properties every link inherits, key by key, unless the link overrides them",
    "links.<link>.material": "a library material name, or an inline {E, rho, nu[, "
                             "yield_strength, name, source]} mapping",
    "links.<link>.section": "cross-section: {shape: rectangle, height, width} or "
                            "{shape: circle, diameter}",
    "links.<link>.flexible": "false makes the link a rigid body (three small-motion DOFs)",
    "point_masses.<joint>": "point mass at a joint, carried by the second body of the joint",
    "drive.speed": "input speed Ω: constant crank speed, or the angular frequency of a "
                   "rocker input's oscillation",
    "drive.initial_angle": "input angle at t = 0 (crank-input families)",
    "drive.amplitude": "rocker-input families: θ = θ_mid + A sin(Ωt) with A this fraction of "
                       "half the feasible input range",
    "effects": "the physical terms built into the model (each adds one group of terms), or auto "
               "to choose them for the tolerance",
    "gravity": "gravity vector [gx, gy] used by the gravity effect",
    "damping.model": ("modal: one damping ratio for every mode of the linkage at every instant "
                      "(from the modes frozen at each phase of the cycle); rayleigh: C = αM + βK"),
    "damping.ratio": "modal damping ratio (used with model modal)",
    "damping.alpha": "Rayleigh mass-proportional coefficient α (used with model rayleigh)",
    "damping.beta": "Rayleigh stiffness-proportional coefficient β (used with model rayleigh)",
    "discretization": "the finite-element model of the flexible links, or auto to choose "
                      "elements and steps for the tolerance",
    "discretization.formulation": "link model: beam (euler_bernoulli, timoshenko), the thesis's "
                                  "seed_lame, 2-D plane_stress, or rigid (no elastic DOFs)",
    "discretization.elements_per_link": "finite elements along each flexible link",
    "discretization.elements_across": "elements across the link's height (plane_stress only)",
    "discretization.modes_per_link": "Craig–Bampton reduction: fixed-interface modes kept per "
                                     "flexible link (0: no reduction)",
    "time.revolutions": "simulated duration, in periods of the input motion",
    "time.steps_per_revolution": "time steps per input period",
    "time.integrator": "time-integration scheme",
    "time.rho_inf": "spectral radius at infinite frequency (generalized_alpha: 1 keeps every "
                    "frequency, smaller values damp the highest ones)",
    "time.beta": "Newmark β (used with newmark; 0.25 with γ 0.5 is the average acceleration "
                 "rule)",
    "time.gamma": "Newmark γ (used with newmark)",
    "time.alpha": "HHT α (used with hht)",
    "time.start": "initial elastic state: undeformed (q = q̇ = 0), quasi_static, or periodic "
                  "(the periodic steady state, with Floquet multipliers)",
    "time.periodic_solver": "how a periodic start finds the steady state: shooting (the "
                            "integrator over one period, exact for its steps) or spectral "
                            "(Fourier collocation, as many harmonics as the response needs; "
                            "the steps set the output instants and the Floquet analysis)",
    "time.collocation_points": "Fourier collocation points per input period with "
                               "periodic_solver: spectral: auto (from 32, doubled up to 256 "
                               "while the spectral tail exceeds time.spectral_tail) or a fixed "
                               "even number",
    "time.spectral_tail": "with periodic_solver: spectral and collocation_points: auto, the "
                          "spectral tail above which the collocation points double (the series' "
                          "time error; discretization: auto sets it from the tolerance)",
    "modal": "natural frequencies of the frozen linkage over the cycle; absent or null: none",
    "modal.modes": "number of natural frequencies computed at each phase",
    "modal.angles": "number of evenly spaced phases of the input cycle analysed",
    "modal.mode_shapes": "accepted and kept in the normalized scene; mode shapes are not "
                         "written to the dataset yet",
    "outputs.stations": "evenly spaced points along each link where station fields are "
                        "written (0 and 1 are the link's ends)",
    "outputs.every": ("write every n-th time step (the histories only: the peaks, dynamic "
                      "amplification and error estimate are over every step)"),
    "outputs.error_estimate": "estimate each elastic case's discretization error from "
                              "companion solutions (a periodic start: one coarser solve; a "
                              "start transient: two, one at twice the steps, shared along a "
                              "speed sweep of 17 or more cases run together: "
                              "`error_estimate_source`)",
    "outputs.error_estimate_sharing": "let a start transient's error estimate come from its "
                                      "neighbours in a speed sweep (every 16th case solves the "
                                      "companions, the cases between get 1.5 times the larger "
                                      "of their two neighbours'); false: this case solves its "
                                      "own, at about three times the cost of its solve",
    "tolerance": "target relative error of the automatic choices (effects: auto, "
                 "discretization: auto)",
}

POINT_MASS_CHECK = Real(low=0.0, unit="kg")
_GRAVITY = Real(unit="m/s^2")
TOLERANCE_CHECK = Real(low=0.0, high=1.0, low_open=True, high_open=True, unit="relative error")
NAME_CHECK = Text()
#: Defaults of the top-level keys that are not blocks.
DEFAULT_GRAVITY = [0.0, -9.81]
DEFAULT_TOLERANCE = 1e-3


# ------------------------------------------------------------------------------- checks
def _block(value: Any, path: str, fields: Mapping[str, tuple[Any, Any]]) -> dict:
    """Validate a mapping against a block spec and fill its defaults."""
    value = {} if value is None else value
    check_keys(value, path, tuple(fields))
    out = {}
    for key, (check, default) in fields.items():
        sub = f"{path}.{key}"
        if key in value:
            out[key] = check(value[key], sub)
        elif default is REQUIRED:
            raise SceneError(sub, f"missing; required: {check.describe()}")
        else:
            out[key] = default
    return out


def _unused_parameters(block: dict, name: str) -> None:
    """Parameters of another model/integrator must stay at their defaults."""
    selector, params = MODEL_PARAMETERS[name]
    chosen = block[selector]
    for key, (_, default) in BLOCKS[name].items():
        users = [choice for choice, keys in params.items() if key in keys]
        if users and chosen not in users and block[key] != default:
            raise SceneError(
                f"{name}.{key}",
                f"is only used with {selector} {join(users)}, but {name}.{selector} is "
                f"{chosen!r} (which uses: {join(params[chosen]) or 'no parameters'}); "
                f"remove it or leave it at its default {default!r}")


def _mechanism(value: Any) -> dict:
    if not isinstance(value, Mapping):
        raise SceneError("mechanism", f"must be a mapping with type ({join(MECHANISM_TYPES)}) "
                                      f"and its lengths; got {shown(value)}")
    if value.get("type") is None:
        raise SceneError("mechanism.type", f"missing; allowed: {join(MECHANISM_TYPES)}")
    kind = Choice(MECHANISM_TYPES)(value["type"], "mechanism.type")
    fields = MECHANISM_FIELDS[kind]
    check_keys(value, "mechanism", ("type",) + tuple(fields))
    rest = {k: v for k, v in value.items() if k != "type"}
    out = {"type": kind, **_block(rest, "mechanism", fields)}
    if kind == "linkage":
        check_description(out)
    return out


def _assembly(mechanism: dict, drive: dict) -> None:
    from .mechanism import assembly_error  # lazy: mechanism imports numpy

    try:
        message = assembly_error(mechanism, drive["amplitude"])
    except (ArithmeticError, ValueError) as exc:
        message = f"cannot be assembled ({exc})"
    if message:
        raise SceneError("mechanism", message)


def _rigid_links(topo) -> dict[str, str]:
    """Links ced models as rigid bodies whatever ``flexible`` says, each with why."""
    why = {link: (f"the {link} is a ternary link (it carries a point), which ced models as a "
                  "rigid body; flexible: true is allowed on binary links only")
           for link in topo.points.values()}
    for sleeve, (_, bar) in topo.sleeves.items():
        why[bar] = (f"the {bar} is the guide bar of an RPR dyad: its sleeve {sleeve} slides "
                    "along it, a load moving over the bar that the linear floating-frame "
                    "model cannot represent, so ced models it as a rigid body; flexible: true "
                    "is allowed on the binary links of RRR and RRP dyads and the input")
    return why


def _links(value: Any, names: tuple[str, ...], rigid: Mapping[str, str] | None = None,
           bodies: Mapping[str, str] | None = None) -> dict:
    """Merge built-in default, ``links.default`` and each named link; resolve and validate.

    Each resolved value is validated at the path where it was written. A link of ``rigid``
    (a ternary link, an RPR guide bar: link -> why) is rigid: ``flexible: true`` written on
    it is refused with that reason, an inherited one is ignored. ``bodies`` (a slider block
    or RPR sleeve -> what it is) are refused as links, saying where their mass is given.
    """
    value = {} if value is None else value
    rigid = rigid or {}
    if isinstance(value, Mapping):
        for body, what in (bodies or {}).items():
            if body in value:
                raise SceneError(f"links.{body}", f"the {body} is {what}, not a link: it has "
                                                  "no material, section or flexibility")
    check_keys(value, "links", ("default",) + names, what="link")
    entries = {}
    for key in ("default",) + names:
        entry = {} if value.get(key) is None else value[key]
        entries[key] = dict(check_keys(entry, f"links.{key}", LINK_KEYS))

    # field -> (raw value, path where it was written)
    default = {f: (BUILTIN_LINK[f], f"links.default.{f}") for f in LINK_KEYS}
    default.update({f: (v, f"links.default.{f}") for f, v in entries["default"].items()})

    out = {}
    # (material path, section path) -> resolved: a link that inherits its material and
    # section resolves to the same values as every other that does, so each place where one
    # is written is resolved once per scene (a six-bar's six blocks cost a four-bar's four).
    resolved: dict[tuple[str, str], tuple[dict, dict]] = {}
    for key in ("default",) + names:
        merged = dict(default)
        if key != "default":
            merged.update({f: (v, f"links.{key}.{f}") for f, v in entries[key].items()})
        where = (merged["material"][1], merged["section"][1])
        if where not in resolved:
            material = resolve_material(*merged["material"])
            resolved[where] = material, section_properties(
                merged["section"][0], material["nu"], merged["section"][1])
        # Flat dicts of numbers and names: a shallow copy keeps the links independent.
        material, section = (dict(block) for block in resolved[where])
        flexible = Bool()(*merged["flexible"])
        if key in rigid:
            if flexible and merged["flexible"][1] == f"links.{key}.flexible":
                raise SceneError(merged["flexible"][1], rigid[key])
            flexible = False
        if key != "default":
            out[key] = {"material": material, "section": section, "flexible": flexible}
    return out


def _point_masses(value: Any, joints: tuple[str, ...]) -> dict:
    value = {} if value is None else value
    check_keys(value, "point_masses", joints, what="joint")
    return {j: POINT_MASS_CHECK(value[j], f"point_masses.{j}") for j in joints if j in value}


def _effects(value: Any) -> list[str] | str:
    if isinstance(value, str) and value == AUTO:
        return AUTO
    allowed = f"a list of distinct names from {join(EFFECTS)}, or {AUTO!r}"
    if not isinstance(value, (list, tuple)):
        raise SceneError("effects", f"must be {allowed}; got {shown(value)}")
    seen: set[str] = set()
    for i, item in enumerate(value):
        if not isinstance(item, str) or item not in EFFECTS:
            raise SceneError(f"effects[{i}]", f"unknown effect {shown(item)}; allowed: "
                                              f"{join(EFFECTS)} (or effects: {AUTO})")
        if item in seen:
            raise SceneError(f"effects[{i}]", f"duplicate effect {item!r}; each effect may be "
                                              f"listed once, from: {join(EFFECTS)}")
        seen.add(item)
    return [e for e in EFFECTS if e in seen]


def _gravity(value: Any) -> list[float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise SceneError("gravity", f"must be a list [gx, gy] of two finite numbers (m/s^2); "
                                    f"got {shown(value)}")
    return [_GRAVITY(g, f"gravity[{i}]") for i, g in enumerate(value)]


def _time(value: Any) -> dict:
    block = _block(value, "time", BLOCKS["time"])
    _unused_parameters(block, "time")
    total = block["revolutions"] * block["steps_per_revolution"]
    if not (math.isfinite(total) and 1 <= round(total) <= MAX_TOTAL_STEPS):
        raise SceneError("time.revolutions", f"revolutions × steps_per_revolution = {total:g} "
                                             f"steps; allowed: 1 to {MAX_TOTAL_STEPS:g} steps")
    return block


def _spectral_allowed(scene: dict) -> None:
    """``time.periodic_solver: spectral`` solves the periodic steady state of a dynamic model.
    With ``discretization: auto`` its collocation points stay adaptive: the ladder of points
    is how the series meets the time part of the tolerance (``time.spectral_tail``, set from
    it by :mod:`ced.auto.discretization`)."""
    if scene["time"]["start"] != "periodic":
        raise SceneError("time.periodic_solver", f"spectral finds a periodic steady state: it "
                                                 f"needs time.start: periodic (got "
                                                 f"{scene['time']['start']!r}); use shooting")
    if scene["discretization"] == AUTO and scene["time"]["collocation_points"] != AUTO:
        raise SceneError("time.collocation_points", "discretization: auto bounds the series' "
                                                    "time error by its spectral tail, which "
                                                    "needs collocation_points: auto (got "
                                                    f"{scene['time']['collocation_points']})")
    if scene["time"]["collocation_points"] != AUTO and \
            scene["time"]["spectral_tail"] != SPECTRAL_TAIL:
        raise SceneError("time.spectral_tail", "sets when adaptive collocation points double; "
                                               "with collocation_points fixed (got "
                                               f"{scene['time']['collocation_points']}) it has "
                                               "no effect: drop one of them")


def check_elastic_axial_force(scene: dict) -> None:
    """``effects: [..., elastic_axial_force]`` adds the elastic response's axial force to the
    rigid motion's in the geometric stiffness (:mod:`ced.response.axial_force`): it needs that
    geometric stiffness, a beam's axial strain, and the response at every step (a periodic
    state by shooting, not a Fourier series).

    Parameters
    ----------
    scene : dict
        A scene whose ``effects`` list holds ``elastic_axial_force``, normalized but for
        that check (its ``discretization`` a block or ``"auto"``).

    Raises
    ------
    SceneError
        Naming the key that does not allow it.
    """
    if "axial_stiffening" not in scene["effects"]:
        raise SceneError("effects", "elastic_axial_force adds to the geometric stiffness of "
                                    "axial_stiffening: list axial_stiffening too")
    disc = scene["discretization"]
    if disc != AUTO and disc["formulation"] not in ("euler_bernoulli", "timoshenko"):
        raise SceneError("discretization.formulation",
                         f"elastic_axial_force needs a beam's axial strain: euler_bernoulli or "
                         f"timoshenko (got {disc['formulation']!r})")
    if scene["time"]["start"] == "periodic" and scene["time"]["revolutions"] < 1:
        raise SceneError("time.revolutions", "elastic_axial_force from a periodic start forms "
                                             "its force over a whole period: at least 1 (got "
                                             f"{scene['time']['revolutions']})")
    if scene["time"]["start"] == "periodic" and scene["time"]["periodic_solver"] != "shooting":
        raise SceneError("time.periodic_solver", "elastic_axial_force iterates on the periodic "
                                                 "state at every step: use shooting (got "
                                                 f"{scene['time']['periodic_solver']!r})")


def _normalize(raw: Any) -> dict:
    if not isinstance(raw, Mapping):
        kind = "empty" if raw is None else type(raw).__name__
        raise SceneError("<scene>", f"the top level must be a mapping with keys from "
                                    f"{join(SCENE_KEYS)}; got {kind}")
    check_keys(raw, "", SCENE_KEYS)
    if raw.get("mechanism") is None:
        raise SceneError("mechanism", f"missing; required: a mapping with type "
                                      f"({join(MECHANISM_TYPES)}) and its lengths")
    from .mechanism import topology

    mechanism = _mechanism(raw["mechanism"])
    topo = topology(mechanism)

    scene: dict[str, Any] = {"name": NAME_CHECK(raw.get("name", ""), "name"), "mechanism": mechanism}
    bodies = {**{b: "the slider block of an RRP dyad (its slider_mass)" for b in topo.sliders},
              **{b: "the sleeve of an RPR dyad (its sleeve_mass, sleeve_inertia)"
                 for b in topo.sleeves}}
    scene["links"] = _links(raw.get("links"), tuple(topo.link_names), _rigid_links(topo),
                            bodies)
    scene["point_masses"] = _point_masses(raw.get("point_masses"), tuple(topo.joint_names))
    scene["drive"] = _block(raw.get("drive"), "drive", BLOCKS["drive"])
    scene["effects"] = _effects(raw["effects"]) if "effects" in raw else list(DEFAULT_EFFECTS)
    scene["gravity"] = _gravity(raw["gravity"]) if "gravity" in raw else list(DEFAULT_GRAVITY)
    scene["damping"] = _block(raw.get("damping"), "damping", BLOCKS["damping"])
    _unused_parameters(scene["damping"], "damping")
    disc = raw.get("discretization")
    scene["discretization"] = AUTO if isinstance(disc, str) and disc == AUTO else _block(disc, "discretization",
                                                               BLOCKS["discretization"])
    time = raw.get("time")
    if (isinstance(scene["discretization"], dict)
            and scene["discretization"]["formulation"] == "seed_lame"
            and not (isinstance(time, Mapping) and "integrator" in time)):
        # The thesis recommends Houbolt's scheme for its model (III.2.4): its default there.
        time = {**(time or {}), "integrator": "houbolt"} if not isinstance(time, str) else time
    scene["time"] = _time(time)
    if scene["time"]["periodic_solver"] == "spectral":
        _spectral_allowed(scene)
    elif scene["time"]["spectral_tail"] != SPECTRAL_TAIL:
        raise SceneError("time.spectral_tail", "bounds the Fourier series of periodic_solver: "
                                               "spectral (got periodic_solver: "
                                               f"{scene['time']['periodic_solver']}); drop it")
    if scene["time"]["periodic_solver"] != "spectral" and \
            scene["time"]["collocation_points"] != AUTO:
        raise SceneError("time.collocation_points", "is the number of Fourier collocation "
                                                    "points of periodic_solver: spectral "
                                                    "(got periodic_solver: "
                                                    f"{scene['time']['periodic_solver']}); "
                                                    "leave it auto or drop it")
    if "elastic_axial_force" in scene["effects"]:
        check_elastic_axial_force(scene)
    modal = raw.get("modal")
    scene["modal"] = None if modal is None else _block(modal, "modal", BLOCKS["modal"])
    scene["outputs"] = _block(raw.get("outputs"), "outputs", BLOCKS["outputs"])
    scene["tolerance"] = TOLERANCE_CHECK(raw["tolerance"], "tolerance") if "tolerance" in raw \
        else DEFAULT_TOLERANCE
    _assembly(mechanism, scene["drive"])
    return scene


# ------------------------------------------------------------------------------- public
def load_scene(source: str | os.PathLike | Mapping) -> dict:
    """Load, validate and normalize a scene.

    Parameters
    ----------
    source : str, os.PathLike or mapping
        Path of a YAML scene file, or the scene as a mapping (for example an already
        normalized scene). A YAML *string* is not accepted: a ``str`` is always a path.

    Returns
    -------
    dict
        A new plain dict with every scene key present (``modal`` is None when no modal
        analysis is asked for), defaults filled, ``effects`` in canonical order, materials
        resolved (:func:`ced.problem.materials.resolve_material`) and section properties computed
        (:func:`ced.problem.materials.section_properties`) for every link of the mechanism.

    Raises
    ------
    SceneError
        With the dotted key path of the first problem found and what is allowed there.

    Examples
    --------
    >>> s = load_scene({"mechanism": {"type": "single_link", "length": 0.5}})
    >>> s["links"]["link"]["material"]["name"], s["time"]["integrator"]
    ('steel', 'generalized_alpha')
    >>> load_scene(s) == s
    True
    """
    if isinstance(source, Mapping):
        check_structure(source, "<scene>")
        raw = source
    elif isinstance(source, (str, os.PathLike)):
        raw = load_yaml(source, "<scene>", "1.2", hint="; pass the path of a YAML scene file "
                        "or a mapping (YAML text is not accepted)")
    else:
        raise SceneError("<scene>", f"must be the path of a YAML scene file or a mapping; "
                                    f"got {type(source).__name__}")
    return _normalize(raw)


def dump_scene(scene: Mapping) -> str:
    """Canonical JSON of a (normalized) scene: sorted keys, compact separators, no NaN.

    Parameters
    ----------
    scene : mapping
        A scene, normally as returned by :func:`load_scene`.

    Returns
    -------
    str
        The JSON text (equal scenes give equal text).
    """
    return json.dumps(scene, sort_keys=True, separators=(",", ":"), ensure_ascii=False,
                      allow_nan=False)


def scene_hash(scene: Mapping) -> str:
    """First 12 hex digits of the SHA-1 of :func:`dump_scene` (pass a normalized scene).

    Parameters
    ----------
    scene : mapping
        A normalized scene (:func:`load_scene`).

    Returns
    -------
    str
        12 hexadecimal digits identifying the scene.
    """
    return hashlib.sha1(dump_scene(scene).encode("utf-8")).hexdigest()[:12]
