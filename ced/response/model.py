"""The KED model of a batch: M(t) q̈ + C(t) q̇ + K(t) q = F(t), built once, evaluated at any time.

:func:`build_model` makes everything that does not change in time: each link's local
matrices (one formulation module of :mod:`ced.fem.elements`, broadcast over the cases), the
DOF layout of the joint coupling (:mod:`ced.fem.coupling`), the recovery operators, the
optional component-mode reduction (:mod:`ced.fem.component_modes`) and modal damping.
:func:`terms_at` evaluates the system at any times from the rigid motion: the joint projection
P(t) and its derivatives, the loads of the requested effects (d'Alembert load, weight,
rotary inertia, the axial force of the rigid motion for axial stiffening), assembled by
:func:`ced.fem.effect_terms.system_terms`. :class:`StepTerms` serves the step grid chunk by
chunk to the marching loop.
"""
from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..fem import elements
from ..fem.component_modes import craig_bampton
from ..fem.coupling import Layout, build_layout, projection
from ..fem.effect_terms import (LinkData, SystemTerms, axial_force_coefficients, permute,
                                split_order, system_terms)
from ..problem.errors import SceneError
from .axial_force import ElasticAxialForce
from .batch import Batch, make_batch
from .modal_damping import ModalDamping, tabulate

__all__ = ["Model", "build_model", "terms_at", "StepTerms"]

#: Bytes of system terms kept in memory at once (steps per chunk follow from the batch size).
_CHUNK_BYTES = 50e6


@dataclass
class Model:
    """Everything about a batch that does not change in time."""

    batch: Batch
    layout: Layout
    links: dict[str, LinkData]
    recovery: dict[str, dict[str, np.ndarray]]  # flexible link -> operator -> (case, st, n)
    stations: np.ndarray
    effects: set[str]
    joint_mass: np.ndarray  # (case, joint) kg
    modal_damping: ModalDamping | None = None  # C over the motion's period
    points: dict[str, np.ndarray] | None = None  # joint at a point of a link -> (case, 2) m
    ternary: dict[str, dict[str, np.ndarray]] | None = None  # rigid link with points -> body
    # Where a model kept by ced.response.model_cache came from: (its serial, the kept model's
    # case of each case); None for a model built for its batch alone.
    origin: tuple[int, np.ndarray] | None = None
    # Effect elastic_axial_force: the elastic response's axial force added to the rigid
    # motion's in the flexible links' geometric stiffness (ced.response.axial_force), set on
    # the copies the fixed-point iteration solves; None for the linear model.
    elastic_axial_force: ElasticAxialForce | None = None


