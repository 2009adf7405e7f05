"""Linkages built from dyads: the description, its checks, its topology and the presets.

A planar linkage of one degree of freedom is an *input link* turning about a ground pivot
plus an ordered list of *dyads*, two bodies and three joints each, whose closed-form position
follows from two already known points (Assur groups of class II; the planar building block of
every closed-form kinematics, docs/theory.md "Linkages built from dyads"):

* ``RRR`` — links ``[l1, l2]``, joints ``[P, M, Q]``: l1 runs from the known point P to the new
  joint M, l2 from the known point Q to M; ``branch: open`` puts M on the left of P→Q.
* ``RRP`` — link ``l1`` from the known point P to the new joint M, and a slider block at M on a
  fixed straight guide through ``guide.point`` at ``guide.angle``; ``branch: open`` puts M
  ahead of P along the guide direction.
* ``RPR`` — links ``[guide, sleeve]``, joints ``[P, T, Q]``: the guide bar turns about the
  known point P, its far end T (``lengths: [L]``) a new joint; the sleeve, a block (not a
  link: ``sleeve_mass``, ``sleeve_inertia``), turns about the known point Q and slides along
  the bar, Q at the signed distance ``offset`` to the left of the bar's line (the inverted
  slider-crank, Whitworth's quick return, the oscillating cylinder). One assembly: the bar
  runs from P through the sleeve.

Known points are the ground pivots, the input link's tip and the *points* of links already
placed (a point of a link in its frame: x from its first joint towards its second, y to the
left; a link with a point is a ternary link). Each known point takes exactly one joint: a
point left unused, a joint attached to nothing and a link used twice are refused, naming the
key. ``four_bar``, ``slider_crank``, ``watt_ii`` and ``stephenson_iii`` are presets: their few
lengths expand into this description (:func:`describe`).

A ternary link is modelled as bars of the link's section welded at its first joint: the bar
to its second joint and one bar to each point off that bar (its mass, centre of mass and
inertia follow, :func:`ternary_bars`).
"""
from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from typing import Any

from .errors import Choice, Real, SceneError, Text, check_keys, join, shown

__all__ = ["DYAD_KINDS", "DYAD_KEYS", "DYAD_MEANINGS", "PRESET_TYPES", "LINKAGE_FIELDS", "PRESET_FIELDS", "describe",
           "check_description", "linkage_topology", "ternary_bars", "bar_ends", "four_bar_loops",
           "assembly_error", "transmission", "ASSEMBLY_SAMPLES"]

DYAD_KINDS = ("RRR", "RRP", "RPR")
#: Keys of each dyad kind besides ``kind`` (the first three required).
DYAD_KEYS = {
    "RRR": ("links", "joints", "lengths", "branch"),
    "RRP": ("links", "joints", "lengths", "branch", "guide", "slider_mass"),
    "RPR": ("links", "joints", "lengths", "offset", "sleeve_mass", "sleeve_inertia"),
}
#: One line of meaning per key of a dyad (``<kind>.<key>``), for the scene reference.
DYAD_MEANINGS = {
    "RRR.links": "[l1, l2]: l1 runs from P to the new joint M, l2 from Q to M",
    "RRR.joints": "[P, M, Q]: P and Q known points, M the new joint of l1 and l2",
    "RRR.lengths": "[|PM|, |QM|] (m)",
    "RRR.branch": "open (default) puts M on the left of P→Q at the start; kept over the cycle",
    "RRP.links": "[rod, slider]: the rod runs from P to M; the slider block (a body, not a "
                 "link) rides on M",
    "RRP.joints": "[P, M]: P a known point, M the new joint on the fixed guide",
    "RRP.lengths": "[|PM|] (m)",
    "RRP.branch": "open (default) puts M ahead of P along the guide",
    "RRP.guide": "{point: [x, y] (m, default [0, 0]), angle (rad, default 0)}: the fixed "
                 "straight guide",
    "RRP.slider_mass": "mass of the slider block at M (kg, default 0)",
    "RPR.links": "[guide, sleeve]: the guide bar (a link, always rigid) turns about P; the "
                 "sleeve (a block, not a link) turns about Q and slides along the bar",
    "RPR.joints": "[P, T, Q]: P and Q known points, T the bar's far end, a new joint later "
                  "dyads may attach to (else free)",
    "RPR.lengths": "[|PT|] (m): the sleeve must stay on the bar, 0 < s ≤ |PT| with "
                   "s = √(|PQ|² − offset²) its distance from P",
    "RPR.offset": "signed distance of Q from the bar's line, to the left of P→T positive "
                  "(m, default 0); its sign chooses the side: an RPR dyad has no branch",
    "RPR.sleeve_mass": "mass of the sleeve, on Q (kg, default 0)",
    "RPR.sleeve_inertia": "moment of inertia of the sleeve about Q (kg m², default 0); it "
                          "turns with the bar",
}
_JOINTS = {"RRR": 3, "RRP": 2, "RPR": 3}
_LENGTHS = {"RRR": 2, "RRP": 1, "RPR": 1}
#: Mechanism types that expand into a dyad description (single_link is not a linkage).
PRESET_TYPES = ("four_bar", "slider_crank", "watt_ii", "stephenson_iii")

