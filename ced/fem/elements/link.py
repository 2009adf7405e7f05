"""Shared machinery of the link "elements": the result dataclass, Gauss quadrature, the
virtual-work integrals common to every formulation and the assembly of a uniform mesh.

A formulation only supplies its shape functions at reference points ξ ∈ [0, 1] of an element
of length h (see :func:`element_integrals` for the keys); everything else is shared, so the
matrices of all formulations follow from the same virtual work (docs/theory.md, floating frame)::

    δW = ∫ δwᵀ ρA [ẅ + 2ωJẇ + (αJ − ω²I) w] + δθ ρI θ̈ + δεᵀ D ε + P δv' v' − δwᵀ b  ds

Every function broadcasts over leading "batch" dimensions of the section and material
parameters (one link of many cases at once); the element count is shared by the batch.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

__all__ = ["LinkMatrices", "gauss_legendre", "element_integrals", "assemble_matrix",
           "assemble_vector", "scatter_rows", "station_elements", "broadcast_parameters"]

DOFS_PER_NODE = 3  # (u, v, θ)


@dataclass(frozen=True)
class LinkMatrices:
    """Local-frame matrices of one link (DOFs node by node (u, v, θ); rigid: (u0, v0, φ)).

    Leading ``...`` dimensions are the batch (cases) the parameters were broadcast to.

    Attributes
    ----------
    mass : (..., n, n) consistent mass M, kg (kg m on translation–rotation, kg m² on rotations)
    translational_mass : (..., n, n) M_w = ∫ρA NᵀN ds, the translational field only, kg
    stiffness : (..., n, n) elastic stiffness K, N/m (N, N m on rotations)
    gyroscopic : (..., n, n) G = ∫ρA NᵀJN ds, antisymmetric, kg
    geometric_stiffness : (..., 3, n, n) basis Kg_k = ∫ s^k v'ᵀv' ds, m^k; for an axial force
        P(s) = P0 + P1 s + P2 s² (N, tension positive) K_g = Σ_k P_k Kg_k
    load_constant : (..., n, 2) L0 = ∫Nᵀ ds, m; f = L0 b0 for a uniform load b0 (N/m, local x, y)
    load_linear : (..., n, 2) L1 = ∫ s Nᵀ ds, m²; f += L1 b1 for b(s) = b0 + s b1
    moment_load : (..., n) ∫N_θ ds, m; f += m0 × this for a distributed couple m0 (N m/m),
        e.g. the rotary-inertia load −ρI α
    node_positions : (..., n_nodes) s of each node, m (rigid: the reference point s = 0)
    end_dofs : ((u, v) at s = 0, (u, v) at s = L) local indices; rigid: ((0, 1), None) since
        the far end is (u0, v0 + Lφ), not a DOF
    end_rotations : (θ at s = 0, θ at s = L) local indices; rigid: (2, 2)
    length : (...) link length L, m
    n_elements : number of elements (1 for rigid)
    shear_parameter : (...) φ = 12EI/(κGA h²) of an element (0 for Euler–Bernoulli, rigid)
    height : (...) in-plane section depth, m, or None (kept for recovery of outer-fibre strain)
    formulation : "euler_bernoulli" | "timoshenko" | "rigid"
    """

    mass: np.ndarray
    translational_mass: np.ndarray
    stiffness: np.ndarray
    gyroscopic: np.ndarray
    geometric_stiffness: np.ndarray
    load_constant: np.ndarray
    load_linear: np.ndarray
    moment_load: np.ndarray
    node_positions: np.ndarray
    end_dofs: tuple
    end_rotations: tuple
    length: np.ndarray
    n_elements: int
    shear_parameter: np.ndarray
    height: np.ndarray | None
    formulation: str

    @property
    def n_dofs(self) -> int:
        return self.mass.shape[-1]

    def axial_force_stiffness(self, p0, p1=0.0, p2=0.0) -> np.ndarray:
        """K_g for P(s) = p0 + p1 s + p2 s² (N, N/m, N/m²; broadcast over the batch)."""
        p = [np.asarray(c, float)[..., None, None] for c in (p0, p1, p2)]
        kg = self.geometric_stiffness
        return p[0] * kg[..., 0, :, :] + p[1] * kg[..., 1, :, :] + p[2] * kg[..., 2, :, :]

    def load(self, b0, b1=(0.0, 0.0)) -> np.ndarray:
        """Consistent load of b(s) = b0 + s b1, b0 (..., 2) N/m and b1 (..., 2) N/m² local."""
        return (np.einsum("...ij,...j->...i", self.load_constant, np.asarray(b0, float))
                + np.einsum("...ij,...j->...i", self.load_linear, np.asarray(b1, float)))


@lru_cache(maxsize=None)
def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n-point Gauss–Legendre points and weights on [0, 1] (exact to degree 2n − 1).

    Parameters
    ----------
    n : int
        Number of points.

    Returns
    -------
    points, weights : numpy.ndarray
        Each (n,), read-only (cached).
    """
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = 0.5 * (x + 1.0), 0.5 * w
    x.flags.writeable = w.flags.writeable = False  # cached: shared by every caller
    return x, w


