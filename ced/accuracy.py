"""Per-case discretization error estimates (DESIGN §5 ``error_estimate``).

The estimate is relative, on the case's peak stress (the largest peak over its links). It
comes from one coarser companion solution and the known convergence orders:

* **Space.** Nodal stresses of cubic Hermite beams (Euler–Bernoulli, Timoshenko) converge as
  O(h²) in the element length; the Q8 plane-stress mesh as well; ``seed_lame``'s quintic
  elements faster (module docstrings). Order 2 is taken for all, which is conservative for
  the faster ones.
* **Time.** Every integrator is second order (Newmark, HHT, generalized-α, Houbolt); the peak
  between samples is interpolated (:func:`ced.recovery.peaks`), so it converges smoothly.

Halving both the elements and the steps scales both error parts by 4, so a fine solution σ and
its companion σ_c give Richardson's asymptotic error |σ − σ_c|/3 whatever the signs of the
parts — no cancellation between space and time can hide in it. The estimate is three times
that, |σ − σ_c|/σ: a safety factor of 3 that keeps it an upper bound when the asymptotic
constants are only approached. Where halving is impossible (fewer than 4 elements or 16 steps)
the missing direction is refined instead, in a separate companion.

Richardson's argument needs the asymptotic range in time, which a strongly dissipative
scheme (Houbolt) reaches only when the first natural period spans many steps. A second,
a-priori term covers that: the integrator's relative frequency error plus its algorithmic
damping ratio at ω₁h (from the exact 1-DOF amplification matrix), doubled (the sensitivity of
a sub-resonant response to its natural frequency) and weighted by the dynamic share of the
response, 1 − 1/amplification. The estimate is the larger of the two terms.

Not estimated: the modal truncation of ``modes_per_link`` (with static load vectors it is
below 1e-5 on the reference four-bar even with one mode per link), and model error (beam vs
plane stress), which the fidelity ladder measures.
"""
from __future__ import annotations

import copy
import math
from typing import NamedTuple

import numpy as np

from .integrators import amplification_matrix, make_integrator

__all__ = ["Companion", "companions", "combine", "time_resolution_error",
           "ORDER", "SAFETY"]

#: Convergence order of peak stress, in element length and in time step.
ORDER = 2
#: Factor between the estimate and Richardson's asymptotic error estimate.
SAFETY = 3.0


class Companion(NamedTuple):
    """A companion discretization of a scene and the factor turning |σ − σ_c|/σ into the
    estimate's share (SAFETY / |r^p − 1| for refinement ratio r, p = ORDER)."""

    scene: dict
    factor: float


def _factor(ratio: float) -> float:
    """SAFETY × Richardson's 1/(r^p − 1), referred to the fine (scene's own) solution.

    ``ratio`` = fine step / companion step: < 1 for a coarser companion (the fine error is
    |Δ|/(r^p − 1) with r = 1/ratio), > 1 for a finer one (the fine error is
    |Δ| r^p/(r^p − 1), with r = ratio).
    """
    if ratio < 1.0:
        r = 1.0 / ratio
        return SAFETY / (r**ORDER - 1.0)
    return SAFETY * ratio**ORDER / (ratio**ORDER - 1.0)