def build_model(batch: Batch) -> Model:
    """Local matrices of every link of every case, the DOF layout and recovery operators.

    The element modules broadcast over cases, so each link is built once for the batch.

    Parameters
    ----------
    batch : Batch
        Structurally identical cases (their scenes, link lengths in m, materials and sections).

    Returns
    -------
    Model
        Link matrices, DOF layout, recovery operators and effects of the batch.
    """
    scene = batch.scenes[0]
    topo = batch.topology
    formulation = scene["discretization"]["formulation"]
    if formulation == "rigid":
        raise ValueError("discretization.formulation: rigid has no elastic model to build")
    n_el = scene["discretization"]["elements_per_link"]
    stations = np.linspace(0.0, 1.0, scene["outputs"]["stations"])
    element = elements.formulation(formulation)
    flexible = {name: scene["links"][name]["flexible"] for name in topo.links}
    links, recovery, sizes, ends = {}, {}, {}, {}
    clamp_dofs: tuple[int, ...] = ()
    extra = ({"elements_across": scene["discretization"]["elements_across"]}
             if formulation == "plane_stress" else {})
    flexible_matrices = _flexible_links(batch, element, n_el, stations, flexible, extra)
    for i, name in enumerate(topo.links):
        if name in topo.points.values():
            # A ternary link (rigid): its matrices are its bars', built by _ternary_links
            # below; the (u0, v0, φ) of a rigid link, its ends following from them.
            links[name], sizes[name], ends[name] = None, 3, ((0, 1), (0, 1))
            continue
        par = {key: batch.link_property(name, "material", key) for key in ("E", "G", "rho")}
        sec = {key: batch.link_property(name, "section", key)
               for key in ("area", "second_moment", "height", "shear_coefficient")}
        length = batch.link_lengths[:, i]
        rotary = 0.0
        if flexible[name]:
            m, recovery[name] = flexible_matrices[name]
            ends[name] = tuple(tuple(int(d) for d in pair) for pair in m.end_dofs)
            if formulation in ("timoshenko", "plane_stress"):
                # The mass carries the section's rotary inertia: the rigid angular
                # acceleration loads it with the couple −ρIα (plane_stress: the exact αy
                # body force through its moment_load).
                rotary = par["rho"] * sec["second_moment"]
            if name == topo.input_link and formulation != "seed_lame":
                # seed_lame (thesis II.5) has no section rotation: v' is a displacement
                # gradient, and fixing it is a constraint its second-order equation cannot
                # take (convergence drops from h¹⁰ to h). The pivot translation holds the link.
                clamp_dofs = tuple(int(d) for d in np.atleast_1d(m.end_rotations[0]))
        else:
            m = elements.rigid_body.link_matrices(length, rho=par["rho"], area=sec["area"],
                                                  second_moment=sec["second_moment"])
            # Its mass carries the section's rotary inertia ρIL on φ (its rigid body's full
            # moment of inertia, as in the inverse dynamics): the rigid angular acceleration
            # loads it with the couple −ρILα, as a Timoshenko beam's sections.
            rotary = par["rho"] * sec["second_moment"]
            sleeve = _sleeve_inertia(batch, name)
            if sleeve is not None:
                # The sleeve of an RPR dyad turns with its guide bar (φ): its moment of
                # inertia about its pivot J joins the bar's on φ, loaded with −Jα; its mass
                # rides on its pivot joint (joint_mass below).
                mass = m.mass.copy()
                mass[..., 2, 2] += sleeve
                m = dataclasses.replace(m, mass=mass)
                rotary = rotary + sleeve / length
            ends[name] = ((0, 1), (0, 1))  # unused: a rigid link's ends follow from (u0, v0, φ)
        links[name] = LinkData(
            mass=m.mass, translational_mass=m.translational_mass, stiffness=m.stiffness,
            gyroscopic=m.gyroscopic, geometric_stiffness=m.geometric_stiffness,
            load_constant=m.load_constant, load_linear=m.load_linear,
            moment_load=m.moment_load, mass_per_length=par["rho"] * sec["area"],
            rotary_inertia_per_length=np.broadcast_to(rotary, length.shape).astype(float))
        sizes[name] = m.mass.shape[-1]
    points, ternary = _ternary_links(batch, links)
    slider = None  # every slider joint is in the topology (topology.sliders)
    layout = build_layout(topo, flexible, sizes, ends, clamp_dofs, slider_joint=slider)
    links = {name: permute(data, split_order(layout, name)) for name, data in links.items()}
    modes = scene["discretization"].get("modes_per_link", 0)
    if modes and any(flexible.values()):
        layout, links, recovery = _reduce(layout, links, recovery, modes, slider)
    joint_mass = batch.bodies.point_mass.copy()
    slider_mass = np.asarray(batch.bodies.slider_mass, float)
    slider_mass = slider_mass[:, None] if slider_mass.ndim == 1 else slider_mass
    for k, joint in enumerate(topo.sliders.values()):
        joint_mass[:, topo.joint_names.index(joint)] += slider_mass[:, k]
    for k, (joint, _) in enumerate(topo.sleeves.values()):
        joint_mass[:, topo.joint_names.index(joint)] += batch.bodies.sleeve_mass[:, k]
    effects = set(scene["effects"])
    model = Model(batch, layout, links, recovery, stations, effects, joint_mass,
                  points=points, ternary=ternary)
    damping = scene["damping"]
    if "damping" in effects and damping["model"] == "modal" and damping["ratio"] > 0:
        model.modal_damping = _modal_damping(model, damping["ratio"])
    return model


def _flexible_links(batch: Batch, element, n_el: int, stations: np.ndarray,
                    flexible: dict[str, bool], extra: dict) -> dict[str, tuple]:
    """(link matrices, recovery operators) of every flexible link, (case, …) each.

    The flexible links share the mesh, so they are built in one call of the element module
    over (link × case), then split: building costs ~2 ms a call whatever the batch (16 to 48
    cases), and a six-bar has three flexible links where a four-bar has two."""
    names = [name for name in batch.topology.links if flexible[name]]
    if not names:
        return {}
    columns = [batch.topology.link_names.index(name) for name in names]

    def stacked(group, key):
        return np.concatenate([np.broadcast_to(batch.link_property(name, group, key),
                                               (batch.size,)) for name in names])

    m = element.link_matrices(
        batch.link_lengths[:, columns].T.reshape(-1), n_el, E=stacked("material", "E"),
        G_shear=stacked("material", "G"), rho=stacked("material", "rho"),
        area=stacked("section", "area"), second_moment=stacked("section", "second_moment"),
        height=stacked("section", "height"),
        shear_coefficient=stacked("section", "shear_coefficient"), **extra)
    operators = element.recovery_matrices(m, stations)
    total = batch.size * len(names)

    def part(x, k):  # link k's cases of an array over (link × case)
        if isinstance(x, np.ndarray) and x.ndim and x.shape[0] == total:
            return x[k * batch.size : (k + 1) * batch.size]
        return x

    return {name: (dataclasses.replace(m, **{f.name: part(getattr(m, f.name), k)
                                             for f in dataclasses.fields(m)}),
                   {key: part(op, k) for key, op in operators.items()})
            for k, name in enumerate(names)}


