"""``discretization: auto``: elements and steps from the scene's tolerance, at least cost.

The scene's ``tolerance`` is a target relative error on peak stress. The choice is made for each
case in four batched stages:

1. **Frequencies.** A frozen modal analysis of the pilot model at four phases gives the largest
   first natural frequency ω₁ over the cycle. The first pilot step count resolves it,
   ω₁h ≤ 1/2, and the crank harmonics up to :data:`HARMONICS` (16 steps per period of the
   highest), and is at least :data:`MIN_STEPS`.
2. **Pilots.** Three cheap solutions, (n, s), (2n, s) and (n, 2s) with n = :data:`PILOT_ELEMENTS`,
   give the constants of the two error terms by Richardson extrapolation at the orders of
   ``ced.accuracy`` (3 in space, 2 in time): e(n_e, s_r) ≈ C_x/n_e³ + C_t/s_r².
3. **Cost model.** The model is always Euler–Bernoulli reduced to :data:`MODES` fixed-interface
   modes per flexible link plus static load vectors (component-mode synthesis), whose truncation
   error is below 1e-5 on the reference four-bar and whose per-step cost grows only slowly with
   the mesh. Measured on one core (reference crank-rocker, batches of 4): a step costs about
   0.1 ms + 0.04 ms per element per case (the recovery and the moving-frame terms work on the
   full mesh) and the reduction of one link about 70 ms × (n_e/128)³, so
   cost ∝ s_r·revolutions·(1 + 0.4 n_e) + 2000 (n_e/128)³.
4. **Choice.** The cheapest (n_e, s_r) on a grid (n_e up to 256, s_r in multiples of 8) with
   C_x/n_e³ + C_t/s_r² ≤ tolerance / :data:`SAFETY`, with at least half the first pilot's
   steps (ω₁h ≤ 1).

The choice, the pilot constants and the predicted error are recorded per case in the variable
``discretization_auto`` (JSON).
"""
from __future__ import annotations

import copy
import math

import numpy as np

from .accuracy import SPACE_ORDER, TIME_ORDER

__all__ = ["resolve_discretization", "MODES", "PILOT_ELEMENTS", "SAFETY"]

#: Fixed-interface modes per flexible link of the chosen (reduced) model.
MODES = 4
#: Elements per link of the coarse pilot.
PILOT_ELEMENTS = 8
#: Minimum and maximum steps per revolution.
MIN_STEPS, MAX_STEPS = 16, 1 << 16
#: Highest crank harmonic resolved a priori (16 steps per its period).
HARMONICS = 4
#: Predicted error must be below tolerance / SAFETY, so that the per-case error_estimate
#: (three times Richardson's, ced.accuracy) comes out near the tolerance.
SAFETY = 3.0
#: Cost of reducing one link of 128 elements, in steps of a one-element model (measured, see
#: the module docstring), and the growth of a step's cost per element per link.
REDUCTION_COST = 2000.0
STEP_COST_PER_ELEMENT = 0.4
_P_SPACE = SPACE_ORDER["euler_bernoulli"]
_ELEMENTS = np.unique(np.round(np.geomspace(2, 256, 40)).astype(int))


def _pilot(scene: dict, elements: int, steps: int) -> dict:
    out = copy.deepcopy(scene)
    out["discretization"] = {"formulation": "euler_bernoulli", "elements_per_link": elements,
                             "elements_across": 2, "modes_per_link": MODES}
    out["time"]["steps_per_revolution"] = steps
    out["outputs"] = {**out["outputs"], "every": 1, "error_estimate": False}
    out["modal"] = None
    return out


def _first_steps(omega1: float, speed: float) -> int:
    """Steps per revolution resolving ω₁ (ω₁h ≤ 1/2) and the first harmonics."""
    by_mode = 2.0 * math.pi * omega1 / speed / 0.5
    steps = max(MIN_STEPS, 16 * HARMONICS, math.ceil(by_mode))
    return int(8 * math.ceil(steps / 8))


def _cost(elements: np.ndarray, steps: np.ndarray, revolutions: float) -> np.ndarray:
    """Relative cost of a reduced model (module docstring, stage 3)."""
    return steps * revolutions * (1.0 + STEP_COST_PER_ELEMENT * elements) + REDUCTION_COST * (
        elements / 128.0) ** 3


