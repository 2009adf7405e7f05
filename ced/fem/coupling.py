"""Joint coupling of the links: DOF layout and the exact time-varying projection z = P(t) y.

Two coordinate sets (docs/theory.md, thesis II.4 with shared pin displacements instead of the
thesis's strain-only joint conditions):

* ``z`` — every link's local DOFs in its own rigid-body frame (flexible link: FE nodal DOFs;
  rigid link: (u0, v0, φ), the small motion of its first end and its small rotation), then
  the global elastic translation U_J of every joint (2 each; point masses live there);
* ``y`` — the independent unknowns: joint translation coordinates (a_J, b_J) expressed in the
  frame of a *host* link, U_J = R(θ_host)(a_J, b_J), then the interior DOFs of flexible links.

Ground pins are fixed, the driven input link is clamped at its ground pivot, a slider block
moves along its fixed guide only. A rigid link adds inextensibility e_iᵀ(U_s − U_f) = 0; it
hosts one of its joints so that this constraint solves for that joint's axial coordinate with
unit coefficient (never ill-conditioned however the links turn). A rigid link whose joints are
all placed already (a closed loop of rigid links, e.g. a six-bar's rigid second dyad hanging
from a rigid first loop) solves its constraint for a remaining free coordinate of one of its
joints instead: the coefficient is then the sine of a transmission angle, which vanishes only
at a toggle of that rigid loop. A joint at a point of a (rigid, ternary) link moves with that
link's small rigid motion: U_E = U_f + φ (x_E e⊥ − y_E e), φ = e⊥ᵀ(U_s − U_f)/L, (x_E, y_E)
the point in the link frame; it has no coordinates of its own. The rigid guide bar P→T of an
RPR dyad turns with its sleeve, which turns about Q at the distance s(t) from P along the bar:
linearizing the closure Q − P = s e + offset e⊥, its small rotation is φ = e⊥ᵀ(U_Q − U_P)/s;
with φ = e⊥ᵀ(U_T − U_P)/L this is the *prismatic* constraint
s e⊥ᵀ(U_T − U_P) − L e⊥ᵀ(U_Q − U_P) = 0, which owns T's transverse coordinate (coefficient
s, vanishing only where the sleeve reaches the bar's pivot) as the bar's inextensibility owns
its axial one. Everything time-dependent is a product of rotations and of the slide s(t), so
P, Ṗ, P̈ are exact (see :mod:`ced.fem.jets`).
"""
from __future__ import annotations

import functools
import os
from dataclasses import dataclass

import numba as nb
import numpy as np

from . import jets
from ..problem.mechanism import Topology

__all__ = ["Layout", "build_layout", "projection"]


