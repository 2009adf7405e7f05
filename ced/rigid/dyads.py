"""Rigid kinematics of any linkage built from dyads, closed form per dyad, batched.

The input link turns about its ground pivot; each dyad is then placed in order from two
known points (RRR, RPR) or a known point and a fixed guide (RRP), exactly as the four-bar and
the slider-crank of :mod:`ced.rigid.kinematics` (which are the one-dyad cases, docs/theory.md
"Linkages built from dyads"). Velocities and accelerations follow from the differentiated
closure of each dyad, in the same order, so every quantity is exact to round-off.
Shapes as in :mod:`ced.rigid.kinematics`: lengths (case,), motion (case, step).
"""
from __future__ import annotations

import numba as nb
import numpy as np

from ..problem.linkage import linkage_topology
from . import kinematics
from .kinematics import (InputMotion, RigidMotion, SINGULAR_SIN, choose_branch, fill_singular,
                         perp, pick, unit, unwrap)

__all__ = ["linkage", "dyad_sines", "point_motion"]


def _column(descriptions: list[dict], get) -> np.ndarray:
    return np.array([get(d) for d in descriptions], float)


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u·v over the last axis (of length 2), written out: numpy's sum over an axis of length
    2 runs its reduction loop once per pair, ~10× the two products (the same bits)."""
    return u[..., 0] * v[..., 0] + u[..., 1] * v[..., 1]


def point_motion(base, angle, velocity, acceleration, local):
    """Position, velocity and acceleration of a point fixed in a moving link frame.

    Parameters
    ----------
    base : tuple of ndarray, each (case, step, 2)
        Position (m), velocity (m/s), acceleration (m/s²) of the frame's origin.
    angle, velocity, acceleration : ndarray, (case, step)
        The frame's angle (rad), angular velocity (rad/s) and acceleration (rad/s²).
    local : ndarray, (case, 2)
        The point in the frame, m.

    Returns
    -------
    tuple of ndarray, each (case, step, 2)
        Position, velocity and acceleration of the point.
    """
    out = tuple(np.empty(np.shape(angle) + (2,)) for _ in range(3))
    _point_motion(base, (np.cos(angle), np.sin(angle)), velocity, acceleration, local, out)
    return out


def _point_motion(base, trig, velocity, acceleration, local, out) -> None:
    """:func:`point_motion` into ``out`` (three (case, step, 2) arrays), from the frame's
    (cos θ, sin θ) ``trig``: r = R(θ) local, then the origin's motion plus r, ω r⊥ and
    α r⊥ − ω² r, component by component (no (case, step, 2) temporaries)."""
    x, y = local[:, 0, None], local[:, 1, None]
    c, s = trig
    rx, ry = x * c + y * -s, x * s + y * c
    w, al = velocity, acceleration
    ww = w * w
    np.add(base[0][..., 0], rx, out=out[0][..., 0])
    np.add(base[0][..., 1], ry, out=out[0][..., 1])
    np.add(base[1][..., 0], w * -ry, out=out[1][..., 0])
    np.add(base[1][..., 1], w * rx, out=out[1][..., 1])
    np.subtract(base[2][..., 0] + al * -ry, ww * rx, out=out[2][..., 0])
    np.subtract(base[2][..., 1] + al * rx, ww * ry, out=out[2][..., 1])


@nb.njit(cache=True, nogil=True)
def _point_rows(joints, base, tip, c, s, w, al, local):
    """:func:`_point_motion` of joint ``tip`` from joint ``base`` of the joint motion
    ``joints`` (position, velocity, acceleration, each (case, step, joint, 2), C-contiguous),
    in place, with its arithmetic operation for operation: one pass instead of a dozen numpy
    calls on strided (case, step) views (a six-bar places four joints so; the same bits).
    ``c``, ``s``, ``w``, ``al`` (case, step) the frame's cos θ, sin θ, ω, α; ``local``
    (case, 2) m."""
    P, V, A = joints
    for i in range(c.shape[0]):
        x, y = local[i, 0], local[i, 1]
        for k in range(c.shape[1]):
            ck, sk, wk, ak = c[i, k], s[i, k], w[i, k], al[i, k]
            rx, ry = x * ck + y * -sk, x * sk + y * ck
            ww = wk * wk
            P[i, k, tip, 0] = P[i, k, base, 0] + rx
            P[i, k, tip, 1] = P[i, k, base, 1] + ry
            V[i, k, tip, 0] = V[i, k, base, 0] + wk * -ry
            V[i, k, tip, 1] = V[i, k, base, 1] + wk * rx
            A[i, k, tip, 0] = (A[i, k, base, 0] + ak * -ry) - ww * rx
            A[i, k, tip, 1] = (A[i, k, base, 1] + ak * rx) - ww * ry


@nb.njit(cache=True, nogil=True)
def _rrr_rates(joints, kp, kq, l1, l2, c1, s1, c2, s2, safe, out):
    """The rates and accelerations of :func:`_rrr` (w1, w2, α1, α2 into ``out``
    (4, case, step)) with its arithmetic operation for operation, where no step is singular:
    one pass instead of some thirty numpy calls (the same bits). ``joints`` the joint motion
    (position, velocity, acceleration, each (case, step, joint, 2)), ``kp``, ``kq`` the
    dyad's outer joints; ``l1``, ``l2`` (case,) m; the rest (case, step)."""
    _, V, A = joints
    for i in range(c1.shape[0]):
        a, b = l1[i], l2[i]
        for k in range(c1.shape[1]):
            dvx, dvy = V[i, k, kq, 0] - V[i, k, kp, 0], V[i, k, kq, 1] - V[i, k, kp, 1]
            w1 = (dvx * c2[i, k] + dvy * s2[i, k]) / (a * safe[i, k])
            w2 = (dvx * c1[i, k] + dvy * s1[i, k]) / (b * safe[i, k])
            k1, k2 = a * w1 * w1, b * w2 * w2
            dax = A[i, k, kq, 0] - A[i, k, kp, 0] + k1 * c1[i, k] - k2 * c2[i, k]
            day = A[i, k, kq, 1] - A[i, k, kp, 1] + k1 * s1[i, k] - k2 * s2[i, k]
            out[0, i, k], out[1, i, k] = w1, w2
            out[2, i, k] = (dax * c2[i, k] + day * s2[i, k]) / (a * safe[i, k])
            out[3, i, k] = (dax * c1[i, k] + day * s1[i, k]) / (b * safe[i, k])


