"""``effects: auto``: choose a scene's effects from cheap dimensionless estimates (docs/theory.md).

Every estimate is the relative change of a link's *peak stress* that an effect causes. It is
worked out from the quasi-static stress of the rigid motion and the lowest mode of the frozen
elastic mechanism, treated as a one-degree-of-freedom oscillator. An effect is simulated when
its estimate exceeds the scene's ``tolerance``, so each neglected effect changes the peak
response by less than the tolerance (as far as the estimate can tell), as docs/theory.md asks.

No time integration is needed. The inputs are the rigid motion over one input period
(closed-form kinematics, :mod:`ced.rigid.kinematics`), the rigid inverse dynamics
(:mod:`ced.rigid.inverse_dynamics`) and ced's own frozen modal analysis
(:mod:`ced.response.frequencies`). This takes about 20 ms per scene.

Quasi-static stress of the rigid motion
---------------------------------------
The mechanism, with its input clamped by the motor, is statically determinate. The internal
forces of each link in the rigid motion are therefore the quasi-static elastic ones (to first
order). They follow from equilibrium of the piece [0, s] of the link under:

- the first-end joint force f (rigid inverse dynamics),
- the drive torque τ (input link only, clamped at its ground pivot), and
- the distributed d'Alembert load and weight q(s) = ρA(g − a(s)).

This gives the axial force N(s, t) = −e·(f + ∫₀ˢ q) and the bending moment
M(s, t) = −τ + s f_y + ∫₀ˢ (s − s′) q_y(s′) ds′. From them the outer-fibre stresses
σ± = N/A ± M h/(2I) are found at :data:`STATIONS` points over the cycle, together with their
spectra σ̂_k at the harmonics kΩ. The inertia part and the weight part are kept apart; both are
linear in their loads.

The common yardstick
--------------------
If the effective stiffness k becomes k(1 − x), the static response changes by the factor
1/(1 − x), that is by the relative amount

    c(x) = |x| / |1 − x|                                                             (1)

where x > 0 softens (compression, centrifugal softening, inertia below resonance) and x < 0
stiffens (tension). To first order c ≈ |x|. Eq. (1) stays correct when x is not small, and it
grows without bound as x → 1 (resonance, buckling), where the effect is always kept.

The estimates
-------------
Notation:

- ω₁: the lowest natural frequency of the frozen elastic mechanism (elastic stiffness and mass,
  no motion-induced terms, smallest over the cycle).
- Ω: the drive speed.
- ω_i, α_i: the angular velocity and acceleration of flexible link i.
- a_k = |σ̂_k|/σ_peak: the harmonics of the quasi-static stress at a point, relative to the
  link's peak stress.
- r_k = kΩ/ω.

=====================  =====================================================================
inertia                Always kept for a moving mechanism: the d'Alembert load of the rigid motion
                       *is* the load. Reported: max|σ_inertia| / σ_peak, as for gravity.
gravity                max|σ_weight| / σ_peak for each flexible link, the largest over the links.
                       By the triangle inequality this bounds the change of the peak stress. A
                       rigid analysis uses the joint forces max|F_weight| / max|F| instead, since
                       they are its result. This is the weight-to-inertial-load ratio ρAg / ρA
                       max|a| weighted by where each load puts stress.
elastic_inertia        max over points of Σ_{k≥1} a_k c(r_k²). Harmonic k drives the mode at kΩ.
                       Its steady response is the quasi-static one times 1/(1 − r_k²), so the
                       quasi-static model misses c(r_k²) = r_k²/|1 − r_k²| of it, and the sum
                       bounds the error of the peak. It is evaluated at ω₁ and at the lowest frozen
                       frequency ω₁√(1 − x_spin − N_c/N_cr) reached in the cycle under
                       motion-induced softening and axial compression. The larger value is used.
centrifugal            x_spin = max_t (ω_i² + |α_i|)/ω₁². The displacement-proportional
                       motion-induced terms (−ω² M_w, αG and the frame terms MP̈, 2ωGṖ of the same
                       order) are a stiffness of size (ω² + |α|)·mass against K ≈ ω₁²·mass. The
                       change is given by :func:`stiffness_change`.
coriolis               (2 max|ω_i| / ω₁) · v. The velocity terms 2ωG q̇ and 2MṖq̇ have size
                       2|ω||q̇|·mass against the elastic force ω₁²|q|·mass, with v = |q̇|/(ω₁|q|)
                       (:func:`velocity_ratio`). These are first-order magnitudes. The gyroscopic
                       forces act in quadrature with the displacement and do no work, so the real
                       change is often far smaller: the estimate is deliberately conservative
                       ("when in doubt include it"). The effect is dropped when the response is
                       quasi-static, because q̇ is then not part of the model.
axial_stiffening       ±N/N_cr. The geometric stiffness of the axial force N(s, t), taken with and
                       without weight (the larger), is compared with the link's buckling load
                       N_cr = π²EI/(K_e L)², using the effective-length factor K_e of the link's end
                       conditions. Both the largest compression (softening) and the largest tension
                       (stiffening) are tried (:func:`stiffness_change`).
elastic_axial_force    elastic_inertia × axial_stiffening. The elastic joint forces add to a link's
                       axial force a share of the size of the elastic part of the internal forces,
                       which the elastic-inertia estimate bounds relative to the rigid ones; the
                       geometric stiffness of that share changes the response by that fraction of
                       axial_stiffening's change. Chosen only where the response is dynamic
                       (quasi-statically the joint forces are the rigid ones to first order) and
                       the scene allows it (a beam formulation; from a periodic start, shooting
                       over at least one revolution); it then brings axial_stiffening with it.
damping                Kept iff the ``damping`` block dissipates (ratio > 0, or α, β > 0) *and* the
                       response is dynamic: a quasi-static solve K q = F has no velocity to damp.
                       Reported: the first-mode damping ratio ζ₁.
=====================  =====================================================================

Near resonance, a small stiffness change moves the resonance and changes the response a lot.
The stiffness-type estimates (centrifugal, axial_stiffening) include this dynamic
magnification (:func:`stiffness_change`).

All estimates describe the *steady forced* response. An ``undeformed`` start applies the full
load suddenly. Without damping, this leaves a free vibration as large as the response itself.
That vibration comes from the initial state, not from the physics, and is not counted for
``elastic_inertia``. Once the dynamic model is chosen, its velocity scale does count for
Coriolis.

Only two things depend on the tolerance: the highest significant harmonic k_max and the
elastic-inertia choice. Both are monotone, so a smaller tolerance never drops an effect.

Validation
----------
The estimates were checked against full KED runs with a periodic start, 1024 steps per
revolution. Each effect was dropped in turn and the change of the peak stress measured. The
cases were:

- the reference four-bar with 5 mm steel links, rigid crank at 30 and 100 rad/s and flexible
  crank at 40 and 80 rad/s;
- Simeon's slider-crank at 30, 75, 150 and 300 rad/s;
- a slider-crank with flexible crank and a 0.2 kg slider;
- a double-crank;
- the Sung–Thompson aluminium crank-rocker;
- a rotating cantilever under its weight.

Every estimate was at least the measured change (gravity on the cantilever: equal to 0.1 %).
Elastic inertia and gravity estimates were 1.2 to 25 times the measured change, typically 2.
Centrifugal and axial-stiffening estimates were 1.5 to 500 times, largest where the measured
change is far below any tolerance. Coriolis estimates were 10² to 10⁵ times.

``elastic_axial_force`` was checked alike (periodic start by shooting, 8 elements, 512 steps
per revolution, undamped) on the reference four-bar with a flexible coupler, and on the Watt
II and Stephenson III of ``benchmarks/peer/linkages.py`` with two flexible links, at 20, 35,
50, 70 and 90 rad/s: the estimate was 8.5 to 2,000 times the change of the peak stress (the
Stephenson III 8.5 to 23 times; the largest change, 21 %, on the Watt II at 90 rad/s, flagged
``resonant``, against an estimate of 27). In the steady state the effect is small below
resonance; from an undeformed start its free vibration carries elastic joint forces of the
size of the response, which the estimate does not count (as for ``elastic_inertia``).
"""
from __future__ import annotations