@dataclass(frozen=True)
class Layout:
    """Which DOFs exist and how they are coupled, identical for every case of a batch.

    Attributes
    ----------
    topology : the mechanism's links and joints
    flexible : link -> bool
    link_sizes : link -> number of local DOFs (z block size)
    end_dofs : link -> ((u, v) local indices at the first end, (u, v) at the second end)
    clamp_dofs : local indices held by the clamp of a flexible input link at its ground pivot
        (a beam's end rotation; every DOF of a continuum's pivot face)
    host : joint -> hosting link name, or None for the global frame
    coordinate_kind : (joint, 0|1) -> "free" | "zero" | "own" | "point" (a joint at a point
        of a rigid link: its translation follows from the link's, no coordinate of its own)
    constraints : list of (rigid link, "axial" | "prismatic", owned (joint, component)):
        a rigid link's inextensibility, or the constraint of an RPR guide bar's rotation to
        its sleeve's (see the module docstring)

    The derived offsets and coordinate lists are worked out once per layout (cached
    properties: a terms evaluation reads them a few dozen times, ~0.1 ms each for a six-bar's
    ``interior_dofs``); the layout is not changed after :func:`build_layout`, nor are they.
    """

    topology: Topology
    flexible: dict[str, bool]
    link_sizes: dict[str, int]
    end_dofs: dict[str, tuple[tuple[int, int], tuple[int, int]]]
    clamp_dofs: tuple[int, ...]
    host: dict[str, str | None]
    coordinate_kind: dict[tuple[str, int], str]
    constraints: list[tuple[str, str, tuple[str, int]]]

    @functools.cached_property
    def link_offsets(self) -> dict[str, int]:
        out, k = {}, 0
        for name in self.topology.links:
            out[name] = k
            k += self.link_sizes[name]
        return out

    @functools.cached_property
    def joint_offsets(self) -> dict[str, int]:
        base = sum(self.link_sizes.values())
        return {j: base + 2 * i for i, j in enumerate(self.topology.joints)}

    @functools.cached_property
    def nz(self) -> int:
        return sum(self.link_sizes.values()) + 2 * len(self.topology.joints)

    @functools.cached_property
    def free_coordinates(self) -> list[tuple[str, int]]:
        return [key for key, kind in self.coordinate_kind.items() if kind == "free"]

    @functools.cached_property
    def interior_dofs(self) -> list[tuple[str, int]]:
        """(link, local index) of every flexible-link DOF that is its own unknown in y."""
        out = []
        for name in self.topology.links:
            if not self.flexible[name]:
                continue
            ends = {i for pair in self.end_dofs[name] for i in pair}
            for i in range(self.link_sizes[name]):
                if i in ends or (name == self.topology.input_link and i in self.clamp_dofs):
                    continue
                out.append((name, i))
        return out

    @functools.cached_property
    def link_blocks(self) -> list[tuple[int, int]]:
        """(start, stop) of each link's interior DOFs in y, for the links that have any.

        A link's terms reach only its own interior DOFs and the joint coordinates
        (:func:`ced.fem.effect_terms.system_terms`), so M and K are block-arrow on these
        ranges: :func:`ced.fem.eigenproblem.natural_frequencies` reduces them block by block.
        """
        out = []
        for name in self.topology.links:
            columns = self.row_split(name)[1]
            if columns:
                out.append((columns[0], columns[-1] + 1))
        return out

    @functools.cached_property
    def ny(self) -> int:
        return len(self.free_coordinates) + len(self.interior_dofs)

    @functools.cached_property
    def projection_rows(self) -> np.ndarray:
        """The z rows in which the joint-coordinate columns of P may be nonzero, ascending,
        int64: the rows :func:`_assemble_point` writes (moving joints' translations, the link
        ends on them, a rigid link's (u0, v0, φ) where its first end moves); every other row
        is zero at every point (a six-bar benchmark's Watt II 15 of 65, its four-bar 6 of
        53). The period's terms hold those rows only (:mod:`ced.response.period_terms`)."""
        return _written_rows(self)

    @functools.cached_property
    def projection_index(self) -> np.ndarray:
        """(nz,) int64: each z row's place in a compact projection (``compact`` of
        :func:`projection`), the rows not in :attr:`projection_rows` at the first of its two
        zero rows (``len(projection_rows)``)."""
        index = np.full(self.nz, len(self.projection_rows), np.int64)
        index[self.projection_rows] = np.arange(len(self.projection_rows))
        return index

    def interior_rows(self) -> np.ndarray:
        """z index of every interior DOF, in y order (after the joint coordinates)."""
        off = self.link_offsets
        return np.array([off[name] + i for name, i in self.interior_dofs], int)

    def expand(self, P0: np.ndarray, y: np.ndarray) -> np.ndarray:
        """z = P y from the joint-coordinate columns ``P0`` (…, nz, nfree) and y (…, ny)."""
        nfree = P0.shape[-1]
        z = (P0 @ y[..., :nfree, None])[..., 0]
        z[..., self.interior_rows()] += y[..., nfree:]
        return z

    def row_split(self, link: str) -> tuple[list[int], list[int], list[int]]:
        """(selected local rows, their y columns, varying local rows) of ``link``'s block of P.

        Interior DOFs of a flexible link are unknowns of their own: their rows of P are
        constant unit rows. Only the other rows (end translations projected from the joints,
        a rigid link's (u0, v0, φ)) vary in time; assembling Pᵀ A P then needs products with
        those few rows only.
        """
        offset = len(self.free_coordinates)
        selected = [(i, offset + c) for c, (name, i) in enumerate(self.interior_dofs)
                    if name == link]
        rows = [i for i, _ in selected]
        chosen = set(rows)
        varying = [i for i in range(self.link_sizes[link]) if i not in chosen]
        return rows, [c for _, c in selected], varying