# The compiled placement of an RRR dyad (_rrr_compiled): no fastmath, so that each operation
# rounds as numpy's does; numpy's error model, so that a division by zero gives inf or NaN as
# numpy's does instead of raising.
_RRR_JIT = dict(cache=True, nogil=True, error_model="numpy")


@nb.njit(**_RRR_JIT)
def _rrr_gap(X, kp, kq, d):
    """Q − P of an RRR dyad into ``d`` (2, case, step); ``X`` the joint positions (case,
    step, joint, 2), ``kp``, ``kq`` the dyad's outer joints."""
    for i in range(d.shape[1]):
        for k in range(d.shape[2]):
            d[0, i, k] = X[i, k, kq, 0] - X[i, k, kp, 0]
            d[1, i, k] = X[i, k, kq, 1] - X[i, k, kp, 1]


@nb.njit(**_RRR_JIT)
def _rrr_cos_beta(l1, l2, dist, out):
    """cos β = (l1² + |PQ|² − l2²)/(2 l1 |PQ|) clipped to [−1, 1] into ``out`` (case, step)
    with :func:`_rrr`'s numpy arithmetic operation for operation (``np.clip`` lets NaN
    pass); ``l1``, ``l2`` (case,) m, ``dist`` |PQ| (case, step) m."""
    for i in range(dist.shape[0]):
        a, b = l1[i], l2[i]
        for k in range(dist.shape[1]):
            x = dist[i, k]
            v = (a * a + x * x - b * b) / (2.0 * a * x)
            if v < -1.0:
                v = -1.0
            elif v > 1.0:
                v = 1.0
            out[i, k] = v