_LENGTH = Real(low=0.0, low_open=True, unit="m")
_COORD = Real(unit="m")
_ANGLE = Real(unit="rad")
_NAME = Text(nonempty=True)
_BRANCH = Choice(("open", "crossed"))
_MASS = Real(low=0.0, unit="kg")
_INERTIA = Real(low=0.0, unit="kg m^2")
_RESERVED = ("ground", "tip")


def _pair(value: Any, path: str, check=_COORD) -> list[float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise SceneError(path, f"must be a list [x, y] of two finite numbers (m); got "
                               f"{shown(value)}")
    return [check(v, f"{path}[{i}]") for i, v in enumerate(value)]


def _names(value: Any, path: str, n: int, what: str) -> list[str]:
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise SceneError(path, f"must be a list of {n} {what} names; got {shown(value)}")
    return [_NAME(v, f"{path}[{i}]") for i, v in enumerate(value)]


class _Ground:
    def describe(self) -> str:
        return "a mapping {pivot name: [x, y]} of the ground pivots (m)"

    def __call__(self, value: Any, path: str) -> dict:
        if not isinstance(value, Mapping) or not value:
            raise SceneError(path, f"must be {self.describe()}; got {shown(value)}")
        return {_NAME(k, path): _pair(v, f"{path}.{k}") for k, v in value.items()}


class _Input:
    fields = {"link": _NAME, "pivot": _NAME, "tip": _NAME, "length": _LENGTH}

    def describe(self) -> str:
        return "a mapping {link, pivot, tip, length}: the input link turns about a ground pivot"

    def __call__(self, value: Any, path: str) -> dict:
        check_keys(value, path, tuple(self.fields))
        out = {}
        for key, check in self.fields.items():
            if key not in value:
                raise SceneError(f"{path}.{key}", f"missing; required: {check.describe()}")
            out[key] = check(value[key], f"{path}.{key}")
        return out


class _Points:
    def describe(self) -> str:
        return "a mapping {point name: {link, at: [x, y]}}, x along the link from its first joint"

    def __call__(self, value: Any, path: str) -> dict:
        value = {} if value is None else value
        if not isinstance(value, Mapping):
            raise SceneError(path, f"must be {self.describe()}; got {shown(value)}")
        out = {}
        for name, entry in value.items():
            sub = f"{path}.{name}"
            check_keys(entry, sub, ("link", "at"))
            for key in ("link", "at"):
                if key not in entry:
                    raise SceneError(f"{sub}.{key}", "missing; a point needs its link and its "
                                                     "coordinates at: [x, y] in the link frame")
            out[_NAME(name, path)] = {"link": _NAME(entry["link"], f"{sub}.link"),
                                      "at": _pair(entry["at"], f"{sub}.at")}
        return out


class _Dyads:
    def describe(self) -> str:
        return (f"a non-empty list of dyads {{kind ({join(DYAD_KINDS)}), links, joints, "
                "lengths[, branch, guide, slider_mass, offset, sleeve_mass, sleeve_inertia]}")

    def __call__(self, value: Any, path: str) -> list:
        if not isinstance(value, (list, tuple)) or not value:
            raise SceneError(path, f"must be {self.describe()}; got {shown(value)}")
        return [self._dyad(d, f"{path}[{i}]") for i, d in enumerate(value)]

    @staticmethod
    def _dyad(value: Any, path: str) -> dict:
        if not isinstance(value, Mapping) or "kind" not in value:
            raise SceneError(path, f"must be a mapping with kind ({join(DYAD_KINDS)}); got "
                                   f"{shown(value)}")
        kind = Choice(DYAD_KINDS)(value["kind"], f"{path}.kind")
        keys = ("kind",) + DYAD_KEYS[kind]
        if kind == "RPR" and "branch" in value:
            raise SceneError(f"{path}.branch", (
                "an RPR dyad has one assembly (its guide bar runs from P through the sleeve); "
                "give the side of the bar's line Q lies on by the sign of offset"))
        check_keys(value, path, keys)
        required = ("links", "joints", "lengths") + (("guide",) if kind == "RRP" else ())
        for key in required:
            if key not in value:
                raise SceneError(f"{path}.{key}", f"missing; a {kind} dyad needs "
                                                  f"{join(required)} (optional: "
                                                  f"{join(k for k in keys[1:] if k not in required)})")
        out = {"kind": kind,
               "links": _names(value["links"], f"{path}.links", 2, "body"),
               "joints": _names(value["joints"], f"{path}.joints", _JOINTS[kind], "joint")}
        n = _LENGTHS[kind]
        lengths = value["lengths"]
        if not isinstance(lengths, (list, tuple)) or len(lengths) != n:
            raise SceneError(f"{path}.lengths", f"must be a list of {n} link length"
                                                f"{'s' if n > 1 else ''} (m); got "
                                                f"{shown(lengths)}")
        out["lengths"] = [_LENGTH(v, f"{path}.lengths[{i}]") for i, v in enumerate(lengths)]
        if kind == "RPR":
            out["offset"] = _COORD(value.get("offset", 0.0), f"{path}.offset")
            out["sleeve_mass"] = _MASS(value.get("sleeve_mass", 0.0), f"{path}.sleeve_mass")
            out["sleeve_inertia"] = _INERTIA(value.get("sleeve_inertia", 0.0),
                                             f"{path}.sleeve_inertia")
            return out
        out["branch"] = _BRANCH(value.get("branch", "open"), f"{path}.branch")
        if kind == "RRP":
            guide = check_keys(value["guide"], f"{path}.guide", ("point", "angle"))
            out["guide"] = {"point": _pair(guide.get("point", [0.0, 0.0]), f"{path}.guide.point"),
                            "angle": _ANGLE(guide.get("angle", 0.0), f"{path}.guide.angle")}
            out["slider_mass"] = _MASS(value.get("slider_mass", 0.0), f"{path}.slider_mass")
        return out


#: Keys of ``mechanism`` for ``type: linkage``: (check, required).
LINKAGE_FIELDS = {"ground": _Ground(), "input": _Input(), "points": _Points(), "dyads": _Dyads()}


def check_description(mech: dict, path: str = "mechanism") -> None:
    """Refuse a dyad description whose names do not make one linkage.

    Every dyad attaches to known points only (ground pivots, the input's tip, points of links
    placed before it, the far end of an RPR guide bar), each known point takes one joint,
    every point is used (the far end of an RPR guide bar may stay free), and every name
    (link, slider, sleeve, joint) is used once.

    Parameters
    ----------
    mech : dict
        A ``type: linkage`` mechanism block, structurally checked (:data:`LINKAGE_FIELDS`).
    path : str
        Key path of the block in messages.

    Raises
    ------
    SceneError
        Naming the key of the first inconsistency.
    """
    inp = mech["input"]
    bodies: dict[str, str] = {}  # body name -> key that introduced it

    def new_body(name: str, where: str) -> None:
        if name in _RESERVED:
            raise SceneError(where, f"{name!r} is reserved; choose another link name")
        if name in bodies:
            raise SceneError(where, f"link {name!r} is used twice (first at {bodies[name]}); "
                                    "every link belongs to exactly one dyad or is the input")
        bodies[name] = where

    new_body(inp["link"], f"{path}.input.link")
    if inp["pivot"] not in mech["ground"]:
        raise SceneError(f"{path}.input.pivot", f"{inp['pivot']!r} is not a ground pivot; "
                                                f"allowed: {join(mech['ground'])}")
    # Known points waiting for a joint: name -> key where they were defined.
    free = {name: f"{path}.ground.{name}" for name in mech["ground"] if name != inp["pivot"]}
    joints = {inp["pivot"]: f"{path}.input.pivot"}
    if inp["tip"] in free or inp["tip"] in joints:
        raise SceneError(f"{path}.input.tip", f"joint name {inp['tip']!r} is already used")
    free[inp["tip"]] = f"{path}.input.tip"
    points = dict(mech.get("points", {}))

    def release_points(link: str) -> None:
        for name, point in list(points.items()):
            if point["link"] == link:
                if name in free or name in joints:
                    raise SceneError(f"{path}.points.{name}", f"joint name {name!r} is "
                                                              "already used")
                free[name] = f"{path}.points.{name}"
                del points[name]

    release_points(inp["link"])
    ends: set[str] = set()  # far ends of RPR guide bars: known points that may stay free
    for i, dyad in enumerate(mech["dyads"]):
        sub = f"{path}.dyads[{i}]"
        kind = dyad["kind"]
        attached = [0] if kind == "RRP" else [0, 2]
        for k in attached:
            name = dyad["joints"][k]
            if name not in free:
                why = ("already carries a joint" if name in joints else
                       "is attached to nothing: not a ground pivot, the input's tip or a point "
                       "of a link placed before this dyad")
                raise SceneError(f"{sub}.joints[{k}]", f"{name!r} {why}; known free points: "
                                                       f"{join(sorted(free)) or 'none'}")
            joints[name] = f"{sub}.joints[{k}]"
            del free[name]
        middle = dyad["joints"][1]
        if middle in joints or middle in free or middle in points:
            raise SceneError(f"{sub}.joints[1]", f"joint name {middle!r} is already used; the "
                                                 "middle joint of a dyad is a new joint")
        for k, link in enumerate(dyad["links"]):
            new_body(link, f"{sub}.links[{k}]")
        if kind == "RPR":
            # The guide's far end is a new known point; a later dyad may attach there.
            free[middle] = f"{sub}.joints[1]"
            ends.add(middle)
        else:
            joints[middle] = f"{sub}.joints[1]"
        if kind == "RRR":
            release_points(dyad["links"][0])
            release_points(dyad["links"][1])
        elif kind == "RRP":
            release_points(dyad["links"][0])
        for name, point in points.items():
            if point["link"] in dyad["links"] and kind != "RRR":
                why = ("a slider block carries no points; put it on a link" if kind == "RRP"
                       else "the guide bar and the sleeve of an RPR dyad carry no points; "
                            "attach a later dyad at the bar's end "
                            f"{dyad['joints'][1]!r} instead")
                raise SceneError(f"{path}.points.{name}", why)
    for name, point in points.items():
        if point["link"] not in bodies:
            raise SceneError(f"{path}.points.{name}.link", f"unknown link {point['link']!r}; "
                                                           f"allowed: {join(bodies)}")
    left = sorted(set(free) - ends)
    if left:
        name = left[0]
        raise SceneError(free[name], f"{name!r} is attached to nothing: no dyad uses it; "
                                     "remove it or attach a dyad there")


def _arm_point(arm: float, angle: float) -> list[float]:
    return [arm * math.cos(angle), arm * math.sin(angle)]


def describe(mech: Mapping) -> dict:
    """The dyad description of a normalized mechanism block (presets expanded).

    Parameters
    ----------
    mech : mapping
        Normalized ``mechanism`` block of type ``linkage`` or a preset (:data:`PRESET_TYPES`);
        lengths in m, angles in rad.

    Returns
    -------
    dict
        ``{type: linkage, ground, input, points, dyads}`` (see the module docstring).

    Examples
    --------
    >>> d = describe({"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
    ...               "rocker": 0.35, "branch": "open"})
    >>> d["dyads"][0]["links"], d["dyads"][0]["joints"]
    (['coupler', 'rocker'], ['B', 'C', 'D'])
    """
    kind = mech["type"]
    if kind == "linkage":
        return {"type": "linkage", "ground": dict(mech["ground"]), "input": dict(mech["input"]),
                "points": dict(mech.get("points", {})), "dyads": list(mech["dyads"])}
    if kind not in PRESET_TYPES:
        raise ValueError(f"mechanism.type: {kind!r} is not a linkage of dyads; allowed: "
                         f"{join(PRESET_TYPES + ('linkage',))}")
    crank = {"link": "crank", "pivot": "A", "tip": "B", "length": mech["crank"]}
    if kind == "slider_crank":
        return {"type": "linkage", "ground": {"A": [0.0, 0.0]}, "input": crank, "points": {},
                "dyads": [{"kind": "RRP", "links": ["rod", "slider"], "joints": ["B", "C"],
                           "lengths": [mech["rod"]], "branch": mech["branch"],
                           "guide": {"point": [0.0, mech["offset"]], "angle": 0.0},
                           "slider_mass": mech["slider_mass"]}]}
    first = {"kind": "RRR", "links": ["coupler", "rocker"], "joints": ["B", "C", "D"],
             "lengths": [mech["coupler"], mech["rocker"]], "branch": mech["branch"]}
    out = {"type": "linkage", "ground": {"A": [0.0, 0.0], "D": [mech["ground"], 0.0]},
           "input": crank, "points": {}, "dyads": [first]}
    if kind == "four_bar":
        return out
    out["ground"]["G"] = [mech["pivot2_x"], mech["pivot2_y"]]
    host, arm = ("rocker", "rocker_arm") if kind == "watt_ii" else ("coupler", "coupler_arm")
    out["points"] = {"E": {"link": host, "at": _arm_point(mech[arm], mech[f"{arm}_angle"])}}
    out["dyads"].append({"kind": "RRR", "links": ["coupler2", "rocker2"],
                         "joints": ["E", "F", "G"],
                         "lengths": [mech["coupler2"], mech["rocker2"]],
                         "branch": mech["branch2"]})
    return out


_FIRST_LOOP = {
    "ground": (_LENGTH, None), "crank": (_LENGTH, None), "coupler": (_LENGTH, None),
    "rocker": (_LENGTH, None), "branch": (_BRANCH, "open"),
}
_SECOND_LOOP = {
    "coupler2": (_LENGTH, None), "rocker2": (_LENGTH, None),
    "pivot2_x": (_COORD, None), "pivot2_y": (_COORD, None), "branch2": (_BRANCH, "open"),
}
#: Scalar keys of the six-bar presets: key -> (check, default or None for required).
PRESET_FIELDS = {
    "watt_ii": {**_FIRST_LOOP, "rocker_arm": (_LENGTH, None),
                "rocker_arm_angle": (_ANGLE, 0.0), **_SECOND_LOOP},
    "stephenson_iii": {**_FIRST_LOOP, "coupler_arm": (_LENGTH, None),
                       "coupler_arm_angle": (_ANGLE, 0.0), **_SECOND_LOOP},
}


def linkage_topology(description: Mapping):
    """The :class:`ced.problem.mechanism.Topology` of a dyad description.

    Links are listed input first, then each dyad's links in order (a slider block or an RPR
    sleeve is a body, not a link); joints in the order they are met (input pivot, input tip,
    then each dyad's joints). A joint connects the body that owns the known point (first) to
    the dyad's link. The far end T of an RPR guide bar no later dyad uses is a free tip
    (``(guide, "tip")``).

    Parameters
    ----------
    description : mapping
        A dyad description (:func:`describe`).

    Returns
    -------
    Topology
        With ``points`` (joint at a point of a link -> that link), ``sliders`` (slider
        block -> its joint, on a fixed guide) and ``sleeves`` (RPR sleeve -> (its pivot
        joint, the guide bar it slides on)).
    """
    from .mechanism import Topology  # mechanism imports numpy; keep this module light

    inp = description["input"]
    links = {inp["link"]: (inp["pivot"], inp["tip"])}
    owner = {inp["tip"]: inp["link"], **{g: "ground" for g in description["ground"]}}
    owner.update({name: p["link"] for name, p in description.get("points", {}).items()})
    joints = {inp["pivot"]: ("ground", inp["link"])}
    sliders, sleeves = {}, {}
    for dyad in description["dyads"]:
        l1, l2 = dyad["links"]
        P, M = dyad["joints"][:2]
        links[l1] = (P, M)
        joints[P] = (owner[P], l1)
        if dyad["kind"] == "RRR":
            Q = dyad["joints"][2]
            links[l2] = (Q, M)
            joints[M] = (l1, l2)
            joints[Q] = (owner[Q], l2)
        elif dyad["kind"] == "RRP":
            joints[M] = (l1, l2)
            sliders[l2] = M
        else:  # RPR: M is the guide's far end, a known point for later dyads
            Q = dyad["joints"][2]
            joints[M] = (l1, "tip")
            owner[M] = l1
            joints[Q] = (owner[Q], l2)
            sleeves[l2] = (Q, l1)
    points = {name: p["link"] for name, p in description.get("points", {}).items()}
    ground = tuple(j for j, (first, _) in joints.items() if first == "ground")
    return Topology(links=links, joints=joints, ground_joints=ground, input_link=inp["link"],
                    points=points, sliders=sliders, sleeves=sleeves)


def ternary_bars(description: Mapping, link: str, length: float) -> list[tuple[float, float]]:
    """End points (x, y) in the link frame of the bars that make up ``link``, m.

    Every bar starts at the link's first joint: one to its second joint (``(length, 0)``),
    and one to each of its points that does not lie on that bar (a point on the bar is a pin
    through it and adds no material).

    Parameters
    ----------
    description : mapping
        A dyad description (:func:`describe`).
    link : str
        The link's name.
    length : float
        Distance from its first to its second joint, m.

    Returns
    -------
    list of (float, float)
        Far ends of the bars, m.
    """
    bars = [(float(length), 0.0)]
    for point in description.get("points", {}).values():
        x, y = point["at"]
        if point["link"] == link and not (y == 0.0 and 0.0 <= x <= length):
            bars.append((float(x), float(y)))
    return bars


def bar_ends(descriptions: list, link: str, lengths):
    """:func:`ternary_bars` of ``link`` for a batch of descriptions of one structure, as
    arrays: the same bars for every case, each flagged where it is made (a point that lies on
    the link's first bar in one case is a pin there, no bar).

    Parameters
    ----------
    descriptions : list of mapping
        One dyad description per case (:func:`describe`), all with the same points.
    link : str
        The link's name.
    lengths : array_like, (case,)
        Distance from its first to its second joint, m.

    Returns
    -------
    ends : ndarray, (case, bar, 2)
        Far ends of the bars in the link frame, m: the bar to the second joint first, then one
        per point of the link in the descriptions' order.
    made : ndarray, (case, bar)
        bool: the bar is part of the link (:func:`ternary_bars` lists exactly these).
    """
    import numpy as np  # lazy, as in transmission: only the batched callers need it

    length = np.asarray(lengths, float)
    names = [name for name, point in descriptions[0].get("points", {}).items()
             if point["link"] == link]
    ends = np.zeros((len(length), 1 + len(names), 2))
    ends[:, 0, 0] = length
    if names:
        ends[:, 1:] = [[d["points"][name]["at"] for name in names] for d in descriptions]
    x, y = ends[..., 0], ends[..., 1]
    made = ~((y == 0.0) & (0.0 <= x) & (x <= length[:, None]))
    made[:, 0] = True
    return ends, made


def four_bar_loops(mech: Mapping) -> list[tuple[float, float, float, float]]:
    """(ground, input, coupler, output) lengths of each four-bar loop of a preset, m.

    The loops whose Grashof type classifies the mechanism: the four-bar itself; for
    ``watt_ii`` also the second four-bar D–E–F–G, driven by the rocker's arm D→E. A
    ``stephenson_iii``'s second loop is a five-bar (its dyad hangs on the coupler) and has
    no Grashof type.

    Parameters
    ----------
    mech : mapping
        Normalized mechanism block of type ``four_bar``, ``watt_ii`` or ``stephenson_iii``.

    Returns
    -------
    list of tuple
        One (ground, input, coupler, output) tuple per four-bar loop, m.
    """
    loops = [(mech["ground"], mech["crank"], mech["coupler"], mech["rocker"])]
    if mech["type"] == "watt_ii":
        ground2 = math.hypot(mech["pivot2_x"] - mech["ground"], mech["pivot2_y"])
        loops.append((ground2, mech["rocker_arm"], mech["coupler2"], mech["rocker2"]))
    return loops


#: Input angles sampled per revolution (or over a rocker's range) by the assembly check.
ASSEMBLY_SAMPLES = 3601


def assembly_error(description: Mapping, angles) -> str | None:
    """Why a dyad description cannot be assembled at some input angle, or None.

    Every RRR dyad needs |l1 − l2| ≤ |PQ| ≤ l1 + l2, every RRP dyad |h| < l1 (h the distance
    of P from the guide) and every RPR dyad |e| < |PQ| (e its offset: the sleeve's distance
    s = √(|PQ|² − e²) from P along the bar must stay positive) with s ≤ L (the sleeve stays on
    the bar of length L) at every input angle; checked on the given samples, so a failure
    narrower than their spacing can pass (the default :data:`ASSEMBLY_SAMPLES` per
    revolution leaves gaps of 0.1°).

    Parameters
    ----------
    description : mapping
        A dyad description (:func:`describe`).
    angles : ndarray, (n,)
        Input angles to check, rad.

    Returns
    -------
    str or None
        A message naming the dyad (``dyads[1]``, its links), the input angle and the lengths.
    """
    for i, error, _ in _placements(description, angles, measures=False):
        if error:
            return f"dyads[{i}]: {error}"
    return None


def transmission(description: Mapping, angles):
    """The transmission measure of every dyad at the given input angles, (n, dyad).

    RRR: |sin μ|, μ the angle between its links (cos μ = (l1² + l2² − |PQ|²)/(2 l1 l2), the
    same on either branch); RRP: |cos(θ_rod − φ_guide)| = √(1 − (h/l1)²), h the distance of P
    from the guide; RPR: s/L, the sleeve's distance from the bar's pivot over the bar's length
    (:func:`ced.rigid.dyads.dyad_sines` gives the same from a rigid motion). From positions
    only, the dyads placed as the assembly check places them, so that a batch's
    ``near_singular`` costs no velocities or accelerations.

    Parameters
    ----------
    description : mapping
        A dyad description (:func:`describe`) that assembles at every angle.
    angles : ndarray, (n,)
        Input angles, rad.

    Returns
    -------
    ndarray, (n, dyad)
        Dimensionless, in [0, 1].

    Raises
    ------
    ValueError
        If a dyad cannot be assembled at one of the angles (the assembly check's message).
    """
    import numpy as np

    out = []
    for i, error, measure in _placements(description, angles, measures=True):
        if error:
            raise ValueError(f"dyads[{i}]: {error}")
        out.append(measure)
    return np.stack(out, axis=-1)


#: Placements kept by :func:`_placements` (cleared when full).
_KEPT_PLACEMENTS = 64
_placements_kept: dict = {}


def _placements(description: Mapping, angles, measures: bool) -> tuple:
    """(index, why it cannot be assembled or None, transmission measure or None) per dyad as
    :func:`_placed` yields them, up to the first that cannot be assembled; the same
    description at the same angles is placed once. Every scene of a batch that differs in
    its drive only (a speed sweep) has the same mechanism, checked at load and again by
    ``near_singular`` over the same sampled turn: one placement serves them all."""
    import numpy as np

    angles = np.ascontiguousarray(angles, dtype=float)
    key = (repr(description), angles.shape, angles.tobytes(), measures)
    kept = _placements_kept.get(key)
    if kept is None:
        kept = tuple((i, error, measure) for i, _, error, measure
                     in _placed(description, angles, measures))
        for _, _, measure in kept:
            if measure is not None:
                measure.flags.writeable = False
        if len(_placements_kept) >= _KEPT_PLACEMENTS:
            _placements_kept.clear()
        _placements_kept[key] = kept
    return kept


def _placed(description: Mapping, angles, measures: bool = True):
    """Place the dyads in order at the input ``angles`` (n,): yield, per dyad, (index, dyad,
    why it cannot be assembled or None, its transmission measure (n,), or None without
    ``measures``) and stop at the first that cannot. Each RRR takes its ``branch`` at every
    angle (a change point is not tracked through: its sine vanishes there anyway). The last
    dyad's links are checked, not placed: no later dyad hangs on them.

    Points are complex numbers x + iy and each placed link's frame is its first joint and
    the unit complex number e along it, so that a point (x, y) of the link is
    origin + (x + iy) e: no angles, no trigonometry past the input's."""
    import numpy as np  # lazy, as in the scene parser: only the assembly check needs it

    inp = description["input"]
    known = {name: complex(*xy) for name, xy in description["ground"].items()}
    frame = {inp["link"]: (known[inp["pivot"]], _unit(angles))}
    points = {name: (point["link"], complex(*point["at"]))
              for name, point in description.get("points", {}).items()}

    ends = {inp["link"]: inp["tip"]}
    ends.update({d["links"][0]: d["joints"][1] for d in description["dyads"]})

    def place(link, length):
        origin, e = frame[link]
        known.setdefault(ends[link], origin + length * e)
        for name, (host, at) in points.items():
            if host == link:
                known[name] = origin + at * e

    ends.update({d["links"][1]: d["joints"][1] for d in description["dyads"]})
    place(inp["link"], inp["length"])
    rtol = 1e-9
    last = len(description["dyads"]) - 1
    for i, dyad in enumerate(description["dyads"]):
        P = known[dyad["joints"][0]]
        l1 = dyad["lengths"][0]
        sign = 1.0 if dyad.get("branch", "open") == "open" else -1.0
        if dyad["kind"] == "RRR":
            l2 = dyad["lengths"][1]
            Q = known[dyad["joints"][2]]
            d = Q - P
            dist = np.abs(d)
            bad = (dist > (l1 + l2) * (1 + rtol)) | (dist < abs(l1 - l2) * (1 - rtol))
            if bad.any():
                k = int(np.argmax(bad))
                yield i, dyad, (f"the RRR dyad {join(dyad['links'])} "
                                f"cannot be assembled at input angle {angles[k]:.4g} rad: "
                                f"|{dyad['joints'][0]}{dyad['joints'][2]}| = {dist[k]:.4g} m "
                                f"is outside [|{l1:g} − {l2:g}|, {l1:g} + {l2:g}] m"), None
                return
            if i < last:
                # M on the circles about P (l1) and Q (l2): a along P→Q, ±h across it (left
                # for the open branch).
                a = np.clip((l1 * l1 - l2 * l2 + dist * dist) / (2 * dist), -l1, l1)
                M = P + (a + 1j * sign * np.sqrt(l1 * l1 - a * a)) * (d / dist)
                frame[dyad["links"][0]] = (P, (M - P) / l1)
                frame[dyad["links"][1]] = (Q, (M - Q) / l2)
                place(dyad["links"][0], l1)
                place(dyad["links"][1], l2)
            measure = None
            if measures:
                cos_mu = np.clip((l1 * l1 + l2 * l2 - dist * dist) / (2 * l1 * l2), -1, 1)
                measure = np.sqrt(1.0 - cos_mu * cos_mu)
            yield i, dyad, None, measure
        elif dyad["kind"] == "RRP":
            along = complex(math.cos(dyad["guide"]["angle"]), math.sin(dyad["guide"]["angle"]))
            # h = n·(P − G0): the imaginary part in the guide's frame.
            h = ((P - complex(*dyad["guide"]["point"])) / along).imag
            bad = np.abs(h) >= l1 * (1 - rtol)
            if bad.any():
                k = int(np.argmax(bad))
                yield i, dyad, (f"the RRP dyad {dyad['links'][0]} cannot reach its "
                                f"guide at input angle {angles[k]:.4g} rad: "
                                f"{dyad['joints'][0]} is {abs(h[k]):.4g} m from it, the link "
                                f"{l1:g} m long"), None
                return
            # n·(M − P) = −h with M − P = l1 e1: e1 = (±√(1 − (h/l1)²) − i h/l1) along.
            cosine = np.sqrt(1 - (h / l1) ** 2)
            if i < last:
                frame[dyad["links"][0]] = (P, (sign * cosine - 1j * h / l1) * along)
                place(dyad["links"][0], l1)
            yield i, dyad, None, cosine if measures else None
        else:
            error, e1, slide = _rpr_assembly(dyad, P, known[dyad["joints"][2]], angles, rtol)
            if error:
                yield i, dyad, error, None
                return
            if i < last:
                frame[dyad["links"][0]] = (P, e1)
                place(dyad["links"][0], l1)
            yield i, dyad, None, np.minimum(slide / l1, 1.0) if measures else None


def _unit(angles):
    """e^{iθ} (n,) at the input angles θ (n,) rad, read-only. The assembly check of every
    scene and ``near_singular`` of every case sample the same turn (ASSEMBLY_SAMPLES angles
    from 0): the last few are kept, their complex exponential being a fifth of placing a
    six-bar."""
    import numpy as np

    angles = np.ascontiguousarray(angles, dtype=float)
    return _unit_of(angles.tobytes(), angles.shape)


@functools.lru_cache(maxsize=4)
def _unit_of(data: bytes, shape: tuple[int, ...]):
    import numpy as np

    out = np.exp(1j * np.frombuffer(data).reshape(shape))
    out.flags.writeable = False
    return out


def _rpr_assembly(dyad: Mapping, P, Q, angles, rtol: float):
    """(message or None, the bar's unit vector as complex numbers (n,), slide (n,) m) of an
    RPR dyad whose pivots are at P and Q (complex, (n,))."""
    import numpy as np

    (guide, sleeve), (p, _, q) = dyad["links"], dyad["joints"]
    length, offset = dyad["lengths"][0], dyad["offset"]
    d = Q - P
    dist = np.abs(d)
    # Q − P = (s + i offset) e with e along the bar: s = √(|PQ|² − offset²) > 0, s ≤ L.
    slide = np.sqrt(np.clip(dist * dist - offset * offset, 0.0, None))
    bad = slide <= rtol * length
    if bad.any():
        k = int(np.argmax(bad))
        return (f"the RPR dyad {guide}, {sleeve} cannot be assembled at input angle "
                f"{angles[k]:.4g} rad: |{p}{q}| = {dist[k]:.4g} m is not more than |offset| = "
                f"{abs(offset):g} m, so the sleeve at {q} would sit on the bar's pivot {p}"
                ), None, None
    bad = slide > length * (1 + rtol)
    if bad.any():
        k = int(np.argmax(bad))
        return (f"the sleeve {sleeve} runs off the end of the guide bar {guide} at input angle "
                f"{angles[k]:.4g} rad: it is {slide[k]:.4g} m along the bar from {p}, the bar "
                f"{length:g} m long (lengths[0])"), None, None
    return None, d / (slide + 1j * offset), slide