import copy
import math

import numpy as np

from ..problem.scene import AUTO, EFFECTS, SceneError, check_elastic_axial_force
from ..response.batch import make_batch
from ..response.frequencies import cycle_frequencies, first_natural_frequency
from ..response.model import build_model
from ..rigid.inverse_dynamics import inverse_dynamics

__all__ = ["choose_effects", "resolve_auto", "fundamental_frequency", "end_conditions",
           "stiffness_change", "quasi_static_error", "velocity_ratio", "BOUNDARY",
           "CYCLE_SAMPLES", "MODAL_PHASES", "STATIONS", "ESTIMATE_CAP"]

#: Samples of one input period for the harmonic analysis (harmonics up to 512 Ω).
CYCLE_SAMPLES = 1024
#: Frozen configurations, evenly spaced over the period, at which ω₁ is computed. The smallest
#: is used, because a linkage's stiffness depends on its configuration.
MODAL_PHASES = 8
#: Elements per flexible link of the probe model. The first bending frequency of a cubic
#: Hermite mesh converges as O(h⁴), so 8 elements are within 1e-6 of the exact value.
PROBE_ELEMENTS = 8
#: Points along each link (ends and mid-point included) where the quasi-static stress is
#: evaluated. M(s) is a cubic, so its extreme lies close to one of them.
STATIONS = 9
#: A signal below this fraction of its reference is rounding noise. The kinematics and
#: the inverse dynamics are accurate to about 1e-15, so this leaves a wide margin.
NOISE_FLOOR = 1e-9
#: Largest estimate reported (resonance, buckling). It is finite so that the report is valid
#: JSON.
ESTIMATE_CAP = 1e9
#: First bending mode of a uniform beam for each end condition: (β₁L, effective-length factor
#: K_e of the buckling load π²EI/(K_e L)²). Clamped–pinned: β₁L = 3.9266, N_cr = 20.19 EI/L².
BOUNDARY = {
    "pinned-pinned": (math.pi, 1.0),
    "clamped-free": (1.875104069, 2.0),
    "clamped-pinned": (3.926602312, math.pi / math.sqrt(20.190729)),
}
_ELASTIC = ("elastic_inertia", "coriolis", "centrifugal", "axial_stiffening",
            "elastic_axial_force", "damping")