@nb.njit(**_RRR_JIT)
def _rrr_first(X, kp, kq, l1, d, dist, cos_beta, choice, out):
    """e1 = (c1, s1) and M − Q = (mx, my) of an RRR dyad into ``out`` (4, case, step), with
    :func:`_rrr`'s numpy arithmetic operation for operation; ``d`` Q − P, ``dist`` |PQ|,
    ``choice`` the solution (0: M left of P→Q)."""
    for i in range(d.shape[1]):
        a = l1[i]
        for k in range(d.shape[2]):
            cb = cos_beta[i, k]
            sb = np.sqrt(1.0 - cb * cb) * (1.0 if choice[i, k] == 0 else -1.0)
            ux, uy = d[0, i, k] / dist[i, k], d[1, i, k] / dist[i, k]
            c1, s1 = ux * cb - uy * sb, uy * cb + ux * sb
            out[0, i, k], out[1, i, k] = c1, s1
            out[2, i, k] = X[i, k, kp, 0] + a * c1 - X[i, k, kq, 0]
            out[3, i, k] = X[i, k, kp, 1] + a * s1 - X[i, k, kq, 1]


@nb.njit(**_RRR_JIT)
def _rrr_second(first, r2, out, singular):
    """e2 = (c2, s2) = (M − Q)/|M − Q| into ``out[0:2]``, ``safe`` (sin(θ2 − θ1), 1 where
    singular) into ``out[2]`` and ``singular`` (case, step), with :func:`_rrr`'s numpy
    arithmetic; ``first`` :func:`_rrr_first`'s output, ``r2`` |M − Q|."""
    for i in range(r2.shape[0]):
        for k in range(r2.shape[1]):
            c1, s1 = first[0, i, k], first[1, i, k]
            c2, s2 = first[2, i, k] / r2[i, k], first[3, i, k] / r2[i, k]
            s21 = s2 * c1 - c2 * s1
            out[0, i, k], out[1, i, k] = c2, s2
            singular[i, k] = abs(s21) < SINGULAR_SIN
            out[2, i, k] = 1.0 if singular[i, k] else s21


