"""Rigid inverse dynamics: pin forces, guide force and input torque (thesis II.1–II.2).

Newton–Euler for every moving body, written as one small linear system per (case, step) and
solved batched. Unknowns: the force of every joint (on the body listed second by the body
listed first, docs/theory.md), the slider guide's normal force and reaction moment, the
normal force and couple of every RPR sleeve on its guide bar, and the input torque on the
input link (the thesis sets the crank's moment equation to zero and so loses the driving
torque, II.1 eq. 3; it is computed here).

A point mass at a joint is carried by the body listed second in the joint's name (the coupler
at B, the rocker at C; the slider at C of a slider-crank; the crank at A, where it only adds
its weight to the ground reaction).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .dyads import point_motion
from .kinematics import RigidMotion
from .small_systems import block_order, solve_batch

__all__ = ["BodyProperties", "InverseDynamics", "inverse_dynamics", "kinetic_energy_rate"]


@dataclass(frozen=True)
class BodyProperties:
    """Mass properties of the links of a batch, each (case, link), plus joint point masses.

    ``mass`` kg, ``inertia`` kg m² about the centre of mass, ``point_mass`` (case, joint) kg,
    ``slider_mass`` (case,) kg for one slider block or (case, slider) kg in the order of
    ``Topology.sliders``. ``centre`` (case, link, 2) m is each centre of mass in its link's
    frame (from the first joint, x towards the second); None puts it at mid-length.
    ``sleeve_mass`` kg and ``sleeve_inertia`` kg m² (case, sleeve), in the order of
    ``Topology.sleeves``: each RPR sleeve's mass at its pivot and moment of inertia about it
    (its centre of mass on the pivot); None without sleeves.
    """

    mass: np.ndarray
    inertia: np.ndarray
    point_mass: np.ndarray
    slider_mass: np.ndarray
    centre: np.ndarray | None = None
    sleeve_mass: np.ndarray | None = None
    sleeve_inertia: np.ndarray | None = None


@dataclass(frozen=True)
class InverseDynamics:
    """``joint_force`` (case, step, joint, 2) N; ``input_torque`` (case, step) N m;
    ``guide_force`` (case, step) N, the guide's normal (y) force on the slider (slider-crank);
    ``sleeve_force`` (case, step, sleeve, 2): the normal force (N, along e⊥ of the guide bar)
    and the couple (N m, counter-clockwise) of the guide bar on each RPR sleeve, None without
    sleeves."""

    joint_force: np.ndarray
    input_torque: np.ndarray
    guide_force: np.ndarray | None
    sleeve_force: np.ndarray | None = None


def _centre_motion(motion: RigidMotion, bodies: BodyProperties, i: int) -> tuple:
    """Position, velocity and acceleration of link i's centre of mass, each (case, step, 2)."""
    link = motion.topology.link_names[i]
    if bodies.centre is None:
        half = 0.5 * motion.lengths[:, i]
        return tuple(motion.link_point(link, half, order) for order in range(3))
    k = motion.topology.joint_names.index(motion.topology.links[link][0])
    base = (motion.joint_position[:, :, k], motion.joint_velocity[:, :, k],
            motion.joint_acceleration[:, :, k])
    return point_motion(base, motion.link_angle[:, :, i], motion.link_angular_velocity[:, :, i],
                        motion.link_angular_acceleration[:, :, i], bodies.centre[:, i])


def _slider_masses(motion: RigidMotion, bodies: BodyProperties) -> np.ndarray:
    """(case, slider) kg."""
    mass = np.asarray(bodies.slider_mass, float)
    return mass[:, None] if mass.ndim == 1 else mass


def _carrier(motion: RigidMotion) -> dict[str, str]:
    """Body that carries each joint's point mass: the second body of the joint (the link
    itself at the free tip of a single link)."""
    return {j: b[0] if b[1] == "tip" else b[1] for j, b in motion.topology.joints.items()}


