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

from dataclasses import dataclass

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
    """

    topology: Topology
    flexible: dict[str, bool]
    link_sizes: dict[str, int]
    end_dofs: dict[str, tuple[tuple[int, int], tuple[int, int]]]
    clamp_dofs: tuple[int, ...]
    host: dict[str, str | None]
    coordinate_kind: dict[tuple[str, int], str]
    constraints: list[tuple[str, str, tuple[str, int]]]

    @property
    def link_offsets(self) -> dict[str, int]:
        out, k = {}, 0
        for name in self.topology.links:
            out[name] = k
            k += self.link_sizes[name]
        return out

    @property
    def joint_offsets(self) -> dict[str, int]:
        base = sum(self.link_sizes.values())
        return {j: base + 2 * i for i, j in enumerate(self.topology.joints)}

    @property
    def nz(self) -> int:
        return sum(self.link_sizes.values()) + 2 * len(self.topology.joints)

    @property
    def free_coordinates(self) -> list[tuple[str, int]]:
        return [key for key, kind in self.coordinate_kind.items() if kind == "free"]

    @property
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

    @property
    def ny(self) -> int:
        return len(self.free_coordinates) + len(self.interior_dofs)

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
        varying = [i for i in range(self.link_sizes[link]) if i not in set(rows)]
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


def _point_rows(layout: Layout, H: np.ndarray, rot: dict, lengths: np.ndarray,
                points: dict[str, np.ndarray], per_case) -> None:
    """Fill the rows of H (3, 2·joints, nx, points) of joints at points of rigid links:
    U_E = U_f + φ (x e⊥ − y e) with φ = e⊥ᵀ(U_s − U_f)/L, in an order where each link's ends
    are known first."""
    topo = layout.topology
    joints = list(topo.joints)
    rows = {j: slice(2 * k, 2 * k + 2) for k, j in enumerate(joints)}
    todo = [j for j in joints if j in topo.points]
    while todo:
        ready = [j for j in todo if not {*topo.links[topo.points[j]]} & set(todo)]
        if not ready:
            raise ValueError(f"joints {todo}: points of links that hang from each other")
        for j in ready:
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
            todo.remove(j)


def projection(
    layout: Layout,
    lengths: np.ndarray,
    link_angle: np.ndarray,
    link_velocity: np.ndarray,
    link_acceleration: np.ndarray,
    points: dict[str, np.ndarray] | None = None,
    guide_angle: dict[str, np.ndarray] | None = None,
    slide: dict[str, tuple] | None = None,
) -> np.ndarray:
    """Jet of the joint-coordinate columns of P(t), shape (3, case, step, nz, nfree).

    z = P y where y = (joint coordinates, interior DOFs); the interior columns of P are
    constant unit columns (each interior DOF is its own z entry), so only the first nfree
    columns are built; :meth:`Layout.expand` applies the whole P.

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
    names = topo.link_names
    # Every jet below has its (case, step) points flattened on the last axis
    # (jets.matmul_points): the products are of 2 × 2 rotations and a few columns, cheap per
    # point but many points; a case's constant repeats over its steps.
    flat = lambda x: x.reshape(ncase * nstep, -1).T  # noqa: E731  (case, step, k) -> (k, points)
    per_case = lambda x: np.repeat(np.asarray(x, float), nstep)  # noqa: E731
    every = jets.rotation_points(flat(link_angle), flat(link_velocity), flat(link_acceleration))
    rot = {n: every[:, :, :, i] for i, n in enumerate(names)}
    frames = _frame_jets(layout, rot, per_case, guide_angle)
    # Only the free and owned coordinates: a zero one contributes nothing, a joint at a point
    # has none (its rows follow from its link's, below).
    coords = [key for key, kind in layout.coordinate_kind.items() if kind in ("free", "own")]
    col = {key: i for i, key in enumerate(coords)}
    nx, npoint = len(coords), ncase * nstep

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
    HE = H[:, :, free_cols]  # joint translations from the free coordinates (U = H E x_free)
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
                s_jet = np.stack(slide[sleeve]).reshape(3, 1, 1, npoint)
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
        # H E with E = (identity on the free rows, the solve on the owned ones).
        HE = HE + jets.matmul_points(H[:, :, own], solve)

    # Padded points axis: the transposed copy at the end reads down the rows at a stride of
    # the points axis, which at a power of two (64 phases × 16 cases) maps every row to the
    # same cache set (5× slower).
    P = np.zeros((3, layout.nz, len(free), npoint + 8))[..., :npoint]
    joint_index = {j: k for k, j in enumerate(topo.joints)}
    for j, off in layout.joint_offsets.items():
        k = joint_index[j]
        P[:, off : off + 2] = HE[:, 2 * k : 2 * k + 2]
    # Every link's end translations in its frame, all links at once: (3, 2, nfree, end, link,
    # points); one product however many links.
    ends = [[joint_index[topo.links[n][e]] for n in names] for e in (0, 1)]
    U = np.moveaxis(HE.reshape((3, -1, 2) + HE.shape[2:])[:, ends], (1, 2), (3, 4))
    local = jets.matmul_points(jets.transpose_points(every)[:, :, :, None], U)
    link_off = layout.link_offsets
    for i, name in enumerate(names):
        off = link_off[name]
        if layout.flexible[name]:
            for e, (u, v) in enumerate(layout.end_dofs[name]):
                P[:, off + u] = local[:, 0, :, e, i]
                P[:, off + v] = local[:, 1, :, e, i]
        else:
            # Rigid link (u0, v0, φ): first-end motion in the link frame and φ = e⊥ᵀ(Us − Uf)/L.
            P[:, off : off + 2] = local[:, :, :, 0, i]
            P[:, off + 2] = (local[:, 1, :, 1, i] - local[:, 1, :, 0, i]) / per_case(lengths[:, i])
    # Back to the points first, as the effects' products read it.
    return np.ascontiguousarray(np.moveaxis(P, -1, 1)).reshape((3,) + shape + P.shape[1:3])
