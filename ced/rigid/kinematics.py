"""Rigid kinematics of planar linkages, closed form, batched over cases and time (thesis II.1–II.2).

All functions take lengths as arrays of shape ``(case,)`` and the input motion as arrays of
shape ``(case, step)``; results carry those two leading dimensions. Angles in rad, lengths in
m, angular velocities in rad/s, angular accelerations in rad/s².
"""
from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..problem.mechanism import GRASHOF_RTOL, Topology, topology

__all__ = ["InputMotion", "RigidMotion", "at_steps", "branch_between", "input_motion", "four_bar",
           "slider_crank", "single_link", "through_change_points"]

#: |sin| of the transmission angle below which the closed-form velocity formulas are replaced
#: by interpolation in time (change points and toggle positions: the formulas become 0/0).
SINGULAR_SIN = 1e-7


@dataclass(frozen=True)
class InputMotion:
    """Angle, angular velocity and acceleration of the input link, each ``(case, step)``."""

    time: np.ndarray
    angle: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray


def at_steps(motion: RigidMotion, steps: np.ndarray) -> RigidMotion:
    """``motion`` at the given indices of its step axis (per-case values as they are).

    Parameters
    ----------
    motion : RigidMotion
        Rigid motion (case, step, …).
    steps : numpy.ndarray
        Indices into its step axis, (n,) int.
    """
    slide = None if motion.slide is None else {
        name: tuple(x[:, steps] for x in value) for name, value in motion.slide.items()}
    branch = None if motion.branch is None else {
        name: choice[:, steps] for name, choice in motion.branch.items()}
    return dataclasses.replace(
        motion, time=motion.time[:, steps], link_angle=motion.link_angle[:, steps],
        link_angular_velocity=motion.link_angular_velocity[:, steps],
        link_angular_acceleration=motion.link_angular_acceleration[:, steps],
        joint_position=motion.joint_position[:, steps],
        joint_velocity=motion.joint_velocity[:, steps],
        joint_acceleration=motion.joint_acceleration[:, steps],
        singular=motion.singular[:, steps], slide=slide, branch=branch)


def branch_between(motion: RigidMotion, lower: np.ndarray, fraction: np.ndarray) -> dict:
    """The assembly solution of every two-solution link at times between steps of ``motion``.

    The solution chosen along a continuous motion changes only where the two touch (a change
    point), so between two steps that chose the same one it is that one. Between two steps
    that chose different ones the touching point lies in between, where the two solutions
    differ by O(step); there the one nearest the link's angle interpolated linearly between
    the steps is taken (the motion's own curve, within O(step²)), the other one being O(step)
    away except within O(step²) of the touching point. A time before the first step
    (``fraction`` < 0 with ``lower`` 0) takes the one nearest the first step's motion
    continued backwards, straight through a touching point at the start as the motion passes
    through the others.

    Parameters
    ----------
    motion : RigidMotion
        A motion on a step grid, with its choices (``motion.branch``).
    lower : numpy.ndarray
        Step before each time, (case, n) int, at most the grid's last step − 1.
    fraction : numpy.ndarray
        Each time's position after ``lower``, in steps, (case, n): in [0, 1), or negative
        before step 0.

    Returns
    -------
    dict of str to tuple of numpy.ndarray
        For each link of ``motion.branch``: the solution to take (case, n) int, 0 or 1, or −1
        where it is the one nearest the link's interpolated angle, and that angle (case, n)
        rad: the ``follow`` argument of :func:`four_bar` and :func:`ced.rigid.dyads.linkage`.
    """
    rows = np.arange(lower.shape[0])[:, None]
    out = {}
    for link, choice in (motion.branch or {}).items():
        before, after = choice[rows, lower], choice[rows, lower + 1]
        angle = motion.link_angle[..., motion.topology.link_names.index(link)]
        start = angle[rows, lower]
        near = start + fraction * (angle[rows, lower + 1] - start)
        out[link] = (np.where((before == after) & (fraction >= 0.0), before, -1), near)
    return out