def _sleeve_inertia(batch: Batch, link: str) -> np.ndarray | None:
    """Moment of inertia (case,) kg m² of the RPR sleeve that turns with ``link``, or None."""
    for k, (_, bar) in enumerate(batch.topology.sleeves.values()):
        if bar == link:
            return batch.bodies.sleeve_inertia[:, k]
    return None


def _ternary_links(batch: Batch, links: dict[str, LinkData]) -> tuple[dict, dict]:
    """Points of the links (case, 2) m, and the rigid model of every link with points.

    A ternary link is rigid (the scene refuses ``flexible: true`` on it) and made of bars of
    its section welded at its first joint (:func:`ced.problem.linkage.ternary_bars`, as its
    rigid mass properties). Its three small-motion DOFs (u0, v0, φ) at the first joint give
    each bar's (R(β)ᵀ(u0, v0), φ), β the bar's direction, so its matrices are the sum of the
    bars' rigid matrices rotated to the link frame: M, M_w, G (the 90° rotation of the
    Coriolis term commutes with R(β)). Its loads are the resultant force and moment of the
    d'Alembert and weight field (:func:`terms_at`), put on (u0, v0) and φ directly; its
    geometric stiffness on φ is Σ F·r over every force on it (:func:`_ternary_loads`)."""
    topo = batch.topology
    if not topo.points:
        return None, None
    from ..problem.linkage import bar_ends, describe

    descriptions = batch.descriptions or [describe(s["mechanism"]) for s in batch.scenes]
    points = {j: np.array([d["points"][j]["at"] for d in descriptions], float)
              for j in topo.points}
    ternary = {}
    for name in sorted(set(topo.points.values()), key=topo.link_names.index):
        i = topo.link_names.index(name)
        par = {key: batch.link_property(name, group, key) for group, key in
               (("material", "rho"), ("section", "area"), ("section", "second_moment"))}
        n = batch.size
        mass, trans, gyro = (np.zeros((n, 3, 3)) for _ in range(3))
        all_ends, made = bar_ends(descriptions, name, batch.link_lengths[:, i])
        # Bar k of every case at once (a case whose point lies on the bar has one bar fewer:
        # those go case by case).
        groups = ([(np.arange(n), all_ends[:, k]) for k in range(made.shape[1])] if made.all()
                  else [([c], all_ends[c, k:k + 1]) for c in range(n)
                        for k in np.flatnonzero(made[c])])
        for (cases, ends), bar in zip(groups, _bar_matrices(groups, par)):
            x, y = np.asarray(ends, float).T
            length = np.hypot(x, y)
            T = np.zeros((len(length), 3, 3))
            T[:, 0, 0] = T[:, 1, 1] = x / length
            T[:, 0, 1], T[:, 1, 0], T[:, 2, 2] = y / length, -y / length, 1.0
            Tt = np.swapaxes(T, -1, -2)
            mass[cases] += Tt @ bar.mass @ T
            trans[cases] += Tt @ bar.translational_mass @ T
            gyro[cases] += Tt @ bar.gyroscopic @ T
        geometric = np.zeros((n, 3, 3, 3))
        geometric[:, 0, 2, 2] = 1.0  # K_φφ = N0 · 1: the coefficient carries Σ F·r
        load_constant = np.broadcast_to(np.eye(3)[:, :2], (n, 3, 2)).copy()
        moment = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (n, 3)).copy()
        links[name] = LinkData(
            mass=mass, translational_mass=trans, stiffness=np.zeros((n, 3, 3)),
            gyroscopic=gyro, geometric_stiffness=geometric, load_constant=load_constant,
            load_linear=np.zeros((n, 3, 2)), moment_load=moment, mass_per_length=np.zeros(n),
            rotary_inertia_per_length=np.zeros(n))
        m = mass[:, 0, 0]
        ternary[name] = {"mass": m, "centre": np.stack([mass[:, 1, 2], -mass[:, 0, 2]], -1)
                         / m[:, None], "inertia": mass[:, 2, 2], "polar": trans[:, 2, 2]}
    return points, ternary