_FE_FORMULATIONS = ("euler_bernoulli", "timoshenko")
_EPS = 1.0 / ESTIMATE_CAP
_UNDEFORMED_NOTE = (
    "; steady forced response only: the free vibration that the undeformed start excites "
    "(as large as the response itself when undamped) comes from the initial state and is "
    "not counted (time.start: periodic or quasi_static avoids it)")


# ------------------------------------------------------------------------- the estimates
def _change(x: float) -> float:
    """c(x) = |x|/|1 − x|, eq. (1), capped at :data:`ESTIMATE_CAP`."""
    x = float(x)
    return float(min(abs(x) / max(abs(1.0 - x), _EPS), ESTIMATE_CAP))


def quasi_static_error(spectrum: np.ndarray, speed: float, omega: float) -> float:
    """Bound on the relative error of a quasi-static response, Σ_{k≥1} a_k c(r_k²).

    Parameters
    ----------
    spectrum : (n,) harmonic amplitudes a_k (k = 0 … n − 1) of the quasi-static response,
        relative to its peak
    speed : drive speed Ω, rad/s
    omega : natural frequency ω of the mode, rad/s

    Notes
    -----
    Harmonic k drives the mode at kΩ. Its steady response is the quasi-static one times
    1/(1 − r²), r = kΩ/ω, so the quasi-static model is wrong by r²/|1 − r²| = c(r²) for that
    harmonic, and the error of the peak is at most the sum over the harmonics. This is tighter
    than c(r²) at the highest significant harmonic alone, which ignores that high harmonics
    are weak. It still bounds their effect and catches a weak harmonic near resonance.
    """
    r2 = (np.arange(1, len(spectrum)) * speed / max(omega, 1e-300)) ** 2
    error = r2 / np.maximum(np.abs(1.0 - r2), _EPS)
    return float(min(np.sum(spectrum[1:] * error), ESTIMATE_CAP))


def stiffness_change(x: float, spectra, speed: float, omega: float) -> float:
    """Relative change of a first-mode response when its stiffness k becomes k(1 − x).

    Parameters
    ----------
    x : relative softening (negative: stiffening)
    spectra : iterable of (n,) relative harmonic amplitudes a_k of the quasi-static response
        at the points of a link (see :func:`quasi_static_error`)
    speed, omega : Ω and the mode's frequency, rad/s

    Notes
    -----
    Quasi-statically the change is c(x), eq. (1). In the dynamic response harmonic k has
    amplitude a_k/|1 − r_k²|, and changes by |x|/|1 − x − r_k²| of it: near resonance a
    stiffness change moves the resonance, and the change is magnified. The bound is
    Σ_k a_k |x| / (|1 − r_k²| |1 − x − r_k²|) at the worst point, relative to the peak
    quasi-static response. Far above resonance, the dynamic response is much smaller than
    the quasi-static one and this normalization could understate the relative change. Taking
    the larger of the bound and c(x) covers that case. It also makes the result independent
    of whether elastic inertia is chosen, which keeps the choice monotone in the tolerance.
    """
    best = _change(x)
    for a in spectra:
        r2 = (np.arange(len(a)) * speed / omega) ** 2
        gain = np.abs(x) / (np.maximum(np.abs(1.0 - r2), _EPS)
                            * np.maximum(np.abs(1.0 - x - r2), _EPS))
        best = max(best, float(np.sum(a * gain)))
    return float(min(best, ESTIMATE_CAP))


def velocity_ratio(start: str, k_max: int, speed: float, omega1: float,
                   inertia_estimate: float) -> tuple[float, str]:
    """v = |q̇|/(ω₁|q|), the elastic velocity scale in units of the first mode's.

    - ``undeformed`` start: the suddenly applied load leaves a free vibration at ω₁ as large as
      the response itself. Without damping it persists, so v = 1.
    - ``periodic``: only the forced response remains, and its harmonics reach k_max Ω at most
      (k_max is the highest harmonic above the tolerance), so v = min(1, k_max Ω/ω₁).
    - ``quasi_static``: the forced response plus a free vibration as large as the mismatch
      between the quasi-static and the dynamic response, which is the elastic-inertia
      estimate, so v = min(1, max(k_max Ω/ω₁, estimate)).

    Parameters
    ----------
    start : str
        The scene's ``time.start``: ``"undeformed"``, ``"periodic"`` or ``"quasi_static"``.
    k_max : int
        Highest crank harmonic whose share of the load is above the tolerance.
    speed : float
        Input speed Ω, rad/s.
    omega1 : float
        Lowest natural frequency ω₁ of the frozen mechanism, rad/s.
    inertia_estimate : float
        Relative size of the elastic-inertia effect (dimensionless), the free vibration left by a
        quasi-static start.

    Returns
    -------
    ratio : float
        The velocity ratio v (dimensionless, at most 1).
    reason : str
        How it was estimated, for the ``effects_auto`` report.
    """
    forced = k_max * speed / omega1
    if start == "undeformed":
        return 1.0, "undeformed start: free vibration at ω₁, |q̇| ≈ ω₁|q|"
    if start == "periodic":
        return min(1.0, forced), f"periodic steady state: |q̇| ≲ k_max Ω |q|, k_max = {k_max}"
    return (min(1.0, max(forced, inertia_estimate)),
            f"quasi-static start: forced harmonics up to k_max = {k_max} plus a free vibration "
            f"of relative size {inertia_estimate:.3g}")


