"""Rigid inverse dynamics: pin forces, guide force and input torque (thesis II.1–II.2).

Newton–Euler for every moving body, written as one small linear system per (case, step) and
solved batched. Unknowns: the force of every joint (on the body listed second by the body
listed first, docs/theory.md), the slider guide's normal force and reaction moment, the
normal force and couple of every RPR sleeve on its guide bar, and the input torque on the
input link (the thesis sets the crank's moment equation to zero and so loses the driving
torque, II.1 eq. 3; it is computed here).

The systems are assembled and solved step by step in a compiled loop (:func:`_solve_compiled`)
from the motion and tables of their entries, with the arithmetic of the numpy assembly
(:func:`_system`, kept as the reference and used with ``CED_KERNEL=numpy``) operation for
operation: the same bits, without the (case, step, n, n) matrices and the temporaries of every
body's centre and load (11 ms instead of 32 for 22 cases × 1025 steps of the reference
four-bar, measured).

A point mass at a joint is carried by the body listed second in the joint's name (the coupler
at B, the rocker at C; the slider at C of a slider-crank; the crank at A, where it only adds
its weight to the ground reaction).
"""
from __future__ import annotations

import functools
import os
from dataclasses import dataclass

import numba as nb
import numpy as np

from .dyads import point_motion
from .kinematics import RigidMotion
from .small_systems import block_order, lu_only, solve_batch, solve_blocks

__all__ = ["BodyProperties", "InverseDynamics", "inverse_dynamics", "kinetic_energy_rate",
           "Solutions", "solutions", "forces_at"]


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
    ncase = motion.time.shape[0]
    g = np.broadcast_to(np.asarray(gravity, float), (ncase, 2))[:, None, :]
    unknowns = _Unknowns(topo)
    if COMPILED:
        x, ratio = _solve_compiled(motion, bodies, g[:, 0], inertia, unknowns)
    else:
        A, rhs = _system(motion, bodies, g, inertia, unknowns)
        # One compiled LU gives the solution and |det A|, of the diagonal blocks only: the
        # bodies of a dyad and its joints' forces form one block, solved from the last dyad
        # back to the input (a Watt II's 15 unknowns as 6, 6 and 3). The pattern holds every
        # entry nonzero at some step, so that the blocks hold at all of them.
        pattern = (A != 0).any(axis=(0, 1))
        x, ratio = solve_batch(A, rhs, _with_dyads(pattern, block_order(pattern)))
    return _forces(motion, unknowns, _regular(x, ratio, motion.singular))


@dataclass(frozen=True)
class Solutions:
    """The Newton–Euler systems of a motion solved by the compiled path, kept so that the
    forces at some of its steps are read instead of solved again
    (:meth:`ced.response.batch.Batch.rigid_forces`): the systems' tables (``data``, as
    :func:`_solve_compiled` makes them), their block order, and the solutions x
    (case, step, unknown) with their Hadamard ratios (case, step), before the singular
    steps are interpolated."""

    data: tuple
    inertia: float
    written: int
    blocks: tuple
    x: np.ndarray
    ratio: np.ndarray


def solutions(motion: RigidMotion, bodies: BodyProperties, gravity: np.ndarray,
              inertia: bool = True) -> Solutions:
    """The Newton–Euler systems of every step of ``motion`` solved and kept
    (:class:`Solutions`; the compiled path of :func:`inverse_dynamics`).

    Parameters
    ----------
    motion, bodies, inertia
        As for :func:`inverse_dynamics`.
    gravity : numpy.ndarray
        Gravity per case, m/s², shape (case, 2).
    """
    unknowns = _Unknowns(motion.topology)
    data, written = _tables(motion, bodies, np.asarray(gravity, float), unknowns)
    blocks = _blocks(data, float(inertia), 3 * len(unknowns.bodies), written)
    x, ratio = _solutions(data, float(inertia), blocks)
    return Solutions(data, float(inertia), written, blocks, x, ratio)