def _bar_matrices(groups: list, par: dict[str, np.ndarray]) -> list:
    """The rigid matrices of the bars of each group (cases, bar ends (case, 2) m) of
    :func:`_ternary_links`, from one call of the element module over them all: a call costs
    ~0.3 ms whatever its size, a ternary link has two or three bars (the same bits)."""
    cases = np.concatenate([np.asarray(c) for c, _ in groups])
    ends = np.concatenate([np.asarray(e, float) for _, e in groups])
    bars = elements.rigid_body.link_matrices(
        np.hypot(ends[:, 0], ends[:, 1]), rho=par["rho"][cases], area=par["area"][cases],
        second_moment=par["second_moment"][cases])
    first = np.cumsum([0] + [len(e) for _, e in groups])
    return [dataclasses.replace(bars, **{key: getattr(bars, key)[a:b] for key in
                                         ("mass", "translational_mass", "gyroscopic")})
            for a, b in zip(first[:-1], first[1:])]


def _ternary_loads(model: Model, name: str, motion, forces, g, has_inertia: bool):
    """Resultant (force in the link frame (case, step, 2), moment about the first joint
    (case, step)) of the weight and d'Alembert field of a rigid ternary link, and its
    geometric stiffness on φ, Σ F·r over the forces on it (joint forces, point masses it
    carries, its own field; r from its first joint in its frame), or None without ``forces``.

    The second-order displacement of a point r under a small rotation φ is −φ²r/2, so the
    forces F on the body store (φ²/2) Σ F·r: for a bar it is ∫N ds, the rigid link's K_g."""
    topo = model.layout.topology
    body = model.ternary[name]
    i = topo.link_names.index(name)
    th = motion.link_angle[..., i]
    c, s = np.cos(th), np.sin(th)
    if COMPILED:
        return _ternary_loads_compiled(model, name, motion, forces, g, has_inertia, c, s)
    local = lambda v: np.stack([c * v[..., 0] + s * v[..., 1],  # noqa: E731
                                -s * v[..., 0] + c * v[..., 1]], axis=-1)
    first, second = topo.links[name]
    acc = lambda k: motion.joint_acceleration[:, :, k] if has_inertia else 0.0  # noqa: E731
    q = local(g - acc(topo.joint_names.index(first)))  # per unit mass at the first joint
    m = body["mass"][:, None]
    cx, cy = body["centre"][:, None, 0], body["centre"][:, None, 1]
    force = m[..., None] * q
    moment = m * (cx * q[..., 1] - cy * q[..., 0])
    stiffness = m * (cx * q[..., 0] + cy * q[..., 1])
    if has_inertia:
        w = motion.link_angular_velocity[..., i]
        al = motion.link_angular_acceleration[..., i]
        force = force + m[..., None] * np.stack([w * w * cx + al * cy, w * w * cy - al * cx],
                                                axis=-1)
        moment = moment - al * body["inertia"][:, None]
        stiffness = stiffness + w * w * body["polar"][:, None]
    if forces is None:
        return force, moment, None
    arms = {second: np.stack([model.batch.link_lengths[:, i], 0 * cx[:, 0]], -1)}
    arms.update({j: model.points[j] for j, link in topo.points.items() if link == name})
    carrier = {j: (b[0] if b[1] == "tip" else b[1]) for j, b in topo.joints.items()}
    for j, arm in arms.items():
        k = topo.joint_names.index(j)
        f = (1.0 if topo.joints[j][1] == name else -1.0) * forces[:, :, k]
        if carrier[j] == name:
            mp = model.batch.bodies.point_mass[:, k][:, None, None]
            f = f + mp * (g - acc(k))
        fl = local(f)  # F·r written out: a sum over an axis of 2 loops per pair
        stiffness = stiffness + (fl[..., 0] * arm[:, None, 0] + fl[..., 1] * arm[:, None, 1])
    return force, moment, stiffness


#: Form a ternary link's loads in one compiled pass (:func:`_ternary_pass`); ``CED_KERNEL=numpy``
#: keeps the numpy expressions of :func:`_ternary_loads`, the reference (the same bits).
COMPILED = os.environ.get("CED_KERNEL", "numba") != "numpy"