def input_motion(
    time: np.ndarray,
    speed: np.ndarray,
    initial_angle: np.ndarray,
    amplitude: np.ndarray | None = None,
) -> InputMotion:
    """Constant-speed rotation, or oscillation θ = θ_mid + A sin(Ωt) when ``amplitude`` is given.

    Parameters
    ----------
    time : (case, step) s
    speed : (case,) rad/s — crank speed Ω, or the oscillation's circular frequency.
    initial_angle : (case,) rad — θ at t = 0 (θ_mid for an oscillating input).
    amplitude : (case,) rad or None — oscillation amplitude A; NaN entries rotate.
    """
    omega = np.asarray(speed, float)[:, None]
    theta0 = np.asarray(initial_angle, float)[:, None]
    angle = theta0 + omega * time
    velocity = np.broadcast_to(omega, time.shape).copy()
    acceleration = np.zeros_like(time)
    amp = None if amplitude is None else np.asarray(amplitude, float)[:, None]
    if amp is not None and np.isfinite(amp).any():  # (no sines for a batch that only rotates)
        rocks = np.broadcast_to(np.isfinite(amp), time.shape)
        phase = omega * time
        sine = np.sin(phase)
        a = np.where(np.isfinite(amp), amp, 0.0)
        angle = np.where(rocks, theta0 + a * sine, angle)
        velocity = np.where(rocks, a * omega * np.cos(phase), velocity)
        acceleration = np.where(rocks, -a * omega**2 * sine, acceleration)
    return InputMotion(time, angle, velocity, acceleration)


@dataclass(frozen=True)
class RigidMotion:
    """Rigid motion of a batch of linkages.

    Arrays: ``link_angle``, ``link_angular_velocity``, ``link_angular_acceleration`` of shape
    (case, step, link); ``joint_position``, ``joint_velocity``, ``joint_acceleration`` of shape
    (case, step, joint, 2); ``lengths`` (case, link). ``singular`` (case, step) marks steps
    where the transmission is singular (change point, toggle) and velocities were interpolated.
    ``guide_angle`` maps each slider block of a linkage of dyads to its guide's angle (case,)
    rad; None for the built-in mechanisms (a slider-crank's guide is parallel to x).
    ``slide`` maps each sleeve of an RPR dyad to its distance s from the guide bar's pivot
    along the bar (m), its rate (m/s) and acceleration (m/s²), each (case, step); None
    without sleeves. ``branch`` maps each link placed by choosing one of two assembly
    solutions (a four-bar's coupler, the first link of an RRR dyad) to the solution taken at
    every step, (case, step) int: 0 the one on the left of the line between the two known
    points (P→Q; B→D for the four-bar), 1 the one on the right; None for the other types.
    """

    topology: Topology
    time: np.ndarray
    lengths: np.ndarray
    link_angle: np.ndarray
    link_angular_velocity: np.ndarray
    link_angular_acceleration: np.ndarray
    joint_position: np.ndarray
    joint_velocity: np.ndarray
    joint_acceleration: np.ndarray
    singular: np.ndarray
    guide_angle: dict[str, np.ndarray] | None = None
    slide: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None
    branch: dict[str, np.ndarray] | None = None

    def link_point(self, link: str, s: np.ndarray | float, order: int = 0) -> np.ndarray:
        """Position (order 0), velocity (1) or acceleration (2) of the point at distance
        ``s`` (m, broadcast against (case,)) from the link's first joint, (case, step, 2)."""
        i = self.topology.link_names.index(link)
        first = self.topology.joint_names.index(self.topology.links[link][0])
        base = (self.joint_position, self.joint_velocity, self.joint_acceleration)[order][:, :, first]
        th = self.link_angle[:, :, i]
        w = self.link_angular_velocity[:, :, i]
        al = self.link_angular_acceleration[:, :, i]
        e = np.stack([np.cos(th), np.sin(th)], axis=-1)
        n = np.stack([-np.sin(th), np.cos(th)], axis=-1)
        s = np.asarray(s, float).reshape(-1, 1, 1) if np.ndim(s) else float(s)
        if order == 0:
            return base + s * e
        if order == 1:
            return base + s * w[..., None] * n
        return base + s * (al[..., None] * n - (w**2)[..., None] * e)