def forces_at(kept: Solutions, motion: RigidMotion, steps: np.ndarray
              ) -> InverseDynamics | None:
    """The forces at ``steps`` of the motion ``kept`` was solved on, read from it: those
    :func:`inverse_dynamics` gives for ``motion`` (the motion at those steps), the same bits,
    or None where its systems there would fall into other blocks (an entry zero at every one
    of those steps), to be solved as usual.

    Parameters
    ----------
    kept : Solutions
        The systems of the motion's steps 0 … k (:func:`solutions`).
    motion : RigidMotion
        The motion at ``steps`` (:func:`ced.rigid.kinematics.at_steps`).
    steps : numpy.ndarray
        Steps of the kept motion, int, shape (step,).
    """
    blocks = _blocks(kept.data, kept.inertia, kept.x.shape[-1], kept.written, steps)
    if not all(np.array_equal(a, b) for a, b in zip(blocks, kept.blocks)):
        return None
    return _forces(motion, _Unknowns(motion.topology),
                   _regular(kept.x[:, steps], kept.ratio[:, steps], motion.singular))


def _forces(motion: RigidMotion, unknowns: "_Unknowns", x: np.ndarray) -> InverseDynamics:
    """The :class:`InverseDynamics` of the solutions x (case, step, unknown)."""
    joints = motion.topology.joint_names
    ncase, nstep = x.shape[:2]
    force = np.zeros((ncase, nstep, len(joints), 2))
    for u, joint in enumerate(unknowns.joints):
        force[:, :, joints.index(joint)] = x[..., 2 * u : 2 * u + 2]
    sleeve_force = None
    if unknowns.sleeves:
        sleeve_force = x[..., unknowns.first_sleeve:].reshape(
            ncase, nstep, len(unknowns.sleeves), 2)
    return InverseDynamics(
        joint_force=force,
        input_torque=x[..., unknowns.torque],
        guide_force=x[..., unknowns.torque + 1] if unknowns.sliders else None,
        sleeve_force=sleeve_force,
    )


class _Unknowns:
    """The bodies (three equations each: the links, the slider blocks, the sleeves) and the
    columns of the unknowns: two per joint force, the input torque, two per slider (guide
    normal force, reaction moment), two per sleeve (normal force, couple)."""

    def __init__(self, topo):
        self.sliders, self.sleeves = list(topo.sliders), list(topo.sleeves)
        self.bodies = topo.link_names + self.sliders + self.sleeves
        self.joints = [j for j in topo.joint_names if topo.joints[j][1] != "tip"]
        self.torque = 2 * len(self.joints)
        self.first_sleeve = self.torque + 1 + 2 * len(self.sliders)
        n = self.first_sleeve + 2 * len(self.sleeves)
        assert n == 3 * len(self.bodies), "mechanism is not statically determinate"


def _system(motion: RigidMotion, bodies: BodyProperties, g: np.ndarray, inertia: bool,
            unknowns: _Unknowns) -> tuple[np.ndarray, np.ndarray]:
    """The Newton–Euler matrix (case, step, 3 body, unknown) and right-hand side
    (case, step, 3 body) by numpy (``CED_KERNEL=numpy``; the reference of
    :func:`_solve_compiled`)."""
    topo = motion.topology
    links, joints = topo.link_names, topo.joint_names
    ncase, nstep = motion.time.shape
    sliders, sleeves, body_names = unknowns.sliders, unknowns.sleeves, unknowns.bodies
    nb = len(body_names)

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
    A = np.zeros((ncase, nstep, 3 * nb, 3 * nb))
    for u, joint in enumerate(unknowns.joints):
        first, second = topo.joints[joint]
        k = joints.index(joint)
        for body, sign in ((first, -1.0), (second, 1.0)):
            if body not in body_names:
                continue
            _put_force(A, 3 * body_names.index(body), 2 * u, sign,
                       motion.joint_position[:, :, k] - centre[:, :, body_names.index(body)])
    for (row, column), value in zip(*_constant_entries(motion, unknowns)):
        A[:, :, row, column] = value[:, None]
    for k, sleeve in enumerate(sleeves):
        M, n = _sleeve_line(motion, sleeve)
        for body, sign in ((sleeve, 1.0), (topo.sleeves[sleeve][1], -1.0)):
            b = body_names.index(body)
            _put_force(A, 3 * b, unknowns.first_sleeve + 2 * k, sign, M - centre[:, :, b], n)
    return A, rhs.reshape(ncase, nstep, 3 * nb)


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