def _ternary_loads_compiled(model: Model, name: str, motion, forces, g, has_inertia: bool,
                            c: np.ndarray, s: np.ndarray):
    """:func:`_ternary_loads` by :func:`_ternary_pass`, from tables of the forces on the link
    (joint, sign, carried) and their arms; ``c``, ``s`` (case, step) its cos θ, sin θ."""
    topo = model.layout.topology
    body = model.ternary[name]
    i = topo.link_names.index(name)
    first, second = topo.links[name]
    ncase, nstep = c.shape
    arms = {second: np.stack([model.batch.link_lengths[:, i], 0 * body["centre"][:, 0]], -1)}
    arms.update({j: model.points[j] for j, link in topo.points.items() if link == name})
    carrier = {j: (b[0] if b[1] == "tip" else b[1]) for j, b in topo.joints.items()}
    table = np.array([[topo.joint_names.index(j), 1 if topo.joints[j][1] == name else -1,
                       carrier[j] == name] for j in arms], np.int64).reshape(-1, 3)
    arm = np.stack([np.asarray(a, float) for a in arms.values()], axis=1)  # (case, arm, 2)
    props = np.stack([body["mass"], body["centre"][:, 0], body["centre"][:, 1],
                      body["inertia"], body["polar"]], axis=-1)
    force, moment, stiffness = np.empty((ncase, nstep, 2)), np.empty(c.shape), np.empty(c.shape)
    joint_forces = np.zeros((ncase, nstep, 0, 2)) if forces is None else forces
    C = lambda x: np.require(x, float, "C")  # noqa: E731  (one signature)
    _ternary_pass(C(c), C(s), C(motion.link_angular_velocity[..., i]),
                  C(motion.link_angular_acceleration[..., i]), C(motion.joint_acceleration),
                  C(np.broadcast_to(g[:, 0], (ncase, 2))), has_inertia,
                  topo.joint_names.index(first), C(props), table, C(arm),
                  C(model.batch.bodies.point_mass), C(joint_forces), forces is not None, force,
                  moment, stiffness)
    return force, moment, (None if forces is None else stiffness)


@nb.njit(cache=True, nogil=True)
def _ternary_pass(c, s, w, al, acc, g, inertia, first, props, table, arm, point_mass, forces,
                  with_forces, force, moment, stiffness):
    """The loads of :func:`_ternary_loads` at every (case, step) with its arithmetic operation
    for operation (the same bits): ``props`` (case, 5) the link's mass, centre (x, y) in its
    frame, moment of inertia about the first joint and polar term; ``table`` (arm, 3) each
    force's joint, sign and whether the link carries the joint's point mass, ``arm``
    (case, arm, 2) its point in the link frame; ``acc`` and ``forces`` (case, step, joint, 2);
    ``g`` (case, 2) m/s²."""
    for i in range(c.shape[0]):
        m, cx, cy, inert, polar = props[i, 0], props[i, 1], props[i, 2], props[i, 3], props[i, 4]
        gx, gy = g[i, 0], g[i, 1]
        for k in range(c.shape[1]):
            ck, sk = c[i, k], s[i, k]
            vx = gx - (acc[i, k, first, 0] if inertia else 0.0)
            vy = gy - (acc[i, k, first, 1] if inertia else 0.0)
            qx, qy = ck * vx + sk * vy, -sk * vx + ck * vy
            fx, fy = m * qx, m * qy
            mo = m * (cx * qy - cy * qx)
            st = m * (cx * qx + cy * qy)
            if inertia:
                ww, a = w[i, k] * w[i, k], al[i, k]
                fx = fx + m * (ww * cx + a * cy)
                fy = fy + m * (ww * cy - a * cx)
                mo = mo - a * inert
                st = st + ww * polar
            force[i, k, 0], force[i, k, 1], moment[i, k] = fx, fy, mo
            if with_forces:
                for r in range(table.shape[0]):
                    j, sign = table[r, 0], float(table[r, 1])
                    px, py = sign * forces[i, k, j, 0], sign * forces[i, k, j, 1]
                    if table[r, 2]:
                        mp = point_mass[i, j]
                        px = px + mp * (gx - (acc[i, k, j, 0] if inertia else 0.0))
                        py = py + mp * (gy - (acc[i, k, j, 1] if inertia else 0.0))
                    lx, ly = ck * px + sk * py, -sk * px + ck * py
                    st = st + (lx * arm[i, r, 0] + ly * arm[i, r, 1])
            stiffness[i, k] = st