# 4 points integrate degree 7 exactly; the highest product is s² v'ᵀv' of a cubic v
# (degree 2 + 2·2 = 6) or ρA vᵀv (degree 6).
N_GAUSS = 4


def _gram(a, b, weight):
    """Σ_g weight[..., g] a[..., g, i] b[..., g, j] → (..., i, j)."""
    return np.einsum("...g,...gi,...gj->...ij", weight, a, b)


def element_integrals(shapes: dict, h, n_elements: int, *, rhoA, rhoI, EA, EI, kGA=None,
                      xi=None, weights=None) -> dict:
    """Element matrices of a uniform mesh by exact Gauss quadrature.

    Parameters
    ----------
    shapes : shape functions at the Gauss points, each (..., g, m) for element DOFs m:
        ``u``, ``v`` translations; ``theta`` section rotation (rotary inertia, moment load);
        ``du`` = u' (axial strain), ``dv`` = v' (geometric stiffness), ``kappa`` bending strain
        (v'' or θ', 1/m), ``gamma`` shear strain v' − θ or None.
    h : (...) element length, m
    n_elements : element count (for the position-dependent integrals)
    rhoA, rhoI, EA, EI, kGA : (...) section properties (kg/m, kg m, N, N m², N); rhoI = 0 drops
        rotary inertia from the mass, kGA is used only with ``gamma``
    xi, weights : the quadrature rule the shapes were evaluated with (default N_GAUSS points)

    Returns
    -------
    dict of element arrays: ``mass``, ``translational_mass``, ``stiffness``, ``gyroscopic``
    (..., m, m), identical for every element; ``geometric_stiffness`` (..., 3, e, m, m),
    ``load_constant`` (..., m, 2), ``load_linear`` (..., e, m, 2), ``moment_load`` (..., m).
    """
    if xi is None:
        xi, weights = gauss_legendre(N_GAUSS)
    h = np.asarray(h, float)
    hw = h[..., None] * weights  # ∫_element f ds = h Σ_g w_g f(ξ_g)
    col = lambda c: np.asarray(c, float)[..., None]  # noqa: E731  (..., 1) for per-point weights
    u, v = shapes["u"], shapes["v"]
    mw = _gram(u, u, col(rhoA) * hw) + _gram(v, v, col(rhoA) * hw)
    mass = mw + _gram(shapes["theta"], shapes["theta"], col(rhoI) * hw)
    # G_ij = ∫ρA (N_i · J N_j) = ∫ρA (v_i u_j − u_i v_j), J = [[0, −1], [1, 0]].
    gyro = _gram(v, u, col(rhoA) * hw) - _gram(u, v, col(rhoA) * hw)
    stiff = (_gram(shapes["du"], shapes["du"], col(EA) * hw)
             + _gram(shapes["kappa"], shapes["kappa"], col(EI) * hw))
    if shapes.get("gamma") is not None:
        stiff = stiff + _gram(shapes["gamma"], shapes["gamma"], col(kGA) * hw)

    # Position along the link of every Gauss point: s = (e + ξ) h, shape (..., e, g).
    s = h[..., None, None] * (np.arange(n_elements)[:, None] + xi)
    powers = np.stack([np.ones_like(s), s, s * s], axis=-3)  # (..., 3, e, g)
    dv = shapes["dv"][..., None, None, :, :]  # broadcast over (k, e)
    geo = _gram(dv, dv, powers * hw[..., None, None, :])
    n_mat = np.stack([u, v], axis=-1)  # (..., g, m, 2) = Nᵀ at each point
    load0 = np.einsum("...g,...gmc->...mc", hw, n_mat)
    load1 = np.einsum("...eg,...gmc->...emc", s * hw[..., None, :], n_mat)
    moment = np.einsum("...g,...gm->...m", hw, shapes["theta"])
    return {"mass": mass, "translational_mass": mw, "stiffness": stiff, "gyroscopic": gyro,
            "geometric_stiffness": geo, "load_constant": load0, "load_linear": load1,
            "moment_load": moment}


