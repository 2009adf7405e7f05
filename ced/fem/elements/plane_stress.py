"""2-D plane-stress continuum link: the thesis's II.3 Lamé equations before the II.5 thin-link
simplification, meshed with quadratic quadrilaterals — the high-fidelity reference formulation.

Geometry and mesh
-----------------
A link of length L and in-plane height h (the section's ``height``; out-of-plane thickness
t = A/h, so a rectangle b × h is exact) occupies x ∈ [0, L], y ∈ [−h/2, h/2] in its own
frame (x from the first joint to the second, docs/theory.md). It is meshed with
``n_elements`` × ``elements_across`` equal rectangles, 8-node serendipity (default) or 9-node
Lagrange. Nodes are numbered column by column along x (bottom to top in each column), two DOFs
(u, v) each.
3 × 3 Gauss quadrature is exact on rectangles for every matrix below (highest degree 4 per
direction: NᵀN, s² N_xᵀN_x), and full integration of quadratic rectangles does not lock in
bending (u = −κxy, v = κ(x² + νy²)/2 lie in both spaces).

Physics (docs/theory.md, thesis II.3; σ = D ε, plane stress)
------------------------------------------------------------
::

    K   = ∫ Bᵀ D B t dA,   D = E/(1 − ν²) [[1, ν, 0], [ν, 1, 0], [0, 0, (1 − ν)/2]]
    M   = M_w = ∫ ρ t NᵀN dA       (the continuum carries its rotary inertia itself)
    G   = ∫ ρ t Nᵀ J N dA           (antisymmetric, J the 90° rotation)
    Kg_k = ∫ s^k (u_xᵀu_x + v_xᵀv_x) (t/A) dA
    L0  = ∫ Nᵀ (t/A) dA,  L1 = ∫ s Nᵀ (t/A) dA
    moment_load = −(t/I) ∫ N_uᵀ y dA,  across_load = ∫ Nᵀ y t dA

*Geometric stiffness.* The beam formulations carry the axial force N(s) as P ∫v'ᵀv' ds. Here
N(s) is spread uniformly over the section, σ_xx = N/A, and acts — as the continuum initial-stress
term ``∫ σ_ij w_,iᵀ w_,j dV`` does — on the x-derivatives of both displacement components. The
u_x part adds N/(EA) relative to the axial stiffness (negligible, and what Green–Lagrange
strain gives); the shear and bending stresses of the rigid motion are left out, as in the
beams.

*Loads.* A distributed load b(s) (N/m) is spread uniformly over the section (body force
b/A), so the resultant of L0 is L per component (take it with :func:`rigid_modes`: the face
DOFs are relative, a plain sum is not the resultant) and the rigid-motion loads ked builds
(ρA(g − a_P), ρA(ω², −α) s) are the exact x-dependent part of the d'Alembert body force.
The rigid body force of the continuum is −ρ(αJ − ω²)(x, y) = ρ(ω²x + αy, ω²y − αx); its
y-dependent part ρ(αy, ω²y) has no resultant. Its α part is a distributed couple: with
m0 = −ρIα (what ked passes for a mass matrix with rotary inertia, I = ``second_moment``)
``m0 × moment_load`` is exactly ρα ∫ N_uᵀ y t dA for any section shape (I is the one
given). The ω² part, ρω²y across the section, is a self-equilibrated transverse stretch that
the (b0, b1, m0) interface cannot carry; ``across_load`` (…, n, 2) holds ∫ Nᵀ y t dA so that
``across_load @ (ρα, ρω²)`` is the whole y part (then drop m0), or ``ρω² across_load[..., 1]``
adds the missing piece. It strains the section by about ρω²h²/E (≈ 4e-8 for steel,
h = 1 cm, 100 rad/s).

Pins (the tie)
--------------
Thesis joints are pins at (0, 0) and (L, 0), transmitting force but no moment. Each end
face's nodal displacements are written as d_i = p + r_i, p the pin translation and r_i a face
deformation with zero weighted mean Σ w_i r_i = 0, w_i = ∫_face N_i dy / h the consistent face
weights (RBE3-like: the pin is the weighted average of its face). The face's centre node
(y = 0) is eliminated, r_c = −Σ_{i≠c} (w_i/w_c) r_i, so the change of variables d = T q is
square and invertible and every matrix is Tᵀ A T (a free link keeps exactly three rigid
modes). The pins' (u, v) are true DOFs: ``end_dofs = ((0, 1), (n − 2, n − 1))``; the force
on a pin spreads over its face as a uniform traction. A rigid rotation about the pin has
p = 0 (the weights are symmetric in y) and costs no energy: the pin carries no moment.
``end_rotations[0]`` is the tuple of the face-0 deformation DOFs r (4 × elements_across
of them): a clamp holding them makes the face move rigidly with the pin translation — the driven
crank's pivot; ``end_rotations[1]`` likewise at L.

DOF order of q: (u, v) of pin 0, then every node's (u, v) in node order with the two face
centre nodes replaced by the pins (face nodes carry their deformation r_i), then pin L.

Recovery
--------
Centre-line (y = 0) ``u``, ``v``, ``rotation`` = ∂v/∂x, ``axial_strain`` = ε_xx; ``curvature``
= −(ε_xx(h/2) − ε_xx(−h/2))/h, so that curvature × h/2 is the outer-fibre bending strain with
the beam sign (ε = u' − y v''); ced's E(ε_axial ± κh/2) then uses the uniaxial modulus,
while the plane-stress σ_xx = E/(1 − ν²)(ε_xx + ν ε_yy) — equal when σ_yy = 0, as in a beam away
from loads and pins; the exact σ_xx at the outer fibres is also given (``stress_top``,
``stress_bottom``, Pa per unit q). Fields whose derivative jumps between elements are
averaged over the adjacent elements. The centre-line v at stations 0 and 1 is that of the face
centre, which differs from the pin's v by the face deformation r_c (local, small).

Examples
--------
>>> lm = link_matrices(0.2, 4, E=2.1e11, G_shear=8.0e10, rho=7850.0, area=1e-4,
...                    second_moment=1e-4 * 0.01**2 / 12, height=0.01)
>>> lm.mass.shape, lm.end_dofs, len(lm.end_rotations[0])
((74, 74), ((0, 1), (72, 73)), 8)
>>> # the resultant of a uniform unit load is L (face DOFs are relative: use the rigid modes)
>>> round(float(rigid_modes(lm)[:, 1] @ lm.load_constant[:, 1]), 12)
0.2
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .link import LinkMatrices, broadcast_parameters, station_elements

__all__ = ["ContinuumLinkMatrices", "link_matrices", "recovery_matrices", "shape_functions",
           "mesh", "rigid_modes", "FORMULATION"]

FORMULATION = "plane_stress"
N_GAUSS = 3  # per direction, exact on rectangles (degree ≤ 4 per direction)
_LOCAL = [(i, j) for j in range(3) for i in range(3)]  # local node grid (x index, y index)


@dataclass(frozen=True)
class ContinuumLinkMatrices(LinkMatrices):
    """:class:`LinkMatrices` plus the mesh and material data of the continuum.

    Attributes
    ----------
    across_load : (..., n, 2) ∫ Nᵀ y t dA, m³; f += across_load @ (ρα, ρω²) is the
        y-dependent part of the rigid d'Alembert body force (see the module docstring)
    elements_across : elements over the height
    nodes_per_element : 8 (serendipity) or 9 (Lagrange)
    youngs_modulus, poisson_ratio, thickness : (...) E (Pa), ν, t = A/h (m)
    transform : (2·nodes, n) the change of variables d = T q from the link DOFs q to the nodal
        displacements d (node order, (u, v) per node) — shared by the batch
    node_coordinates : (..., nodes, 2) (x, y) of every node, m
    """

    across_load: np.ndarray | None = None
    elements_across: int = 2
    nodes_per_element: int = 8
    youngs_modulus: np.ndarray | None = None
    poisson_ratio: np.ndarray | None = None
    thickness: np.ndarray | None = None
    transform: np.ndarray | None = None
    node_coordinates: np.ndarray | None = None


# --------------------------------------------------------------------------- shape functions
def shape_functions(xi, eta, nodes_per_element: int = 8) -> dict:
    """Reference shape functions on [−1, 1]² at points (ξ, η) (g,) → dict of (g, m) arrays.

    ``N``, ``dxi`` = ∂N/∂ξ, ``deta`` = ∂N/∂η; local nodes in the order of the 3 × 3 grid
    (x index fastest), without the centre for the 8-node serendipity element.

    Parameters
    ----------
    xi, eta : array_like
        Reference coordinates ξ, η ∈ [−1, 1] of the points, shape (g,).
    nodes_per_element : int, optional
        8 (serendipity) or 9 (Lagrange).

    Returns
    -------
    dict
        ``N``, ``dxi``, ``deta``, each (g, m) with m = ``nodes_per_element``.
    """
    xi, eta = np.asarray(xi, float), np.asarray(eta, float)
    if nodes_per_element == 9:
        def q(t):  # 1-D quadratic Lagrange at −1, 0, 1 and derivatives
            return (np.stack([0.5 * t * (t - 1), 1 - t * t, 0.5 * t * (t + 1)], -1),
                    np.stack([t - 0.5, -2 * t, t + 0.5], -1))
        lx, dlx = q(xi)
        ly, dly = q(eta)
        N = np.stack([lx[..., i] * ly[..., j] for i, j in _LOCAL], -1)
        dxi = np.stack([dlx[..., i] * ly[..., j] for i, j in _LOCAL], -1)
        deta = np.stack([lx[..., i] * dly[..., j] for i, j in _LOCAL], -1)
        return {"N": N, "dxi": dxi, "deta": deta}
    if nodes_per_element != 8:
        raise ValueError(f"nodes_per_element must be 8 or 9, got {nodes_per_element}")
    N, dxi, deta = [], [], []
    for i, j in _LOCAL:
        if (i, j) == (1, 1):
            continue
        a, b = i - 1, j - 1
        if a and b:  # corner
            N.append(0.25 * (1 + a * xi) * (1 + b * eta) * (a * xi + b * eta - 1))
            dxi.append(0.25 * a * (1 + b * eta) * (2 * a * xi + b * eta))
            deta.append(0.25 * b * (1 + a * xi) * (a * xi + 2 * b * eta))
        elif a == 0:  # mid-side of a horizontal edge
            N.append(0.5 * (1 - xi * xi) * (1 + b * eta))
            dxi.append(-xi * (1 + b * eta))
            deta.append(0.5 * b * (1 - xi * xi))
        else:  # mid-side of a vertical edge
            N.append(0.5 * (1 + a * xi) * (1 - eta * eta))
            dxi.append(0.5 * a * (1 - eta * eta))
            deta.append(-eta * (1 + a * xi))
    return {"N": np.stack(N, -1), "dxi": np.stack(dxi, -1), "deta": np.stack(deta, -1)}


def _local_grid(nodes_per_element: int):
    return [p for p in _LOCAL if nodes_per_element == 9 or p != (1, 1)]


# ------------------------------------------------------------------------------------ mesh
def mesh(n_elements: int, elements_across: int, nodes_per_element: int = 8) -> dict:
    """Topology of the structured mesh (independent of sizes).

    Parameters
    ----------
    n_elements : int
        Elements along the link, ne.
    elements_across : int
        Elements across the section height, na.
    nodes_per_element : int, optional
        8 or 9 (see :func:`shape_functions`).

    Returns
    -------
    dict: ``grid`` (nodes, 2) integer positions (column c, row r) on the half-element grid,
    x = c a/2, y = −h/2 + r b/2; ``connectivity`` (ne·na, m) node indices of each element
    (element (e, k) at index e·na + k, local node order of :func:`shape_functions`);
    ``element_index`` (ne·na, 2) the (e, k) of each element; ``node`` dict (c, r) → index.
    """
    ne, na = int(n_elements), int(elements_across)
    node, grid = {}, []
    for c in range(2 * ne + 1):
        for r in range(2 * na + 1):
            if nodes_per_element == 8 and c % 2 and r % 2:
                continue
            node[(c, r)] = len(grid)
            grid.append((c, r))
    local = _local_grid(nodes_per_element)
    conn, index = [], []
    for e in range(ne):
        for k in range(na):
            conn.append([node[(2 * e + i, 2 * k + j)] for i, j in local])
            index.append((e, k))
    return {"grid": np.array(grid, int), "connectivity": np.array(conn, int),
            "element_index": np.array(index, int), "node": node}


def _face_transform(na: int):
    """T_f (2m, 2m) of one face with m = 2na + 1 nodes bottom to top: columns (u, v) of the
    pin at the centre node's slots, the other nodes' columns their deformation r_i."""
    m = 2 * na + 1
    w = np.zeros(m)  # consistent weights of quadratic edges: (1, 4, 1)/6 of each edge
    for k in range(na):
        w[2 * k: 2 * k + 3] += np.array([1.0, 4.0, 1.0]) / (6.0 * na)
    c = na
    Tf = np.eye(2 * m)
    for comp in range(2):
        Tf[comp::2, 2 * c + comp] = 1.0  # pin translation moves every node
        for i in range(m):
            if i != c:
                Tf[2 * c + comp, 2 * i + comp] = -w[i] / w[c]
    return Tf, w


def _transform(n_elements, na, nodes_per_element):
    """(T, order, faces, topo, tie): d = T q (T (nd, nd), columns in the final DOF order),
    ``order`` the slot of each final DOF, ``faces`` the DOF slots of the two end faces, the
    mesh ``topo`` and the cheap applicator ``tie`` of Tᵀ A T."""
    topo = mesh(n_elements, na, nodes_per_element)
    n_nodes = len(topo["grid"])
    nd = 2 * n_nodes
    m = 2 * na + 1
    Tf, w = _face_transform(na)
    faces = [np.arange(2 * m), nd - 2 * m + np.arange(2 * m)]  # face 0 / L DOF slots
    T = np.eye(nd)
    for f in faces:
        T[np.ix_(f, f)] = Tf
    pin = [int(f[2 * na]) for f in faces]  # u slot of each face's centre node
    rest = [i for i in range(nd) if i not in (pin[0], pin[0] + 1, pin[1], pin[1] + 1)]
    order = np.array([pin[0], pin[0] + 1] + rest + [pin[1], pin[1] + 1], int)
    return T[:, order], order, faces, topo, _Tie(Tf, faces, order)


# ------------------------------------------------------------------------------- assembly
def _assemble_matrix(ke, conn, nd, per_element=False):
    """Σ over elements of (..., E, 2m, 2m) (per_element) or (..., 2m, 2m) (shared by every
    element) into (..., nd, nd).

    For a fixed local pair (a, b) the global pairs of different elements are distinct (each
    local grid position maps injectively), so fancy-index += never collides."""
    dof = np.stack([2 * conn, 2 * conn + 1], -1).reshape(conn.shape[0], -1)  # (E, 2m)
    shared = not per_element
    out = np.zeros(ke.shape[:-2 if shared else -3] + (nd, nd))
    for a in range(dof.shape[1]):
        for b in range(dof.shape[1]):
            val = ke[..., a, b]
            out[..., dof[:, a], dof[:, b]] += val[..., None] if shared else val
    return out


def _assemble_vector(fe, conn, nd):
    """(..., E, 2m, c) element vectors into (..., nd, c)."""
    dof = np.stack([2 * conn, 2 * conn + 1], -1).reshape(conn.shape[0], -1)
    out = np.zeros(fe.shape[:-3] + (nd, fe.shape[-1]))
    for a in range(dof.shape[1]):
        out[..., dof[:, a], :] += fe[..., :, a, :]
    return out


class _Tie:
    """The change of variables d = T q, applied cheaply: T is the identity but for the two
    face blocks (T_f) followed by the permutation ``order`` of the columns."""

    def __init__(self, Tf, faces, order):
        self.Tf, self.faces, self.order = Tf, faces, order

    def matrix(self, A):
        """Tᵀ A T of (..., nd, nd)."""
        A = A.copy()
        for f in self.faces:
            A[..., :, f] = A[..., :, f] @ self.Tf
            A[..., f, :] = self.Tf.T @ A[..., f, :]
        return A[..., self.order, :][..., :, self.order]

    def vector(self, f):
        """Tᵀ f of (..., nd, c)."""
        f = f.copy()
        for face in self.faces:
            f[..., face, :] = self.Tf.T @ f[..., face, :]
        return f[..., self.order, :]


def _lame(E, G_shear, nu):
    if nu is None:
        if G_shear is None:
            raise ValueError("plane_stress needs Poisson's ratio nu or the shear modulus G_shear")
        nu = np.asarray(E, float) / (2.0 * np.asarray(G_shear, float)) - 1.0
    nu = np.asarray(nu, float)
    if np.any(~((nu > -1.0) & (nu < 0.5))):
        raise ValueError(f"plane_stress needs -1 < nu < 0.5, got {nu}")
    return nu


def link_matrices(length, n_elements: int, *, E, rho, area, second_moment, G_shear=None,
                  height, shear_coefficient=None, rotary_inertia: bool = False, nu=None,
                  elements_across: int = 2, nodes_per_element: int = 8
                  ) -> ContinuumLinkMatrices:
    """Matrices of a link meshed with ``n_elements`` × ``elements_across`` plane-stress quads.

    Parameters
    ----------
    length : (...) link length L, m
    n_elements : elements along the link (shared by the batch)
    E : (...) Young's modulus, Pa
    rho : (...) density, kg/m³
    area : (...) section area A, m² (thickness t = A/h)
    second_moment : (...) I, m⁴ — only scales ``moment_load`` so that m0 = −ρIα is exact
    G_shear : (...) shear modulus, Pa; ν = E/(2G) − 1 unless ``nu`` is given
    height : (...) in-plane depth h, m (required)
    shear_coefficient, rotary_inertia : ignored (the continuum needs neither; its mass has all
        the inertia)
    nu : (...) Poisson's ratio (takes precedence over G_shear)
    elements_across : elements over the height (≥ 1)
    nodes_per_element : 8 (serendipity) or 9 (Lagrange)

    Returns
    -------
    ContinuumLinkMatrices; n = 2 × (number of nodes) DOFs, ordered as in the module docstring.
    """
    ne, na = int(n_elements), int(elements_across)
    if ne < 1 or na < 1:
        raise ValueError(f"n_elements and elements_across must be >= 1, got {ne}, {na}")
    if height is None:
        raise ValueError("plane_stress needs the section height")
    p = broadcast_parameters(length=length, E=E, rho=rho, area=area, I=second_moment,
                             height=height, G=G_shear, nu=nu)
    L, h = p["length"], p["height"]
    if np.any(~(L > 0)) or np.any(~(h > 0)) or np.any(~(p["area"] > 0)):
        raise ValueError("link length, section height and area must be positive")
    nuv = np.broadcast_to(_lame(p["E"], p["G"], p["nu"]), L.shape).astype(float)
    t = p["area"] / h
    T, order, faces, topo, tie = _transform(ne, na, nodes_per_element)
    conn, eidx = topo["connectivity"], topo["element_index"]
    nd = T.shape[0]

    # Reference shapes at the 3 × 3 Gauss points.
    g1, w1 = np.polynomial.legendre.leggauss(N_GAUSS)
    XI, ETA = np.meshgrid(g1, g1, indexing="ij")
    xi, eta, wg = XI.ravel(), ETA.ravel(), np.outer(w1, w1).ravel()
    sh = shape_functions(xi, eta, nodes_per_element)
    m2 = 2 * sh["N"].shape[-1]

    def comp(a, c):  # scalar shapes (..., g, m) → vector-field component c rows (..., g, 2m)
        out = np.zeros(a.shape[:-1] + (m2,))
        out[..., c::2] = a
        return out

    a_el, b_el = L / ne, h / na  # element sizes (...)
    col = lambda v: np.asarray(v, float)[..., None]  # noqa: E731
    dA = col(a_el * b_el / 4.0) * wg  # (..., g)
    Nx = sh["dxi"] * col(2.0 / a_el)[..., None]  # (..., g, m)
    Ny = sh["deta"] * col(2.0 / b_el)[..., None]
    Nu, Nv = comp(sh["N"], 0), comp(sh["N"], 1)
    ux, uy, vx, vy = comp(Nx, 0), comp(Ny, 0), comp(Nx, 1), comp(Ny, 1)

    def gram(A, B, weight):
        return np.einsum("...g,...gi,...gj->...ij", weight, A, B)

    c0 = p["E"] / (1.0 - nuv**2) * t  # plane-stress modulus × thickness
    gam = uy + vx
    ke = col(col(c0)) * (gram(ux, ux, dA) + gram(vy, vy, dA)
                         + col(col(nuv)) * (gram(ux, vy, dA) + gram(vy, ux, dA))
                         + col(col(0.5 * (1.0 - nuv))) * gram(gam, gam, dA))
    rho_t = col(p["rho"] * t)
    mw = gram(Nu, Nu, rho_t * dA) + gram(Nv, Nv, rho_t * dA)
    gy = gram(Nv, Nu, rho_t * dA) - gram(Nu, Nv, rho_t * dA)  # ∫ρt (v_i u_j − u_i v_j)

    # Position-dependent element integrals, per element column e (x) and row k (y).
    x_el = col(a_el)[..., None] * (np.arange(ne)[:, None] + 0.5 * (1.0 + xi))  # (..., ne, g)
    y_el = (col(-h / 2)[..., None]
            + col(b_el)[..., None] * (np.arange(na)[:, None] + 0.5 * (1.0 + eta)))  # (..., na, g)
    per_len = dA / col(h)  # t/A dA = dA/h
    powers = np.stack([np.ones_like(x_el), x_el, x_el**2], -3)  # (..., 3, ne, g)
    kg_cols = (gram(ux[..., None, None, :, :], ux[..., None, None, :, :],
                    powers * per_len[..., None, None, :])
               + gram(vx[..., None, None, :, :], vx[..., None, None, :, :],
                      powers * per_len[..., None, None, :]))  # (..., 3, ne, 2m, 2m)
    Nmat = np.stack([Nu, Nv], -1)  # (..., g, 2m, 2)
    l0 = np.einsum("...g,...gmc->...mc", per_len, Nmat)
    l1_cols = np.einsum("...eg,...gmc->...emc", x_el * per_len[..., None, :], Nmat)
    across_rows = np.einsum("...kg,...gmc->...kmc", y_el * col(t)[..., None] * dA[..., None, :],
                            Nmat)
    e_of, k_of = eidx[:, 0], eidx[:, 1]
    batch = L.shape

    mats = {
        "stiffness": _assemble_matrix(ke, conn, nd),
        "translational_mass": _assemble_matrix(mw, conn, nd),
        "gyroscopic": _assemble_matrix(gy, conn, nd),
    }
    kg_full = _assemble_matrix(kg_cols[..., e_of, :, :], conn, nd,
                               per_element=True)  # (..., 3, nd, nd)
    n_el = conn.shape[0]
    load0 = _assemble_vector(np.broadcast_to(l0[..., None, :, :], batch + (n_el, m2, 2)),
                             conn, nd)
    load1 = _assemble_vector(l1_cols[..., e_of, :, :], conn, nd)
    across = _assemble_vector(across_rows[..., k_of, :, :], conn, nd)

    out = {k: tie.matrix(v) for k, v in mats.items()}
    across_q = tie.vector(across)
    return ContinuumLinkMatrices(
        mass=out["translational_mass"],
        translational_mass=out["translational_mass"].copy(),
        stiffness=out["stiffness"],
        gyroscopic=out["gyroscopic"],
        geometric_stiffness=tie.matrix(kg_full),
        load_constant=tie.vector(load0),
        load_linear=tie.vector(load1),
        moment_load=-across_q[..., 0] / col(p["I"]),
        across_load=across_q,
        node_positions=topo["grid"][:, 0] * col(a_el / 2.0),
        end_dofs=((0, 1), (nd - 2, nd - 1)),
        end_rotations=tuple(_face_dofs(order, f) for f in faces),
        length=L,
        n_elements=ne,
        shear_parameter=np.zeros(batch),
        height=h,
        formulation=FORMULATION,
        elements_across=na,
        nodes_per_element=int(nodes_per_element),
        youngs_modulus=p["E"],
        poisson_ratio=nuv,
        thickness=t,
        transform=T,
        node_coordinates=np.stack(np.broadcast_arrays(
            topo["grid"][:, 0] * col(a_el / 2.0),
            -col(h / 2.0) + topo["grid"][:, 1] * col(b_el / 2.0)), -1),
    )


def _face_dofs(order, face_slots):
    """Final indices of a face's deformation DOFs r (its slots except the pin's)."""
    idx = np.flatnonzero(np.isin(order, face_slots))
    return tuple(int(i) for i in idx if i not in (0, 1, len(order) - 2, len(order) - 1))


def rigid_modes(matrices: ContinuumLinkMatrices) -> np.ndarray:
    """(..., n, 3) link-DOF vectors of the rigid motions: unit translations along x and y and a
    unit (small) rotation about pin 0, d = (−y, x). The resultant of a load vector f is
    rigid_modes(lm)[..., :2]ᵀ f (the face DOFs are relative, so Σ f is not the resultant).

    Parameters
    ----------
    matrices : ContinuumLinkMatrices
        The link's matrices (node coordinates, m, and the DOF transform).

    Returns
    -------
    numpy.ndarray
        The rigid-motion vectors (…, n, 3): translations in m per m, rotation in m per rad.
    """
    xy = matrices.node_coordinates
    d = np.zeros(xy.shape[:-2] + (2 * xy.shape[-2], 3))
    d[..., 0::2, 0] = 1.0
    d[..., 1::2, 1] = 1.0
    d[..., 0::2, 2] = -xy[..., 1]
    d[..., 1::2, 2] = xy[..., 0]
    return np.linalg.solve(matrices.transform, d)


# ------------------------------------------------------------------------------- recovery
def recovery_matrices(matrices: ContinuumLinkMatrices, stations) -> dict:
    """Operators (..., st, n) mapping the link DOFs q to fields at normalized stations
    ξ ∈ [0, 1].

    Parameters
    ----------
    matrices : ContinuumLinkMatrices
        The link's plane-stress matrices (mesh, length and height in m, E in Pa, ν).
    stations : array_like
        Normalized stations ξ ∈ [0, 1] along the link, shape (st,).

    Returns
    -------
    dict: ``u``, ``v`` (m) and ``rotation`` ∂v/∂x (rad) on the centre line y = 0;
    ``axial_strain`` ε_xx at y = 0; ``curvature`` −(ε_xx(h/2) − ε_xx(−h/2))/h (1/m, so that
    curvature × h/2 is the outer-fibre bending strain with the beam sign); ``strain_top``,
    ``strain_bottom`` ε_xx at y = ±h/2; ``stress_top``, ``stress_bottom`` plane-stress σ_xx at
    y = ±h/2 (Pa). Values whose derivatives jump between elements are averaged over the
    elements meeting at the point (two along x at interior nodes, two across at y = 0 when
    elements_across is even).
    """
    lm = matrices
    ne, na, npe = lm.n_elements, lm.elements_across, lm.nodes_per_element
    topo = mesh(ne, na, npe)
    conn = topo["connectivity"]
    nd = lm.transform.shape[0]
    L, h = lm.length, lm.height
    a_el, b_el = L / ne, h / na
    (left, right), (xl, xr) = station_elements(stations, ne)
    st = len(left)
    # Element rows and η at y = −h/2, 0, +h/2.
    if na % 2:
        centre = [((na - 1) // 2, 0.0)]
    else:
        centre = [(na // 2 - 1, 1.0), (na // 2, -1.0)]
    places = {"bottom": [(0, -1.0)], "centre": centre, "top": [(na - 1, 1.0)]}
    E, nu = lm.youngs_modulus, lm.poisson_ratio
    col = lambda v: np.asarray(v, float)[..., None, None]  # noqa: E731

    def field(where):
        """(u, v, u_x, v_x, v_y) operators (..., st, nd) at y = where, averaged."""
        acc = [0.0] * 5
        combos = [(e, x, k, et) for e, x in ((left, xl), (right, xr)) for k, et in places[where]]
        for e, x, k, et in combos:
            sh = shape_functions(2.0 * x - 1.0, np.full(st, et), npe)
            nodes = conn[e * na + k]  # (st, m)
            vals = [sh["N"], sh["N"], sh["dxi"] * col(2.0 / a_el), sh["dxi"] * col(2.0 / a_el),
                    sh["deta"] * col(2.0 / b_el)]
            comps = [0, 1, 0, 1, 1]
            for i, (val, c) in enumerate(zip(vals, comps)):
                op = np.zeros(np.shape(L) + (st, nd))
                op[..., np.arange(st)[:, None], 2 * nodes + c] = val
                acc[i] = acc[i] + op / len(combos)
        return [a @ lm.transform for a in acc]

    u, v, ux_c, vx_c, _ = field("centre")
    *_, ux_t, _, vy_t = field("top")
    *_, ux_b, _, vy_b = field("bottom")
    scale = col(E / (1.0 - nu**2))
    return {
        "u": u, "v": v, "rotation": vx_c, "axial_strain": ux_c,
        "curvature": -(ux_t - ux_b) / col(h),
        "strain_top": ux_t, "strain_bottom": ux_b,
        "stress_top": scale * (ux_t + col(nu) * vy_t),
        "stress_bottom": scale * (ux_b + col(nu) * vy_b),
    }