def _reduce(layout: Layout, links: dict, recovery: dict, modes: int, slider: str | None):
    """Craig–Bampton reduction of every flexible link (:mod:`ced.fem.component_modes`) and the
    layout of the reduced blocks: interior = modal coordinates, then the boundary rows
    unchanged."""
    topo = layout.topology
    sizes, ends = dict(layout.link_sizes), dict(layout.end_dofs)
    clamp = layout.clamp_dofs
    links, recovery = dict(links), dict(recovery)
    for name in topo.links:
        if not layout.flexible[name]:
            continue
        rows, _, varying = layout.row_split(name)
        if modes > len(rows):  # as modal.modes beyond the model's DOFs: an impossible value
            raise SceneError("discretization.modes_per_link", (
                f"{modes} modes per link asked for, but the {name} has only {len(rows)} "
                f"interior degrees of freedom at this mesh; ask for at most {len(rows)} or "
                "refine the mesh (elements_per_link)"))
        order = split_order(layout, name)
        links[name], basis = craig_bampton(links[name], len(rows), modes)
        n_interior = links[name].mass.shape[-1] - len(varying)
        recovery[name] = {key: op[..., order] @ basis for key, op in recovery[name].items()}
        position = {local: n_interior + j for j, local in enumerate(varying)}
        sizes[name] = n_interior + len(varying)
        ends[name] = tuple((position[u], position[v]) for u, v in layout.end_dofs[name])
        if name == topo.input_link and clamp:
            clamp = tuple(position[i] for i in clamp)
    return (build_layout(topo, layout.flexible, sizes, ends, clamp, slider_joint=slider),
            links, recovery)


def terms_at(
    model: Model,
    times: np.ndarray,
    effects: set[str] | None = None,
    extras: frozenset[str] = frozenset(),
    compact: bool = False,
    modal_damping: bool = True,
) -> tuple[SystemTerms, np.ndarray]:
    """System terms and the projection value at arbitrary times (case, step).

    ``effects`` defaults to the scene's; the modal analysis passes them without damping.
    ``extras`` asks for ``elastic_mass`` / ``elastic_stiffness`` as well (see
    :class:`ced.fem.effect_terms.SystemTerms`).

    Parameters
    ----------
    model : Model
        The batch's model from :func:`build_model`.
    times : numpy.ndarray
        Times, s, shape (case, step).
    effects : set of str, optional
        Effects to include; default the scene's.
    extras : frozenset of str, optional
        Extra terms to form: ``"elastic_mass"``, ``"elastic_stiffness"``.
    compact : bool, optional
        Return the projection's rows ``layout.projection_rows`` only (the others are zero).
    modal_damping : bool, optional
        Add the modal damping's table (:mod:`ced.response.modal_damping`); False leaves it
        to the caller, which adds it where the terms are no longer sampled: it is piecewise
        linear in time, not smooth like the rest (:func:`ced.response.period_terms.period_terms`).

    Returns
    -------
    terms : SystemTerms
        M, C, K (case, step, ny, ny) and F (case, step, ny) in the independent elastic
        coordinates y.
    projection : numpy.ndarray
        The joint-coordinate columns of the projection z = P y, shape (case, step, nz, nfree)
        (:func:`ced.fem.coupling.projection`), or (case, step, row, nfree) with ``compact``.
    """
    batch, layout = model.batch, model.layout
    effects = model.effects if effects is None else effects
    topo = layout.topology
    motion = batch.rigid_motion(times)
    gravity = batch.gravity if "gravity" in effects else np.zeros_like(batch.gravity)
    has_inertia = "inertia" in effects
    guides = ({topo.sliders[b]: phi for b, phi in motion.guide_angle.items()}
              if motion.guide_angle else None)
    P = projection(layout, batch.link_lengths, motion.link_angle,
                   motion.link_angular_velocity, motion.link_angular_acceleration,
                   model.points, guides, motion.slide, compact=True)
    g = gravity[:, None, :]
    loads, axial = {}, {} if "axial_stiffening" in effects else None
    forces = sleeve_forces = None
    if axial is not None:
        rigid = batch.rigid_forces(times, has_inertia, gravity, motion)
        forces, sleeve_forces = rigid.joint_force, rigid.sleeve_force
    carrier = {j: (b[0] if b[1] == "tip" else b[1]) for j, b in topo.joints.items()}
    for i, name in enumerate(topo.links):
        th = motion.link_angle[..., i]
        c, s = np.cos(th), np.sin(th)
        first = topo.links[name][0]
        kf = topo.joint_names.index(first)
        rho_a = model.links[name].mass_per_length[:, None, None]
        acc = motion.joint_acceleration[:, :, kf] if has_inertia else 0.0
        if model.ternary and name in model.ternary:
            force, moment, stiffness = _ternary_loads(model, name, motion, forces, g,
                                                      has_inertia)
            loads[name] = (force, np.zeros_like(force), moment)
            if axial is not None:
                axial[name] = np.stack([stiffness, 0 * stiffness, 0 * stiffness])
            continue
        glob = rho_a * (g - acc)  # distributed load at s = 0, global, N/m
        b0 = np.stack([c * glob[..., 0] + s * glob[..., 1],
                       -s * glob[..., 0] + c * glob[..., 1]], axis=-1)
        if has_inertia:
            w = motion.link_angular_velocity[..., i]
            al = motion.link_angular_acceleration[..., i]
            b1 = rho_a * np.stack([w * w, -al], axis=-1)
        else:
            b1 = np.zeros_like(b0)
        loads[name] = (b0, b1, None)
        if has_inertia and np.any(model.links[name].rotary_inertia_per_length):
            # Section rotation θ_link + ψ: rotary inertia loads the ψ DOFs with −ρI α.
            rho_i = model.links[name].rotary_inertia_per_length[:, None]
            loads[name] = (b0, b1, -rho_i * motion.link_angular_acceleration[..., i])
        if axial is not None:
            sign = 1.0 if topo.joints[first][1] == name else -1.0
            f = sign * forces[:, :, kf]
            if carrier[first] == name:
                mp = batch.bodies.point_mass[:, kf][:, None, None]
                f = f + mp * (g - acc)
            fx = c * f[..., 0] + s * f[..., 1]
            axial[name] = axial_force_coefficients(fx, b0[..., 0], b1[..., 0])
            added = model.elastic_axial_force
            if added is not None and name in added.coefficients:
                axial[name] = axial[name] + added.at(name, times)
    acc_j = motion.joint_acceleration if has_inertia else 0.0
    joint_load = model.joint_mass[:, None, :, None] * (gravity[:, None, None, :] - acc_j)
    if "damping" in effects and model.batch.scenes[0]["damping"]["model"] == "rayleigh":
        extras = extras | {"elastic_mass", "elastic_stiffness"}
    terms = system_terms(layout, model.links, P, motion.link_angular_velocity,
                         motion.link_angular_acceleration, loads, axial, model.joint_mass,
                         joint_load, effects, frozenset(extras))
    if sleeve_forces is not None:
        _add_sleeve_stiffness(layout, motion, P[0], sleeve_forces, terms.stiffness)
    if "damping" in effects:
        _add_damping(model, terms, times, modal_damping)
    rows = layout.projection_rows
    if compact:
        return terms, P[0, ..., : len(rows), :]
    full = np.zeros(P.shape[1:3] + (layout.nz, P.shape[-1]))
    full[..., rows, :] = P[0, ..., : len(rows), :]
    return terms, full