def unit(angle: np.ndarray) -> np.ndarray:
    """(cos θ, sin θ) on a new last axis."""
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1)


def perp(angle: np.ndarray) -> np.ndarray:
    """(−sin θ, cos θ), the unit vector a quarter turn ahead, on a new last axis."""
    return np.stack([-np.sin(angle), np.cos(angle)], axis=-1)


#: Unwrap angles in a compiled loop (:func:`unwrap`); ``CED_KERNEL=numpy`` keeps ``np.unwrap``,
#: the reference it is tested against (the same bits).
COMPILED = os.environ.get("CED_KERNEL", "numba") != "numpy"


def unwrap(angle: np.ndarray) -> np.ndarray:
    """``np.unwrap(angle, axis=1)``: each step's jump of more than π brought back by 2π.

    np.unwrap makes five temporaries and a remainder at every step (0.8 ms for 22 cases ×
    1025 steps, measured, four times a cosine of them); :func:`_unwrap_rows` does the same
    arithmetic in one pass, the remainder only where a step jumps.

    Parameters
    ----------
    angle : numpy.ndarray
        Angles (case, step), rad.

    Returns
    -------
    numpy.ndarray
        The unwrapped angles (case, step), rad.
    """
    if not COMPILED:
        return np.unwrap(angle, axis=1)
    angle = np.require(angle, float, ("C", "W"))  # one signature, compiled once
    out = np.empty_like(angle)
    _unwrap_rows(angle, out)
    return out


@nb.njit(cache=True, nogil=True)
def _unwrap_rows(p, out):
    """np.unwrap(p, axis=1) with its default period 2π into ``out``, operation for operation:
    the step's jump dd, its remainder mod(dd + π, 2π) − π (numpy's, from fmod) where
    |dd| ≥ π, +π rather than −π for a jump of +π exactly, the corrections summed from the
    first in step order (as cumsum) and added to the angles."""
    pi, period = math.pi, 2.0 * math.pi
    for c in range(p.shape[0]):
        total = 0.0
        for k in range(p.shape[1]):
            if k == 0:
                out[c, 0] = p[c, 0]
                continue
            dd = p[c, k] - p[c, k - 1]
            corr = 0.0
            if not abs(dd) < pi:
                a = dd - -pi
                mod = np.fmod(a, period)  # numpy's npy_divmod: the sign of the divisor
                if mod != 0.0:
                    if (period < 0.0) != (mod < 0.0):
                        mod += period
                else:
                    mod = math.copysign(0.0, period)
                ddmod = mod + -pi
                if ddmod == -pi and dd > 0.0:
                    ddmod = pi
                corr = ddmod - dd
            total = corr if k == 1 else total + corr
            out[c, k] = p[c, k] + total


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def track_branch(
    candidates: np.ndarray, start_index: np.ndarray, touching: np.ndarray
) -> np.ndarray:
    """Pick, step by step, the candidate that continues the motion smoothly.

    ``candidates`` (2, case, step) are the two assembly solutions. The branches of a linkage
    touch only at a change point (S + L = P + Q, ``touching``); elsewhere the choice never
    changes, however close the branches come. Where they touch, the candidate nearest to the
    linear extrapolation of the last two steps is kept, so the motion passes straight through
    the singular configuration instead of reflecting off it — where a step falls within
    :data:`_MEET` of the touching point (a dyad's loop; a four-bar's change points are
    counted in closed form instead, :func:`through_change_points`). Deterministic.

    Returns
    -------
    numpy.ndarray
        The candidate chosen at every step, (case, step) int, 0 or 1 (:func:`pick` takes it).
    """
    ncase, nstep = candidates.shape[1:]
    choice = np.broadcast_to(start_index[:, None], (ncase, nstep)).copy()
    # Only change-point cases whose branches come close need the sequential pass, and only
    # change-point cases their gap.
    close = np.asarray(touching, bool).copy()
    if close.any() and nstep >= 3:
        close[close] = _branches_meet(candidates[0, close] - candidates[1, close])
    if not close.any() or nstep < 3:
        return choice
    cand = candidates[:, close]
    index = choice[close]
    chosen = np.empty(cand.shape[1:])
    rows = np.arange(cand.shape[1])
    chosen[:, 0] = cand[index[:, 0], rows, 0]
    chosen[:, 1] = cand[index[:, 1], rows, 1]
    for k in range(2, nstep):
        predicted = 2.0 * chosen[:, k - 1] - chosen[:, k - 2]
        dist = np.abs(np.angle(np.exp(1j * (cand[:, :, k] - predicted))))
        index[:, k] = np.argmin(dist, axis=0)
        chosen[:, k] = cand[index[:, k], rows, k]
    choice[close] = index
    return choice


