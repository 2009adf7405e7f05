"""Time marching of the reduced KED system with its full discrete state.

Arrays have shape (case, n, r): r columns share each step's factorization, so the shooting
method propagates the unit initial states and the forced response together and obtains the
exact one-period map of the discretized system (its monodromy matrix).

State of the Newmark family (:mod:`ced.integrators`, Arnold & Brüls form): (q, v, ẍ, a) with ẍ
satisfying the equation of motion at every step; the independent part is (q, v, a). State of
Houbolt: the history (q_n, q_{n−1}, q_{n−2}); from a start (q0, v0) its first two steps are
average-acceleration Newmark steps, as in :func:`ced.integrators.integrate`.

Matrices come from ``terms(k) -> (M, C, K, F)``, (case, n, n) / (case, n); C may be None.
Column 0 carries the external force F; the other columns are homogeneous solutions.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .integrators import Houbolt, NewmarkFamily, alpha_step, houbolt_step, newmark

__all__ = ["start", "march", "from_independent", "independent"]

Terms = Callable[[int], tuple]


def _forced(F: np.ndarray, r: int) -> np.ndarray:
    out = np.zeros(F.shape + (r,))
    out[..., 0] = F
    return out


def _columns(terms1, r: int):
    M, C, K, F = terms1
    return M, C, K, _forced(F, r)


def _consistent_acceleration(terms0, q, v):
    """ẍ from the equation of motion: M ẍ = F − C v − K q."""
    M, C, K, F = terms0
    rhs = _forced(F, q.shape[-1]) - K @ q
    if C is not None:
        rhs = rhs - C @ v
    return np.linalg.solve(M, rhs)


def start(terms: Terms, q0: np.ndarray, v0: np.ndarray) -> tuple:
    """Newmark-family state at step 0 from q0, v0 (case, n, r): a₀ = ẍ₀ (Chung & Hulbert)."""
    acc = _consistent_acceleration(terms(0), q0, v0)
    return q0, v0, acc, acc


def from_independent(terms: Terms, scheme, q0, v0, a0) -> tuple:
    """Full state at step 0 from the independent part (q, v, a) of the Newmark family, or the
    history (q_n, q_{n−1}, q_{n−2}) of Houbolt passed as (q0, v0, a0)."""
    if isinstance(scheme, Houbolt):
        return q0, v0, a0
    return q0, v0, _consistent_acceleration(terms(0), q0, v0), a0


def independent(scheme, state: tuple) -> np.ndarray:
    """Stack the independent part of a state along axis 1: (case, 3n, r)."""
    if isinstance(scheme, Houbolt):
        return np.concatenate(state[:3], axis=1)
    q, v, _, a = state
    return np.concatenate([q, v, a], axis=1)


def march(
    scheme,
    terms: Terms,
    h: np.ndarray,
    n_steps: int,
    state: tuple,
    record: Callable[[int, tuple], None] | None = None,
) -> tuple:
    """Advance ``state`` from step 0 to ``n_steps``; ``record(k, state)`` sees every step.

    A Houbolt run may start from a Newmark state (4 arrays): it then takes two
    average-acceleration steps to build its history.
    """
    hh = np.asarray(h, float).reshape(-1, 1, 1)
    r = state[0].shape[-1]
    if record is not None:
        record(0, state)
    history = None
    if isinstance(scheme, Houbolt) and len(state) == 3:
        history = state
    past = [state[0]]
    starter = newmark()
    for k in range(n_steps):
        terms1 = _columns(terms(k + 1), r)
        if isinstance(scheme, NewmarkFamily):
            q, v, acc, a = state
            state = alpha_step(scheme, hh, q, v, acc, a, terms1, columns=True)
        elif history is None:  # Houbolt's start: average-acceleration Newmark steps
            q, v, acc, a = state
            state = alpha_step(starter, hh, q, v, acc, a, terms1, columns=True)
            past.append(state[0])
            if len(past) == 3:
                history = (past[2], past[1], past[0])
                state = history
        else:
            q1, _, _ = houbolt_step(hh, *history, terms1, columns=True)
            history = (q1, history[0], history[1])
            state = history
        if record is not None:
            record(k + 1, state)
    return state