def assemble_matrix(ke: np.ndarray, n_elements: int, batch: tuple) -> np.ndarray:
    """Sum element matrices of a chain of elements into the link matrix.

    ke : (*batch, m, m) shared by every element, or (*batch, e, m, m) per element
    Returns (*batch, n, n). A vectorized scatter-add (``np.bincount``) over all elements and
    the whole batch; element e's DOFs start at node e.

    Parameters
    ----------
    ke : numpy.ndarray
        Element matrix (*batch, m, m), shared by every element, or (*batch, e, m, m) per element.
    n_elements : int
        Number of elements e of the chain.
    batch : tuple
        The leading batch shape.

    Returns
    -------
    numpy.ndarray
        The link matrix (*batch, n, n).
    """
    return _scatter(ke, n_elements, batch, matrix=True)


def assemble_vector(fe: np.ndarray, n_elements: int, batch: tuple) -> np.ndarray:
    """Sum element vectors (*batch, [e,] m, c) into (*batch, n, c).

    Parameters
    ----------
    fe : numpy.ndarray
        Element vectors (*batch, m, c), shared by every element, or (*batch, e, m, c).
    n_elements : int
        Number of elements e of the chain.
    batch : tuple
        The leading batch shape.

    Returns
    -------
    numpy.ndarray
        The link vectors (*batch, n, c).
    """
    return _scatter(fe, n_elements, batch, matrix=False)


def _scatter(ae, n_elements, batch, matrix):
    m, c = ae.shape[-2:]
    if ae.ndim == len(batch) + 2:  # shared by all elements
        ae = ae[..., None, :, :]
    ae = np.broadcast_to(ae, tuple(batch) + (n_elements, m, c))
    n = DOFS_PER_NODE * n_elements + (m - DOFS_PER_NODE)
    dof = DOFS_PER_NODE * np.arange(n_elements)[:, None] + np.arange(m)  # (e, m)
    cols = dof if matrix else np.arange(c)[None, :]
    width = n if matrix else c
    flat = (dof[:, :, None] * width + cols[:, None, :]).ravel()  # (e·m·c,)
    nb = int(np.prod(batch, dtype=int))
    idx = (np.arange(nb)[:, None] * (n * width) + flat).ravel()
    out = np.bincount(idx, weights=ae.reshape(nb, -1).ravel(), minlength=nb * n * width)
    return out.reshape(tuple(batch) + (n, width))