def follow_branch(candidates: np.ndarray, index: np.ndarray, near: np.ndarray) -> np.ndarray:
    """The candidate given for every (case, time), instead of tracking them in sequence.

    Parameters
    ----------
    candidates : numpy.ndarray
        The two assembly solutions, (2, case, n), rad.
    index : numpy.ndarray
        The candidate to take, (case, n) int: 0 or 1, or −1 for the one nearest ``near``
        (:func:`branch_between`).
    near : numpy.ndarray
        Angle the candidate is chosen by where ``index`` is −1, (case, n), rad (any turn).

    Returns
    -------
    numpy.ndarray
        The candidate chosen, (case, n) int, 0 or 1.
    """
    open_ = index < 0
    if not open_.any():
        return index
    gap = np.abs(np.angle(np.exp(1j * (candidates[:, open_] - near[open_]))))
    choice = index.copy()
    choice[open_] = np.argmin(gap, axis=0)
    return choice


def pick(candidates: np.ndarray, choice: np.ndarray) -> np.ndarray:
    """The candidates (2, case, n) chosen by ``choice`` (case, n), (case, n)."""
    return np.take_along_axis(candidates, choice[None], axis=0)[0]


def choose_branch(candidates: np.ndarray, start_index: np.ndarray, touching: np.ndarray,
                   follow: tuple | None) -> np.ndarray:
    """:func:`track_branch` along the times, or, given ``follow`` (index, near), the choice
    it gives (:func:`follow_branch`)."""
    if follow is None:
        return track_branch(candidates, start_index, touching)
    return follow_branch(candidates, *follow)


#: Smallest gap (rad) between the two branches of a case, over its steps, below which they
#: count as meeting (:func:`track_branch`).
_MEET = 1e-2
#: Distance (in turns) from a touching crank angle within which a step counts as on it.
_ON_LEVEL = 1e-12


def _crossing_parity(angle: np.ndarray, level: float) -> np.ndarray:
    """(case, step) int, 0 or 1: the parity of the number of times the input angle has crossed
    ``level`` (mod 2π) since the start. A step on the level (within :data:`_ON_LEVEL` turns)
    takes the previous step's count, the leading ones the first step's off it: the two
    assembly solutions coincide there, and a motion that starts on the level starts on the
    side it moves to. The parity of the crossings is that of the net ones, whatever the path
    (a rocking input crosses back and forth)."""
    x = (angle - level) / (2.0 * np.pi)
    on = np.abs(x - np.rint(x)) <= _ON_LEVEL
    side = np.floor(x)
    steps = np.arange(x.shape[1])
    last_off = np.maximum.accumulate(np.where(on, -1, steps), axis=1)
    first_off = np.argmax(~on, axis=1)[:, None]
    side = np.take_along_axis(side, np.where(last_off < 0, first_off, last_off), axis=1)
    return ((side - side[:, :1]) % 2).astype(np.int64)