# ------------------------------------------------------------------- mechanism quantities
def end_conditions(topo, link: str) -> str:
    """End conditions of a link's first bending mode.

    The motor holds the driven input link, so it is clamped at its ground pivot. Its other end
    is free at a tip (single link) or pinned to the next link. Pins share translations only,
    so every other link is pinned at both ends.

    Parameters
    ----------
    topo : Topology
        The mechanism's topology (:class:`ced.problem.mechanism.Topology`): links, joints,
        input link.
    link : str
        Name of the link.

    Returns
    -------
    str
        ``"clamped-free"``, ``"clamped-pinned"`` or ``"pinned-pinned"``, a key of
        :data:`BOUNDARY`.
    """
    if link != topo.input_link:
        return "pinned-pinned"
    second = topo.links[link][1]
    return "clamped-free" if topo.joints[second][1] == "tip" else "clamped-pinned"


def _probe_scene(scene: dict) -> dict:
    """The scene with only inertia and elastic inertia, a modest Euler–Bernoulli mesh (or
    Timoshenko, if the scene uses it), no damping and no modal block."""
    probe = copy.deepcopy(scene)
    probe["effects"] = ["inertia", "elastic_inertia"]
    disc = scene["discretization"]
    formulation = disc["formulation"] if isinstance(disc, dict) else "euler_bernoulli"
    if formulation not in _FE_FORMULATIONS:
        formulation = "euler_bernoulli"
    probe["discretization"] = {"formulation": formulation, "elements_per_link": PROBE_ELEMENTS,
                               "elements_across": 2}
    probe["damping"] = {"model": "modal", "ratio": 0.0, "alpha": 0.0, "beta": 0.0}
    probe["modal"] = None
    return probe


def _cycle_times(speed: float, n: int) -> np.ndarray:
    """(1, n) evenly spaced times over one input period 2π/Ω, s.

    The samples sit at the middles of n equal intervals. This keeps the spacing uniform for
    the FFT and avoids the input angles 0 and π, where a change-point linkage folds and its
    inverse dynamics are singular.
    """
    return (2.0 * math.pi / speed) * (np.arange(n)[None, :] + 0.5) / n


def fundamental_frequency(scene: dict) -> tuple[float, str]:
    """Lowest natural frequency ω₁ (rad/s) of the frozen elastic mechanism, and how it was got.

    The first choice is ced's own model: K and M with elastic inertia only (no motion-induced
    terms), at :data:`MODAL_PHASES` configurations over the cycle, keeping the smallest value.
    This includes the mobility of the joints, point masses, the slider and the rigid links.
    Should the frozen system be singular, the fallback is the first bending frequency
    (β₁L)²/L² √(EI/ρA) of each flexible link with its end conditions
    (:func:`end_conditions`), again the smallest. The result is ``inf`` without elastic DOFs.

    Parameters
    ----------
    scene : dict
        A normalized scene.

    Returns
    -------
    omega : float
        Lowest natural frequency ω₁, rad/s (``inf`` without elastic DOFs).
    reason : str
        How it was obtained (frozen modal analysis or beam formula), for the report.
    """
    batch = make_batch([_probe_scene(scene)])
    model = build_model(batch)
    if model.layout.ny == 0:
        return math.inf, "no elastic degrees of freedom"
    phases = 2.0 * math.pi * (np.arange(MODAL_PHASES) + 0.5) / MODAL_PHASES
    try:
        freq = cycle_frequencies(model, phases, 1, effects={"elastic_inertia"})
    except np.linalg.LinAlgError:
        pass  # a singular frozen system: the beam formula below
    else:
        omega = float(first_natural_frequency(freq, over="min")[0])
        if math.isfinite(omega) and omega > 0.0:
            return omega, f"frozen modal analysis of the mechanism at {MODAL_PHASES} phases"
    topo = batch.topology
    best = math.inf
    for i, name in enumerate(topo.link_names):
        link = scene["links"][name]
        if not link["flexible"]:
            continue
        EI = link["material"]["E"] * link["section"]["second_moment"]
        rho_a = link["material"]["rho"] * link["section"]["area"]
        beta_l = BOUNDARY[end_conditions(topo, name)][0]
        length = float(batch.link_lengths[0, i])
        best = min(best, beta_l**2 / length**2 * math.sqrt(EI / rho_a))
    return best, "first bending frequency of the flexible links (beam formula)"