def build_layout(
    topology: Topology,
    flexible: dict[str, bool],
    link_sizes: dict[str, int],
    end_dofs: dict[str, tuple[tuple[int, int], tuple[int, int]]],
    clamp_dofs: tuple[int, ...] = (),
    slider_joint: str | None = None,
) -> Layout:
    """Choose hosts and the coordinates that rigid-link constraints eliminate.

    Rigid links attached to the ground are treated first, so that a chain ground → rigid →
    rigid hosts every joint at the link that constrains it. A closed loop of rigid links (all
    links rigid) leaves no elastic freedom: every joint coordinate is then fixed.

    Parameters
    ----------
    topology : Topology
        Links (first and second joint) and joints of the mechanism, its ground joints and input
        link.
    flexible : dict of str to bool
        Whether each link is flexible (rigid links are constrained, not discretized).
    link_sizes : dict of str to int
        Number of local DOFs of each link.
    end_dofs : dict of str to tuple
        Per link, the local indices ((u, v) at the first end, (u, v) at the second end) of the
        end translations that the joints share.
    clamp_dofs : tuple of int, optional
        Local indices held by the clamp of a flexible input link at its ground pivot.
    slider_joint : str or None, optional
        A joint on a slider guide (its translation along the guide free, across it fixed),
        besides those of ``topology.sliders``. The guide's direction is given to
        :func:`projection` (``guide_angle``; parallel to x by default).

    Returns
    -------
    Layout
        The DOF layout: joint hosts and the kind (zero, free, constrained) of every joint
        coordinate.
    """
    links, joints = topology.links, topology.joints
    host: dict[str, str | None] = {}
    kind: dict[tuple[str, int], str] = {}
    for j in joints:
        if j in topology.ground_joints:
            host[j] = None
            kind[(j, 0)] = kind[(j, 1)] = "zero"
    for j in sorted(set(topology.sliders.values()) | {slider_joint} - {None},
                    key=list(joints).index):
        host[j] = None  # in the guide's frame: U = X (cos φ, sin φ)
        kind[(j, 0)] = "free"
        kind[(j, 1)] = "zero"
    for j, link in topology.points.items():
        if flexible[link]:
            raise ValueError(f"links.{link}.flexible: a link with a point ({j}) is rigid")
        host[j] = None
        kind[(j, 0)] = kind[(j, 1)] = "point"

    constraints = []
    guides = set()
    for sleeve, (_, bar) in topology.sleeves.items():
        if flexible[bar]:
            raise ValueError(f"links.{bar}.flexible: the guide bar of the sleeve {sleeve} is "
                             "rigid")
        # The bar's far end: its axial coordinate solves the bar's inextensibility, its
        # transverse one the bar's turning with the sleeve.
        tip = links[bar][1]
        host[tip] = bar
        kind[(tip, 0)] = kind[(tip, 1)] = "own"
        constraints += [(bar, "axial", (tip, 0)), (bar, "prismatic", (tip, 1))]
        guides.add(bar)
    rigid = [n for n in links if not flexible[n] and n not in guides]
    rigid.sort(key=lambda n: 0 if links[n][0] in topology.ground_joints else 1)
    for name in rigid:
        first, second = links[name]
        if name == topology.input_link:
            # Clamped rigid input link: inextensible and not rotating → its far joint is fixed.
            if second not in host:
                host[second] = name
                kind[(second, 0)] = kind[(second, 1)] = "zero"
            continue
        target = next((j for j in (second, first) if j not in host), None)
        if target is None:
            # Both joints placed (a closed loop of rigid links): the constraint owns a free
            # coordinate left at one of them, if any (else it holds already: all rigid).
            left = next((key for key in ((second, 1), (second, 0), (first, 1), (first, 0))
                         if kind.get(key) == "free"), None)
            if left is not None:
                kind[left] = "own"
                constraints.append((name, "axial", left))
            continue
        host[target] = name
        kind[(target, 0)] = "own"
        kind.setdefault((target, 1), "free")
        constraints.append((name, "axial", (target, 0)))
    for j in joints:
        if j not in host:
            host[j] = next((n for n in links if j in links[n] and flexible[n]), None)
            kind[(j, 0)] = kind[(j, 1)] = "free"
    if not any(flexible.values()):
        for key in kind:
            kind[key] = "zero"
        constraints = []
    # Order coordinates by joint then component for a stable y layout.
    kind = {key: kind[key] for key in sorted(kind, key=lambda k: (list(joints).index(k[0]), k[1]))}
    return Layout(topology, dict(flexible), dict(link_sizes), dict(end_dofs), tuple(clamp_dofs),
                  host,
                  kind, constraints)