def choose(space: float, time: float, tolerance: float, revolutions: float,
           min_steps: int) -> tuple[int, int, float]:
    """The cheapest (elements, steps per revolution) meeting the tolerance.

    Parameters
    ----------
    space, time : float
        Error constants C_x and C_t: e ≈ C_x/n_e^p + C_t/s_r² (relative), p = the
        Euler–Bernoulli order of ``ced.accuracy.SPACE_ORDER``.
    tolerance : float
        Target relative error on peak stress.
    revolutions : float
        Simulated input periods (the cost is per step).
    min_steps : int
        Fewest steps per revolution allowed (resolution of ω₁ and the harmonics).

    Returns
    -------
    elements, steps, predicted error
    """
    steps = np.arange(8 * math.ceil(min_steps / 8), MAX_STEPS + 1, 8)
    ne, sr = np.meshgrid(_ELEMENTS, steps, indexing="ij")
    predicted = space / ne**_P_SPACE + time / sr**TIME_ORDER
    cost = np.where(predicted <= tolerance / SAFETY, _cost(ne, sr, revolutions), np.inf)
    if not np.isfinite(cost).any():  # beyond the grid: the finest setting, flagged by its error
        return int(_ELEMENTS[-1]), int(steps[-1]), float(predicted[-1, -1])
    i, j = np.unravel_index(np.argmin(cost), cost.shape)
    return int(ne[i, j]), int(sr[i, j]), float(predicted[i, j])


def resolve_discretization(scenes: list[dict], solve) -> tuple[list[dict], list[dict]]:
    """Replace ``discretization: auto`` in normalized scenes by a chosen discretization.

    Parameters
    ----------
    scenes : list of dict
        Normalized scenes; those with ``discretization == "auto"`` are resolved.
    solve : callable
        list of scenes → dict of (case,) arrays: ``peak`` (peak stress, Pa), ``omega1`` (largest
        first natural frequency over the cycle, rad/s, when the scenes ask for a modal
        analysis); injected by :mod:`ced.simulation` so the pilots are batched like any run.

    Returns
    -------
    scenes, reports
        The scenes with the chosen discretization, and per scene a report (empty dict when
        the scene was not ``auto``).
    """
    auto = [i for i, s in enumerate(scenes) if s["discretization"] == "auto"]
    reports: list[dict] = [{} for _ in scenes]
    if not auto:
        return scenes, reports
    out = list(scenes)
    base = [_pilot(scenes[i], PILOT_ELEMENTS, 64) for i in auto]
    for s in base:
        s["modal"] = {"modes": 1, "angles": 4, "mode_shapes": False}
    omega1 = solve(base)["omega1"]
    steps0 = [_first_steps(w, scenes[i]["drive"]["speed"]) for i, w in zip(auto, omega1)]
    n = PILOT_ELEMENTS
    coarse = [_pilot(scenes[i], n, s) for i, s in zip(auto, steps0)]
    finer_x = [_pilot(scenes[i], 2 * n, s) for i, s in zip(auto, steps0)]
    finer_t = [_pilot(scenes[i], n, 2 * s) for i, s in zip(auto, steps0)]
    first = solve(coarse)
    peak = first["peak"]
    peak_x = solve(finer_x)["peak"]
    peak_t = solve(finer_t)["peak"]
    for j, i in enumerate(auto):
        scene, s0 = scenes[i], steps0[j]
        sigma = abs(peak[j]) if peak[j] else 1.0
        # Richardson: at order p the coarse error is 2^p/(2^p − 1) of the difference to the
        # refined one.
        gs, gt = 2.0**_P_SPACE, 2.0**TIME_ORDER
        space = gs / (gs - 1.0) * abs(peak_x[j] - peak[j]) / sigma * n**_P_SPACE
        time = gt / (gt - 1.0) * abs(peak_t[j] - peak[j]) / sigma * s0**TIME_ORDER
        w1 = float(omega1[j])

        elements, steps, predicted = choose(space, time, scene["tolerance"],
                                            scene["time"]["revolutions"], s0 // 2)
        chosen = copy.deepcopy(scene)
        chosen["discretization"] = {"formulation": "euler_bernoulli",
                                    "elements_per_link": elements, "elements_across": 2,
                                    "modes_per_link": MODES}
        chosen["time"]["steps_per_revolution"] = steps
        out[i] = chosen
        reports[i] = {"elements_per_link": elements, "steps_per_revolution": steps,
                      "modes_per_link": MODES, "formulation": "euler_bernoulli",
                      "predicted_error": predicted, "tolerance": scene["tolerance"],
                      "space_constant": space, "time_constant": time,
                      "first_frequency": w1 / (2.0 * math.pi)}
    return out, reports