def _internal_forces(motion, batch, gravity: np.ndarray, inertia: bool) -> dict:
    """Quasi-static internal forces of every link in the rigid motion, under the d'Alembert
    loads (``inertia``) and/or the weight (``gravity``).

    Returns {link: (N, M)}, each (step, station): the axial force N (tension positive) and the
    bending moment M (N m) at :data:`STATIONS` points s ∈ [0, L]. Equilibrium of the piece
    [0, s] is taken under:

    - the first-end joint force f, plus the point mass riding there, as in
      :func:`ced.response.model.terms_at`,
    - the drive torque τ on the input link, and
    - q(s) = ρA(g − a_first − s(α n − ω² e)).

    This gives N = −(f_x + q0_x s + q1_x s²/2) and M = −τ + s f_y + q0_y s²/2 + q1_y s³/6,
    with q = q0 + s q1 in the link frame (e, n).

    Raises ``numpy.linalg.LinAlgError`` where the inverse dynamics is singular (a sample
    exactly at a folded configuration).
    """
    topo = batch.topology
    rigid = inverse_dynamics(motion, batch.bodies, gravity, inertia=inertia)
    on = 1.0 if inertia else 0.0
    g = np.asarray(gravity, float)[None, :]
    out = {}
    for i, name in enumerate(topo.link_names):
        first = topo.links[name][0]
        kf = topo.joint_names.index(first)
        force = rigid.joint_force[0, :, kf]
        f = force if topo.joints[first][1] == name else -force
        acc = on * motion.joint_acceleration[0, :, kf]
        carrier = topo.joints[first][0] if topo.joints[first][1] == "tip" else topo.joints[first][1]
        if carrier == name:  # the point mass at the first joint rides on this link
            f = f + batch.bodies.point_mass[0, kf] * (g - acc)
        th = motion.link_angle[0, :, i]
        e = np.stack([np.cos(th), np.sin(th)], axis=-1)
        n = np.stack([-np.sin(th), np.cos(th)], axis=-1)
        length = float(batch.link_lengths[0, i])
        rho_a = batch.bodies.mass[0, i] / length
        w, al = motion.link_angular_velocity[0, :, i], motion.link_angular_acceleration[0, :, i]
        q0x, q0y = (rho_a * np.sum(d * (g - acc), axis=-1) for d in (e, n))
        q1x, q1y = rho_a * on * w * w, -rho_a * on * al
        fx, fy = np.sum(e * f, axis=-1), np.sum(n * f, axis=-1)
        tau = rigid.input_torque[0] if name == topo.input_link else np.zeros_like(fx)
        s = np.linspace(0.0, length, STATIONS)[None, :]
        col = lambda v: v[:, None]  # noqa: E731
        N = -(col(fx) + col(q0x) * s + 0.5 * col(q1x) * s * s)
        M = -col(tau) + col(fy) * s + 0.5 * col(q0y) * s * s + col(q1y) * s**3 / 6.0
        out[name] = (N, M)
    return out


def _stress(link: dict, forces: tuple) -> np.ndarray:
    """Outer-fibre stresses σ± = N/A ± M h/(2I), (step, station, 2), Pa."""
    N, M = forces
    sec = link["section"]
    axial, bending = N / sec["area"], M * 0.5 * sec["height"] / sec["second_moment"]
    return np.stack([axial + bending, axial - bending], axis=-1)


def _spectra(stress: np.ndarray) -> list[np.ndarray]:
    """One-sided harmonic amplitudes of the stress at each point and fibre, relative to the
    link's peak stress: a list of (n/2 + 1,) arrays (empty if the link is unloaded).
    Amplitudes below :data:`NOISE_FLOOR` of the peak are rounding noise and set to zero."""
    peak = float(np.max(np.abs(stress)))
    if peak <= 0.0:
        return []
    X = np.abs(np.fft.rfft(stress.reshape(stress.shape[0], -1), axis=0)) / stress.shape[0]
    X[1:] *= 2.0  # one-sided amplitudes (the Nyquist bin is negligible here)
    X[X < NOISE_FLOOR * peak] = 0.0  # rounding noise
    return list((X / peak).T)


def _shares(parts: dict, norm, what: str, unit: str) -> dict:
    """Contributions of the d'Alembert load and of the weight to a peak result.

    ``parts`` maps an item (link or joint) to its (inertia, weight) parts, arrays over the
    cycle, and ``norm`` gives the magnitude of their sum or of either part. For each part the
    largest over items of max|part| / max|inertia + weight| is returned, with a text. By the
    triangle inequality this bounds the change of the item's peak when the part is left out.
    Items whose peak is rounding noise are skipped. Returns {"inertia": (value, text),
    "weight": (value, text)}.
    """
    peaks = {k: float(np.max(norm(i + w))) for k, (i, w) in parts.items()}
    top = max(peaks.values())
    out = {}
    for j, part in enumerate(("inertia", "weight")):
        ratios = {k: float(np.max(norm(p[j]))) / peaks[k] for k, p in parts.items()
                  if peaks[k] > NOISE_FLOOR * top}
        k = max(ratios, key=ratios.get)
        out[part] = (min(ratios[k], ESTIMATE_CAP),
                     f"{what} {k}: max|{part}|/peak = {ratios[k] * peaks[k]:.4g}/{peaks[k]:.4g} "
                     f"{unit}")
    return out


