"""Time marching of the reduced KED system with its full discrete state.

The state is three arrays of shape (case, n, r): (q, v, a) for the Newmark family (Newmark,
HHT, generalized-α, all in the weighted-residual form of :mod:`ced.integrators`), and
(q_n, q_{n−1}, q_{n−2}) for Houbolt. Extra columns r share each step's factorization: the
shooting method propagates the unit initial states and the forced response together, so the
monodromy matrix is the exact one-period map of the discretized system.

Matrices come from ``terms(k) -> (M, C, K, F)`` (case, n, n) / (case, n), C may be None.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .integrators import NewmarkFamily, alpha_step, houbolt_step

__all__ = ["State", "initial_state", "march", "velocity_of"]

State = tuple[np.ndarray, np.ndarray, np.ndarray]
Terms = Callable[[int], tuple]


def initial_state(scheme, terms: Terms, h: float | np.ndarray, q0, v0) -> State:
    """Discrete state at step 0 from displacement q0 and velocity v0 (case, n, r).

    Newmark family: a0 from the equation of motion at t = 0. Houbolt: the two back values
    from Taylor expansion, q_{−j} = q0 − j h v0 + (j h)²/2 a0 (second-order start).
    """
    M, C, K, F = terms(0)
    rhs = F[..., None] * _forced_mask(q0) - K @ q0
    if C is not None:
        rhs = rhs - C @ v0
    a0 = np.linalg.solve(M, rhs)
    if isinstance(scheme, NewmarkFamily):
        return q0, v0, a0
    hh = np.asarray(h, float).reshape(-1, 1, 1)
    return (q0, q0 - hh * v0 + 0.5 * hh**2 * a0, q0 - 2 * hh * v0 + 2.0 * hh**2 * a0)


def _forced_mask(x: np.ndarray) -> np.ndarray:
    """Only column 0 carries the external force; the others are homogeneous solutions."""
    mask = np.zeros(x.shape[-1])
    mask[0] = 1.0
    return mask


def velocity_of(scheme, state: State, h) -> np.ndarray:
    """Velocity carried by a state (Houbolt: its backward-difference formula)."""
    if isinstance(scheme, NewmarkFamily):
        return state[1]
    hh = np.asarray(h, float).reshape(-1, 1, 1)
    q0, q1, q2 = state
    # v_n from the three-point backward difference of the stored history plus q_n.
    return (3.0 * q0 - 4.0 * q1 + q2) / (2.0 * hh)


def march(
    scheme,
    terms: Terms,
    h: float | np.ndarray,
    n_steps: int,
    state: State,
    record: Callable[[int, State], None] | None = None,
) -> State:
    """Advance ``state`` from step 0 to ``n_steps``; ``record(k, state)`` sees every step."""
    hh = np.asarray(h, float).reshape(-1, 1, 1)
    mask = _forced_mask(state[0])
    if record is not None:
        record(0, state)
    current = terms(0)
    for k in range(n_steps):
        nxt = terms(k + 1)
        if isinstance(scheme, NewmarkFamily):
            state = _newmark_step(scheme, current, nxt, hh, state, mask)
        else:
            state = _houbolt_step(nxt, hh, state, mask)
        current = nxt
        if record is not None:
            record(k + 1, state)
    return state


def _newmark_step(s: NewmarkFamily, t0, t1, h, state, mask) -> State:
    M0, C0, K0, F0 = t0
    M1, C1, K1, F1 = t1
    return alpha_step(s, h, *state, (M0, C0, K0, F0[..., None] * mask),
                      (M1, C1, K1, F1[..., None] * mask), columns=True)


def _houbolt_step(t1, h, state, mask) -> State:
    M1, C1, K1, F1 = t1
    q0, q1, q2 = state
    q_new, _, _ = houbolt_step(h, q0, q1, q2, (M1, C1, K1, F1[..., None] * mask), columns=True)
    return q_new, q0, q1