def _rrr(P, Q, l1, l2, branch, follow=None, joints=None):
    """Place an RRR dyad: angles, rates and accelerations of its links P→M and Q→M, the
    (cos, sin) of both angles and the solution chosen at each step (``follow``: as
    :func:`ced.rigid.kinematics.four_bar` takes it). ``joints`` (the joint motion and the
    indices of P and Q in it) places it by :func:`_rrr_compiled`."""
    if joints is not None and kinematics.COMPILED:
        return _rrr_compiled(P, Q, l1, l2, branch, follow, joints)
    dx, dy = Q[0][..., 0] - P[0][..., 0], Q[0][..., 1] - P[0][..., 1]
    dist = np.hypot(dx, dy)
    psi = np.arctan2(dy, dx)
    cos_beta = np.clip((l1 * l1 + dist * dist - l2 * l2) / (2.0 * l1 * dist), -1.0, 1.0)
    beta = np.arccos(cos_beta)
    candidates = np.stack([psi + beta, psi - beta])  # M left / right of P→Q
    start = np.where(branch > 0, 0, 1)
    # A dyad that assembles over the whole motion has its two solutions meet only where the
    # loop passes a change point: there the one continuing straight through is kept.
    choice = choose_branch(candidates, start, np.ones(len(l1), bool), follow)
    th1 = unwrap(pick(candidates, choice))
    # e1 = R(±β) (Q − P)/|Q − P| and e2 = (M − Q)/|M − Q| without trigonometry (five sines
    # and cosines a step and dyad otherwise: a third of its placement): the same to round-off.
    sin_beta = np.sqrt(1.0 - cos_beta * cos_beta) * np.where(choice == 0, 1.0, -1.0)
    ux, uy = dx / dist, dy / dist
    c1, s1 = ux * cos_beta - uy * sin_beta, uy * cos_beta + ux * sin_beta
    # M − Q with M = P + l1 e1.
    mx, my = P[0][..., 0] + l1 * c1 - Q[0][..., 0], P[0][..., 1] + l1 * s1 - Q[0][..., 1]
    th2 = unwrap(np.arctan2(my, mx))
    r2 = np.hypot(mx, my)  # l2 where the dyad assembles
    c2, s2 = mx / r2, my / r2
    # l1 ω1 e⊥1 − l2 ω2 e⊥2 = vQ − vP, dotted with e2 and e1 (e⊥i·ej = sin(θj − θi)).
    s21 = s2 * c1 - c2 * s1
    singular = np.abs(s21) < SINGULAR_SIN
    safe = np.where(singular, 1.0, s21)
    (w1, al1), (w2, al2) = _rrr_rates_numpy(P, Q, l1, l2, (c1, s1, c2, s2, safe), singular)
    return (th1, w1, al1), (th2, w2, al2), singular, (c1, s1), (c2, s2), choice


def _rrr_compiled(P, Q, l1, l2, branch, follow, joints):
    """:func:`_rrr` with its arithmetic between the transcendental functions in compiled
    passes (:func:`_rrr_gap`, :func:`_rrr_first`, :func:`_rrr_second`, :func:`_rrr_rates`;
    numpy's ``hypot``, ``arctan2`` and ``arccos`` kept, whose bits a compiled libm call need
    not match): five passes instead of some thirty numpy calls on (case, step) arrays and
    their strided joint views, the same bits (tested against ``CED_KERNEL=numpy``): the
    Watt II's placement of 16 cases × 258 steps 1.08 → 0.92 ms. The result is
    :func:`_rrr`'s."""
    motion, kp, kq = joints
    X = motion[0]
    a, b = (np.require(x[:, 0], float, "C") for x in (l1, l2))
    d = np.empty((2,) + X.shape[:2])
    _rrr_gap(X, kp, kq, d)
    dist = np.hypot(d[0], d[1])
    psi = np.arctan2(d[1], d[0])
    cos_beta = np.empty_like(dist)
    _rrr_cos_beta(a, b, dist, cos_beta)
    beta = np.arccos(cos_beta)
    candidates = np.empty((2,) + psi.shape)  # M left / right of P→Q
    np.add(psi, beta, out=candidates[0])
    np.subtract(psi, beta, out=candidates[1])
    choice = choose_branch(candidates, np.where(branch > 0, 0, 1), np.ones(len(l1), bool),
                           follow)
    th1 = unwrap(pick(candidates, choice))
    first = np.empty((4,) + psi.shape)  # c1, s1, mx, my
    _rrr_first(X, kp, kq, a, d, dist, cos_beta, np.require(choice, np.int64, "C"), first)
    th2 = unwrap(np.arctan2(first[3], first[2]))
    second = np.empty((3,) + psi.shape)  # c2, s2, safe
    singular = np.empty(psi.shape, bool)
    _rrr_second(first, np.hypot(first[2], first[3]), second, singular)
    trig = (first[0], first[1], second[0], second[1], second[2])
    if singular.any():
        rates = _rrr_rates_numpy(P, Q, l1, l2, trig, singular)
    else:
        out = np.empty((4,) + th1.shape)
        _rrr_rates(motion, kp, kq, a, b, *trig, out)
        rates = (out[0], out[2]), (out[1], out[3])
    (w1, al1), (w2, al2) = rates
    return ((th1, w1, al1), (th2, w2, al2), singular, (first[0], first[1]),
            (second[0], second[1]), choice)