def _vector_norm(x: np.ndarray) -> np.ndarray:
    return np.linalg.norm(x, axis=-1)


# ------------------------------------------------------------------------------ public
def choose_effects(scene: dict) -> tuple[list[str], dict]:
    """Choose the effects of a normalized scene whose ``effects`` is ``"auto"``.

    Parameters
    ----------
    scene : dict
        A scene normalized by :func:`ced.problem.scene.load_scene` (its ``effects`` is not read, so
        any normalized scene may be passed).

    Returns
    -------
    effects : list of str
        The chosen effects, in the canonical order of :data:`ced.problem.scene.EFFECTS`.
    report : dict
        ``{effect: {"included": bool, "estimate": float, "reason": str}}`` for every effect of
        :data:`ced.problem.scene.EFFECTS`, in that order. ``estimate`` is the relative
        contribution of the effect to the peak stress (dimensionless, finite, at most :data:`ESTIMATE_CAP`),
        compared with ``scene["tolerance"]``. JSON-serializable.

    Notes
    -----
    The estimates and their reasoning are in the module docstring. An effect is included when
    its estimate exceeds the tolerance, except that ``inertia`` is always included,
    ``coriolis`` and ``damping`` only come with ``elastic_inertia``, and elastic effects
    never apply to a rigid formulation or to a mechanism without flexible links.
    """
    tol = float(scene["tolerance"])
    batch = make_batch([_probe_scene(scene)])
    topo = batch.topology
    speed = float(batch.speed[0])
    gravity = np.asarray(scene["gravity"], float)
    disc = scene["discretization"]
    rigid = isinstance(disc, dict) and disc["formulation"] == "rigid"
    flexible = [] if rigid else [n for n in topo.link_names if scene["links"][n]["flexible"]]
    motion = batch.rigid_motion(_cycle_times(speed, CYCLE_SAMPLES))
    report: dict[str, dict] = {}
    weightless = not np.any(gravity)

    # A sample exactly at a folded configuration: unbounded forces, the weight's share unknown.
    note = "the inverse dynamics is singular in the cycle"
    singular = {"inertia": (1.0, note), "weight": (ESTIMATE_CAP, note)}
    if not flexible:  # rigid analysis: the result is the joint forces
        try:
            forces = {part: inverse_dynamics(motion, batch.bodies, gv, inertia=on).joint_force[0]
                      for part, gv, on in (("inertia", np.zeros(2), True),
                                           ("weight", gravity, False))}
            shares = _shares({j: (forces["inertia"][:, k], forces["weight"][:, k])
                              for k, j in enumerate(topo.joint_names)},
                             _vector_norm, "joint", "N")
        except np.linalg.LinAlgError:  # a sample hit a folded configuration exactly
            shares = singular
        _inertia_and_gravity(report, shares, tol, weightless)
        why = ("discretization.formulation is rigid: no elastic degrees of freedom" if rigid
               else "no flexible link: no elastic degrees of freedom")
        for effect in _ELASTIC:
            report[effect] = _entry(False, 0.0, why)
        return _finish(report)

    try:
        parts = {"inertia": _internal_forces(motion, batch, np.zeros(2), True),
                 "weight": _internal_forces(motion, batch, gravity, False)}
    except np.linalg.LinAlgError:  # a sample hit a folded configuration exactly
        parts, stress, shares = None, None, singular
    else:
        stress = {n: {key: _stress(scene["links"][n], parts[key][n]) for key in parts}
                  for n in flexible}
        shares = _shares({n: (s["inertia"], s["weight"]) for n, s in stress.items()},
                         np.abs, "stress of the", "Pa")
    _inertia_and_gravity(report, shares, tol, weightless)

    omega1, how = fundamental_frequency(scene)
    if not math.isfinite(omega1):
        for effect in _ELASTIC:
            report[effect] = _entry(False, 0.0, how)
        return _finish(report)
    report.update(_elastic_effects(scene, batch, motion, flexible, parts, stress, omega1, how,
                                   tol))
    return _finish(report)


def _inertia_and_gravity(report, shares, tol, weightless) -> None:
    """Report entries of inertia and gravity from :func:`_shares`."""
    share, where = shares["inertia"]
    report["inertia"] = _entry(True, share, (
        "always included for a moving mechanism: the d'Alembert load of the rigid motion is "
        f"the load ({where})"))
    if weightless:
        report["gravity"] = _entry(False, 0.0, "the gravity vector is zero")
    else:
        ratio, where = shares["weight"]
        report["gravity"] = _entry(ratio > tol, ratio, (
            f"weight against the whole load, by the quasi-static peak it produces: {where}"))