def scatter_rows(values: np.ndarray, elements: np.ndarray, n: int) -> np.ndarray:
    """Rows of a (*batch, st, n) operator from element-level values (*batch, st, m).

    ``elements`` (st,) is the element of each row; its m DOFs start at node ``elements``.

    Parameters
    ----------
    values : numpy.ndarray
        Element-level operator rows (*batch, st, m).
    elements : numpy.ndarray
        Element index of each row, shape (st,), int.
    n : int
        Number of link DOFs.

    Returns
    -------
    numpy.ndarray
        The operator (*batch, st, n), zero outside each row's element.
    """
    st, m = values.shape[-2:]
    out = np.zeros(values.shape[:-2] + (st, n))
    dof = DOFS_PER_NODE * np.asarray(elements)[:, None] + np.arange(m)
    out[..., np.arange(st)[:, None], dof] = values
    return out


def station_elements(stations, n_elements: int, tol: float = 1e-9):
    """Elements on the left and right of normalized stations ξ ∈ [0, 1] and local coordinates.

    A station on an interior node (|ξ n_e − round| < tol) belongs to both adjacent elements;
    elsewhere (and at the link ends) both sides are the same element. Averaging an operator
    over the two sides gives the mean of the one-sided values at nodes (used for the
    discontinuous Euler–Bernoulli curvature), and the exact value elsewhere.

    Parameters
    ----------
    stations : array_like
        Normalized stations ξ ∈ [0, 1], shape (st,).
    n_elements : int
        Number of elements n_e along the link.
    tol : float, optional
        Tolerance on ξ n_e for a station to count as lying on a node.

    Returns
    -------
    (left, right) element indices (st,), (xi_left, xi_right) local coordinates in [0, 1].
    """
    t = np.asarray(stations, float) * n_elements
    if np.any((t < -tol) | (t > n_elements + tol)):
        raise ValueError("stations must lie in [0, 1]")
    r = np.round(t)
    t = np.where(np.abs(t - r) < tol, r, t)
    left = np.clip(np.ceil(t) - 1, 0, n_elements - 1).astype(int)
    right = np.clip(np.floor(t), 0, n_elements - 1).astype(int)
    return (left, right), (t - left, t - right)


def broadcast_parameters(**params):
    """Broadcast scalar/array parameters to one batch shape (None entries pass through)."""
    keys = [k for k, v in params.items() if v is not None]
    arrays = np.broadcast_arrays(*[np.asarray(params[k], float) for k in keys])
    out = dict(params)
    out.update({k: np.array(a) for k, a in zip(keys, arrays)})
    return out


def build_link(shape_functions, formulation: str, length, n_elements: int, *, rhoA, rhoI, EA,
               EI, kGA=None, phi=None, height=None) -> LinkMatrices:
    """Integrate and assemble a uniform chain of ``n_elements`` beam elements.

    ``shape_functions(xi, h, phi)`` returns the dict described in :func:`element_integrals`.
    All parameters are already broadcast to one batch shape (see :func:`broadcast_parameters`).
    """
    n_elements = int(n_elements)
    if n_elements < 1:
        raise ValueError(f"n_elements must be >= 1, got {n_elements}")
    length = np.asarray(length, float)
    if np.any(~(length > 0)):
        raise ValueError("link length must be positive")
    batch = length.shape
    h = length / n_elements
    phi = np.zeros(batch) if phi is None else np.asarray(phi, float)
    xi, w = gauss_legendre(N_GAUSS)
    el = element_integrals(shape_functions(xi, h, phi), h, n_elements, rhoA=rhoA, rhoI=rhoI,
                           EA=EA, EI=EI, kGA=kGA, xi=xi, weights=w)
    mat = {k: assemble_matrix(el[k], n_elements, batch)
           for k in ("mass", "translational_mass", "stiffness", "gyroscopic")}
    geo = assemble_matrix(el["geometric_stiffness"], n_elements, batch + (3,))
    n = mat["mass"].shape[-1]
    return LinkMatrices(
        **mat,
        geometric_stiffness=geo,
        load_constant=assemble_vector(el["load_constant"], n_elements, batch),
        load_linear=assemble_vector(el["load_linear"], n_elements, batch),
        moment_load=assemble_vector(el["moment_load"][..., None], n_elements, batch)[..., 0],
        node_positions=h[..., None] * np.arange(n_elements + 1),
        end_dofs=((0, 1), (n - 3, n - 2)),
        end_rotations=(2, n - 1),
        length=length,
        n_elements=n_elements,
        shear_parameter=phi,
        height=None if height is None else np.asarray(height, float),
        formulation=formulation,
    )