def companions(scene: dict) -> list[Companion]:
    """Companion discretizations of a normalized scene with an elastic formulation.

    One companion with both elements and steps halved where both can be halved; otherwise one
    per direction (the one that cannot be halved is doubled). Modes per link are kept (the
    companion's count is clipped to what its coarser mesh has).

    Parameters
    ----------
    scene : dict
        Normalized scene (:func:`ced.scene.load_scene`) with ``discretization`` a dict.

    Returns
    -------
    list of Companion
    """
    disc, time = scene["discretization"], scene["time"]
    ne, spr = disc["elements_per_link"], time["steps_per_revolution"]
    coarse_ne = ne // 2 if ne >= 4 else None
    coarse_spr = spr // 2 if spr >= 16 and (spr // 2) * time["revolutions"] % 1 == 0 else None
    every = scene["outputs"]["every"]

    def variant(n_el: int, steps: int) -> dict:
        out = copy.deepcopy(scene)
        out["discretization"]["elements_per_link"] = n_el
        out["time"]["steps_per_revolution"] = steps
        # Keep the output instants when possible: a step twice as long, half as many per output.
        out["outputs"]["every"] = max(1, every * steps // spr)
        out["modal"] = None  # only the peak stress is compared
        out["name"] = f"{scene.get('name', '')} (error-estimate companion)"
        return out

    if coarse_ne is not None and coarse_spr is not None:
        ratio = max(coarse_ne / ne, coarse_spr / spr)  # the smaller refinement ratio governs
        return [Companion(variant(coarse_ne, coarse_spr), _factor(ratio))]
    space_ne = coarse_ne if coarse_ne is not None else 2 * ne
    time_spr = coarse_spr if coarse_spr is not None else 2 * spr
    return [Companion(variant(space_ne, spr), _factor(space_ne / ne)),
            Companion(variant(ne, time_spr), _factor(time_spr / spr))]


def time_resolution_error(time_cfg: dict, omega_h: np.ndarray, dynamic_share: np.ndarray
                          ) -> np.ndarray:
    """A-priori relative error of the response from the integrator's dispersion at ω₁h.

    Parameters
    ----------
    time_cfg : dict
        The scene's ``time`` block (integrator and its parameters).
    omega_h : (case,) array
        First natural circular frequency × step, rad per step.
    dynamic_share : (case,) array
        1 − 1/amplification, the part of the response due to vibration, in [0, 1].

    Returns
    -------
    (case,) array
        2 × share × (|ω̄/ω − 1| + ξ̄), with ω̄h the phase advance per step and ξ̄ the
        algorithmic damping ratio of the scheme's principal root.
    """
    from .ked import _scheme_params  # the scene → integrator parameters map lives there

    scheme = make_integrator(time_cfg["integrator"], **_scheme_params(time_cfg))
    W = np.clip(np.asarray(omega_h, float), 1e-6, None)
    roots = np.linalg.eigvals(amplification_matrix(scheme, W))
    # The principal root is the complex one whose phase per step is nearest ωh; spurious roots
    # are real (possibly negative, phase π). Without a complex root the mode is overdamped by
    # the scheme: its response is lost.
    oscillatory = roots.imag > 1e-12 * np.abs(roots)
    distance = np.where(oscillatory, np.abs(np.angle(roots) - W[..., None]), np.inf)
    principal = np.take_along_axis(roots, distance.argmin(axis=-1)[..., None], -1)[..., 0]
    advance = np.where(oscillatory.any(axis=-1), np.abs(np.angle(principal)), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        frequency_error = np.where(advance > 0, np.abs(advance / W - 1.0), 1.0)
        damping = np.where(advance > 0, -np.log(np.abs(principal)) / advance, 1.0)
    unresolved = W >= math.pi  # beyond Nyquist the mode is not represented at all
    error = 2.0 * np.clip(dynamic_share, 0.0, 1.0) * (frequency_error + np.abs(damping))
    return np.where(unresolved, np.clip(dynamic_share, 0.0, 1.0), error)


def combine(peak: np.ndarray, companion_peaks: list[np.ndarray], factors: list[float],
            time_error: np.ndarray | None = None) -> np.ndarray:
    """The relative error estimate of each case's peak stress.

    Parameters
    ----------
    peak : (case,) peak stress of the scene's own discretization, Pa
    companion_peaks : list of (case,) arrays, the companions' peak stress, Pa
    factors : list of float, :attr:`Companion.factor` of each companion
    time_error : (case,) array or None, :func:`time_resolution_error`

    Returns
    -------
    (case,) array, dimensionless; NaN where a companion failed
    """
    scale = np.where(np.abs(peak) > 0, np.abs(peak), np.nan)
    estimate = sum(f * np.abs(peak - c) for c, f in zip(companion_peaks, factors)) / scale
    estimate = np.where(np.abs(peak) > 0, estimate, 0.0)
    if time_error is not None:
        estimate = np.fmax(estimate, time_error)
    return estimate