def _rrr_rates_numpy(P, Q, l1, l2, trig, singular):
    """((ω1, α1), (ω2, α2)) of an RRR dyad from the (cos, sin) of its links ``trig``
    (c1, s1, c2, s2 and sin(θ2 − θ1), 1 where ``singular``), interpolated at the singular
    steps."""
    c1, s1, c2, s2, safe = trig
    dvx, dvy = Q[1][..., 0] - P[1][..., 0], Q[1][..., 1] - P[1][..., 1]
    w1 = (dvx * c2 + dvy * s2) / (l1 * safe)
    w2 = (dvx * c1 + dvy * s1) / (l2 * safe)
    w1, w2 = fill_singular(w1, singular), fill_singular(w2, singular)
    # aQ − aP + l1 ω1² e1 − l2 ω2² e2, dotted with e2 and e1.
    k1, k2 = l1 * w1 * w1, l2 * w2 * w2
    dax = Q[2][..., 0] - P[2][..., 0] + k1 * c1 - k2 * c2
    day = Q[2][..., 1] - P[2][..., 1] + k1 * s1 - k2 * s2
    al1 = (dax * c2 + day * s2) / (l1 * safe)
    al2 = (dax * c1 + day * s1) / (l2 * safe)
    return (w1, fill_singular(al1, singular)), (w2, fill_singular(al2, singular))


def _rrp(P, length, guide_angle, guide_point, branch):
    """Place an RRP dyad: the link P→M with M on the fixed guide; angle, rate, acceleration."""
    phi = guide_angle[:, None]
    n = perp(phi)  # guide normal, (case, 1, 2)
    height = _dot(P[0] - guide_point[:, None], n)
    # n·(M − P) = −h with M − P = l e1: sin(θ1 − φ) = −h/l, cos(θ1 − φ) = ±√(1 − sin²).
    sin_rel = -height / length
    cos_rel = branch * np.sqrt(np.clip(1.0 - sin_rel**2, 0.0, None))
    th = unwrap(np.arctan2(sin_rel, cos_rel)) + phi
    # n·vM = 0 and n·aM = 0 on a fixed guide (n·e⊥1 = cos(θ1 − φ), n·e1 = sin(θ1 − φ)).
    w = -_dot(P[1], n) / (length * cos_rel)
    al = (-_dot(P[2], n) + length * w * w * sin_rel) / (length * cos_rel)
    return th, w, al


def _rpr(P, Q, offset):
    """Place an RPR dyad: the guide bar's angle, rate, acceleration, the sleeve's slide and
    the (cos, sin) of the bar's angle.

    The bar turns about P; the sleeve turns about Q and slides along it, Q at the signed
    distance ``offset`` e to the left of the bar's line: Q − P = s e1 + e e⊥1 (e1 along the
    bar, s the sleeve's distance from P along it). Hence s = √(|PQ|² − e²) and
    θ1 = ψ − atan2(e, s), ψ the angle of P→Q. Differentiating the closure once,
    vQ − vP = (ṡ − e ω) e1 + s ω e⊥1, and twice,
    aQ − aP = (s̈ − e α − s ω²) e1 + (2 ṡ ω − e ω² + s α) e⊥1, each dotted with e⊥1 and e1.
    """
    d = Q[0] - P[0]
    dist2 = _dot(d, d)
    e = offset[:, None]
    s = np.sqrt(np.clip(dist2 - e * e, 0.0, None))
    th = unwrap(np.arctan2(d[..., 1], d[..., 0]) - np.arctan2(e, s))
    e1, n1 = unit(th), perp(th)
    dv, da = Q[1] - P[1], Q[2] - P[2]
    w = _dot(dv, n1) / s
    ds = _dot(dv, e1) + e * w
    al = (_dot(da, n1) - 2.0 * ds * w + e * w * w) / s
    dds = _dot(da, e1) + e * al + s * w * w
    return (th, w, al), (s, ds, dds), (e1[..., 0], e1[..., 1])