def recovery_operators(shape_functions, matrices: LinkMatrices, stations,
                       names: dict, superconvergent: dict | None = None) -> dict:
    """Station operators (*batch, st, n) for the fields ``names`` (output → shape key).

    Each operator is the average of its left- and right-element evaluations (identical except
    at interior nodes, see :func:`station_elements`). Fields listed in ``superconvergent``
    (output → (points, degree)) are recovered instead from their superconvergent points, see
    :func:`superconvergent_rows`.
    """
    superconvergent = superconvergent or {}
    ne, n = matrices.n_elements, matrices.n_dofs
    h = matrices.length / ne
    (left, right), (xl, xr) = station_elements(stations, ne)
    out = {}
    sides = [(e, shape_functions(x, h, matrices.shear_parameter)) for e, x in ((left, xl),
                                                                               (right, xr))]
    for name, key in names.items():
        if name in superconvergent:
            points, degree = superconvergent[name]
            out[name] = superconvergent_rows(shape_functions, matrices, stations, key, points,
                                             degree)
        else:
            out[name] = 0.5 * sum(scatter_rows(sh[key], e, n) for e, sh in sides)
    return out


def superconvergent_rows(shape_functions, matrices: LinkMatrices, stations, key: str,
                         points: int, degree: int) -> np.ndarray:
    """Station operator of a strain field recovered from its superconvergent points.

    A strain that is a polynomial of degree p per element (the curvature of cubic Hermite or
    linked-interpolation beams, p = 1; the axial strain of a linear bar, p = 0) is accurate to
    one order more at the p + 1 Gauss–Legendre points of each element than elsewhere: there the
    second derivative of (s − a)²(s − b)², the leading error term of the Hermite interpolant's
    curvature, vanishes (Barlow, Int. J. Numer. Meth. Eng. 10 (1976) 243–251; Zienkiewicz &
    Zhu's patch recovery rests on it). Read at fixed stations instead, the error constant
    changes with the station's position inside its element — and so with the mesh — and
    refinement converges erratically, which defeats Richardson error estimates. Here each
    station takes the Lagrange polynomial of ``degree`` through the ``degree + 1`` nearest
    sampling points (over element boundaries), O(h^(degree+1)) and smooth under refinement.

    Returns
    -------
    (*batch, st, n) operator.
    """
    ne, n = matrices.n_elements, matrices.n_dofs
    h = matrices.length / ne
    xg, _ = gauss_legendre(points)
    values = shape_functions(xg, h, matrices.shear_parameter)[key]  # (*batch, points, m)
    elements = np.repeat(np.arange(ne), points)
    rows = scatter_rows(np.concatenate([values] * ne, axis=-2), elements, n)  # (*b, ne·p, n)
    where = (elements + np.tile(xg, ne)) / ne  # normalized positions of the sampling points
    k = min(degree + 1, len(where))
    stations = np.asarray(stations, float)
    start = np.clip(np.searchsorted(where, stations) - k // 2, 0, len(where) - k)
    window = start[:, None] + np.arange(k)  # (st, k) nearest sampling points
    nodes = where[window]
    weights = np.ones_like(nodes)
    for j in range(k):  # Lagrange basis at each station
        for i in range(k):
            if i != j:
                weights[:, j] *= (stations - nodes[:, i]) / (nodes[:, j] - nodes[:, i])
    return np.einsum("sk,...skn->...sn", weights, rows[..., window, :])
