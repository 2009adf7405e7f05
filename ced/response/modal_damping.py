"""Modal damping over the cycle: every mode of the linkage, frozen at each instant, gets ζ.

C(t) = M Φ diag(2ζω) Φᵀ M, from the mass-normalised modes Φ, ω of the linkage's elastic
mass and stiffness M(t), K(t) at the configuration of time t. They depend on the configuration
only (the joint coordinates are global, the links' own in their frames: :mod:`ced.fem.coupling`),
so C is a function of the phase of the rigid motion's period, tabulated once per model on a
phase grid and interpolated linearly (:class:`ModalDamping`).

Why not one C for the whole cycle (ced ≤ 2026-11-29 froze it at t = 0): the joint coordinates
are global, so a stiff mode's large coefficient 2ζω at the start lands on motions that are
soft later, once the links have turned. At the convergence study's change-point four-bar the
modes of the frozen C had up to 7ζ (and ~3·10⁶ ζ at the change point itself), and the peak
stress depended by 11 % on how many stiff modes the mesh had (every FE DOF against the
Craig–Bampton models). Defining C per link in the link's frame instead (each link's free
modes damped) would be consistent but gives the linkage's modes other ratios than ζ: 0.43ζ
for a pinned–pinned coupler's first mode.

Why linear interpolation: a convex combination of positive semidefinite matrices is positive
semidefinite, so the interpolated damping never feeds energy in. The grid is refined by
bisection where the interpolant is off the exact damping at an interval's midpoint by more
than :data:`TOLERANCE`, measured in the midpoint's modal basis relative to 2ζω (the ratio's
own scale, mode by mode), so that the ratios of the slow modes are held as well as the stiff
ones'. Modes slower than a tenth of the first mode's median over the period (the slow mode a
change point passes through) are measured against that floor: their damping is small beside
anything it acts with.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..fem.eigenproblem import natural_frequencies

__all__ = ["ModalDamping", "tabulate", "damping_matrix", "TOLERANCE", "INITIAL_SAMPLES",
           "MAX_LEVEL", "MAX_PHASES"]

#: Largest error of the interpolated damping at an interval's midpoint, relative to 2ζω in
#: the midpoint's modal basis, before the interval is halved.
TOLERANCE = 1e-2
#: Evenly spaced phases of the period the table starts from.
INITIAL_SAMPLES = 16
#: Halvings at most: intervals of the period no shorter than 1 / (16 · 2⁶) = 1/1024.
MAX_LEVEL = 6
#: Phases a table holds at most (its memory: :func:`ced.simulation.size.solver_bytes`).
MAX_PHASES = INITIAL_SAMPLES * 2**MAX_LEVEL + 1
#: The floor of the modal scale, as a fraction of the first mode's median over the period.
FLOOR = 0.1
#: Phase of the table's first sample. Irrational, so that no set of samples is a set of steps
#: of a step grid: there the rigid motion is read from a kept solve scaled from unit speed
#: (:meth:`ced.response.batch.Batch.rigid_motion`), equal only to round-off, and the table
#: would depend on the steps per revolution of the batch that built it.
OFFSET = (math.sqrt(5.0) - 1.0) / 2.0 / INITIAL_SAMPLES


@dataclass
class ModalDamping:
    """C(t) of a batch tabulated over the phase of its rigid motion's period.

    ``phase`` (case, sample), the samples' fractions of the period after :data:`OFFSET`,
    ascending from 0 to 1 (the same in every case; 1 repeats 0); ``matrix``
    (case, sample, ny, ny) N s/m in the model's elastic coordinates; ``turns`` (case,) input
    turns of the period (:attr:`ced.response.batch.Batch.motion_turns`). No speed: a model
    serves batches at any speed (:mod:`ced.response.model_cache`), and the configuration is
    a function of the phase.
    """

    phase: np.ndarray
    matrix: np.ndarray
    turns: np.ndarray

    def at(self, times: np.ndarray, speed: np.ndarray,
           cases: np.ndarray | None = None) -> np.ndarray:
        """C at ``times`` (case, step) s of cases at input ``speed`` (case,) rad/s.

        ``cases`` (optional, int): the table's cases the rows of ``times`` and ``speed`` are
        (default: all, in order).

        Returns
        -------
        numpy.ndarray
            (case, step, ny, ny) N s/m.
        """
        rows = np.arange(len(self.turns)) if cases is None else np.asarray(cases)
        period = 2.0 * math.pi * self.turns[rows] / speed  # (case,) s
        phase = np.mod(times / period[:, None] - OFFSET, 1.0)
        grid = self.phase[0]
        lower = np.clip(np.searchsorted(grid, phase, side="right") - 1, 0, len(grid) - 2)
        w = ((phase - grid[lower]) / (grid[lower + 1] - grid[lower]))[..., None, None]
        rows = rows[:, None]
        # In place: the result is a period's worth of dense matrices, its temporaries as large
        out = self.matrix[rows, lower]
        out *= 1.0 - w
        upper = self.matrix[rows, lower + 1]
        upper *= w
        out += upper
        return out


def damping_matrix(mass: np.ndarray, stiffness: np.ndarray, ratio: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """C = M Φ diag(2ζω) Φᵀ M from every mode of (K, M), batched over leading axes.

    Parameters
    ----------
    mass, stiffness : numpy.ndarray
        Elastic mass and stiffness (..., n, n), kg and N/m in the elastic coordinates.
    ratio : float
        ζ, fraction of critical damping.

    Returns
    -------
    damping : numpy.ndarray
        (..., n, n) N s/m.
    omega : numpy.ndarray
        (..., n) rad/s, |ω| of each mode, ascending.
    shapes : numpy.ndarray
        (..., n, n) mass-normalised mode shapes (columns).
    """
    n = stiffness.shape[-1]
    freq, shapes = natural_frequencies(stiffness, mass, n, shapes=True)
    omega = 2.0 * math.pi * np.abs(freq)
    m_phi = mass @ shapes
    return m_phi @ (2.0 * ratio * omega[..., None] * np.swapaxes(m_phi, -1, -2)), omega, shapes


def tabulate(elastic_terms: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
             period: np.ndarray, turns: np.ndarray, ratio: float) -> ModalDamping:
    """Tabulate C over the period, halving intervals until linear interpolation holds.

    Parameters
    ----------
    elastic_terms : callable
        times (case, n) s ↦ (M, K), the elastic mass and stiffness (case, n, ny, ny) at the
        configurations of those times.
    period : numpy.ndarray
        (case,) s, the rigid motion's period at the speed ``elastic_terms`` is evaluated at.
    turns : numpy.ndarray
        (case,) input turns of the period.
    ratio : float
        ζ > 0.

    Returns
    -------
    ModalDamping
    """
    def exact(phases: np.ndarray):
        M, K = elastic_terms(period[:, None] * (phases[None, :] + OFFSET))
        return damping_matrix(M, K, ratio)

    phase = np.linspace(0.0, 1.0, INITIAL_SAMPLES + 1)
    matrix, omega, _ = exact(phase[:-1])
    matrix = np.concatenate([matrix, matrix[:, :1]], axis=1)  # periodic: 1 is 0
    floor = FLOOR * np.median(omega[..., 0], axis=1)  # (case,)
    active = np.ones(INITIAL_SAMPLES, bool)  # intervals [phase[i], phase[i + 1]] to test
    for _ in range(MAX_LEVEL):
        left = np.flatnonzero(active)
        if not left.size:
            break
        middle = 0.5 * (phase[left] + phase[left + 1])
        C_mid, omega, shapes = exact(middle)
        linear = 0.5 * (matrix[:, left] + matrix[:, left + 1])
        scale = np.sqrt(2.0 * ratio * np.maximum(omega, floor[:, None, None]))
        modal = np.swapaxes(shapes, -1, -2) @ (linear - C_mid) @ shapes
        error = np.abs(modal) / (scale[..., :, None] * scale[..., None, :])
        failed = error.max(axis=(0, 2, 3)) > TOLERANCE  # (interval,) over every case
        # Every midpoint joins the grid (its exact C is paid for); the failed intervals'
        # halves are tested again.
        phase = np.insert(phase, left + 1, middle)
        matrix = np.insert(matrix, left + 1, C_mid, axis=1)
        active = np.zeros(len(phase) - 1, bool)
        new_left = left + np.arange(1, left.size + 1)  # a midpoint's index after the insert
        active[(new_left - 1)[failed]] = True
        active[new_left[failed]] = True
    return ModalDamping(np.broadcast_to(phase, (len(turns), len(phase))).copy(), matrix,
                        np.asarray(turns))