def inverse_dynamics(
    motion: RigidMotion,
    bodies: BodyProperties,
    gravity: np.ndarray = (0.0, 0.0),
    inertia: bool = True,
) -> InverseDynamics:
    """Solve Newton–Euler for all joint forces and the input torque.

    Parameters
    ----------
    motion : rigid motion of the batch
    bodies : mass properties
    gravity : (2,) m/s², or (case, 2)
    inertia : include the d'Alembert forces of the rigid motion (the ``inertia`` effect);
        without them the result is the static force analysis under gravity.
    """
    topo = motion.topology
    links, joints = topo.link_names, topo.joint_names
    ncase, nstep = motion.time.shape
    g = np.broadcast_to(np.asarray(gravity, float), (ncase, 2))[:, None, :]

    # Moving bodies with three equations each: the links, the slider blocks, the sleeves.
    sliders, sleeves = list(topo.sliders), list(topo.sleeves)
    body_names = links + sliders + sleeves
    nb = len(body_names)
    joint_unknowns = [j for j in joints if topo.joints[j][1] != "tip"]
    nunk = 2 * len(joint_unknowns) + 1 + 2 * len(sliders) + 2 * len(sleeves)
    assert nunk == 3 * nb, "mechanism is not statically determinate"

    # d'Alembert right-hand side per body: Σ F = m (a − g), Σ M_G = I α (+ point masses).
    rhs = np.zeros((ncase, nstep, nb, 3))
    centre = np.zeros((ncase, nstep, nb, 2))
    for i, link in enumerate(links):
        centre[:, :, i], _, acc = _centre_motion(motion, bodies, i)
        m = bodies.mass[:, i][:, None, None]
        rhs[:, :, i, :2] = m * (inertia * acc - g)
        rhs[:, :, i, 2] = (
            inertia * bodies.inertia[:, i][:, None] * motion.link_angular_acceleration[:, :, i])
    slider_mass = _slider_masses(motion, bodies)
    for k, slider in enumerate(sliders):
        i, js = len(links) + k, joints.index(topo.sliders[slider])
        centre[:, :, i] = motion.joint_position[:, :, js]
        rhs[:, :, i, :2] = slider_mass[:, k][:, None, None] * (
            inertia * motion.joint_acceleration[:, :, js] - g
        )
    for k, sleeve in enumerate(sleeves):  # centre of mass on the pivot, turning with the bar
        pivot, bar = topo.sleeves[sleeve]
        i, js = len(links) + len(sliders) + k, joints.index(pivot)
        centre[:, :, i] = motion.joint_position[:, :, js]
        rhs[:, :, i, :2] = bodies.sleeve_mass[:, k][:, None, None] * (
            inertia * motion.joint_acceleration[:, :, js] - g)
        rhs[:, :, i, 2] = inertia * bodies.sleeve_inertia[:, k][:, None] * (
            motion.link_angular_acceleration[:, :, links.index(bar)])
    carrier = _carrier(motion)
    for k, joint in enumerate(joints):
        body = carrier[joint]
        if body not in body_names:
            continue
        i = body_names.index(body)
        mp = bodies.point_mass[:, k][:, None, None]
        force = mp * (inertia * motion.joint_acceleration[:, :, k] - g)
        rhs[:, :, i, :2] += force
        arm = motion.joint_position[:, :, k] - centre[:, :, i]
        rhs[:, :, i, 2] += arm[..., 0] * force[..., 1] - arm[..., 1] * force[..., 0]
    # Coefficient matrix: rows (body, equation), columns the unknowns.
    A = np.zeros((ncase, nstep, 3 * nb, nunk))
    for u, joint in enumerate(joint_unknowns):
        first, second = topo.joints[joint]
        k = joints.index(joint)
        for body, sign in ((first, -1.0), (second, 1.0)):
            if body not in body_names:
                continue
            _put_force(A, 3 * body_names.index(body), 2 * u, sign,
                       motion.joint_position[:, :, k] - centre[:, :, body_names.index(body)])
    col = 2 * len(joint_unknowns)
    A[:, :, 3 * body_names.index(topo.input_link) + 2, col] = 1.0  # input torque
    for k, slider in enumerate(sliders):
        i, c = len(links) + k, col + 1 + 2 * k
        if motion.guide_angle is not None:  # guide normal (−sin φ, cos φ)
            phi = motion.guide_angle[slider][:, None]
            A[:, :, 3 * i, c] = -np.sin(phi)
            A[:, :, 3 * i + 1, c] = np.cos(phi)
        else:
            A[:, :, 3 * i + 1, c] = 1.0  # guide parallel to x: normal force along y
        A[:, :, 3 * i + 2, c + 1] = 1.0  # guide reaction moment
    first_sleeve = col + 1 + 2 * len(sliders)
    for k, sleeve in enumerate(sleeves):
        _sleeve_columns(A, motion, topo, body_names, centre, sleeve, first_sleeve + 2 * k)
    x = _solve_regular(A, rhs.reshape(ncase, nstep, 3 * nb), motion.singular)

    force = np.zeros((ncase, nstep, len(joints), 2))
    for u, joint in enumerate(joint_unknowns):
        force[:, :, joints.index(joint)] = x[..., 2 * u : 2 * u + 2]
    sleeve_force = None
    if sleeves:
        sleeve_force = x[..., first_sleeve:].reshape(ncase, nstep, len(sleeves), 2)
    return InverseDynamics(
        joint_force=force,
        input_torque=x[..., col],
        guide_force=x[..., col + 1] if sliders else None,
        sleeve_force=sleeve_force,
    )