def _add_sleeve_stiffness(layout: Layout, motion, P0: np.ndarray, sleeve_forces: np.ndarray,
                          K: np.ndarray) -> None:
    """Add the second-order work of each RPR sleeve's normal force to K (axial stiffening).

    To second order the closure of an RPR dyad, with the bar's small rotation φ and the pivots'
    translations U_P, U_Q, is g = e⊥·ΔU − s φ − φ e·ΔU − (offset/2) φ² = 0, ΔU = U_Q − U_P
    (expand e⊥(θ + φ)·(Q + U_Q − offset e⊥(θ + φ) − P − U_P)). The linear model keeps its
    first-order part (the prismatic constraint, :mod:`ced.fem.coupling`); the normal force N
    of the bar on the sleeve (the multiplier of g: its force on U_Q is N e⊥) works on the
    second-order part, which stores V = N (φ e·ΔU + (offset/2) φ²): K gains
    N offset zφ zφᵀ + N (zφ wᵀ + w zφᵀ), zφ the bar's φ row of P, w = eᵀ(P_Q − P_P). The bar's
    own forces (pivot, end, weight, d'Alembert) act through its ∫N ds like any rigid link's.
    ``P0`` is the compact projection of :func:`terms_at`.
    """
    topo = layout.topology
    nf = P0.shape[-1]
    if not nf:
        return
    link_offsets, joint_offsets = layout.link_offsets, layout.joint_offsets
    index = layout.projection_index  # P0 is compact (terms_at): a joint's rows consecutive

    def rows(j):  # a joint's two rows of P0
        r = index[joint_offsets[j]]
        return P0[..., r:r + 2, :]

    for k, (sleeve, (pivot, bar)) in enumerate(topo.sleeves.items()):
        i = topo.link_names.index(bar)
        base = topo.links[bar][0]
        th = motion.link_angle[..., i]
        e = np.stack([np.cos(th), np.sin(th)], axis=-1)
        n = np.stack([-e[..., 1], e[..., 0]], axis=-1)
        kq, kp = topo.joint_names.index(pivot), topo.joint_names.index(base)
        offset = np.sum((motion.joint_position[:, :, kq] - motion.joint_position[:, :, kp]) * n,
                        axis=-1)
        z_phi = P0[..., index[link_offsets[bar] + 2], :]
        w = np.einsum("csa,csaf->csf", e, rows(pivot) - rows(base))
        N = sleeve_forces[:, :, k, 0]
        K[..., :nf, :nf] += ((N * offset)[..., None, None] * z_phi[..., :, None]
                             * z_phi[..., None, :])
        K[..., :nf, :nf] += N[..., None, None] * (z_phi[..., :, None] * w[..., None, :]
                                                  + w[..., :, None] * z_phi[..., None, :])


