"""``discretization: auto``: elements and steps from the scene's tolerance, at least cost.

The scene's ``tolerance`` is a target relative error on peak stress. The choice is made for each
case in four batched stages:

1. **Frequencies.** A frozen modal analysis of the pilot model at four phases gives the largest
   first natural frequency ω₁ over the cycle. The first pilot step count resolves it,
   ω₁h ≤ 1/2, and the crank harmonics up to :data:`HARMONICS` (16 steps per period of the
   highest), and is at least :data:`MIN_STEPS`.
2. **Pilots.** Three cheap solutions, (n, s), (2n, s) and (n, 2s) with n = :data:`PILOT_ELEMENTS`,
   give the two error terms at the pilot by Richardson extrapolation at order 2, e_x and e_t;
   elsewhere e(n_e, s_r) ≈ e_x (n/n_e)^p + e_t (s/s_r)², with p = 3 towards coarser meshes and
   p = 2 towards finer ones (peak stress converges between the two, ``ced.accuracy``): each
   extrapolation errs on the safe side.
3. **Cost model.** The model is Euler–Bernoulli reduced to :data:`MODES` fixed-interface
   modes per flexible link plus static load vectors (component-mode synthesis; the full mesh
   where that is smaller, up to 4 elements), whose truncation
   error is below 1e-5 on the reference four-bar and whose per-step cost grows only slowly with
   the mesh. Measured on one core (reference crank-rocker, batches of 4): a step costs about
   0.1 ms + 0.04 ms per element per case (the recovery and the moving-frame terms work on the
   full mesh) and the reduction of one link about 70 ms × (n_e/128)³, so
   cost ∝ s_r·revolutions·(1 + 0.4 n_e) + 2000 (n_e/128)³.
4. **Choice.** The cheapest (n_e, s_r) on a grid (n_e up to 256, s_r in multiples of 8) with
   e(n_e, s_r) ≤ tolerance / :data:`SAFETY`, with at least half the first pilot's
   steps (ω₁h ≤ 1).

One discretization serves all ``auto`` scenes of a call, the most demanding one's, so that
they share one time grid (one ``step`` dimension) and batch together. The choice, each case's
own choice, the pilot errors and the predicted error are recorded per case in the variable
``discretization_auto`` (JSON).
"""
from __future__ import annotations

import copy
import math

import numpy as np

from .accuracy import TIME_ORDER

__all__ = ["resolve_discretization", "MODES", "PILOT_ELEMENTS", "SAFETY"]

#: Fixed-interface modes per flexible link of the chosen (reduced) model.
MODES = 4
#: Elements per link of the coarse pilot.
PILOT_ELEMENTS = 8
#: Minimum and maximum steps per revolution.
MIN_STEPS, MAX_STEPS = 16, 1 << 16
#: Highest crank harmonic resolved a priori (16 steps per its period).
HARMONICS = 4
#: Predicted error must be below tolerance / SAFETY (the pilots' constants were within 40 %
#: of the measured errors on the convergence study's reference scenes).
SAFETY = 2.0
#: Cost of reducing one link of 128 elements, in steps of a one-element model (measured, see
#: the module docstring), and the growth of a step's cost per element per link.
REDUCTION_COST = 2000.0
STEP_COST_PER_ELEMENT = 0.4
_ELEMENTS = np.unique(np.round(np.geomspace(2, 256, 40)).astype(int))


def _pilot(scene: dict, elements: int, steps: int) -> dict:
    out = copy.deepcopy(scene)
    out["discretization"] = {"formulation": "euler_bernoulli", "elements_per_link": elements,
                             "elements_across": 2, "modes_per_link": MODES}
    out["time"]["steps_per_revolution"] = steps
    out["outputs"] = {**out["outputs"], "every": 1, "error_estimate": False}
    out["modal"] = None
    return out


def _modes(elements: int) -> int:
    """Modes per link of the chosen model: the full mesh where it has fewer interior DOFs than
    the reduced basis (MODES modes + 5 static load vectors), i.e. up to 4 elements."""
    return 0 if 3 * elements - 3 <= MODES + 5 else MODES


def _first_steps(omega1: float, speed: float) -> int:
    """Steps per revolution resolving ω₁ (ω₁h ≤ 1/2) and the first harmonics."""
    by_mode = 2.0 * math.pi * omega1 / speed / 0.5
    steps = max(MIN_STEPS, 16 * HARMONICS, math.ceil(by_mode))
    return int(8 * math.ceil(steps / 8))


def _cost(elements: np.ndarray, steps: np.ndarray, revolutions: float) -> np.ndarray:
    """Relative cost of a reduced model (module docstring, stage 3)."""
    return steps * revolutions * (1.0 + STEP_COST_PER_ELEMENT * elements) + REDUCTION_COST * (
        elements / 128.0) ** 3


def predicted_error(space: float, time: float, steps0: int, elements: np.ndarray,
                    steps: np.ndarray) -> np.ndarray:
    """e(n_e, s_r) from the pilot's error terms (module docstring, stage 2).

    Parameters
    ----------
    space, time : float
        Relative errors of the space and time discretization at the pilot
        (:data:`PILOT_ELEMENTS` elements, ``steps0`` steps per revolution).
    """
    ratio = PILOT_ELEMENTS / np.asarray(elements, float)
    order = np.where(ratio > 1.0, 3.0, 2.0)
    return space * ratio**order + time * (steps0 / np.asarray(steps, float)) ** TIME_ORDER


def choose(space: float, time: float, steps0: int, tolerance: float, revolutions: float,
           min_steps: int) -> tuple[int, int, float]:
    """The cheapest (elements, steps per revolution) meeting the tolerance.

    Parameters
    ----------
    space, time : float
        Relative space and time errors at the pilot, see :func:`predicted_error`.
    steps0 : int
        The pilot's steps per revolution.
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
    predicted = predicted_error(space, time, steps0, ne, sr)
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
    choices = []
    for j, i in enumerate(auto):
        scene, s0 = scenes[i], steps0[j]
        sigma = abs(peak[j]) if peak[j] else 1.0
        # Richardson at order 2: the coarse error is 4/3 of the difference to the refined one
        # (8/7 at order 3; 4/3 is the safe side).
        space = 4.0 / 3.0 * abs(peak_x[j] - peak[j]) / sigma
        time = 4.0 / 3.0 * abs(peak_t[j] - peak[j]) / sigma
        elements, steps, predicted = choose(space, time, s0, scene["tolerance"],
                                            scene["time"]["revolutions"], s0 // 2)
        choices.append((elements, steps))
        reports[i] = {"own_choice": [elements, steps], "predicted_error": predicted,
                      "tolerance": scene["tolerance"], "pilot_space_error": space,
                      "pilot_time_error": time, "pilot_steps_per_revolution": s0,
                      "first_frequency": float(omega1[j]) / (2.0 * math.pi)}
    # One discretization for the call, the most demanding case's: the cases then share one
    # time grid (a dataset has one step dimension) and batch together; every case meets its
    # tolerance with it.
    elements = max(e for e, _ in choices)
    steps = max(s for _, s in choices)
    for i in auto:
        chosen = copy.deepcopy(scenes[i])
        chosen["discretization"] = {"formulation": "euler_bernoulli",
                                    "elements_per_link": elements, "elements_across": 2,
                                    "modes_per_link": _modes(elements)}
        chosen["time"]["steps_per_revolution"] = steps
        out[i] = chosen
        reports[i].update(elements_per_link=elements, steps_per_revolution=steps,
                          modes_per_link=_modes(elements), formulation="euler_bernoulli")
    return out, reports