def _frame_jets(layout: Layout, link_rot: dict[str, np.ndarray], per_case,
                guide_angle: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """Rotation jet of each joint's host frame (a slider joint's: its guide's), points last
    (3, 2, 2, points) or, for a constant frame, (3, 2, 2, 1)."""
    eye = np.zeros((3, 2, 2, 1))
    eye[0, :, :, 0] = np.eye(2)
    out = {j: (link_rot[h] if h is not None else eye) for j, h in layout.host.items()}
    for j, phi in (guide_angle or {}).items():
        c, s = per_case(np.cos(phi)), per_case(np.sin(phi))
        R = np.zeros((3, 2, 2, len(c)))
        R[0] = np.stack([np.stack([c, -s]), np.stack([s, c])])
        out[j] = R
    return out


def _point_order(topo: Topology) -> list[str]:
    """The joints at points of rigid links, in an order where each link's ends are known
    first (a point's link may hang from another point)."""
    order, todo = [], [j for j in topo.joints if j in topo.points]
    while todo:
        ready = [j for j in todo if not {*topo.links[topo.points[j]]} & set(todo)]
        if not ready:
            raise ValueError(f"joints {todo}: points of links that hang from each other")
        order += ready
        todo = [j for j in todo if j not in ready]
    return order


def _point_rows(layout: Layout, H: np.ndarray, rot: dict, lengths: np.ndarray,
                points: dict[str, np.ndarray], per_case) -> None:
    """Fill the rows of H (3, 2·joints, nx, points) of joints at points of rigid links:
    U_E = U_f + φ (x e⊥ − y e) with φ = e⊥ᵀ(U_s − U_f)/L, in an order where each link's ends
    are known first."""
    topo = layout.topology
    joints = list(topo.joints)
    rows = {j: slice(2 * k, 2 * k + 2) for k, j in enumerate(joints)}
    for j in _point_order(topo):
        link = topo.points[j]
        i = topo.link_names.index(link)
        first, second = topo.links[link]
        R = rot[link]
        e, n = R[:, :, 0:1], R[:, :, 1:2]
        xy = np.asarray(points[j], float)
        w = per_case(xy[:, 0]) * n - per_case(xy[:, 1]) * e
        Hf = H[:, rows[first]]
        phi = jets.matmul_points(jets.transpose_points(n), H[:, rows[second]] - Hf)
        phi = phi / per_case(lengths[:, i])
        H[:, rows[j]] = Hf + jets.matmul_points(w, phi)


def projection(
    layout: Layout,
    lengths: np.ndarray,
    link_angle: np.ndarray,
    link_velocity: np.ndarray,
    link_acceleration: np.ndarray,
    points: dict[str, np.ndarray] | None = None,
    guide_angle: dict[str, np.ndarray] | None = None,
    slide: dict[str, tuple] | None = None,
    compact: bool = False,
) -> np.ndarray:
    """Jet of the joint-coordinate columns of P(t), shape (3, case, step, nz, nfree).

    z = P y where y = (joint coordinates, interior DOFs); the interior columns of P are
    constant unit columns (each interior DOF is its own z entry), so only the first nfree
    columns are built; :meth:`Layout.expand` applies the whole P. With ``compact`` the rows
    :attr:`Layout.projection_rows` only, then two zero rows, (3, case, step, row + 2,
    nfree): z row r is row ``layout.projection_index[r]`` of it (the other rows are zero at
    every point; a Watt II's 15 of 65 rows), so that the terms are formed from a quarter of
    the memory.

    Parameters
    ----------
    layout : DOF layout of the batch
    lengths : (case, link) m
    link_angle, link_velocity, link_acceleration : (case, step, link) rigid motion
    points : joint at a point of a link -> its coordinates in the link frame (case, 2) m;
        every joint of ``layout.topology.points``
    guide_angle : slider joint -> direction of its fixed guide (case,) rad; parallel to x if
        absent
    slide : RPR sleeve -> its distance s from the guide bar's pivot along the bar, with its
        rate and acceleration (each (case, step): m, m/s, m/s²); every sleeve of
        ``layout.topology.sleeves``
    """
    topo = layout.topology
    ncase, nstep = shape = link_angle.shape[:2]
    if COMPILED and not topo.sleeves and len(layout.constraints) <= 1:
        return _projection_compiled(layout, lengths, link_angle, link_velocity,
                                    link_acceleration, points, guide_angle, compact)
    names = topo.link_names
    # Every jet below has its (case, step) points flattened on the last axis
    # (jets.matmul_points): the products are of 2 × 2 rotations and a few columns, cheap per
    # point but many points; a case's constant repeats over its steps.
    # The points axis is padded with copies of the last point (_PAD of them): the assembly
    # reads every row of a point at a stride of the axis, which at a power of two (64 phases
    # × 16 cases) maps them all to one cache set.
    flat = lambda x: _padded(x.reshape(ncase * nstep, -1).T)  # noqa: E731  (k, points)
    per_case = lambda x: _padded(np.repeat(np.asarray(x, float), nstep))  # noqa: E731
    every = jets.rotation_points(flat(link_angle), flat(link_velocity), flat(link_acceleration))
    rot = {n: every[:, :, :, i] for i, n in enumerate(names)}
    frames = _frame_jets(layout, rot, per_case, guide_angle)
    # Only the free and owned coordinates: a zero one contributes nothing, a joint at a point
    # has none (its rows follow from its link's, below).
    coords = [key for key, kind in layout.coordinate_kind.items() if kind in ("free", "own")]
    col = {key: i for i, key in enumerate(coords)}
    nx, npoint = len(coords), ncase * nstep + _PAD

    # U = H x: joint translations from host-frame coordinates, (3, 2·joints, nx, points).
    H = np.zeros((3, 2 * len(topo.joints), nx, npoint))
    for k, j in enumerate(topo.joints):
        for axis in (0, 1):
            if (j, axis) in col:
                H[:, 2 * k : 2 * k + 2, col[(j, axis)]] = frames[j][:, :, axis]
    if topo.points:
        _point_rows(layout, H, rot, lengths, points, per_case)

    # x = E x_free: zero coordinates vanish, owned ones solve the rigid-link constraints.
    free = layout.free_coordinates
    free_cols = [col[key] for key in free]
    own, solve = [], np.zeros((3, 0, len(free), npoint))
    if layout.constraints:
        rows = np.zeros((3, len(layout.constraints), nx, npoint))
        joint_index = {j: k for k, j in enumerate(topo.joints)}
        sleeve_of = {bar: (sleeve, pivot) for sleeve, (pivot, bar) in topo.sleeves.items()}

        def across(direction, joint, base):  # direction-row jet · (U_joint − U_base)
            k, b = joint_index[joint], joint_index[base]
            return jets.matmul_points(direction, H[:, 2 * k : 2 * k + 2]
                                      - H[:, 2 * b : 2 * b + 2])

        for r, (name, what, _) in enumerate(layout.constraints):
            first, second = topo.links[name]
            if what == "prismatic":  # s e⊥ᵀ(U_T − U_P) − L e⊥ᵀ(U_Q − U_P) = 0
                sleeve, pivot = sleeve_of[name]
                n_row = jets.transpose_points(rot[name][:, :, 1:2])
                s_jet = _padded(np.stack(slide[sleeve]).reshape(3, 1, 1, -1))
                L = per_case(lengths[:, names.index(name)])
                rows[:, r : r + 1] = (jets.matmul_points(s_jet, across(n_row, second, first))
                                      - L * across(n_row, pivot, first))
                continue
            e_row = jets.transpose_points(rot[name][:, :, 0:1])  # e_iᵀ as a (1, 2) jet
            for joint, sign in ((second, 1.0), (first, -1.0)):
                k = joint_index[joint]
                rows[:, r : r + 1] += sign * jets.matmul_points(e_row, H[:, 2 * k : 2 * k + 2])
        own = [col[c[2]] for c in layout.constraints]
        solve = -jets.matmul_points(jets.inverse_points(rows[:, :, own]), rows[:, :, free_cols])

    joint_rows, link_rows, nrow = _row_tables(layout, compact)
    P = np.zeros((3, ncase * nstep, nrow, len(free)))
    _assemble(H, np.array(free_cols, np.int64), np.array(own, np.int64), solve, every,
              _link_ends(layout), link_rows, np.ascontiguousarray(lengths, dtype=float),
              nstep, joint_rows, P)
    return P.reshape((3,) + shape + P.shape[2:])


def _row_tables(layout: Layout, compact: bool) -> tuple[np.ndarray, np.ndarray, int]:
    """The rows :func:`_assemble` writes, :func:`_joint_rows` and :func:`_link_rows`, and the
    rows of P: z's, or with ``compact`` their places in the compact projection
    (:func:`projection`)."""
    joint_rows, link_rows = _joint_rows(layout), _link_rows(layout)
    if not compact:
        return joint_rows, link_rows, layout.nz
    index = layout.projection_index
    compact_rows = lambda rows: np.where(rows >= 0, index[rows], -1)  # noqa: E731
    return (compact_rows(joint_rows), compact_rows(link_rows),
            len(layout.projection_rows) + 2)


#: Copies of the last point appended to the points axis (see :func:`projection`).
_PAD = 8


def _padded(x: np.ndarray) -> np.ndarray:
    """x with its last axis extended by :data:`_PAD` copies of its last entry."""
    return np.concatenate([x, np.repeat(x[..., -1:], _PAD, axis=-1)], axis=-1)


def _link_ends(layout: Layout) -> np.ndarray:
    """(link, 2) int: the joint index of each link's first and second end."""
    topo = layout.topology
    joints = list(topo.joints)
    return np.array([[joints.index(j) for j in topo.links[n]] for n in topo.link_names],
                    np.int64).reshape(-1, 2)


def _joint_rows(layout: Layout) -> np.ndarray:
    """(2·joint,) int: the z row of each joint translation component, −1 for a joint that
    does not move (no free or owned coordinate, not at a point: a ground pivot, a clamped
    input's tip), whose rows of P are zero."""
    moving = ("free", "own", "point")
    return np.array([off + a if any(layout.coordinate_kind[(j, b)] in moving for b in (0, 1))
                     else -1 for j, off in layout.joint_offsets.items() for a in (0, 1)],
                    np.int64)


def _link_rows(layout: Layout) -> np.ndarray:
    """(link, 4) int: the z rows a link's end translations go to, in its frame: a flexible
    link's (u, v) at its first end then at its second; a rigid link's (u0, v0, φ, −1)."""
    out = []
    for name, off in layout.link_offsets.items():
        if layout.flexible[name]:
            out.append([off + d for end in layout.end_dofs[name] for d in end])
        else:
            out.append([off, off + 1, off + 2, -1])
    return np.array(out, np.int64).reshape(-1, 4)


def _written_rows(layout: Layout) -> np.ndarray:
    """:attr:`Layout.projection_rows`: the rows :func:`_assemble_point` writes, by its tests."""
    joint_rows, ends, rows = _joint_rows(layout), _link_ends(layout), _link_rows(layout)
    out = {int(r) for r in joint_rows if r >= 0}
    for (first, second), link in zip(ends, rows):
        rigid = link[3] < 0
        moving = (joint_rows[2 * first] >= 0, joint_rows[2 * second] >= 0)
        for e in range(2):
            if not (moving[e] or (rigid and e == 1 and moving[0])):
                continue
            if not rigid:
                out.update(int(link[2 * e + a]) for a in range(2))
            elif e == 0:  # a rigid link's (u0, v0): its first end's translation
                out.update(int(link[a]) for a in range(2))
            else:  # its φ, from its second end's
                out.add(int(link[2]))
    return np.array(sorted(out), np.int64)


@nb.njit(cache=True, nogil=True)
def _assemble(H, free, own, solve, rot, ends, rows, lengths, nstep, joint_rows, P):
    """Joint and link-end rows of P (3, point, row, nfree; z's rows or the compact ones of
    :func:`projection`, as the row tables say), zero elsewhere, at every point
    (:func:`_assemble_point`) from ``H`` (3, 2·joints, nx, point), ``solve``
    (3, owned, nfree, point) and ``rot`` (3, 2, 2, link, point), which may have more points
    than P (padding); ``lengths`` (case, link) m, ``nstep`` points per case; P zero on
    entry."""
    U = np.zeros((3, H.shape[1], free.shape[0]))
    for p in range(P.shape[1]):
        _assemble_point(H[:, :, :, p], free, own, solve[:, :, :, p], rot[:, :, :, :, p], ends,
                        rows, lengths[p // nstep], joint_rows, P, p, U)


@nb.njit(inline="always", cache=True, nogil=True)
def _assemble_point(H, free, own, solve, rot, ends, rows, lengths, joint_rows, P, p, U):
    """Joint and link-end rows of P[:, p] (3, nz, nfree) at one point: the joint translations
    U = H E (E: the identity on the free coordinates, ``solve`` on the owned ones:
    H[free] + H[own] solve) and each link's end translations in its frame, Rᵀ U, with their
    two time derivatives (Leibniz). ``H`` (3, 2·joints, nx), ``solve`` (3, owned, nfree),
    ``rot`` (3, 2, 2, link), ``lengths`` (link,) m at the point; ``U`` (3, 2·joints, nfree)
    is scratch, zero on entry; ``joint_rows`` (2·joints,) the joints' z rows (−1: a joint
    that does not move, :func:`_joint_rows`).

    A joint that does not move is skipped, and so are the link ends on it: their rows would
    be +0.0 (U is +0.0 there, and r·(+0.0) summed from +0.0 is +0.0), which P and U hold
    already; so are a rigid link's second-end rows it does not use. The same bits as
    computing them, a third to a half of the work (the ground pivots)."""
    nj2, nf, nc = H.shape[1], free.shape[0], own.shape[0]
    for r in range(nj2):
        if joint_rows[r] < 0:
            continue
        for f in range(nf):
            u0, u1, u2 = H[0, r, free[f]], H[1, r, free[f]], H[2, r, free[f]]
            for c in range(nc):
                h0, h1, h2 = H[0, r, own[c]], H[1, r, own[c]], H[2, r, own[c]]
                s0, s1, s2 = solve[0, c, f], solve[1, c, f], solve[2, c, f]
                u0 += h0 * s0
                u1 += h1 * s0 + h0 * s1
                u2 += h2 * s0 + 2.0 * (h1 * s1) + h0 * s2
            U[0, r, f], U[1, r, f], U[2, r, f] = u0, u1, u2
            for d in range(3):
                P[d, p, joint_rows[r], f] = U[d, r, f]
    for i in range(ends.shape[0]):
        rigid = rows[i, 3] < 0
        moving = (joint_rows[2 * ends[i, 0]] >= 0, joint_rows[2 * ends[i, 1]] >= 0)
        for e in range(2):
            k = 2 * ends[i, e]
            if not (moving[e] or (rigid and e == 1 and moving[0])):
                continue  # zero rows (a rigid link's φ is not if its first end moves)
            for a in range(2):  # (Rᵀ U)[a] = Σ_b R[b, a] U[b]
                if rigid and e == 1 and a == 0:
                    continue  # not used: φ takes the transverse component
                for f in range(nf):
                    v0 = v1 = v2 = 0.0
                    for b in range(2):
                        r0, r1, r2 = rot[0, b, a, i], rot[1, b, a, i], rot[2, b, a, i]
                        w0, w1, w2 = U[0, k + b, f], U[1, k + b, f], U[2, k + b, f]
                        v0 += r0 * w0
                        v1 += r1 * w0 + r0 * w1
                        v2 += r2 * w0 + 2.0 * (r1 * w1) + r0 * w2
                    if not rigid:
                        row = rows[i, 2 * e + a]
                        P[0, p, row, f], P[1, p, row, f], P[2, p, row, f] = v0, v1, v2
                    elif e == 0:  # (u0, v0): the first end's translation
                        row = rows[i, a]
                        P[0, p, row, f], P[1, p, row, f], P[2, p, row, f] = v0, v1, v2
                    else:  # φ = e⊥ᵀ(Us − Uf)/L
                        L = lengths[i]
                        row, first = rows[i, 2], rows[i, 1]
                        P[0, p, row, f] = (v0 - P[0, p, first, f]) / L
                        P[1, p, row, f] = (v1 - P[1, p, first, f]) / L
                        P[2, p, row, f] = (v2 - P[2, p, first, f]) / L


#: Build P in one compiled pass over the points (:func:`_project`) where the layout has no
#: RPR sleeve and at most one rigid-link constraint; ``CED_KERNEL=numpy`` keeps the numpy
#: jets (:mod:`ced.fem.jets`), the reference it is tested against (the same bits).
COMPILED = os.environ.get("CED_KERNEL", "numba") != "numpy"


def _projection_compiled(layout: Layout, lengths: np.ndarray, link_angle: np.ndarray,
                         link_velocity: np.ndarray, link_acceleration: np.ndarray,
                         points: dict[str, np.ndarray] | None,
                         guide_angle: dict[str, np.ndarray] | None,
                         compact: bool = False) -> np.ndarray:
    """:func:`projection` by :func:`_project`, from tables of the layout: each point's jets
    (rotations, H, the point rows, the constraint and its solution) stay in a few hundred
    bytes of scratch instead of arrays over every point with a numpy call per joint and link
    (a Watt II's point and owned coordinate cost 3× the four-bar's projection so)."""
    topo = layout.topology
    ncase, nstep = shape = link_angle.shape[:2]
    joints, names = list(topo.joints), topo.link_names
    guides = guide_angle or {}
    # Per joint: its frame (0 the global one, 1 its host link's, 2 a fixed guide's) and which.
    frame = np.zeros((len(joints), 2), np.int64)
    for k, j in enumerate(joints):
        if j in guides:
            frame[k] = (2, list(guides).index(j))
        elif layout.host[j] is not None:
            frame[k] = (1, names.index(layout.host[j]))
    guide = np.zeros((ncase, len(guides), 2))
    for g, phi in enumerate(guides.values()):
        guide[:, g, 0], guide[:, g, 1] = np.cos(phi), np.sin(phi)
    coords = [key for key, kind in layout.coordinate_kind.items() if kind in ("free", "own")]
    col = {key: i for i, key in enumerate(coords)}
    column = np.array([[col.get((j, axis), -1) for axis in (0, 1)] for j in joints],
                      np.int64).reshape(-1, 2)
    order = _point_order(topo)
    point = np.array([[joints.index(j), names.index(topo.points[j]),
                       *(joints.index(e) for e in topo.links[topo.points[j]])] for j in order],
                     np.int64).reshape(-1, 4)
    xy = np.zeros((ncase, len(order), 2))
    for q, j in enumerate(order):
        xy[:, q] = np.asarray(points[j], float)
    constraint = np.array([[names.index(name), *(joints.index(e) for e in topo.links[name])]
                           for name, _, _ in layout.constraints], np.int64).reshape(-1, 3)
    free = np.array([col[key] for key in layout.free_coordinates], np.int64)
    own = np.array([col[c[2]] for c in layout.constraints], np.int64)
    joint_rows, link_rows, nrow = _row_tables(layout, compact)
    flat = lambda x: np.require(x, float, "C").reshape(ncase * nstep, -1)  # noqa: E731
    P = np.zeros((3, ncase * nstep, nrow, len(free)))
    _project(flat(np.cos(link_angle)), flat(np.sin(link_angle)), flat(link_velocity),
             flat(link_acceleration), nstep, frame, guide, column, len(coords), point, xy,
             constraint, free, own, _link_ends(layout), link_rows,
             np.ascontiguousarray(lengths, dtype=float), joint_rows, P)
    return P.reshape((3,) + shape + P.shape[2:])


@nb.njit(cache=True, nogil=True)
def _project(cos, sin, w, al, nstep, frame, guide, column, nx, point, xy, constraint, free,
             own, ends, rows, lengths, joint_rows, P):
    """P (3, point, row, nfree; as for :func:`_assemble`) point by point with the arithmetic
    of the numpy path of :func:`projection` operation for operation (the jets of
    :mod:`ced.fem.jets`): the link rotation jets, H, the rows of joints at points, one
    rigid-link constraint solved for its owned coordinate, then :func:`_assemble_point`.
    ``cos``, ``sin``, ``w``, ``al`` (point, link) the rigid link angles' cosine and sine,
    rad/s, rad/s²; the tables as :func:`_projection_compiled` makes them; P zero on
    entry."""
    nlink, njoint, nf, nc = cos.shape[1], frame.shape[0], free.shape[0], own.shape[0]
    rot = np.empty((3, 2, 2, nlink))
    H = np.empty((3, 2 * njoint, nx))
    R = np.empty((3, max(nc, 1), nx))
    solve = np.empty((3, nc, nf))
    U = np.zeros((3, 2 * njoint, nf))  # the rows of joints that do not move stay zero
    e, n, wv = np.empty((3, 2)), np.empty((3, 2)), np.empty((3, 2))
    D, phi = np.empty((3, 2)), np.empty(3)
    for p in range(P.shape[1]):
        case = p // nstep
        for i in range(nlink):  # jets.rotation_points
            c, s, ww, aa = cos[p, i], sin[p, i], w[p, i], al[p, i]
            cj = (c, -ww * s, -aa * s - ww * ww * c)
            sj = (s, ww * c, aa * c - ww * ww * s)
            for d in range(3):
                rot[d, 0, 0, i], rot[d, 0, 1, i] = cj[d], -sj[d]
                rot[d, 1, 0, i], rot[d, 1, 1, i] = sj[d], cj[d]
        H[:] = 0.0
        for k in range(njoint):  # a coordinate's column: its frame's axis
            for axis in range(2):
                x = column[k, axis]
                if x < 0:
                    continue
                for b in range(2):
                    if frame[k, 0] == 1:
                        for d in range(3):
                            H[d, 2 * k + b, x] = rot[d, b, axis, frame[k, 1]]
                    elif frame[k, 0] == 2:
                        g = frame[k, 1]
                        cg, sg = guide[case, g, 0], guide[case, g, 1]
                        H[0, 2 * k + b, x] = (cg if b == axis else
                                              (-sg if b == 0 else sg))
                    else:
                        H[0, 2 * k + b, x] = 1.0 if b == axis else 0.0
        for q in range(point.shape[0]):  # _point_rows
            j, i, kf, ks = point[q, 0], point[q, 1], point[q, 2], point[q, 3]
            x, y, L = xy[case, q, 0], xy[case, q, 1], lengths[case, i]
            for d in range(3):
                for b in range(2):
                    e[d, b], n[d, b] = rot[d, b, 0, i], rot[d, b, 1, i]
                    wv[d, b] = x * n[d, b] - y * e[d, b]
            for m in range(nx):
                for d in range(3):
                    for b in range(2):
                        D[d, b] = H[d, 2 * ks + b, m] - H[d, 2 * kf + b, m]
                phi[0] = _dot(n, 0, D, 0)
                phi[1] = _dot(n, 1, D, 0) + _dot(n, 0, D, 1)
                phi[2] = _dot(n, 2, D, 0) + 2.0 * _dot(n, 1, D, 1) + _dot(n, 0, D, 2)
                for d in range(3):
                    phi[d] = phi[d] / L
                for b in range(2):
                    t0 = wv[0, b] * phi[0]
                    t1 = wv[1, b] * phi[0] + wv[0, b] * phi[1]
                    t2 = wv[2, b] * phi[0] + 2.0 * (wv[1, b] * phi[1]) + wv[0, b] * phi[2]
                    H[0, 2 * j + b, m] = H[0, 2 * kf + b, m] + t0
                    H[1, 2 * j + b, m] = H[1, 2 * kf + b, m] + t1
                    H[2, 2 * j + b, m] = H[2, 2 * kf + b, m] + t2
        for r in range(nc):  # e_iᵀ(U_s − U_f) = 0, as the numpy path sums it
            i = constraint[r, 0]
            for d in range(3):
                for b in range(2):
                    e[d, b] = rot[d, b, 0, i]
            for m in range(nx):
                for d in range(3):
                    R[d, r, m] = 0.0
                for k, sign in ((constraint[r, 2], 1.0), (constraint[r, 1], -1.0)):
                    for d in range(3):
                        for b in range(2):
                            D[d, b] = H[d, 2 * k + b, m]
                    R[0, r, m] += sign * _dot(e, 0, D, 0)
                    R[1, r, m] += sign * (_dot(e, 1, D, 0) + _dot(e, 0, D, 1))
                    R[2, r, m] += sign * (_dot(e, 2, D, 0) + 2.0 * _dot(e, 1, D, 1)
                                          + _dot(e, 0, D, 2))
        if nc == 1:  # jets.inverse_points of the 1 × 1 jet, then −X⁻¹ R[free]
            x0, x1, x2 = R[0, 0, own[0]], R[1, 0, own[0]], R[2, 0, own[0]]
            y0 = 1.0 / x0
            y1 = -((y0 * x1) * y0)
            y2 = -(y0 * (x2 * y0 + 2.0 * (x1 * y1)))
            for f in range(nf):
                f0, f1, f2 = R[0, 0, free[f]], R[1, 0, free[f]], R[2, 0, free[f]]
                solve[0, 0, f] = -(y0 * f0)
                solve[1, 0, f] = -(y1 * f0 + y0 * f1)
                solve[2, 0, f] = -(y2 * f0 + 2.0 * (y1 * f1) + y0 * f2)
        _assemble_point(H, free, own, solve, rot, ends, rows, lengths[case], joint_rows, P, p,
                        U)


@nb.njit(inline="always", cache=True, nogil=True)
def _dot(x, dx, y, dy):
    """x[dx] · y[dy] of two 2-vector jets (3, 2), summed as :func:`ced.fem.jets._product`."""
    return x[dx, 0] * y[dy, 0] + x[dx, 1] * y[dy, 1]