def _elastic_effects(scene, batch, motion, flexible, parts, stress, omega1, how, tol) -> dict:
    """Report entries of the effects of the elastic model (see the module docstring)."""
    topo = batch.topology
    speed = float(batch.speed[0])
    idx = {n: topo.link_names.index(n) for n in flexible}
    out = {}

    # Spectra of the quasi-static stress (inertia and weight, whether or not gravity is chosen:
    # the estimate must not depend on that choice), and the highest harmonic above tolerance.
    if stress is None:
        spectra = {}
    else:
        spectra = {n: _spectra(s["inertia"] + s["weight"]) for n, s in stress.items()}
    every = [a for pair in spectra.values() for a in pair]
    k_max = max((int(np.flatnonzero(a[1:] > tol).max()) + 1 for a in every
                 if np.any(a[1:] > tol)), default=0)

    # Motion-induced stiffness (ω² + |α|)·mass against K ≈ ω₁²·mass.
    w = np.abs(motion.link_angular_velocity[0])
    al = np.abs(motion.link_angular_acceleration[0])
    spin = {n: float(np.max(w[:, i] ** 2 + al[:, i])) for n, i in idx.items()}
    spin_link = max(spin, key=spin.get)
    x_spin = spin[spin_link] / omega1**2

    # Axial force against the buckling load, with and without weight (the larger, so that the
    # choice of gravity cannot lower it).
    axial = {}
    for name, i in idx.items():
        link = scene["links"][name]
        bc = end_conditions(topo, name)
        n_cr = (math.pi / (BOUNDARY[bc][1] * float(batch.link_lengths[0, i]))) ** 2 * (
            link["material"]["E"] * link["section"]["second_moment"])
        if parts is None:  # unbounded joint forces: treated as buckling-size axial forces
            axial[name] = (bc, n_cr, 0.0, n_cr)
            continue
        bare = parts["inertia"][name][0]
        loaded = bare + parts["weight"][name][0]
        tension = max(float(bare.max()), float(loaded.max()), 0.0)
        compression = max(-float(bare.min()), -float(loaded.min()), 0.0)
        axial[name] = (bc, n_cr, tension, compression)
    n_soft = max(c / n_cr for _, n_cr, _, c in axial.values())

    # elastic_inertia, at ω₁ and at the lowest frozen frequency of the cycle.
    soft = 1.0 - x_spin - n_soft
    omega_low = omega1 * math.sqrt(max(soft, 1e-12))
    if spectra:
        def quasi_static(name):
            return max((quasi_static_error(a, speed, wv) for a in spectra[name]
                        for wv in (omega1, omega_low)), default=0.0)

        k_link = max(flexible, key=quasi_static)
        inertia = quasi_static(k_link)
    else:
        k_link, inertia = "mechanism", ESTIMATE_CAP
    dynamic = inertia > tol
    low = (f"{omega_low:.4g} rad/s" if soft > 0.0
           else "0 (the frozen structure loses its stiffness)")
    out["elastic_inertia"] = _entry(dynamic, inertia, (
        "quasi-static error of the first mode forced at the harmonics kΩ of the quasi-static "
        f"stress of the {k_link}: max over points of Σ_k (|σ_k|/σ_peak) r²/|1 − r²|, r = kΩ/ω, "
        f"at ω = ω₁ and at the lowest frozen frequency ω₁√(1 − x_spin − N_c/N_cr) = {low}; "
        f"Ω/ω₁ = {speed / omega1:.4g}, highest harmonic above the tolerance k_max = {k_max} "
        f"(k_max Ω/ω₁ = {k_max * speed / omega1:.4g}); ω₁ = {omega1:.5g} rad/s "
        f"({omega1 / (2 * math.pi):.5g} Hz, {how})"
        + (_UNDEFORMED_NOTE if scene["time"]["start"] == "undeformed" else "")))

    # coriolis: velocity-proportional terms, meaningful only in a dynamic response.
    w_max = {n: float(np.max(w[:, i])) for n, i in idx.items()}
    fastest = max(w_max, key=w_max.get)
    v, why_v = velocity_ratio(scene["time"]["start"], k_max, speed, omega1, inertia)
    coriolis = 2.0 * w_max[fastest] / omega1 * v
    if dynamic:
        out["coriolis"] = _entry(coriolis > tol, coriolis, (
            f"2 max|ω|/ω₁ × |q̇|/(ω₁|q|) = 2 × {w_max[fastest]:.4g}/{omega1:.4g} × {v:.3g} "
            f"({fastest}; {why_v}); a first-order bound, conservative"))
    else:
        out["coriolis"] = _entry(False, coriolis, (
            "the response is quasi-static (elastic_inertia neglected): velocity terms need q̇ "
            f"and have no meaning (the dynamic estimate would be {coriolis:.3g})"))

    # centrifugal: the stiffness change x_spin, magnified where the response is dynamic.
    est = stiffness_change(x_spin, every, speed, omega1)
    out["centrifugal"] = _entry(est > tol, est, (
        f"motion-induced stiffness of the {spin_link}: x = max(ω² + |α|)/ω₁² = "
        f"{spin[spin_link]:.4g}/{omega1**2:.4g} = {x_spin:.3g}; change of the forced response "
        f"{est:.3g} (x/|1 − x| = {_change(x_spin):.3g} quasi-statically)"))

    # axial_stiffening: geometric stiffness ±N/N_cr, magnified where the response is dynamic.
    def axial_change(name):
        _, n_cr, tension, compression = axial[name]
        return max(stiffness_change(compression / n_cr, every, speed, omega1),
                   stiffness_change(-tension / n_cr, every, speed, omega1))

    name = max(axial, key=axial_change)
    bc, n_cr, tension, compression = axial[name]
    est = axial_change(name)
    out["axial_stiffening"] = _entry(est > tol, est, (
        f"axial force of the {name} against its buckling load π²EI/(K_e L)² = {n_cr:.4g} N "
        f"({bc}): max tension {tension:.4g} N, max compression {compression:.4g} N; change of "
        f"the forced response {est:.3g}"))
    # elastic_axial_force: the elastic joint forces add to each link's axial force a share of
    # the size of the elastic part of the internal forces, which the elastic-inertia estimate
    # bounds relative to the rigid ones; its geometric stiffness then changes the response by
    # that share of axial_stiffening's change.
    out["elastic_axial_force"] = _elastic_axial_force(scene, inertia, est, dynamic, tol)
    if out["elastic_axial_force"]["included"] and not out["axial_stiffening"]["included"]:
        out["axial_stiffening"]["included"] = True  # the geometric stiffness it adds to
        out["axial_stiffening"]["reason"] += "; included for elastic_axial_force, which adds to it"

    # damping: as the scene asks, where there is a velocity to damp.
    d = scene["damping"]
    if d["model"] == "modal":
        zeta = d["ratio"]
        what = f"modal ratio ζ = {zeta:.4g}"
    else:
        zeta = d["alpha"] / (2.0 * omega1) + d["beta"] * omega1 / 2.0
        what = (f"Rayleigh α = {d['alpha']:.4g} 1/s, β = {d['beta']:.4g} s: "
                f"ζ₁ = α/2ω₁ + βω₁/2 = {zeta:.4g}")
    if zeta <= 0.0:
        out["damping"] = _entry(False, 0.0, "the damping block gives no damping")
    elif not dynamic:
        out["damping"] = _entry(False, zeta, (
            f"{what}, but the response is quasi-static (elastic_inertia neglected): damping "
            "forces need q̇ and have no meaning"))
    else:
        out["damping"] = _entry(True, zeta, f"{what}: dissipation asked for by the scene")
    return out