def linkage(descriptions: list[dict], motion: InputMotion,
            follow: dict[str, tuple] | None = None) -> RigidMotion:
    """Closed-form kinematics of a batch of linkages of one dyad structure.

    Parameters
    ----------
    descriptions : list of dict
        One dyad description per case (:func:`ced.problem.linkage.describe`), all with the
        same names and dyad kinds; lengths in m, angles in rad.
    motion : InputMotion
        The input link's angle, angular velocity and acceleration, (case, step).
    follow : dict, optional
        For the first link of each RRR dyad, its assembly solution at each time (index, near),
        each (case, step), as :func:`ced.rigid.kinematics.four_bar` takes it, instead of
        tracking it along the times from the dyad's branch.

    Returns
    -------
    RigidMotion
        Angles and rates of every link (case, step, link), positions, velocities and
        accelerations of every joint (case, step, joint, 2), the link lengths first→second
        joint (case, link), the guide angle of every slider block (rad, (case,)), the
        slide of every RPR sleeve along its guide bar (m, m/s, m/s², (case, step)) and the
        solution chosen for the first link of every RRR dyad (case, step).
    """
    first = descriptions[0]
    topo = linkage_topology(first)
    shape = motion.angle.shape
    # Every joint's motion is written in place into the arrays of the result.
    joint_motion = tuple(np.zeros(shape + (len(topo.joint_names), 2)) for _ in range(3))
    known: dict[str, tuple] = {
        name: tuple(x[:, :, j] for x in joint_motion) for j, name in enumerate(topo.joint_names)}
    index = {name: j for j, name in enumerate(topo.joint_names)}
    placed = set(first["ground"])
    for name in placed & set(known):
        known[name][0][...] = _column(descriptions, lambda d: d["ground"][name])[:, None, :]
    angles: dict[str, tuple] = {}
    trig: dict[str, tuple] = {}  # (cos θ, sin θ) of every link placed: computed once
    lengths: dict[str, np.ndarray] = {}
    guide_angle: dict[str, np.ndarray] = {}
    slide: dict[str, tuple] = {}
    branch: dict[str, np.ndarray] = {}
    singular = np.zeros(shape, bool)
    inp = first["input"]
    lengths[inp["link"]] = _column(descriptions, lambda d: d["input"]["length"])
    angles[inp["link"]] = (motion.angle, motion.velocity, motion.acceleration)

    def place(link: str) -> None:
        """Known points at the second joint and at the points of a placed link (the first
        placement of a point is kept: a dyad's middle joint is placed from its first link)."""
        start = known[topo.links[link][0]]
        local = {topo.links[link][1]: np.stack([lengths[link], 0 * lengths[link]], axis=-1)}
        for name, point in first.get("points", {}).items():
            if point["link"] == link:
                local[name] = _column(descriptions, lambda d: d["points"][name]["at"])
        if link not in trig:
            trig[link] = (np.cos(angles[link][0]), np.sin(angles[link][0]))
        for name, xy in local.items():
            if name not in placed and name in known:
                if kinematics.COMPILED:
                    _point_rows(joint_motion, index[topo.links[link][0]], index[name],
                                *(np.require(x, float, "C") for x in (*trig[link],
                                                                      *angles[link][1:], xy)))
                else:
                    _point_motion(start, trig[link], *angles[link][1:], xy, known[name])
                placed.add(name)

    place(inp["link"])
    for k, dyad in enumerate(first["dyads"]):
        l1, l2 = dyad["links"]
        P = known[dyad["joints"][0]]
        lengths[l1] = _column(descriptions, lambda d: d["dyads"][k]["lengths"][0])
        if dyad["kind"] == "RPR":
            offset = _column(descriptions, lambda d: d["dyads"][k]["offset"])
            angles[l1], slide[l2], trig[l1] = _rpr(P, known[dyad["joints"][2]], offset)
            place(l1)
            continue
        sign = _column(descriptions, lambda d: 1.0 if d["dyads"][k]["branch"] == "open"
                       else -1.0)[:, None]
        if dyad["kind"] == "RRR":
            Q = known[dyad["joints"][2]]
            lengths[l2] = _column(descriptions, lambda d: d["dyads"][k]["lengths"][1])
            angles[l1], angles[l2], bad, trig[l1], trig[l2], branch[l1] = _rrr(
                P, Q, lengths[l1][:, None], lengths[l2][:, None], sign[:, 0],
                None if follow is None else follow[l1], (joint_motion, index[dyad["joints"][0]], index[dyad["joints"][2]]))
            singular |= bad
            place(l1)
            place(l2)
        else:
            phi = _column(descriptions, lambda d: d["dyads"][k]["guide"]["angle"])
            point = _column(descriptions, lambda d: d["dyads"][k]["guide"]["point"])
            angles[l1] = _rrp(P, lengths[l1][:, None], phi, point, sign)
            guide_angle[l2] = phi
            place(l1)
    names = topo.link_names
    return RigidMotion(
        topology=topo,
        time=motion.time,
        lengths=np.stack([lengths[n] for n in names], axis=-1),
        link_angle=np.stack([angles[n][0] for n in names], axis=-1),
        link_angular_velocity=np.stack([angles[n][1] for n in names], axis=-1),
        link_angular_acceleration=np.stack([angles[n][2] for n in names], axis=-1),
        joint_position=joint_motion[0],
        joint_velocity=joint_motion[1],
        joint_acceleration=joint_motion[2],
        singular=singular,
        guide_angle=guide_angle,
        slide=slide or None,
        branch=branch or None,
    )


