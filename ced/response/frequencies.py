"""Natural frequencies of a batch over the input cycle (thesis III.3.1.b).

The frozen eigenproblem (:func:`ced.fem.eigenproblem.natural_frequencies`) of the KED model
at phases of the input cycle, with the stiffness-type effects of the scene; the one way ced gets
a case's first natural frequency (:func:`first_natural_frequency`), whether from a modal
analysis the scene asked for, for the error estimate, the ``discretization: auto`` pilots or
the ``effects: auto`` probe.
"""
from __future__ import annotations

import math

import numpy as np

from ..fem.eigenproblem import natural_frequencies
from ..problem.errors import SceneError
from .model import Model, terms_at

__all__ = ["modal_phases", "cycle_frequencies", "first_natural_frequency", "buckled",
           "check_modes", "BUCKLED_TOLERANCE"]

#: A frozen frequency below −BUCKLED_TOLERANCE × the largest computed one is a negative
#: eigenvalue of K_eff (relative size 1e-10, far above round-off of the eigensolver, ~1e-16;
#: an exact mechanism mode, λ = 0, stays below it): the frozen structure is statically unstable.
BUCKLED_TOLERANCE = 1e-5


def modal_phases(angles: int) -> np.ndarray:
    """``angles`` evenly spaced phases of the input cycle from 0, rad (the ``modal_angle``
    coordinate: crank angle − initial angle for a rotating input).

    Parameters
    ----------
    angles : int
        Number of phases.

    Returns
    -------
    numpy.ndarray
        Phases 2π k/angles, k = 0 … angles − 1, rad, shape (angles,).
    """
    return 2.0 * math.pi * np.arange(angles) / angles


def cycle_frequencies(model: Model, phases: np.ndarray, modes: int,
                      effects: set[str] | None = None) -> np.ndarray:
    """Natural frequencies of the frozen system at phases of the motion's period, Hz.

    The period is the input cycle, or two for a case whose motion repeats only every two
    turns (:attr:`ced.response.batch.Batch.motion_turns`: a change point passed once a turn,
    its second turn on the other assembly branch): its phases are then of both turns, phase
    φ at Ωt = 2φ, so that the frequencies span every configuration it passes through.

    Parameters
    ----------
    model : the batch's KED model
    phases : (phase,) rad, phases of the period (Ωt for a motion that repeats every turn)
    modes : number of frequencies per phase
    effects : effects whose stiffness-type terms enter K_eff (default: the scene's); damping
        never enters

    Returns
    -------
    ndarray, (case, phase, mode), Hz; negative for a negative eigenvalue (see
    :func:`ced.fem.eigenproblem.natural_frequencies`)
    """
    effects = (model.effects if effects is None else set(effects)) - {"damping"}
    batch = model.batch
    times = (np.asarray(phases, float)[None, :] * batch.motion_turns[:, None]
             / batch.speed[:, None])
    terms, _ = terms_at(model, times, effects, frozenset({"elastic_mass"}))
    return natural_frequencies(terms.stiffness, terms.elastic_mass, modes)


def first_natural_frequency(frequency: np.ndarray, over: str = "max") -> np.ndarray:
    """A case's first natural frequency over the cycle, rad/s, (case,).

    Parameters
    ----------
    frequency : (case, phase, mode) Hz, from :func:`cycle_frequencies` or a dataset's
        ``natural_frequency``
    over : ``"max"`` (the highest first frequency over the cycle: the mode a step must
        resolve) or ``"min"`` (the lowest: the softest configuration); non-finite values are
        ignored

    Examples
    --------
    >>> f = np.array([[[10.0, 40.0], [12.0, 41.0]]])   # Hz at two phases
    >>> first_natural_frequency(f).round(3), first_natural_frequency(f, "min").round(3)
    (array([75.398]), array([62.832]))
    """
    f1 = np.abs(np.asarray(frequency, float)[:, :, 0])
    if over == "max":
        value = np.max(np.where(np.isfinite(f1), f1, 0.0), axis=1)
    elif over == "min":
        value = np.min(np.where(np.isfinite(f1), f1, np.inf), axis=1)
    else:
        raise ValueError(f"over: {over!r}; allowed: 'max', 'min'")
    return 2.0 * np.pi * value


def buckled(frequency: np.ndarray) -> np.ndarray:
    """(case,) bool: the frozen K_eff has a negative eigenvalue at some modal angle.

    :func:`ced.fem.eigenproblem.natural_frequencies` reports a negative eigenvalue λ as the
    frequency −√|λ|/2π. With axial stiffening, a link compressed beyond its Euler load has one (the
    linear model then describes a link that would buckle); centrifugal softening of a
    near-mechanism mode (change points) gives one too.

    Parameters
    ----------
    frequency : numpy.ndarray
        Natural frequencies, Hz, shape (case, modal_angle, mode), negative for a negative
        eigenvalue.

    Returns
    -------
    numpy.ndarray
        Shape (case,), bool.
    """
    scale = np.abs(frequency).max(axis=(1, 2), keepdims=True)
    return (frequency < -BUCKLED_TOLERANCE * scale).any(axis=(1, 2))


def check_modes(scene: dict, ny: int) -> None:
    """A discretized model with ny DOFs has exactly ny modes: asking for more is an impossible
    value, reported before any work rather than padded with NaN.

    Parameters
    ----------
    scene : dict
        A normalized scene (its ``modal`` block, if any).
    ny : int
        Number of elastic DOFs of the discretized model.

    Raises
    ------
    SceneError
        ``modal.modes`` is larger than ``ny``.
    """
    modal = scene.get("modal")
    if modal and ny and modal["modes"] > ny:
        raise SceneError(
            "modal.modes", f"{modal['modes']} modes asked for, but the discretized model has "
            f"only {ny} degrees of freedom (discretization {scene['discretization']}); ask for "
            f"at most {ny} or refine the discretization")