def _elastic_axial_force(scene: dict, inertia: float, axial: float, dynamic: bool,
                         tol: float) -> dict:
    """Report entry of ``elastic_axial_force``: estimate ``inertia`` × ``axial`` (the
    elastic-inertia and axial-stiffening estimates), chosen above ``tol`` where the response
    is dynamic and the scene allows the effect
    (:func:`ced.problem.scene.check_elastic_axial_force`)."""
    est = min(inertia * axial, ESTIMATE_CAP)
    what = (f"the elastic joint forces' share of the axial force, elastic_inertia's estimate "
            f"({inertia:.3g}) of the rigid one, in the geometric stiffness: {inertia:.3g} × "
            f"axial_stiffening's estimate {axial:.3g} = {est:.3g}")
    if not dynamic:
        return _entry(False, est, (
            f"{what}; the response is quasi-static (elastic_inertia neglected): its joint "
            "forces are the rigid ones to first order"))
    try:
        check_elastic_axial_force({**scene, "effects": ["axial_stiffening",
                                                        "elastic_axial_force"]})
    except SceneError as refusal:
        return _entry(False, est, f"{what}; not possible in this scene: {refusal}")
    return _entry(est > tol, est, what + (
        "; solved by fixed-point iterations of the whole run (some 4–10 solves)"
        if est > tol else ""))


def _entry(included: bool, estimate: float, reason: str) -> dict:
    return {"included": bool(included), "estimate": float(min(estimate, ESTIMATE_CAP)),
            "reason": reason}


def _finish(report: dict) -> tuple[list[str], dict]:
    ordered = {e: report[e] for e in EFFECTS}
    return [e for e in EFFECTS if ordered[e]["included"]], ordered


def resolve_auto(scene: dict) -> tuple[dict, dict | None]:
    """Resolve ``effects: auto`` of a normalized scene.

    Parameters
    ----------
    scene : dict
        A normalized scene; its ``effects`` is a list of effect names or ``"auto"``.

    Returns
    -------
    scene : dict
        A deep copy of ``scene``. When ``effects`` was ``"auto"`` it is replaced by the chosen
        list; otherwise the copy equals the input.
    report : dict or None
        The report of :func:`choose_effects` (stored as the dataset attribute
        ``effects_auto``), or None when the effects were an explicit list.
    """
    out = copy.deepcopy(scene)
    if not (isinstance(scene["effects"], str) and scene["effects"] == AUTO):
        return out, None
    out["effects"], report = choose_effects(scene)
    return out, report