def through_change_points(angle: np.ndarray, start_index: np.ndarray, at_half_turn: np.ndarray,
                          at_zero: np.ndarray) -> np.ndarray:
    """The assembly solution of a change-point four-bar's coupler at every step, in closed form.

    Its coupler and rocker are collinear (β = 0 or π, the two solutions ψ ± β one) only at
    the crank angle where |BD| is extreme and equals b + c or |b − c|: θ2 ≡ π where
    g + a = b + c, θ2 ≡ 0 where |g − a| = |b − c| (both for a parallelogram). There β is
    V-shaped in θ2 (|BD| is stationary), so the solution that continues smoothly — the motion
    passing straight through, as rigid links with inertia do — changes label at every crossing
    of that angle. Counting crossings makes the motion independent of how the steps sample
    the change point; tracking the nearest solution step by step (:func:`track_branch`) saw
    the two touch only where a step fell within a small gap of it and otherwise reflected the
    motion off it (a velocity jump of twice the coupler's).

    Parameters
    ----------
    angle : numpy.ndarray
        The crank angle θ2 at every step, (case, step), rad.
    start_index : numpy.ndarray
        The solution at the start, (case,) int, 0 or 1.
    at_half_turn, at_zero : numpy.ndarray
        Whether the two solutions touch at θ2 ≡ π and at θ2 ≡ 0, (case,) bool.

    Returns
    -------
    numpy.ndarray
        The solution at every step, (case, step) int, 0 or 1 (:func:`pick` takes it).
    """
    flips = (np.where(at_half_turn[:, None], _crossing_parity(angle, np.pi), 0)
             + np.where(at_zero[:, None], _crossing_parity(angle, 0.0), 0))
    return (start_index[:, None] + flips) % 2


def _branches_meet(difference: np.ndarray) -> np.ndarray:
    """(case,) bool: the branches' wrapped angular gap |angle(exp(i d))| of the difference d
    (case, step) falls below :data:`_MEET` at some step.

    That exact gap costs a complex exponential a step (0.7 ms for 22 cases × 1025 steps,
    measured, as much as a four-bar's other trigonometry). The difference wrapped by
    remainder, d − 2π rint(d / 2π), is the same gap to ~1e-13 rad while |d| ≤ 1e3: it decides
    every case whose smallest gap is not within 1e-9 of the threshold, and the exact gap the
    others (the same decisions, hence the same motion)."""
    period = 2.0 * np.pi
    approx = np.abs(difference - period * np.rint(difference / period)).min(axis=1)
    meet = approx < _MEET
    unsure = ~(np.abs(approx - _MEET) > 1e-9) | ~(np.abs(difference).max(axis=1) <= 1e3)
    if unsure.any():
        gap = np.abs(np.angle(np.exp(1j * difference[unsure])))
        meet[unsure] = gap.min(axis=1) < _MEET
    return meet


def fill_singular(values: np.ndarray, singular: np.ndarray) -> np.ndarray:
    """Replace values at singular steps by linear interpolation in step index (per case)."""
    if not singular.any():
        return values
    out = values.copy()
    steps = np.arange(values.shape[1])
    for c in np.flatnonzero(singular.any(axis=1)):
        good = ~singular[c]
        if good.sum() < 2:
            out[c] = 0.0
            continue
        out[c, ~good] = np.interp(steps[~good], steps[good], values[c, good])
    return out


def _over_pivot(th2, a, d, psi, over):
    """The diagonal B→D of the kites ``over`` (case,), crank as long as the ground and
    coupler as long as the rocker: their crank pin B passes over the rocker pivot D at θ2 = 0
    (mod 2π), where B→D reverses and its angle ψ jumps by π (no other four-bar has |BD| = 0:
    it needs a = g, and |b − c| ≤ |BD|). Written as BD = 2a sin(θ2/2) u with the unit vector
    u = (sin(θ2/2), −cos(θ2/2)) (exact for a = g), the length signed by sin(θ2/2) and ψ the
    angle of u continue smoothly through it: the two assembly solutions ψ ± β keep their labels
    (C left or right of u, which is B→D for 0 < θ2 < 2π) and the motion passes over D on the
    branch it is on, as it does through every change point, instead of reversing its coupler
    (a kite or rhombus; at θ2 = 0 itself ψ was undefined and the motion NaN).

    Parameters
    ----------
    th2 : (case, step) rad
    a : (case, 1) m, the crank
    d, psi : (case, step) m, rad: |BD| and its angle

    Returns
    -------
    (d, psi) with the rows ``over`` replaced by the signed length and the angle of u.
    """
    half = 0.5 * th2[over]
    d, psi = d.copy(), psi.copy()
    d[over] = 2.0 * a[over] * np.sin(half)
    psi[over] = half - 0.5 * np.pi
    return d, psi