def _sleeve_line(motion: RigidMotion, sleeve: str) -> tuple[np.ndarray, np.ndarray]:
    """Where and along what a guide bar pushes its sleeve, each (case, step, 2): the normal
    force N (along the bar's e⊥) acts at the sleeve's point of the bar's line, M = P + s e
    (a frictionless slide transmits no force along the bar); +N and the couple +C on the
    sleeve, −N, −C on the bar."""
    topo = motion.topology
    pivot, bar = topo.sleeves[sleeve]
    th = motion.link_angle[:, :, topo.link_names.index(bar)]
    e = np.stack([np.cos(th), np.sin(th)], axis=-1)
    n = np.stack([-np.sin(th), np.cos(th)], axis=-1)
    P = motion.joint_position[:, :, topo.joint_names.index(topo.links[bar][0])]
    return P + motion.slide[sleeve][0][..., None] * e, n


def _constant_entries(motion: RigidMotion, unknowns: _Unknowns
                      ) -> tuple[list[tuple[int, int]], list[np.ndarray]]:
    """The entries of the Newton–Euler matrix that do not change with time, (row, column)
    and their values (case,): the input torque, each slider's guide normal force and
    reaction moment, each sleeve's couple."""
    topo, bodies = motion.topology, unknowns.bodies
    ncase = motion.time.shape[0]
    one = np.ones(ncase)
    at = [(3 * bodies.index(topo.input_link) + 2, unknowns.torque)]
    value = [one]
    for slider in unknowns.sliders:
        i, c = bodies.index(slider), unknowns.torque + 1 + 2 * unknowns.sliders.index(slider)
        if motion.guide_angle is not None:  # guide normal (−sin φ, cos φ)
            phi = np.asarray(motion.guide_angle[slider], float)
            at += [(3 * i, c), (3 * i + 1, c)]
            value += [-np.sin(phi), np.cos(phi)]
        else:
            at.append((3 * i + 1, c))  # guide parallel to x: normal force along y
            value.append(one)
        at.append((3 * i + 2, c + 1))  # guide reaction moment
        value.append(one)
    for k, sleeve in enumerate(unknowns.sleeves):
        for body, sign in ((sleeve, 1.0), (topo.sleeves[sleeve][1], -1.0)):
            at.append((3 * bodies.index(body) + 2, unknowns.first_sleeve + 2 * k + 1))
            value.append(sign * one)
    return at, value


#: Hadamard ratio |det A| / Π‖rowᵢ‖ of the Newton–Euler matrix (1 for orthogonal rows, 0 when
#: singular) below which a step counts as singular; an LU, far cheaper than a condition number.
SINGULAR_RATIO = 1e-12

#: Assemble and solve the Newton–Euler systems in the compiled loop (:func:`_solve_compiled`);
#: ``CED_KERNEL=numpy`` assembles them with numpy (:func:`_system`), the reference it is
#: tested against (the same bits).
COMPILED = os.environ.get("CED_KERNEL", "numba") != "numpy"

# No fastmath: the assembly rounds as the numpy of _system does (no contracted multiply-adds),
# so that the systems, and hence the solutions from the same LU, are the same bits.
_JIT = dict(cache=True, nogil=True)
#: Steps assembled per call of the LU (:func:`ced.rigid.small_systems.solve_blocks`): their
#: matrices stay in the L2 cache (64 × 15² doubles for a six-bar, 115 kB).
_CHUNK = 64


