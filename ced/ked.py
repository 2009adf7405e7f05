"""Linear kineto-elasto-dynamics of a batch: M(t) q̈ + C(t) q̇ + K(t) q = F(t) (DESIGN §3).

Builds each link's local matrices, the joint projections, and the terms of the requested
effects; integrates from the requested start state (``undeformed``, ``quasi_static`` or the
exact ``periodic`` steady state found by shooting, whose monodromy matrix gives the Floquet
multipliers); recovers deflections, strains and stresses; runs the modal analysis over the
cycle. Everything is vectorized across the cases of the batch.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import io
from .assembly import Layout, build_layout, projection
from .cases import Batch
from .dynamics import inverse_dynamics
from .errors import SceneError
from .effects import (LinkData, SystemTerms, axial_force_coefficients, permute, split_order,
                      system_terms)
from .integrators import NewmarkFamily, make_integrator
from .modal import natural_frequencies
from .recovery import link_fields, peaks
from .reduction import craig_bampton
from .stepping import from_independent, independent, march
from .stepping import start as start_state

__all__ = ["elastic_response", "Model", "build_model", "LARGE_DEFLECTION", "RESONANCE_GAP",
           "dyad_sine_min", "near_singular", "BUCKLED_TOLERANCE", "NEAR_SINGULAR_SIN"]

#: Deflection / link length above which the linear model's validity is flagged.
LARGE_DEFLECTION = 0.01
#: A Floquet multiplier μ with |1 − μ| below this is near resonance: a crank harmonic k within
#: about 1 % of a natural frequency (|1 − μ| ≈ 2πk |ω/kΩ − 1|) ...
RESONANCE_GAP = 0.05
#: ... and the case is flagged resonant when such near-resonant modes carry more than this
#: share of the periodic displacement (a barely excited high mode near a harmonic is not).
RESONANCE_SHARE = 0.5
#: max |μ| above which the periodic system is parametrically unstable.
INSTABILITY_MARGIN = 1e-6
#: A frozen frequency below −BUCKLED_TOLERANCE × the largest computed one is a negative
#: eigenvalue of K_eff (relative size 1e-10, far above round-off of the eigensolver, ~1e-16;
#: an exact mechanism mode, λ = 0, stays below it): the frozen structure is statically unstable.
BUCKLED_TOLERANCE = 1e-5
#: |sin μ| (μ the coupler–rocker angle) below which the structure has lost its stiffness: the
#: soft mode across the dyad keeps less than 1 % of its stiffness, a tenth of its frequency.
NEAR_SINGULAR_SIN = 0.1
#: Bytes of system terms kept in memory at once (steps per chunk follow from the batch size).
_CHUNK_BYTES = 50e6


def _element_module(formulation: str):
    """The element module of a flexible-link formulation (see :mod:`ced.elements`)."""
    from . import elements

    if formulation == "rigid" or formulation not in elements.FORMULATIONS:
        available = sorted(set(elements.FORMULATIONS) - {"rigid"})
        raise NotImplementedError(
            f"discretization.formulation: {formulation!r} has no element model yet; "
            f"available: {available} (and rigid)")
    return elements.formulation(formulation)


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
    modal_damping: np.ndarray | None = None  # (case, ny, ny)


def _link_parameter(batch: Batch, link: str, group: str, key: str) -> np.ndarray:
    """A material or section value of ``link`` for every case, (case,)."""
    return np.array([s["links"][link][group][key] for s in batch.scenes], float)


def build_model(batch: Batch) -> Model:
    """Local matrices of every link of every case, the DOF layout and recovery operators.

    The element modules broadcast over cases, so each link is built once for the batch.
    """
    from .elements import rigid

    scene = batch.scenes[0]
    topo = batch.topology
    formulation = scene["discretization"]["formulation"]
    n_el = scene["discretization"]["elements_per_link"]
    stations = np.linspace(0.0, 1.0, scene["outputs"]["stations"])
    element = _element_module(formulation)
    flexible = {name: scene["links"][name]["flexible"] for name in topo.links}
    links, recovery, sizes, ends = {}, {}, {}, {}
    clamp_dofs: tuple[int, ...] = ()
    for i, name in enumerate(topo.links):
        par = {key: _link_parameter(batch, name, "material", key) for key in ("E", "G", "rho")}
        sec = {key: _link_parameter(batch, name, "section", key)
               for key in ("area", "second_moment", "height", "shear_coefficient")}
        length = batch.link_lengths[:, i]
        rotary = 0.0
        if flexible[name]:
            extra = ({"elements_across": scene["discretization"]["elements_across"]}
                     if formulation == "plane_stress" else {})
            m = element.link_matrices(
                length, n_el, E=par["E"], G_shear=par["G"], rho=par["rho"], area=sec["area"],
                second_moment=sec["second_moment"], height=sec["height"],
                shear_coefficient=sec["shear_coefficient"], **extra)
            recovery[name] = element.recovery_matrices(m, stations)
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
            m = rigid.link_matrices(length, rho=par["rho"], area=sec["area"],
                                    second_moment=sec["second_moment"])
            ends[name] = ((0, 1), (0, 1))  # unused: a rigid link's ends follow from (u0, v0, φ)
        links[name] = LinkData(
            mass=m.mass, translational_mass=m.translational_mass, stiffness=m.stiffness,
            gyroscopic=m.gyroscopic, geometric_stiffness=m.geometric_stiffness,
            load_constant=m.load_constant, load_linear=m.load_linear,
            moment_load=m.moment_load, mass_per_length=par["rho"] * sec["area"],
            rotary_inertia_per_length=np.broadcast_to(rotary, length.shape).astype(float))
        sizes[name] = m.mass.shape[-1]
    slider = "C" if batch.mechanism_type == "slider_crank" else None
    layout = build_layout(topo, flexible, sizes, ends, clamp_dofs, slider_joint=slider)
    links = {name: permute(data, split_order(layout, name)) for name, data in links.items()}
    modes = scene["discretization"].get("modes_per_link", 0)
    if modes and any(flexible.values()):
        layout, links, recovery = _reduce(layout, links, recovery, modes, slider)
    joint_mass = batch.bodies.point_mass.copy()
    if slider is not None:
        joint_mass[:, topo.joint_names.index(slider)] += batch.bodies.slider_mass
    effects = set(scene["effects"])
    model = Model(batch, layout, links, recovery, stations, effects, joint_mass)
    if "damping" in effects and scene["damping"]["model"] == "modal":
        model.modal_damping = _modal_damping(model, scene["damping"]["ratio"])
    return model


def _reduce(layout: Layout, links: dict, recovery: dict, modes: int, slider: str | None):
    """Craig–Bampton reduction of every flexible link (:mod:`ced.reduction`) and the layout
    of the reduced blocks: interior = modal coordinates, then the boundary rows unchanged."""
    topo = layout.topology
    sizes, ends = dict(layout.link_sizes), dict(layout.end_dofs)
    clamp = layout.clamp_dofs
    links, recovery = dict(links), dict(recovery)
    for name in topo.links:
        if not layout.flexible[name]:
            continue
        rows, _, varying = layout.row_split(name)
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
) -> tuple[SystemTerms, np.ndarray]:
    """System terms and the projection value at arbitrary times (case, step).

    ``effects`` defaults to the scene's; the modal analysis passes them without damping.
    ``extras`` asks for ``elastic_mass`` / ``elastic_stiffness`` as well (see
    :class:`ced.effects.SystemTerms`).
    """
    batch, layout = model.batch, model.layout
    effects = model.effects if effects is None else effects
    topo = layout.topology
    motion = batch.rigid_motion(times)
    gravity = batch.gravity if "gravity" in effects else np.zeros_like(batch.gravity)
    has_inertia = "inertia" in effects
    P = projection(layout, batch.link_lengths, motion.link_angle,
                   motion.link_angular_velocity, motion.link_angular_acceleration)
    g = gravity[:, None, :]
    loads, axial = {}, {} if "axial_stiffening" in effects else None
    forces = None
    if axial is not None:
        forces = inverse_dynamics(motion, batch.bodies, gravity, inertia=has_inertia).joint_force
    carrier = {j: (b[0] if b[1] == "tip" else b[1]) for j, b in topo.joints.items()}
    for i, name in enumerate(topo.links):
        th = motion.link_angle[..., i]
        c, s = np.cos(th), np.sin(th)
        first = topo.links[name][0]
        kf = topo.joint_names.index(first)
        rho_a = model.links[name].mass_per_length[:, None, None]
        acc = motion.joint_acceleration[:, :, kf] if has_inertia else 0.0
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
    acc_j = motion.joint_acceleration if has_inertia else 0.0
    joint_load = model.joint_mass[:, None, :, None] * (gravity[:, None, None, :] - acc_j)
    if "damping" in effects and model.batch.scenes[0]["damping"]["model"] == "rayleigh":
        extras = extras | {"elastic_mass", "elastic_stiffness"}
    terms = system_terms(layout, model.links, P, motion.link_angular_velocity,
                         motion.link_angular_acceleration, loads, axial, model.joint_mass,
                         joint_load, effects, frozenset(extras))
    if "damping" in effects:
        _add_damping(model, terms)
    return terms, P[0]


def _add_damping(model: Model, terms: SystemTerms) -> None:
    d = model.batch.scenes[0]["damping"]
    if d["model"] == "rayleigh":
        extra = d["alpha"] * terms.elastic_mass + d["beta"] * terms.elastic_stiffness
    else:
        extra = np.broadcast_to(model.modal_damping[:, None], terms.stiffness.shape)
    terms.damping = extra if terms.damping is None else terms.damping + extra


def _modal_damping(model: Model, ratio: float) -> np.ndarray:
    """C = M Φ diag(2ζω) Φᵀ M from the frozen structure at t = 0 (mass-normalised Φ), held
    constant over the cycle: a phenomenological damping that gives every mode the ratio ζ."""
    t0 = np.zeros((model.batch.size, 1))
    terms, _ = terms_at(model, t0, model.effects - {"damping"},
                        frozenset({"elastic_mass", "elastic_stiffness"}))
    K, M = terms.elastic_stiffness[:, 0], terms.elastic_mass[:, 0]
    n = K.shape[-1]
    freq, shapes = natural_frequencies(K, M, n, shapes=True)
    omega = 2.0 * math.pi * np.abs(freq)
    MPhi = M @ shapes
    return MPhi @ (2.0 * ratio * omega[..., None] * np.swapaxes(MPhi, -1, -2))


class _TermCache:
    """Terms over the step grid, computed chunk by chunk as the march asks for them."""

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


def _shoot(scheme, cache: _TermCache, h, steps_per_period: int, ny: int, ncase: int):
    """Exact periodic state of the discretized system and its Floquet multipliers.

    Propagates the 3n unit states (homogeneous) and the zero state under the forcing (column
    0) over one period with shared factorizations: s_N = Φ s_0 + p, s the independent state
    ((q, v, a) of the Newmark family, the history of Houbolt). The periodic state solves
    (I − Φ) s_0 = p — by least squares where I − Φ is singular, so exact resonance stays finite.
    """
    r = 3 * ny
    # Shoot in the scaled state (q, h v, h² a) (Houbolt: its history, all in m) so that the
    # columns of Φ are commensurate; unscaled, ω h ≫ 1 axial modes make I − Φ look singular.
    hh = np.asarray(h, float)[:, None]
    if isinstance(scheme, NewmarkFamily):
        scale = np.concatenate([np.ones((ncase, ny)), np.repeat(hh, ny, 1),
                                np.repeat(hh**2, ny, 1)], axis=1)  # (case, 3n)
    else:
        scale = np.ones((ncase, r))
    cols = np.concatenate([np.zeros((ncase, r, 1)),
                           np.broadcast_to(np.eye(r), (ncase, r, r)) / scale[:, :, None]], axis=2)
    parts = [cols[:, i * ny : (i + 1) * ny].copy() for i in range(3)]
    end = march(scheme, cache, h, steps_per_period, from_independent(cache, scheme, *parts))
    final = independent(scheme, end) * scale[:, :, None]  # (case, 3n, r + 1), scaled
    p, Phi = final[..., 0], final[..., 1:]
    A = np.eye(r) - Phi
    s0 = np.empty_like(p)
    for c in range(ncase):
        # Equilibrate rows and columns first: for generalized-α the stiff modes' algorithmic
        # accelerations make Φ strongly non-normal (entries ~ (ωh)², e.g. 1e9 for the static
        # load vectors of a finely meshed reduced link) while I − Φ itself is harmless; only
        # a true resonance (a multiplier at 1) should reach the least-squares branch. Without
        # this, cond(I − Φ) crossed 1e13 on the double-rocker reference at 40 elements and the
        # least-squares state was wrong by 80 %.
        rows = 1.0 / np.maximum(np.abs(A[c]).max(axis=1), 1e-300)
        scaled = rows[:, None] * A[c]
        columns = 1.0 / np.maximum(np.abs(scaled).max(axis=0), 1e-300)
        scaled = scaled * columns[None, :]
        if np.linalg.cond(scaled) < 1e13:
            s0[c] = columns * np.linalg.solve(scaled, rows * p[c])
        else:  # exact resonance: the minimum-norm periodic state keeps results finite
            s0[c] = np.linalg.lstsq(A[c], p[c], rcond=1e-13)[0]
    s0 = s0 / scale
    multipliers, vectors = np.linalg.eig(Phi)
    q0, v0, a0 = (s0[:, i * ny : (i + 1) * ny, None] for i in range(3))
    return (q0, v0, a0), multipliers, _resonant(multipliers, vectors, p, ny)


def _resonant(mu: np.ndarray, V: np.ndarray, p: np.ndarray, ny: int) -> np.ndarray:
    """(case,) bool: near-resonant Floquet modes dominate the periodic displacement.

    With Φ = V diag(μ) V⁻¹ the periodic state is Σ_i V_i c_i/(1 − μ_i), c = V⁻¹p; the share of
    the modes with |1 − μ_i| < RESONANCE_GAP in its displacement part is compared with
    RESONANCE_SHARE.
    """
    near = np.abs(1.0 - mu) < RESONANCE_GAP
    flagged = np.zeros(mu.shape[0], bool)
    for c in np.flatnonzero(near.any(axis=-1)):
        try:
            coeff = np.linalg.solve(V[c], p[c].astype(complex))
        except np.linalg.LinAlgError:
            flagged[c] = True  # defective monodromy at a multiplier near 1: resonance
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            x = coeff / (1.0 - mu[c])
        x = np.where(np.isfinite(x), x, 1e300)
        total = np.linalg.norm(V[c][:ny] @ x)
        part = np.linalg.norm(V[c][:ny][:, near[c]] @ x[near[c]])
        flagged[c] = part > RESONANCE_SHARE * max(total, 1e-300)
    return flagged


def elastic_response(batch: Batch, status: np.ndarray) -> dict[str, np.ndarray]:
    """Elastic variables of DESIGN §5 for a batch (arrays with a leading case axis).

    ``status`` (case,) holds the flags of the rigid analysis; the returned ``status`` adds the
    elastic ones (resonant, parametrically_unstable, large_deflection, near_singular where the
    pin-jointed structure loses its stiffness, buckled).
    """
    model = build_model(batch)
    scene = batch.scenes[0]
    _check_modes(scene, model.layout.ny)
    status = status.copy()
    status[near_singular(batch)] |= io.STATUS_FLAGS["near_singular"]
    result: dict[str, np.ndarray] = {}
    qz, qz_static = _response(model, status, result)
    result.update(_recover(model, qz, qz_static))
    relative = result["peak_deflection"] / batch.link_lengths
    status[(relative > LARGE_DEFLECTION).any(axis=1)] |= io.STATUS_FLAGS["large_deflection"]
    if scene.get("modal") and model.layout.ny:
        freq = _modal(model, scene["modal"])
        result["natural_frequency"] = freq
        status[_buckled(freq)] |= io.STATUS_FLAGS["buckled"]
    if scene["discretization"]["formulation"] == "seed_lame":
        # The thesis's wave analysis (III.3.1.a), reported per link material.
        for key, name in (("c1", "longitudinal_wave_speed"), ("c2", "transverse_wave_speed")):
            result[name] = np.stack([_link_parameter(batch, link, "material", key)
                                     for link in batch.topology.links], axis=1)
    result["status"] = status
    return result


def _response(model: Model, status: np.ndarray, result: dict):
    """Joint and link displacements z at the output steps, dynamic and quasi-static
    (case, out_step, nz); adds the Floquet results of a periodic start to ``result``."""
    batch, layout = model.batch, model.layout
    scene = batch.scenes[0]
    ncase, ny, n_steps, h = batch.size, layout.ny, batch.n_steps, batch.step_size
    out_steps = np.arange(0, n_steps + 1, scene["outputs"]["every"])
    qz = np.zeros((ncase, len(out_steps), layout.nz))
    qz_static = np.zeros_like(qz)
    if not ny:
        return qz, qz_static
    cache = _TermCache(model, h, n_steps)

    def static(j):
        K, F = cache.terms.stiffness[:, j], cache.terms.force[:, j]
        return layout.expand(cache.P[:, j], np.linalg.solve(K, F[..., None])[..., 0])

    if "elastic_inertia" not in model.effects:  # quasi-static: K q = F at each instant
        for i, k in enumerate(out_steps):
            qz[:, i] = static(cache.load(k))
        return qz, qz

    time_cfg = scene["time"]
    scheme = make_integrator(time_cfg["integrator"], **_scheme_params(time_cfg))
    if time_cfg["start"] == "periodic":
        periodic, mu, resonant = _shoot(scheme, cache, h, time_cfg["steps_per_revolution"],
                                        ny, ncase)
        cache = _TermCache(model, h, n_steps)
        state = from_independent(cache, scheme, *periodic)
        largest = np.abs(mu).max(axis=-1)
        result["floquet_multiplier_max"] = largest
        status[largest > 1.0 + INSTABILITY_MARGIN] |= io.STATUS_FLAGS["parametrically_unstable"]
        status[resonant] |= io.STATUS_FLAGS["resonant"]
    else:
        q0 = np.zeros((ncase, ny, 1))
        v0 = np.zeros_like(q0)
        if time_cfg["start"] == "quasi_static":
            q0, v0 = _quasi_static_start(model, h)
        state = start_state(cache, q0, v0)

    out_index = {int(k): i for i, k in enumerate(out_steps)}

    def record(k, st):
        i = out_index.get(k)
        if i is not None:
            j = cache.load(k)
            qz[:, i] = layout.expand(cache.P[:, j], st[0][..., 0])
            qz_static[:, i] = static(j)

    march(scheme, cache, h, n_steps, state, record)
    return qz, qz_static


def _recover(model: Model, qz: np.ndarray, qz_static: np.ndarray) -> dict[str, np.ndarray]:
    """Deflection, strains, stress at the stations, per-link peaks, dynamic amplification."""
    batch, layout = model.batch, model.layout
    topo = layout.topology
    ncase, nout = qz.shape[:2]
    shape = (ncase, nout, len(topo.links), len(model.stations))
    fields = {name: np.zeros(shape) for name in
              ("deflection", "axial_displacement", "bending_strain", "axial_strain", "stress")}
    static_deflection = np.zeros(shape)
    offsets = layout.link_offsets
    for i, name in enumerate(topo.links):
        if name not in model.recovery:
            continue  # rigid link: no strain
        rows = slice(offsets[name], offsets[name] + layout.link_sizes[name])
        height = _link_parameter(batch, name, "section", "height")
        E = _link_parameter(batch, name, "material", "E")
        for key, value in link_fields(qz[..., rows], model.recovery[name], model.stations,
                                      height, E).items():
            fields[key][:, :, i] = value
        static_deflection[:, :, i] = link_fields(
            qz_static[..., rows], model.recovery[name], model.stations, height,
            E)["deflection"]
    peak = peaks(fields["deflection"])
    static_peak = peaks(static_deflection)
    with np.errstate(divide="ignore", invalid="ignore"):
        amplification = np.where(static_peak > 0, peak / static_peak, 1.0)
    return {**fields, "peak_deflection": peak, "peak_stress": peaks(fields["stress"]),
            "dynamic_amplification": amplification}


def _scheme_params(time_cfg: dict) -> dict:
    name = time_cfg["integrator"]
    if name == "newmark":
        return {"beta": time_cfg["beta"], "gamma": time_cfg["gamma"]}
    if name == "hht":
        return {"alpha": time_cfg["alpha"]}
    if name == "generalized_alpha":
        return {"rho_inf": time_cfg["rho_inf"]}
    return {}


def _quasi_static_start(model: Model, h: np.ndarray):
    """q0 = K⁻¹F at t = 0 and q̇0 from the quasi-static solution at ±h (central difference)."""
    times = h[:, None] * np.array([-1.0, 0.0, 1.0])[None, :]
    terms, _ = terms_at(model, times)
    y = np.linalg.solve(terms.stiffness, terms.force[..., None])
    v0 = (y[:, 2] - y[:, 0]) / (2.0 * h[:, None, None])
    return y[:, 1], v0


def _modal(model: Model, modal: dict) -> np.ndarray:
    """Frequencies at ``modal.angles`` evenly spaced phases of the input cycle, Hz."""
    n = modal["angles"]
    phase = 2.0 * math.pi * np.arange(n) / n
    times = phase[None, :] / model.batch.speed[:, None]
    terms, _ = terms_at(model, times, model.effects - {"damping"}, frozenset({"elastic_mass"}))
    return natural_frequencies(terms.stiffness, terms.elastic_mass, modal["modes"])


def _check_modes(scene: dict, ny: int) -> None:
    """A discretized model with ny DOFs has exactly ny modes: asking for more is an impossible
    value (DESIGN §4), reported before any work rather than padded with NaN."""
    modal = scene.get("modal")
    if modal and ny and modal["modes"] > ny:
        raise SceneError(
            "modal.modes", f"{modal['modes']} modes asked for, but the discretized model has "
            f"only {ny} degrees of freedom (discretization {scene['discretization']}); ask for "
            f"at most {ny} or refine the discretization")


def _buckled(freq: np.ndarray) -> np.ndarray:
    """(case,) bool: the frozen K_eff has a negative eigenvalue at some modal angle.

    :func:`ced.modal.natural_frequencies` reports a negative eigenvalue λ as the frequency
    −√|λ|/2π. With axial stiffening, a link compressed beyond its Euler load has one (the
    linear model then describes a link that would buckle); centrifugal softening of a
    near-mechanism mode (change points) gives one too.
    """
    scale = np.abs(freq).max(axis=(1, 2), keepdims=True)
    return (freq < -BUCKLED_TOLERANCE * scale).any(axis=(1, 2))


def dyad_sine_min(batch: Batch) -> np.ndarray:
    """Smallest |sin μ| over the motion, μ the angle between coupler and rocker at C, (case,).

    Exact, not sampled on the step grid: with d = |BD| = √(a² + g² − 2ag cos θ),
    cos μ = (b² + c² − d²)/(2bc) is monotonic in d, so |sin μ| is smallest at an end of the
    range of d the input traverses (θ over the whole circle for a crank; θ_mid ± A for a rocker
    input, where d is extreme at the ends or at θ = kπ inside). 1 for mechanisms without a dyad.
    """
    if batch.mechanism_type != "four_bar":
        return np.ones(batch.size)
    L = batch.lengths
    g, a, b, c = L["ground"], L["crank"], L["coupler"], L["rocker"]
    amp = np.where(np.isfinite(batch.amplitude), batch.amplitude, math.pi)
    lo, hi = batch.initial_angle - amp, batch.initial_angle + amp
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


def near_singular(batch: Batch) -> np.ndarray:
    """(case,) bool: the elastic structure loses its stiffness somewhere in the cycle.

    Coupler and rocker pinned at C resist a motion of C across their common line only through
    the angle between them: whatever holds the structure (their axial stiffness, the bending of
    a flexible input link seen through the linkage's velocity ratio, which grows as 1/sin μ
    towards a toggle), the stiffness of that mode scales as sin²μ and its frequency as |sin μ|;
    at sin μ = 0 (change point, toggle) the pin-jointed structure is an infinitesimal mechanism.
    Flagged when |sin μ| falls below NEAR_SINGULAR_SIN somewhere in the motion, exactly
    (:func:`dyad_sine_min`), not only on the step grid. Example: a double rocker (0.5, 0.35,
    0.1, 0.45) at 99 % of its input range has sin μ = 0.127 and its lowest frozen frequency
    drops from 25.5 Hz to 3.6 Hz at the extremes, in proportion.
    """
    return dyad_sine_min(batch) < NEAR_SINGULAR_SIN