def _add_damping(model: Model, terms: SystemTerms, times: np.ndarray, modal: bool) -> None:
    d = model.batch.scenes[0]["damping"]
    if d["model"] == "rayleigh":
        extra = d["alpha"] * terms.elastic_mass + d["beta"] * terms.elastic_stiffness
    elif model.modal_damping is not None and modal:
        extra = model.modal_damping.at(times, model.batch.speed)
    else:
        return  # modal, ζ = 0, or left to the caller
    terms.damping = extra if terms.damping is None else terms.damping + extra


def _modal_damping(model: Model, ratio: float) -> ModalDamping:
    """C(t) = M Φ diag(2ζω) Φᵀ M from the modes frozen at each phase of the rigid motion's
    period (:mod:`ced.response.modal_damping`): every mode of the linkage gets ζ throughout.

    Tabulated at unit speed, so that the table is the same bits whatever the cases' speeds:
    the configuration at a phase is, and :mod:`ced.response.model_cache` serves a model to
    batches at other speeds. For the same reason it is tabulated once per distinct model
    (:func:`ced.response.model_cache.model_key`: a speed sweep's cases share one table).
    """
    from .model_cache import at_cases, model_key  # that module builds on this one

    batch = model.batch
    keys = [model_key(scene) for scene in batch.scenes]
    first: dict[bytes, int] = {}
    for i, key in enumerate(keys):
        first.setdefault(key, i)
    distinct = np.array(sorted(first.values()))
    row = {case: k for k, case in enumerate(distinct)}
    turns = batch.motion_turns[distinct]
    unit = make_batch([batch.scenes[i] for i in distinct])
    unit = dataclasses.replace(unit, speed=np.ones(unit.size),
                               step_size=unit.step_size * unit.speed, _turns=turns)
    at_unit_speed = at_cases(model, unit, distinct)

    def elastic_terms(times):  # no effects: the loads and rigid forces are not needed
        terms, _ = terms_at(at_unit_speed, times, set(),
                            frozenset({"elastic_mass", "elastic_stiffness"}))
        return terms.elastic_mass, terms.elastic_stiffness

    table = tabulate(elastic_terms, 2.0 * math.pi * turns.astype(float), turns, ratio)
    cases = np.array([row[first[key]] for key in keys])
    return ModalDamping(table.phase[cases], table.matrix[cases], table.turns[cases])


class StepTerms:
    """Terms over the step grid, computed chunk by chunk as the march asks for them.

    ``load(k)`` makes step k available and returns its index j in the current chunk
    (``terms`` and ``P`` hold the chunk); calling the object with k returns (M, C, K, F) at
    step k, the ``terms`` argument of :func:`ced.response.integrators.march` (through
    :func:`ced.response.integrators.forced_columns`).
    """

    def __init__(self, model: Model, h: np.ndarray, n_steps: int):
        self.model, self.h, self.n_steps = model, h, n_steps
        layout = model.layout
        per_step = model.batch.size * 8 * (4 * layout.ny**2 + 3 * layout.nz * layout.ny)
        self.chunk = int(min(n_steps + 1, max(4, _CHUNK_BYTES // max(per_step, 1))))
        self.start, self.terms, self.P = None, None, None

    def load(self, k: int):
        if self.start is None or not (self.start <= k < self.start + self.chunk):
            self.start = k
            steps = np.arange(k, min(k + self.chunk, self.n_steps + 1))
            times = self.h[:, None] * steps[None, :]
            self.terms, self.P = terms_at(self.model, times)
        return k - self.start

    def __call__(self, k: int):
        j = self.load(k)
        t = self.terms
        M = t.mass[:, j] if t.mass is not None else None
        C = t.damping[:, j] if t.damping is not None else None
        return M, C, t.stiffness[:, j], t.force[:, j]