def dyad_sines(motion: RigidMotion, description: dict) -> np.ndarray:
    """The transmission quality of every dyad, (case, step, dyad), in [0, 1].

    RRR: |sin| of the angle between its two links; where it falls to 0 the dyad is at a toggle
    and the pin-jointed structure loses its stiffness across the dyad (as the four-bar's
    :func:`ced.problem.mechanism.dyad_sine_min`). RRP: |cos(θ_rod − φ_guide)|. RPR: s/L, the
    sleeve's distance from the guide bar's pivot as a fraction of the bar's length: the bar
    turns by ω = e⊥·(vQ − vP)/s, so its end moves (L/s) times as fast as the sleeve's pivot
    moves across the bar, and what the end carries is felt at the sleeve amplified by L/s
    (the stiffness seen at the end scales as (s/L)², as a dyad's across its joint as sin²).
    At s = 0 the sleeve sits on the pivot (|PQ| = |offset|), which the assembly check refuses;
    s/L flags the approach to it.

    Parameters
    ----------
    motion : RigidMotion
        Rigid motion of linkages with the structure of ``description``.
    description : dict
        A dyad description (:func:`ced.problem.linkage.describe`).

    Returns
    -------
    ndarray, (case, step, dyad)
        Dimensionless, in [0, 1].
    """
    names = motion.topology.link_names
    out = []
    for dyad in description["dyads"]:
        i = names.index(dyad["links"][0])
        th1 = motion.link_angle[..., i]
        if dyad["kind"] == "RRR":
            th2 = motion.link_angle[..., names.index(dyad["links"][1])]
            out.append(np.abs(np.sin(th2 - th1)))
        elif dyad["kind"] == "RRP":
            out.append(np.abs(np.cos(th1 - motion.guide_angle[dyad["links"][1]][:, None])))
        else:
            slide = motion.slide[dyad["links"][1]][0]
            out.append(np.clip(slide / motion.lengths[:, i, None], 0.0, 1.0))
    return np.stack(out, axis=-1)
