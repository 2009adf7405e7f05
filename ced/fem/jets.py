"""Second-order jets: a time-dependent array with its first two time derivatives.

A jet holds X, Ẋ, Ẍ on its first axis; here with the matrix axes next and the points
(every case and step) last, shape (3, rows, columns, …, points). The projections of the
elastic model (docs/theory.md: link-end DOFs are projections of joint translations, and the
time derivatives of those projections belong to the exact equations) are products of rotation
matrices; carrying jets through the products gives Ṗ and P̈ exactly, without finite
differences. The matrices are tiny (2 × 2 rotations by a few joint-coordinate columns) and the
points many: numpy's batched matmul over stacks of such matrices costs ~0.1 µs per matrix,
while with the points on the last (contiguous) axis a product is a few elementwise passes.
"""
from __future__ import annotations

import numpy as np

__all__ = ["rotation_points", "matmul_points", "transpose_points", "inverse_points"]


def rotation_points(angle: np.ndarray, velocity: np.ndarray,
                    acceleration: np.ndarray) -> np.ndarray:
    """Jet of R(θ) = [[cos θ, −sin θ], [sin θ, cos θ]], shape (3, 2, 2) + angle.shape.

    Uses d/dt cos θ = −ω sin θ, d²/dt² cos θ = −α sin θ − ω² cos θ (and likewise for sin).

    Parameters
    ----------
    angle, velocity, acceleration : numpy.ndarray
        θ (rad), ω (rad/s), α (rad/s²), each of the same shape.

    Returns
    -------
    numpy.ndarray
        (R, Ṙ, R̈), shape (3, 2, 2) + angle.shape.
    """
    c, s = np.cos(angle), np.sin(angle)
    w, a = velocity, acceleration
    cos_jet = np.stack([c, -w * s, -a * s - w * w * c])
    sin_jet = np.stack([s, w * c, a * c - w * w * s])
    out = np.empty((3, 2, 2) + np.shape(angle))
    out[:, 0, 0] = cos_jet
    out[:, 0, 1] = -sin_jet
    out[:, 1, 0] = sin_jet
    out[:, 1, 1] = cos_jet
    return out


def _product(x: np.ndarray, y: np.ndarray, out: np.ndarray, scratch: np.ndarray) -> None:
    """out = X Y for matrices (a, b, …) and (b, c, …) with the points last: Σ_k X[:, k] Y[k],
    into ``out`` with one ``scratch`` array of its shape (no temporaries: on this machine a
    fresh array of a few hundred kB costs a page fault per 4 kB, ~10× its arithmetic)."""
    np.multiply(x[:, 0, None], y[None, 0], out=out)
    for k in range(1, x.shape[1]):
        np.multiply(x[:, k, None], y[None, k], out=scratch)
        out += scratch


def _product_shape(x: np.ndarray, y: np.ndarray) -> tuple[int, ...]:
    """Shape of X Y for (a, b, …) and (b, c, …), the point axes broadcast."""
    return np.broadcast_shapes((x.shape[0], 1) + x.shape[2:], (1, y.shape[1]) + y.shape[2:])


def _times(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """X Y for matrices (a, b, …) and (b, c, …) with the points last, a new array."""
    shape = _product_shape(x, y)
    out = np.empty(shape)
    _product(x, y, out, np.empty(shape))
    return out


def matmul_points(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Jet of X Y by the Leibniz rule: (XY)' = X'Y + XY', (XY)'' = X''Y + 2X'Y' + XY''.

    Parameters
    ----------
    x, y : numpy.ndarray
        Jets (3, a, b, …) and (3, b, c, …), the trailing point axes broadcast.

    Returns
    -------
    numpy.ndarray
        The jet of X Y, (3, a, c, …).
    """
    shape = _product_shape(x[0], y[0])
    out = np.empty((3,) + shape)
    term, scratch = np.empty(shape), np.empty(shape)
    _product(x[0], y[0], out[0], scratch)
    _product(x[1], y[0], out[1], scratch)
    _product(x[0], y[1], term, scratch)
    out[1] += term
    _product(x[2], y[0], out[2], scratch)
    _product(x[1], y[1], term, scratch)
    term *= 2.0
    out[2] += term
    _product(x[0], y[2], term, scratch)
    out[2] += term
    return out


def transpose_points(x: np.ndarray) -> np.ndarray:
    """Jet of Xᵀ with the points last: (3, a, b, …) → (3, b, a, …), a view.

    Parameters
    ----------
    x : numpy.ndarray
        A jet (3, a, b, …).

    Returns
    -------
    numpy.ndarray
        The jet of Xᵀ.
    """
    return np.swapaxes(x, 1, 2)


def inverse_points(x: np.ndarray) -> np.ndarray:
    """Jet of X⁻¹: (X⁻¹)' = −X⁻¹ X' X⁻¹, (X⁻¹)'' = −X⁻¹ (X'' Y + 2 X' Y') with Y = X⁻¹.

    Parameters
    ----------
    x : numpy.ndarray
        A jet (3, n, n, …) of an invertible matrix.

    Returns
    -------
    numpy.ndarray
        The jet of X⁻¹, (3, n, n, …).
    """
    y0 = np.moveaxis(np.linalg.inv(np.moveaxis(x[0], (0, 1), (-2, -1))), (-2, -1), (0, 1))
    y1 = -_times(_times(y0, x[1]), y0)
    y2 = -_times(y0, _times(x[2], y0) + 2.0 * _times(x[1], y1))
    return np.stack([y0, y1, y2])