def four_bar(
    ground: np.ndarray,
    crank: np.ndarray,
    coupler: np.ndarray,
    rocker: np.ndarray,
    motion: InputMotion,
    branch: np.ndarray,
    follow: tuple[np.ndarray, np.ndarray] | None = None,
) -> RigidMotion:
    """Closed-form four-bar kinematics with continuous branch tracking.

    Parameters
    ----------
    ground, crank, coupler, rocker : (case,) m
    motion : input (crank) angle, velocity, acceleration
    branch : (case,) +1 for ``open`` (C on the left of B→D at t = 0), −1 for ``crossed``.
    follow : (index, near), each (case, step), optional
        The coupler's assembly solution at each time, as :func:`follow_branch` takes it (from
        :func:`branch_between` of a motion on a step grid), instead of tracking it along the
        times from ``branch``: for times that are not a sequence of their own.
    """
    g, a, b, c = (np.asarray(x, float)[:, None] for x in (ground, crank, coupler, rocker))
    th2, w2, al2 = motion.angle, motion.velocity, motion.acceleration
    ncase, nstep = th2.shape
    # Every joint's position, velocity, acceleration written in place, component by component,
    # each cos and sin once: the arithmetic (and bits) of the vector expressions
    # a ω2 e⊥2 etc., without a (case, step, 2) temporary per term.
    P, V, Acc = joints = tuple(np.zeros((ncase, nstep, 4, 2)) for _ in range(3))
    c2, s2 = np.cos(th2), np.sin(th2)
    _tip(joints, 1, a, (c2, s2), w2, al2)
    Bx, By = P[:, :, 1, 0], P[:, :, 1, 1]
    P[:, :, 3, 0] = g
    BDx, BDy = g - Bx, 0.0 - By  # D − B, D = (g, 0)
    d = np.hypot(BDx, BDy)
    psi = np.arctan2(BDy, BDx)
    over = ((a == g) & (b == c))[:, 0]
    if over.any():
        d, psi = _over_pivot(th2, a, d, psi, over)
    # Angle at B between B→D and B→C (law of cosines); clipped at the toggle limits.
    with np.errstate(invalid="ignore"):  # 0/0 where a kite's B is on D: β = π/2 there
        cos_beta = np.clip((b * b + d * d - c * c) / (2.0 * b * d), -1.0, 1.0)
    if over.any():
        cos_beta[over[:, None] & (d == 0.0)] = 0.0
    beta = np.arccos(cos_beta)
    candidates = np.stack([psi + beta, psi - beta])  # C left of B→D, C right of B→D
    start = np.where(np.asarray(branch)[:] > 0, 0, 1)
    ordered = np.sort(np.concatenate([g, a, b, c], axis=1), axis=1)
    s_plus_l, p_plus_q = ordered[:, 0] + ordered[:, 3], ordered[:, 1] + ordered[:, 2]
    touching = np.abs(s_plus_l - p_plus_q) <= GRASHOF_RTOL * np.maximum(s_plus_l, p_plus_q)
    if follow is None and touching.any():
        # Change points in closed form; the kites' B over D is not one (``_over_pivot``).
        scale = GRASHOF_RTOL * np.maximum(s_plus_l, p_plus_q)
        choice = np.broadcast_to(start[:, None], th2.shape).copy()
        choice[touching] = through_change_points(
            th2[touching], start[touching],
            (np.abs((g + a) - (b + c))[:, 0] <= scale)[touching],
            ((np.abs(np.abs(g - a) - np.abs(b - c))[:, 0] <= scale) & ~over)[touching])
    else:
        choice = choose_branch(candidates, start, touching, follow)
    th3 = unwrap(pick(candidates, choice))
    c3, s3 = np.cos(th3), np.sin(th3)
    Cx = np.add(Bx, b * c3, out=P[:, :, 2, 0])
    Cy = np.add(By, b * s3, out=P[:, :, 2, 1])
    th4 = unwrap(np.arctan2(Cy - 0.0, Cx - g))
    c4, s4 = np.cos(th4), np.sin(th4)

    # Velocities: a ω2 e⊥2 + b ω3 e⊥3 = c ω4 e⊥4, dotted with e4 and e3 (e⊥i·ej = sin(θj − θi)).
    s34 = np.sin(th3 - th4)
    singular = np.abs(s34) < SINGULAR_SIN
    safe = np.where(singular, 1.0, s34)
    w3 = a * w2 * np.sin(th4 - th2) / (b * safe)
    w4 = a * w2 * np.sin(th3 - th2) / (c * safe)
    w3, w4 = fill_singular(w3, singular), fill_singular(w4, singular)
    # Accelerations: b α3 e⊥3 − c α4 e⊥4 = −R with the known part R = aB − b ω3² e3 + c ω4² e4,
    # aB = a (α2 e⊥2 − ω2² e2) the acceleration of B.
    aBx, aBy = Acc[:, :, 1, 0], Acc[:, :, 1, 1]
    b33, c44 = b * (w3 * w3), c * (w4 * w4)
    Rx = aBx - b33 * c3 + c44 * c4
    Ry = aBy - b33 * s3 + c44 * s4
    # R·e4 and R·e3 summed from +0.0 as numpy's sum over the last axis is (so that the
    # sign of a zero α, at a change point, is that of the vector expression's too).
    al3 = (0.0 + Rx * c4 + Ry * s4) / (b * safe)
    al4 = (0.0 + Rx * c3 + Ry * s3) / (c * safe)
    al3, al4 = fill_singular(al3, singular), fill_singular(al4, singular)

    cw4 = c * w4
    np.multiply(cw4, -s4, out=V[:, :, 2, 0])
    np.multiply(cw4, c4, out=V[:, :, 2, 1])
    w4w4 = w4 * w4
    np.multiply(c, al4 * -s4 - w4w4 * c4, out=Acc[:, :, 2, 0])
    np.multiply(c, al4 * c4 - w4w4 * s4, out=Acc[:, :, 2, 1])
    return RigidMotion(
        topology=topology("four_bar"),
        time=motion.time,
        lengths=np.stack([x[:, 0] for x in (a, b, c)], axis=-1),
        link_angle=np.stack([th2, th3, th4], axis=-1),
        link_angular_velocity=np.stack([w2, w3, w4], axis=-1),
        link_angular_acceleration=np.stack([al2, al3, al4], axis=-1),
        joint_position=P,
        joint_velocity=V,
        joint_acceleration=Acc,
        singular=singular,
        branch={"coupler": choice},
    )