def _regular(x: np.ndarray, ratio: np.ndarray, singular: np.ndarray) -> np.ndarray:
    """The solutions x (case, step, unknown) with those of singular steps interpolated in time.

    At a change point or dead centre the rigid linkage is statically indeterminate (the
    Newton–Euler matrix is singular) and the interpolated kinematics there are not exactly
    consistent, so a direct solve gives no answer or an absurd one (~1e17 N m). Forces are
    continuous through the configuration on the smooth branch, so they are interpolated from
    the regular neighbours, as the velocities are (:mod:`ced.rigid.kinematics`).
    """
    bad = np.asarray(singular, bool) | ~(ratio > SINGULAR_RATIO)
    good = ~bad
    x[bad] = 0.0
    if bad.any():
        steps = np.arange(x.shape[1])
        for c in np.flatnonzero(bad.any(axis=1)):
            ok = good[c]
            if ok.sum() < 2:
                continue  # no regular step to learn from: leave zero (flagged upstream)
            for k in range(x.shape[2]):
                x[c, ~ok, k] = np.interp(steps[~ok], steps[ok], x[c, ok, k])
    return x


def _solve_compiled(motion: RigidMotion, bodies: BodyProperties, g: np.ndarray,
                    inertia: bool, unknowns: _Unknowns) -> tuple[np.ndarray, np.ndarray]:
    """Solutions (case, step, unknown) and Hadamard ratios (case, step) of the Newton–Euler
    systems of :func:`_system`, assembled step by step in a compiled loop from the motion
    and tables of the entries: no (case, step, n, n) array, no temporaries per body."""
    data, written = _tables(motion, bodies, g, unknowns)
    return _solutions(data, float(inertia),
                      _blocks(data, float(inertia), 3 * len(unknowns.bodies), written))


def _tables(motion: RigidMotion, bodies: BodyProperties, g: np.ndarray,
            unknowns: _Unknowns) -> tuple[tuple, int]:
    """The motion and tables :func:`_assemble` reads (``data``), and how many entries of a
    system it writes."""
    topo = motion.topology
    links, joints = topo.link_names, topo.joint_names
    names = unknowns.bodies
    ncase, nstep = motion.time.shape
    nlink, nb = len(links), len(names)
    # Per body: how its centre moves (0 mid-length of its link, 1 a point of its link's frame,
    # 2 on a joint), that joint (the link's first), its link and the link whose α it takes.
    table = np.full((nb, 4), -1, np.int64)
    local = np.zeros((ncase, nb, 2))
    mass = np.zeros((ncase, nb))
    turning = np.zeros((ncase, nb))
    for i, link in enumerate(links):
        table[i] = (0 if bodies.centre is None else 1, joints.index(topo.links[link][0]), i, i)
        if bodies.centre is None:
            local[:, i, 0] = 0.5 * motion.lengths[:, i]
        else:
            local[:, i] = bodies.centre[:, i]
    mass[:, :nlink], turning[:, :nlink] = bodies.mass, bodies.inertia
    for k, slider in enumerate(unknowns.sliders):
        table[nlink + k, :2] = (2, joints.index(topo.sliders[slider]))
        mass[:, nlink + k] = _slider_masses(motion, bodies)[:, k]
    for k, sleeve in enumerate(unknowns.sleeves):
        i, (pivot, bar) = names.index(sleeve), topo.sleeves[sleeve]
        table[i, :2], table[i, 3] = (2, joints.index(pivot)), links.index(bar)
        mass[:, i], turning[:, i] = bodies.sleeve_mass[:, k], bodies.sleeve_inertia[:, k]
    carrier = _carrier(motion)
    carried = np.array([names.index(carrier[j]) if carrier[j] in names else -1
                        for j in joints], np.int64)
    # The force unknowns: (body, column, sign, 0 joint / 1 sleeve, which), as _put_force.
    forces = []
    for u, joint in enumerate(unknowns.joints):
        for body, sign in zip(topo.joints[joint], (-1, 1)):
            if body in names:
                forces.append((names.index(body), 2 * u, sign, 0, joints.index(joint)))
    line = np.empty((ncase, nstep, len(unknowns.sleeves), 4))
    for k, sleeve in enumerate(unknowns.sleeves):
        line[:, :, k, :2], line[:, :, k, 2:] = _sleeve_line(motion, sleeve)
        for body, sign in ((sleeve, 1), (topo.sleeves[sleeve][1], -1)):
            forces.append((names.index(body), unknowns.first_sleeve + 2 * k, sign, 1, k))
    at, value = _constant_entries(motion, unknowns)
    angle = motion.link_angle
    data = tuple(np.require(a, float, ("C", "W")) for a in (  # one signature, compiled once
        motion.joint_position, motion.joint_acceleration, np.cos(angle), np.sin(angle),
        motion.link_angular_velocity, motion.link_angular_acceleration, line, local, mass,
        turning, bodies.point_mass, g, np.stack(value, axis=-1)))
    data += (table, carried, np.array(forces, np.int64).reshape(-1, 5),
             np.array(at, np.int64).reshape(-1, 2))
    # The entries _assemble writes: (row, column) offsets of a joint force's, a sleeve's.
    offsets = (((0, 0), (1, 1), (2, 0), (2, 1)), ((0, 0), (1, 0), (2, 0)))
    written = {(3 * i + r, col + q) for i, col, _, kind, _ in forces for r, q in offsets[kind]}
    return data, len(written | set(at))


