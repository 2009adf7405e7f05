"""Mechanism geometry: topology, Grashof classification, input limits and transmission criteria.

Four-bar naming (docs/theory.md, docs/guide/first_scene.md): ground pivots A = (0, 0) and D = (ground, 0); links crank (A→B),
coupler (B→C), rocker (D→C). Slider-crank: crank (A→B), rod (B→C), slider at C on a guide
parallel to x at signed ``offset``. Single link: one link A→B driven about A, free tip B.
Six-bars (``watt_ii``, ``stephenson_iii``) and any ``linkage`` are built from dyads
(:mod:`ced.problem.linkage`); their first loop, a four-bar, is classified here.

The family is named by the motion of the input link (the crank position) and the output link
(the rocker position), thesis I.1.1 (Grashof's law).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "FAMILIES",
    "CRANK_INPUT_FAMILIES",
    "Topology",
    "topology",
    "classify",
    "input_limits",
    "InputLimits",
    "assembly_error",
    "dyad_sine_min",
    "near_singular",
    "NEAR_SINGULAR_SIN",
]

#: Relative tolerance for the Grashof equality S + L = P + Q.
GRASHOF_RTOL = 1e-9

FAMILIES = (
    "crank_rocker",
    "rocker_crank",
    "double_crank",
    "double_rocker",
    "change_point",
    "triple_rocker",
    "slider_crank",
)
#: Families whose input link turns fully and is driven at constant speed.
CRANK_INPUT_FAMILIES = ("crank_rocker", "double_crank", "slider_crank")


@dataclass(frozen=True)
class Topology:
    """Links and joints of a mechanism type.

    ``links`` maps each link to its (first, second) joint: the link's x-axis runs from the first
    to the second. ``joints`` maps each joint to the (first, second) body it connects: the joint
    force is the force exerted on the second body by the first ("ground" and "slider" are
    bodies without elastic model). ``points`` maps a joint at a point of a link other than its
    two ends (a ternary link's third joint) to that link; ``sliders`` maps each slider block
    (a body on a fixed straight guide) to its joint; ``sleeves`` maps each sleeve of an RPR
    dyad (a body turning about its pivot joint and sliding along a guide link) to (its pivot
    joint, the guide link).
    """

    links: dict[str, tuple[str, str]]
    joints: dict[str, tuple[str, str]]
    ground_joints: tuple[str, ...]
    input_link: str = "crank"
    points: dict[str, str] = field(default_factory=dict)
    sliders: dict[str, str] = field(default_factory=dict)
    sleeves: dict[str, tuple[str, str]] = field(default_factory=dict)

    @property
    def link_names(self) -> list[str]:
        return list(self.links)

    @property
    def joint_names(self) -> list[str]:
        return list(self.joints)


_TOPOLOGIES = {
    "four_bar": Topology(
        links={"crank": ("A", "B"), "coupler": ("B", "C"), "rocker": ("D", "C")},
        joints={
            "A": ("ground", "crank"),
            "B": ("crank", "coupler"),
            "C": ("coupler", "rocker"),
            "D": ("ground", "rocker"),
        },
        ground_joints=("A", "D"),
    ),
    "slider_crank": Topology(
        links={"crank": ("A", "B"), "rod": ("B", "C")},
        joints={"A": ("ground", "crank"), "B": ("crank", "rod"), "C": ("rod", "slider")},
        ground_joints=("A",),
        sliders={"slider": "C"},
    ),
    "single_link": Topology(
        links={"link": ("A", "B")},
        joints={"A": ("ground", "link"), "B": ("link", "tip")},
        ground_joints=("A",),
        input_link="link",
    ),
}



def _six_bar(kind: str) -> Topology:
    from .linkage import PRESET_FIELDS, describe, linkage_topology

    # The topology does not depend on the lengths: any values name the same links and joints.
    dummy = {key: (default if default is not None else 1.0)
             for key, (_, default) in PRESET_FIELDS[kind].items()}
    return linkage_topology(describe({"type": kind, **dummy}))


_SIX_BARS = {kind: _six_bar(kind) for kind in ("watt_ii", "stephenson_iii")}


def topology(mechanism_type: str | Mapping) -> Topology:
    """Return the :class:`Topology` of a mechanism type, or of a mechanism block.

    Parameters
    ----------
    mechanism_type : str or mapping
        ``four_bar``, ``slider_crank``, ``single_link``, ``watt_ii`` or ``stephenson_iii``
        (their topology is fixed by the type), or a normalized ``mechanism`` block (required
        for ``type: linkage``, whose topology is its dyad list,
        :func:`ced.problem.linkage.linkage_topology`).

    Returns
    -------
    Topology
        Links (with their first and second joints), joints (with the bodies they connect),
        ground joints and the input link.

    Examples
    --------
    >>> topology("four_bar").link_names
    ['crank', 'coupler', 'rocker']
    """
    from .linkage import describe, linkage_topology

    mech = mechanism_type if isinstance(mechanism_type, Mapping) else None
    kind = mech["type"] if mech is not None else mechanism_type
    if kind == "linkage":
        if mech is None:
            raise ValueError("mechanism.type: the topology of a linkage is its dyad list; pass "
                             "the mechanism block")
        return linkage_topology(describe(mech))
    if kind in _SIX_BARS:
        return _SIX_BARS[kind]
    try:
        return _TOPOLOGIES[kind]
    except KeyError:
        raise ValueError(
            f"mechanism.type: unknown type {kind!r}; allowed: "
            f"{sorted(_TOPOLOGIES) + sorted(_SIX_BARS) + ['linkage']}"
        ) from None


def _close(x: float, y: float) -> bool:
    return abs(x - y) <= GRASHOF_RTOL * max(abs(x), abs(y))


def classify(ground: float, crank: float, coupler: float, rocker: float) -> str:
    """Grashof family of a four-bar (thesis I.1.1).

    Parameters
    ----------
    ground, crank, coupler, rocker : float
        Link lengths, m. The crank is the input link, the rocker the output link.

    Returns
    -------
    str
        ``change_point`` if S + L = P + Q (relative tolerance 1e-9), else for a Grashof linkage
        (S + L < P + Q) ``crank_rocker`` / ``rocker_crank`` / ``double_crank`` /
        ``double_rocker`` when the shortest link is the crank / rocker / ground / coupler,
        else ``triple_rocker``.

    Examples
    --------
    >>> classify(0.5, 0.1, 0.45, 0.35)
    'crank_rocker'
    >>> classify(1.0, 3.0, 2.0, 2.0)
    'change_point'
    """
    lengths = {"ground": ground, "crank": crank, "coupler": coupler, "rocker": rocker}
    for name, value in lengths.items():
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"mechanism.{name}: must be a finite length > 0 m, got {value!r}")
    ordered = sorted(lengths.values())
    s, p, q, l = ordered
    if _close(s + l, p + q):
        return "change_point"
    if s + l > p + q:
        return "triple_rocker"
    shortest = min(lengths, key=lengths.__getitem__)
    return {
        "crank": "crank_rocker",
        "rocker": "rocker_crank",
        "ground": "double_crank",
        "coupler": "double_rocker",
    }[shortest]


@dataclass(frozen=True)
class InputLimits:
    """Feasible range of the input (crank) angle of a four-bar, rad.

    ``full_rotation`` is True when the input turns fully; otherwise the input rocks in
    [``lower``, ``upper``] (the branch with positive mid angle when the range is split in two
    mirror intervals), and ``mid``, ``half_range`` describe that interval.
    """

    full_rotation: bool
    lower: float
    upper: float

    @property
    def mid(self) -> float:
        return 0.5 * (self.lower + self.upper)

    @property
    def half_range(self) -> float:
        return 0.5 * (self.upper - self.lower)


def input_limits(ground: float, crank: float, coupler: float, rocker: float) -> InputLimits:
    """Feasible input angles of a four-bar.

    The distance d = |BD| = sqrt(a² + g² − 2ag cos θ) must lie in [|b − c|, b + c] for the dyad
    B–C–D to close; d grows with |θ| on [0, π], so the feasible set is θ_min ≤ |θ| ≤ θ_max.
    At the limits coupler and rocker are collinear (toggle positions).

    Parameters
    ----------
    ground, crank, coupler, rocker : float
        Link lengths, m.

    Returns
    -------
    InputLimits
        ``full_rotation`` (bool), and the input angle's ``lower`` and ``upper`` limits, rad (a
        rocker input oscillates between them).

    Examples
    --------
    >>> lim = input_limits(0.5, 0.1, 0.45, 0.35)
    >>> lim.full_rotation
    True
    """
    g, a, b, c = ground, crank, coupler, rocker
    if assembly_error({"type": "four_bar", "ground": g, "crank": a, "coupler": b, "rocker": c}):
        raise ValueError("four-bar cannot be assembled: the longest link exceeds the sum of the others")

    def angle_at(distance: float) -> float:
        cosine = (a * a + g * g - distance * distance) / (2.0 * a * g)
        return math.acos(min(1.0, max(-1.0, cosine)))

    tol = GRASHOF_RTOL * (a + b + c + g)
    theta_min = angle_at(abs(b - c)) if abs(g - a) < abs(b - c) - tol else 0.0
    theta_max = angle_at(b + c) if g + a > b + c + tol else math.pi
    if theta_min == 0.0 and theta_max == math.pi:
        return InputLimits(True, -math.pi, math.pi)
    if theta_min == 0.0:
        return InputLimits(False, -theta_max, theta_max)
    if theta_max == math.pi:
        return InputLimits(False, theta_min, 2.0 * math.pi - theta_min)
    return InputLimits(False, theta_min, theta_max)


def assembly_error(mechanism: dict, amplitude: float = 1.0) -> str | None:
    """Why a mechanism cannot be assembled, or None if it can.

    A linkage of dyads (``watt_ii``, ``stephenson_iii``, ``linkage``) must assemble over the
    whole motion of its input: a full turn, or for a six-bar whose first loop is a rocker-input
    four-bar the oscillation θ_mid ± ``amplitude`` × half-range
    (:func:`ced.problem.linkage.assembly_error`, sampled).

    Parameters
    ----------
    mechanism : dict
        Normalized ``mechanism`` block of a scene (``type`` and lengths in m).
    amplitude : float
        ``drive.amplitude``: the fraction of a rocker input's feasible half-range it sweeps.

    Returns
    -------
    str or None
        A message for the user, naming the lengths involved.
    """
    kind = mechanism.get("type")
    if kind == "four_bar":
        names = ("ground", "crank", "coupler", "rocker")
        lengths = np.array([float(mechanism[n]) for n in names])
        longest = int(np.argmax(lengths))
        others = lengths.sum() - lengths[longest]
        if lengths[longest] >= others * (1.0 - GRASHOF_RTOL):
            return (
                f"four-bar cannot be assembled: the {names[longest]} ({lengths[longest]:g} m) "
                f"is not shorter than the sum of the other three links ({others:g} m)"
            )
        return None
    if kind == "slider_crank":
        crank, rod = float(mechanism["crank"]), float(mechanism["rod"])
        offset = float(mechanism.get("offset", 0.0))
        if crank + abs(offset) >= rod * (1.0 - GRASHOF_RTOL):
            return (
                f"slider-crank cannot turn fully: crank + |offset| = {crank + abs(offset):g} m "
                f"must be less than rod = {rod:g} m"
            )
        return None
    if kind == "single_link":
        return None
    if kind in ("watt_ii", "stephenson_iii", "linkage"):
        return _linkage_assembly_error(mechanism, amplitude)
    return f"unknown mechanism type {kind!r}; allowed: {sorted(_TOPOLOGIES)}"


#: Assembly checks kept by :func:`_linkage_assembly_error` (cleared when full).
_KEPT_CHECKS = 64
_checks_kept: dict[tuple[str, float], str | None] = {}


def _linkage_assembly_error(mechanism: dict, amplitude: float) -> str | None:
    """:func:`_check_linkage` of a mechanism and drive amplitude, kept by value: the scenes of
    a speed sweep share their mechanism, and checking it again costs ~60 µs a scene (the
    sampled angles, the description's key for its placements) against ~3 µs."""
    key = (repr(mechanism), float(amplitude))
    if key not in _checks_kept:
        if len(_checks_kept) >= _KEPT_CHECKS:
            _checks_kept.clear()
        _checks_kept[key] = _check_linkage(mechanism, amplitude)
    return _checks_kept[key]


def _check_linkage(mechanism: dict, amplitude: float) -> str | None:
    from .linkage import ASSEMBLY_SAMPLES, assembly_error as dyads_error, describe

    if mechanism["type"] == "linkage":
        angles = np.linspace(0.0, 2.0 * math.pi, ASSEMBLY_SAMPLES)
    else:
        loop = {key: mechanism[key] for key in ("ground", "crank", "coupler", "rocker")}
        message = assembly_error({"type": "four_bar", **loop})
        if message:
            return "first loop: " + message
        limits = input_limits(*loop.values())
        if limits.full_rotation:
            angles = np.linspace(0.0, 2.0 * math.pi, ASSEMBLY_SAMPLES)
        else:
            half = amplitude * limits.half_range
            angles = np.linspace(limits.mid - half, limits.mid + half, ASSEMBLY_SAMPLES)
    return dyads_error(describe(mechanism), angles)


#: |sin μ| (μ the coupler–rocker angle) below which the structure has lost its stiffness: the
#: soft mode across the dyad keeps less than 1 % of its stiffness, a tenth of its frequency.
NEAR_SINGULAR_SIN = 0.1


def dyad_sine_min(ground, crank, coupler, rocker, initial_angle, amplitude) -> np.ndarray:
    """Smallest |sin μ| over the motion of four-bars, μ the angle between coupler and rocker at C.

    Exact, not sampled on a step grid: with d = |BD| = √(a² + g² − 2ag cos θ),
    cos μ = (b² + c² − d²)/(2bc) is monotonic in d, so |sin μ| is smallest at an end of the
    range of d the input traverses (θ over the whole circle for a crank; θ_mid ± A for a rocker
    input, where d is extreme at the ends or at θ = kπ inside).

    Parameters
    ----------
    ground, crank, coupler, rocker : array_like, (case,)
        Link lengths, m.
    initial_angle : array_like, (case,)
        Input angle at t = 0, or the mid angle θ_mid of an oscillating input, rad.
    amplitude : array_like, (case,)
        Oscillation amplitude A of the input, rad; NaN for a fully rotating input.

    Returns
    -------
    ndarray, (case,)
        min |sin μ| over the motion, dimensionless.

    Examples
    --------
    >>> float(dyad_sine_min(0.5, 0.1, 0.45, 0.35, 0.0, float("nan")))  # doctest: +ELLIPSIS
    0.85...
    """
    g, a, b, c = (np.asarray(x, float) for x in (ground, crank, coupler, rocker))
    theta0, amp = np.asarray(initial_angle, float), np.asarray(amplitude, float)
    amp = np.where(np.isfinite(amp), amp, math.pi)
    lo, hi = theta0 - amp, theta0 + amp
    cos_ends = np.stack([np.cos(lo), np.cos(hi)])
    # θ = 2kπ (cos 1) or (2k + 1)π (cos −1) inside [lo, hi]; a crank covers both.
    has_zero = np.floor(hi / (2 * math.pi)) >= np.ceil(lo / (2 * math.pi))
    has_pi = np.floor((hi - math.pi) / (2 * math.pi)) >= np.ceil((lo - math.pi) / (2 * math.pi))
    cos_max = np.where(has_zero, 1.0, cos_ends.max(axis=0))
    cos_min = np.where(has_pi, -1.0, cos_ends.min(axis=0))
    sines = []
    for cos_theta in (cos_max, cos_min):
        d2 = a * a + g * g - 2.0 * a * g * cos_theta
        cos_mu = np.clip((b * b + c * c - d2) / (2.0 * b * c), -1.0, 1.0)
        sines.append(np.sqrt(1.0 - cos_mu**2))
    return np.minimum(*sines)


def near_singular(ground, crank, coupler, rocker, initial_angle, amplitude) -> np.ndarray:
    """Whether the elastic structure of four-bars loses its stiffness somewhere in the cycle.

    Coupler and rocker pinned at C resist a motion of C across their common line only through
    the angle between them: whatever holds the structure (their axial stiffness, the bending of
    a flexible input link seen through the linkage's velocity ratio, which grows as 1/sin μ
    towards a toggle), the stiffness of that mode scales as sin²μ and its frequency as |sin μ|;
    at sin μ = 0 (change point, toggle) the pin-jointed structure is an infinitesimal mechanism.
    Flagged when |sin μ| falls below :data:`NEAR_SINGULAR_SIN` somewhere in the motion, exactly
    (:func:`dyad_sine_min`, same parameters), not only on a step grid. Example: a double rocker
    (0.5, 0.35, 0.1, 0.45) at 99 % of its input range has sin μ = 0.127 and its lowest frozen
    frequency drops from 25.5 Hz to 3.6 Hz at the extremes, in proportion.

    Parameters
    ----------
    ground, crank, coupler, rocker : array_like, (case,)
        Link lengths, m.
    initial_angle : array_like, (case,)
        Input angle at t = 0, or the mid angle θ_mid of an oscillating input, rad.
    amplitude : array_like, (case,)
        Oscillation amplitude A of the input, rad; NaN for a fully rotating input.

    Returns
    -------
    ndarray of bool, (case,)
        True where the structure comes near a toggle or change point.
    """
    return dyad_sine_min(ground, crank, coupler, rocker, initial_angle, amplitude) \
        < NEAR_SINGULAR_SIN