def slider_crank(
    crank: np.ndarray,
    rod: np.ndarray,
    offset: np.ndarray,
    motion: InputMotion,
    branch: np.ndarray,
) -> RigidMotion:
    """Closed-form slider-crank kinematics; the slider C moves on y = ``offset``.

    ``branch`` +1 (``open``) puts the slider on the +x side of B (cos θ_rod > 0), −1 on the −x
    side. Requires crank + |offset| < rod, so the rod never turns vertical.

    Parameters
    ----------
    crank, rod, offset : ndarray, (case,)
        Crank and rod lengths and the guide's signed offset, m.
    motion : InputMotion
        The input link's angle, angular velocity and acceleration over time (rad, rad/s,
        rad/s²).
    branch : ndarray, (case,)
        +1 (``open``) or −1 (``crossed``).

    Returns
    -------
    RigidMotion
        Positions (m), velocities and accelerations of every link, joint and centre of mass.
    """
    a, b, e = (np.asarray(x, float)[:, None] for x in (crank, rod, offset))
    sigma = np.asarray(branch, float)[:, None]
    th2, w2, al2 = motion.angle, motion.velocity, motion.acceleration
    c2, s2 = np.cos(th2), np.sin(th2)
    sin3 = (e - a * s2) / b
    cos3 = sigma * np.sqrt(np.clip(1.0 - sin3**2, 0.0, None))
    th3 = unwrap(np.arctan2(sin3, cos3))
    # a sinθ2 + b sinθ3 = e differentiated once and twice.
    w3 = -a * w2 * c2 / (b * cos3)
    al3 = (a * w2**2 * s2 - a * al2 * c2 + b * w3**2 * sin3) / (b * cos3)
    joints = tuple(np.zeros(th2.shape + (3, 2)) for _ in range(3))
    _tip(joints, 1, a, (c2, s2), w2, al2)
    _tip(joints, 2, b, (np.cos(th3), np.sin(th3)), w3, al3, base=1)
    return RigidMotion(
        topology=topology("slider_crank"),
        time=motion.time,
        lengths=np.stack([a[:, 0], b[:, 0]], axis=-1),
        link_angle=np.stack([th2, th3], axis=-1),
        link_angular_velocity=np.stack([w2, w3], axis=-1),
        link_angular_acceleration=np.stack([al2, al3], axis=-1),
        joint_position=joints[0],
        joint_velocity=joints[1],
        joint_acceleration=joints[2],
        singular=np.zeros(th2.shape, bool),
    )