def _blocks(data: tuple, inertia: float, n: int, written: int,
            steps: np.ndarray | None = None) -> tuple:
    """The :func:`ced.rigid.small_systems.block_order` of the systems of ``data`` (at
    ``steps``, default all), or one dense block where they are structurally singular."""
    steps = np.arange(data[0].shape[1], dtype=np.int64) if steps is None else steps
    pattern = _pattern(data, inertia, n, written, steps.astype(np.int64))
    blocks = block_order(pattern)
    if blocks is None:  # structurally singular: one dense LU (as solve_batch)
        whole = np.arange(n, dtype=np.int64)
        blocks = (whole, whole, np.array([0, n], np.int64))
    return _with_dyads(pattern, blocks)


def _with_dyads(pattern: np.ndarray, blocks: tuple | None) -> tuple | None:
    """``blocks`` (a :func:`ced.rigid.small_systems.block_order` of the Newton–Euler
    ``pattern``) with the ``dyads`` table of :func:`ced.rigid.small_systems.solve_blocks`:
    the blocks of two links' equations in three joint forces (an RRR dyad's), solved in
    closed form, the others by LU."""
    if blocks is None:
        return None
    rows, cols, starts = blocks
    # Kept by pattern and order: every terms evaluation checks its steps' blocks again.
    table = _dyad_table(len(pattern), np.asarray(pattern, bool).tobytes(), rows.tobytes(),
                        cols.tobytes(), starts.tobytes())
    return rows, cols, starts, table.copy()  # writable: one signature of the kernels


@functools.lru_cache(maxsize=32)
def _dyad_table(n: int, pattern: bytes, rows: bytes, cols: bytes, starts: bytes) -> np.ndarray:
    """The ``dyads`` table of :func:`_with_dyads` from the bytes of its arrays."""
    pattern = np.frombuffer(pattern, bool).reshape(n, n)
    rows, cols, starts = (np.frombuffer(x, np.int64) for x in (rows, cols, starts))
    table = lu_only(starts)
    for k in range(len(starts) - 1):
        found = _dyad_block(pattern, rows[starts[k]:starts[k + 1]],
                            cols[starts[k]:starts[k + 1]])
        if found is not None:
            table[k] = found
    return table