def _put_force(A: np.ndarray, row: int, column: int, sign: float, arm: np.ndarray,
               direction: np.ndarray | None = None) -> None:
    """Enter an unknown force in a body's three equations: a 2-vector unknown in columns
    ``column, column + 1`` (``direction`` None), or a scalar along ``direction``
    (case, step, 2) in ``column``; ``arm`` (case, step, 2) from the body's centre to the
    point of application, for the moment equation (arm × F)."""
    if direction is None:
        A[:, :, row, column] = sign
        A[:, :, row + 1, column + 1] = sign
        A[:, :, row + 2, column] = -sign * arm[..., 1]
        A[:, :, row + 2, column + 1] = sign * arm[..., 0]
        return
    A[:, :, row, column] = sign * direction[..., 0]
    A[:, :, row + 1, column] = sign * direction[..., 1]
    A[:, :, row + 2, column] = sign * (arm[..., 0] * direction[..., 1]
                                       - arm[..., 1] * direction[..., 0])


def _sleeve_columns(A, motion: RigidMotion, topo, body_names, centre, sleeve: str,
                    column: int) -> None:
    """The normal force N (along the bar's e⊥) and couple C of a guide bar on its sleeve:
    +N, +C on the sleeve, −N, −C on the bar, N acting at the sleeve's point of the bar's
    line, M = P + s e (a frictionless slide transmits no force along the bar)."""
    pivot, bar = topo.sleeves[sleeve]
    i = topo.link_names.index(bar)
    th = motion.link_angle[:, :, i]
    e = np.stack([np.cos(th), np.sin(th)], axis=-1)
    n = np.stack([-np.sin(th), np.cos(th)], axis=-1)
    P = motion.joint_position[:, :, topo.joint_names.index(topo.links[bar][0])]
    M = P + motion.slide[sleeve][0][..., None] * e
    for body, sign in ((sleeve, 1.0), (bar, -1.0)):
        b = body_names.index(body)
        _put_force(A, 3 * b, column, sign, M - centre[:, :, b], n)
        A[:, :, 3 * b + 2, column + 1] = sign
#: Hadamard ratio |det A| / Π‖rowᵢ‖ of the Newton–Euler matrix (1 for orthogonal rows, 0 when
#: singular) below which a step counts as singular; an LU, far cheaper than a condition number.
SINGULAR_RATIO = 1e-12