def single_link(length: np.ndarray, motion: InputMotion) -> RigidMotion:
    """One link driven about the ground pivot A, free tip B.

    Parameters
    ----------
    length : ndarray, (case,)
        Link length, m.
    motion : InputMotion
        The link's angle, angular velocity and acceleration over time (rad, rad/s, rad/s²).

    Returns
    -------
    RigidMotion
        Positions (m), velocities and accelerations of the link, its joints and centre of mass.
    """
    L = np.asarray(length, float)[:, None]
    th, w, al = motion.angle, motion.velocity, motion.acceleration
    joints = tuple(np.zeros(th.shape + (2, 2)) for _ in range(3))
    _tip(joints, 1, L, (np.cos(th), np.sin(th)), w, al)
    return RigidMotion(
        topology=topology("single_link"),
        time=motion.time,
        lengths=L,
        link_angle=th[..., None],
        link_angular_velocity=w[..., None],
        link_angular_acceleration=al[..., None],
        joint_position=joints[0],
        joint_velocity=joints[1],
        joint_acceleration=joints[2],
        singular=np.zeros(th.shape, bool),
    )


def _tip(joints: tuple, tip: int, length: np.ndarray, trig: tuple, w: np.ndarray,
         al: np.ndarray, base: int | None = None) -> None:
    """Write the motion of joint ``tip`` at ``length`` (case, 1) along a link from joint
    ``base`` (None: from the ground pivot at the origin) into ``joints`` (position, velocity,
    acceleration, each (case, step, joint, 2)): base + l e, + l ω e⊥, + l (α e⊥ − ω² e), with
    the link's (cos θ, sin θ) ``trig``, component by component (the bits of the vector
    expressions, a zero's sign included: nothing is added to a tip on the ground pivot)."""
    c, s = trig
    terms = (length * c, length * s), (length * w * -s, length * w * c), (
        length * (al * -s - w * w * c), length * (al * c - w * w * s))
    for out, (x, y) in zip(joints, terms):
        if base is None:
            out[:, :, tip, 0], out[:, :, tip, 1] = x, y
        else:
            np.add(out[:, :, base, 0], x, out=out[:, :, tip, 0])
            np.add(out[:, :, base, 1], y, out=out[:, :, tip, 1])