def _dyad_block(pattern: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> tuple | None:
    """(first row of body a, of body b, x column of the force on a alone, of the shared
    force, of the force on b alone) where the block ``rows`` × ``cols`` of the pattern is a
    dyad's (:func:`ced.rigid.small_systems.solve_blocks`), else None.

    It is when its rows are two bodies' (x, y, moment) equations and its columns three joint
    forces (x, y), each x (y) force row holding the x (y) components of two of them, one of
    which the other body's x (y) row holds too, and each moment row none of the other body's
    own force. The force rows' entries are the unit signs of the joint forces (``_assemble``),
    the pivots the closed form divides by."""
    bodies = sorted({int(r) // 3 for r in rows})
    pairs = sorted({int(c) // 2 for c in cols})
    if (len(rows) != 6 or len(bodies) != 2 or len(pairs) != 3
            or sorted(rows) != [3 * i + d for i in bodies for d in range(3)]
            or sorted(cols) != [2 * u + d for u in pairs for d in range(2)]):
        return None
    inside = lambda r: {int(c) for c in cols if pattern[r, c]}  # noqa: E731
    held = [{c // 2 for c in inside(3 * i)} for i in bodies]
    if any(len(h) != 2 for h in held) or len(held[0] & held[1]) != 1:
        return None
    (shared,) = held[0] & held[1]
    (alone_a,), (alone_b,) = held[0] - {shared}, held[1] - {shared}
    for i, own, other in ((bodies[0], alone_a, alone_b), (bodies[1], alone_b, alone_a)):
        x_cols, y_cols = {2 * own, 2 * shared}, {2 * own + 1, 2 * shared + 1}
        if (inside(3 * i) != x_cols or inside(3 * i + 1) != y_cols
                or inside(3 * i + 2) & {2 * other, 2 * other + 1}):
            return None
    return 3 * bodies[0], 3 * bodies[1], 2 * alone_a, 2 * shared, 2 * alone_b


def _solutions(data: tuple, inertia: float, blocks: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Solutions (case, step, unknown) and Hadamard ratios (case, step) of the systems of
    ``data`` by :func:`_solve`."""
    ncase, nstep = data[0].shape[:2]
    n = len(blocks[0])
    x = np.empty((ncase, nstep, n))
    ratio = np.empty((ncase, nstep))
    _solve(data, inertia, *blocks, x, ratio)
    return x, ratio


@nb.njit(inline="always", **_JIT)
def _assemble(data, inertia, c, s, centre, A, b):
    """The Newton–Euler system of case c at step s into A (n, n) and b (n,), with the
    arithmetic of :func:`_system` operation for operation. Every call writes the same
    entries of A (those of the tables ``forces`` and ``at``): the others must be zero on
    entry. ``centre`` (body, 2) is scratch."""
    (P, Pa, cos, sin, w, al, line, local, mass, turning, point, g, value, table, carried,
     forces, at) = data
    gx, gy = g[c, 0], g[c, 1]
    for i in range(table.shape[0]):
        kind, j, link, turn = table[i, 0], table[i, 1], table[i, 2], table[i, 3]
        if kind == 2:  # a slider block or a sleeve: on its joint
            centre[i, 0], centre[i, 1] = P[c, s, j, 0], P[c, s, j, 1]
            ax, ay = Pa[c, s, j, 0], Pa[c, s, j, 1]
        else:
            co, si, ww, aa = cos[c, s, link], sin[c, s, link], w[c, s, link], al[c, s, link]
            x, y = local[c, i, 0], local[c, i, 1]
            if kind == 0:  # RigidMotion.link_point at x along the link
                centre[i, 0], centre[i, 1] = P[c, s, j, 0] + x * co, P[c, s, j, 1] + x * si
                ax = Pa[c, s, j, 0] + x * (aa * -si - ww * ww * co)
                ay = Pa[c, s, j, 1] + x * (aa * co - ww * ww * si)
            else:  # dyads.point_motion of (x, y) in the link's frame
                rx, ry = x * co + y * -si, x * si + y * co
                centre[i, 0], centre[i, 1] = P[c, s, j, 0] + rx, P[c, s, j, 1] + ry
                ax = Pa[c, s, j, 0] + aa * -ry - ww * ww * rx
                ay = Pa[c, s, j, 1] + aa * rx - ww * ww * ry
        b[3 * i] = mass[c, i] * (inertia * ax - gx)
        b[3 * i + 1] = mass[c, i] * (inertia * ay - gy)
        b[3 * i + 2] = inertia * turning[c, i] * al[c, s, turn] if turn >= 0 else 0.0
    for k in range(carried.shape[0]):  # point masses, on the body that carries them
        i = carried[k]
        if i < 0:
            continue
        fx = point[c, k] * (inertia * Pa[c, s, k, 0] - gx)
        fy = point[c, k] * (inertia * Pa[c, s, k, 1] - gy)
        b[3 * i] += fx
        b[3 * i + 1] += fy
        b[3 * i + 2] += (P[c, s, k, 0] - centre[i, 0]) * fy - (P[c, s, k, 1] - centre[i, 1]) * fx
    for f in range(forces.shape[0]):
        i, col, sign, k = forces[f, 0], forces[f, 1], float(forces[f, 2]), forces[f, 4]
        r = 3 * i
        if forces[f, 3] == 0:  # a joint force, 2 unknowns
            A[r, col] = sign
            A[r + 1, col + 1] = sign
            A[r + 2, col] = -sign * (P[c, s, k, 1] - centre[i, 1])
            A[r + 2, col + 1] = sign * (P[c, s, k, 0] - centre[i, 0])
        else:  # a sleeve's normal force along the bar's e⊥ at M
            nx, ny = line[c, s, k, 2], line[c, s, k, 3]
            A[r, col] = sign * nx
            A[r + 1, col] = sign * ny
            A[r + 2, col] = sign * ((line[c, s, k, 0] - centre[i, 0]) * ny
                                    - (line[c, s, k, 1] - centre[i, 1]) * nx)
    for e in range(at.shape[0]):
        A[at[e, 0], at[e, 1]] = value[c, e]


@nb.njit(**_JIT)
def _pattern(data, inertia, n, written, steps):
    """Which entries of the Newton–Euler matrices are nonzero at some case and one of
    ``steps``, (n, n), as ``(A != 0).any(axis=(0, 1))``; the scan stops once all the
    ``written`` entries the assembly writes are (at the first step, unless an arm is zero
    there)."""
    ncase = data[0].shape[0]
    pattern = np.zeros((n, n), np.bool_)
    A, b = np.empty((n, n)), np.empty(n)
    centre = np.empty((n // 3, 2))
    found = 0
    for c in range(ncase):
        for s in steps:
            A[:] = 0.0
            _assemble(data, inertia, c, s, centre, A, b)
            for i in range(n):
                for j in range(n):
                    if A[i, j] != 0.0 and not pattern[i, j]:
                        pattern[i, j] = True
                        found += 1
            if found == written:
                return pattern
    return pattern


@nb.njit(**_JIT)
def _solve(data, inertia, rows, cols, starts, dyads, x, ratio):
    """Assemble and solve, :data:`_CHUNK` steps at a time, every (case, step) system."""
    ncase, nstep, n = x.shape
    centre = np.empty((n // 3, 2))
    # Zeroed once: every step writes the same entries (the tables'), the others stay zero.
    # A chunk of the full size and one for the steps left over, so that solve_blocks is
    # always called on whole C-contiguous arrays (one signature).
    full = (np.zeros((_CHUNK, n, n)), np.empty((_CHUNK, n)), np.empty((_CHUNK, n)),
            np.empty(_CHUNK))
    left = nstep % _CHUNK
    tail = (np.zeros((left, n, n)), np.empty((left, n)), np.empty((left, n)), np.empty(left))
    for c in range(ncase):
        for s0 in range(0, nstep, _CHUNK):
            A, b, xs, rs = full if s0 + _CHUNK <= nstep else tail
            for k in range(A.shape[0]):
                _assemble(data, inertia, c, s0 + k, centre, A[k], b[k])
            solve_blocks(A, b, xs, rs, rows, cols, starts, dyads)
            x[c, s0:s0 + A.shape[0]] = xs
            ratio[c, s0:s0 + A.shape[0]] = rs


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