def _solve_regular(A: np.ndarray, b: np.ndarray, singular: np.ndarray) -> np.ndarray:
    """Solve A x = b per (case, step); at singular steps interpolate x in time.

    At a change point or dead centre the rigid linkage is statically indeterminate (the
    Newton–Euler matrix is singular) and the interpolated kinematics there are not exactly
    consistent, so a direct solve gives no answer or an absurd one (~1e17 N m). Forces are
    continuous through the configuration on the smooth branch, so they are interpolated from
    the regular neighbours, as the velocities are (:mod:`ced.rigid.kinematics`).
    """
    # One compiled LU gives the solution and |det A|, of the diagonal blocks only: the bodies
    # of a dyad and its joints' forces form one block, solved from the last dyad back to the
    # input (a Watt II's 15 unknowns as 6, 6 and 3). The pattern holds every entry nonzero
    # at some step, so that the blocks hold at all of them.
    x, ratio = solve_batch(A, b, block_order((A != 0).any(axis=(0, 1))))
    bad = np.asarray(singular, bool) | ~(ratio > SINGULAR_RATIO)
    good = ~bad
    x[bad] = 0.0
    if bad.any():
        steps = np.arange(b.shape[1])
        for c in np.flatnonzero(bad.any(axis=1)):
            ok = good[c]
            if ok.sum() < 2:
                continue  # no regular step to learn from: leave zero (flagged upstream)
            for k in range(b.shape[2]):
                x[c, ~ok, k] = np.interp(steps[~ok], steps[ok], x[c, ok, k])
    return x


def kinetic_energy_rate(motion: RigidMotion, bodies: BodyProperties, gravity=(0.0, 0.0)):
    """dT/dt + dV/dt of the whole mechanism, W: Σ m v·(a − g) + I ω α over bodies and masses.

    Used to check the power balance P_input = input_torque × ω_input.

    Parameters
    ----------
    motion : RigidMotion
        The rigid motion (:mod:`ced.rigid.kinematics`).
    bodies : BodyProperties
        Masses (kg) and moments of inertia (kg m²) of links and point masses.
    gravity : (2,) sequence of float
        Gravity vector, m/s².

    Returns
    -------
    ndarray, (case, step)
        The rate of change of kinetic plus potential energy, W.
    """
    topo = motion.topology
    ncase = motion.time.shape[0]
    g = np.broadcast_to(np.asarray(gravity, float), (ncase, 2))[:, None, :]
    rate = np.zeros(motion.time.shape)
    for i, link in enumerate(topo.link_names):
        _, v, a = _centre_motion(motion, bodies, i)
        rate += bodies.mass[:, i][:, None] * np.sum(v * (a - g), axis=-1)
        rate += (
            bodies.inertia[:, i][:, None]
            * motion.link_angular_velocity[:, :, i]
            * motion.link_angular_acceleration[:, :, i]
        )
    for k, _ in enumerate(topo.joint_names):
        v, a = motion.joint_velocity[:, :, k], motion.joint_acceleration[:, :, k]
        rate += bodies.point_mass[:, k][:, None] * np.sum(v * (a - g), axis=-1)
    slider_mass = _slider_masses(motion, bodies)
    for s, slider in enumerate(topo.sliders):
        k = topo.joint_names.index(topo.sliders[slider])
        v, a = motion.joint_velocity[:, :, k], motion.joint_acceleration[:, :, k]
        rate += slider_mass[:, s][:, None] * np.sum(v * (a - g), axis=-1)
    for s, (pivot, bar) in enumerate(topo.sleeves.values()):
        k, i = topo.joint_names.index(pivot), topo.link_names.index(bar)
        v, a = motion.joint_velocity[:, :, k], motion.joint_acceleration[:, :, k]
        rate += bodies.sleeve_mass[:, s][:, None] * np.sum(v * (a - g), axis=-1)
        rate += (bodies.sleeve_inertia[:, s][:, None] * motion.link_angular_velocity[:, :, i]
                 * motion.link_angular_acceleration[:, :, i])
    return rate
