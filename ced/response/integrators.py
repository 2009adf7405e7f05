"""Implicit time integrators for batched, linear, time-varying second-order systems.

The systems are

    M(t) ẍ + C(t) v + K(t) q = F(t),        v = dq/dt,  ẍ = d²q/dt²,

with every array carrying optional leading batch dimensions (cases): ``M, C, K`` have shape
``(..., n, n)``; ``F, q, v, ẍ`` have shape ``(..., n)`` ("vector layout") or ``(..., n, r)``
("column layout", r right-hand-side columns sharing each step's factorization, as needed for
monodromy matrices). Units are those of the caller: with q in m and t in s, v is m/s, ẍ is m/s²,
the step h is s, and M, C, K, F must be consistent (kg, N s/m, N/m, N).

Schemes (docs/theory.md, "Time integration"):

* Newmark family (Newmark 1959; HHT-α, Hilber, Hughes & Taylor 1977; generalized-α, Chung &
  Hulbert 1993) in the form of Arnold & Brüls (2007), which stays second-order accurate for
  time-varying matrices::

      M₁ẍ₁ + C₁v₁ + K₁q₁ = F₁                          (equation of motion at t_{n+1})
      (1−αm) a₁ + αm a₀ = (1−αf) ẍ₁ + αf ẍ₀            (algorithmic acceleration a)
      q₁ = q₀ + h v₀ + h²((½−β) a₀ + β a₁)
      v₁ = v₀ + h((1−γ) a₀ + γ a₁)

  where index 0/1 means t_n / t_{n+1} and ẍ is the true acceleration. Multiplying the second
  line by M gives Chung & Hulbert's weighted residual
  (1−αm) M a₁ + αm M a₀ + (1−αf)(C v₁ + K q₁) + αf(C v₀ + K q₀) = (1−αf)F₁ + αf F₀ when M, C,
  K are constant, so both forms share the amplification matrix. With M(t) varying and
  αm ≠ αf that weighted residual is only first-order accurate (it pairs M(t_{n+1−αm}) with the
  acceleration at t_{n+1−αf}), which is why it is not used here. Newmark is αm = αf = 0 (then
  a = ẍ); HHT-α is αm = 0, αf = −α. The algorithmic a approximates ẍ(t_n + (αm − αf) h)
  (Arnold & Brüls 2007); it is internal state, the driver returns ẍ.
* Houbolt (1950): the equation of motion at t_{n+1} with third-order backward differences
  of q for ẍ and v; started by two steps of average-acceleration Newmark (trapezoidal rule),
  self-starting and second-order, so the global order stays 2. (Sub-steps would need the
  matrices between grid points, which ``system(k)`` does not provide.)

All schemes solve for the true acceleration ẍ_{n+1} with the same kind of step matrix
S = M + c_C C + c_K K (:func:`effective_coefficients`).

Public API: integrator constructors (:func:`newmark`, :func:`hht`, :func:`generalized_alpha`,
:func:`houbolt`, :func:`make_integrator`, :func:`integrator_for` a scene's ``time`` block), the
per-step building blocks (:func:`alpha_step`, :func:`houbolt_step`,
:func:`effective_coefficients`), the one marching loop :func:`march` with its discrete
:class:`State` (:func:`start`, :func:`from_independent`, :func:`independent`,
:func:`forced_columns`), the convenience driver :func:`integrate` (the whole history, built on
:func:`march`), and the 1-DOF stability tools (:func:`amplification_matrix`,
:func:`spectral_radius`).

The marching loop works in the column layout (..., n, r): r columns share each step's
factorization, so the shooting method (:mod:`ced.response.periodic`) propagates the unit
initial states and the forced response together and obtains the exact one-period map of the
discretized system (its monodromy matrix).

References
----------
N. M. Newmark, "A method of computation for structural dynamics", J. Eng. Mech. Div. ASCE 85
(1959) 67–94.
J. C. Houbolt, "A recurrence matrix solution for the dynamic response of elastic aircraft",
J. Aeronaut. Sci. 17 (1950) 540–550.
H. M. Hilber, T. J. R. Hughes, R. L. Taylor, "Improved numerical dissipation for time
integration algorithms in structural dynamics", Earthq. Eng. Struct. Dyn. 5 (1977) 283–292.
J. Chung, G. M. Hulbert, "A time integration algorithm for structural dynamics with improved
numerical dissipation: the generalized-α method", J. Appl. Mech. 60 (1993) 371–375.
M. Arnold, O. Brüls, "Convergence of the generalized-α scheme for constrained mechanical
systems", Multibody Syst. Dyn. 18 (2007) 185–202.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

__all__ = [
    "NewmarkFamily",
    "Houbolt",
    "Integrator",
    "EffectiveCoefficients",
    "newmark",
    "hht",
    "generalized_alpha",
    "houbolt",
    "make_integrator",
    "INTEGRATORS",
    "effective_coefficients",
    "alpha_step",
    "houbolt_step",
    "integrator_for",
    "State",
    "start",
    "from_independent",
    "independent",
    "forced_columns",
    "march",
    "integrate",
    "amplification_matrix",
    "spectral_radius",
    "stability_limit",
]

Solve = Callable[[np.ndarray, np.ndarray], np.ndarray]
#: ``(M, C, K, F)`` at one time; C may be None (no damping), F may be None (no load).
Terms = tuple[np.ndarray, "np.ndarray | None", np.ndarray, "np.ndarray | None"]


@dataclass(frozen=True)
class NewmarkFamily:
    """Generalized-α coefficients (Chung & Hulbert 1993), dimensionless.

    Attributes
    ----------
    alpha_m, alpha_f : float
        Weights of the old time level in the algorithmic-acceleration recursion
        (1−αm) a_{n+1} + αm a_n = (1−αf) ẍ_{n+1} + αf ẍ_n (module docstring).
    beta, gamma : float
        Newmark parameters of the displacement and velocity updates.
    name : str
        Constructor that made it ("newmark", "hht" or "generalized_alpha").
    """

    alpha_m: float
    alpha_f: float
    beta: float
    gamma: float
    name: str = "generalized_alpha"


@dataclass(frozen=True)
class Houbolt:
    """Houbolt's (1950) third-order backward-difference scheme.

    Attributes
    ----------
    starter : NewmarkFamily
        Self-starting scheme used for the first two steps (the backward differences need
        q_{n−2}); average-acceleration Newmark, second-order accurate.
    name : str
        "houbolt".
    """

    starter: NewmarkFamily = NewmarkFamily(0.0, 0.0, 0.25, 0.5, "newmark")
    name: str = "houbolt"


Integrator = NewmarkFamily | Houbolt


def _in_range(owner: str, param: str, value: float, lo: float, hi: float, lo_txt: str,
              hi_txt: str) -> float:
    value = float(value)
    if not lo <= value <= hi:  # also rejects NaN
        raise ValueError(
            f"{owner}: parameter {param} = {value!r} outside the allowed range "
            f"[{lo_txt}, {hi_txt}]")
    return value


def newmark(beta: float = 0.25, gamma: float = 0.5) -> NewmarkFamily:
    """Newmark (1959) scheme; the default is the average-acceleration (trapezoidal) rule.

    Parameters
    ----------
    beta : float, in [0, 1/2]
        Displacement-update weight (dimensionless). beta = 0 is the central-difference
        member (explicit for a diagonal M without damping, conditionally stable).
    gamma : float, in [1/2, 1]
        Velocity-update weight; gamma > 1/2 adds numerical damping but makes the scheme
        first-order accurate; gamma < 1/2 (negative damping) is rejected.
        Unconditional stability needs 2 beta >= gamma >= 1/2.
    """
    beta = _in_range("newmark", "beta", beta, 0.0, 0.5, "0", "0.5")
    gamma = _in_range("newmark", "gamma", gamma, 0.5, 1.0, "0.5", "1")
    return NewmarkFamily(0.0, 0.0, beta, gamma, "newmark")


def hht(alpha: float = -0.05) -> NewmarkFamily:
    """HHT-α scheme (Hilber, Hughes & Taylor 1977).

    Parameters
    ----------
    alpha : float, in [-1/3, 0]
        Dissipation parameter (dimensionless); alpha = 0 is the trapezoidal rule. The
        high-frequency spectral radius is (1 + alpha)/(1 − alpha) (1/2 at alpha = −1/3).

    Notes
    -----
    αm = 0, αf = −alpha, γ = ½ − alpha, β = ¼(1 − alpha)² (HHT 1977). alpha = −1/3 is
    generalized-α with ρ∞ = 1/2.
    """
    alpha = _in_range("hht", "alpha", alpha, -1.0 / 3.0, 0.0, "-1/3", "0")
    return NewmarkFamily(0.0, -alpha, 0.25 * (1.0 - alpha) ** 2, 0.5 - alpha, "hht")


def generalized_alpha(rho_inf: float = 0.9) -> NewmarkFamily:
    """Generalized-α scheme (Chung & Hulbert 1993).

    Parameters
    ----------
    rho_inf : float, in [0, 1]
        Spectral radius at ωh → ∞ (dimensionless): 1 means no numerical dissipation
        (αm = αf = ½; with a_0 = ẍ_0 the trajectory is the trapezoidal rule's), 0 annihilates
        the highest frequencies in one step.

    Notes
    -----
    αm = (2ρ∞ − 1)/(ρ∞ + 1), αf = ρ∞/(ρ∞ + 1), γ = ½ − αm + αf, β = ¼(1 − αm + αf)²
    (Chung & Hulbert 1993): second order, unconditionally stable, with
    high-frequency dissipation maximal and low-frequency dissipation minimal for the given ρ∞.
    """
    rho = _in_range("generalized_alpha", "rho_inf", rho_inf, 0.0, 1.0, "0", "1")
    am = (2.0 * rho - 1.0) / (rho + 1.0)
    af = rho / (rho + 1.0)
    return NewmarkFamily(am, af, 0.25 * (1.0 - am + af) ** 2, 0.5 - am + af, "generalized_alpha")


def houbolt() -> Houbolt:
    """Houbolt (1950) scheme (no parameters); see :class:`Houbolt` for the start."""
    return Houbolt()


#: Constructors by scheme name (the ``time.integrator`` values of a scene).
INTEGRATORS: dict[str, Callable[..., Integrator]] = {
    "newmark": newmark,
    "hht": hht,
    "generalized_alpha": generalized_alpha,
    "houbolt": houbolt,
}

_PARAMS = {"newmark": ("beta", "gamma"), "hht": ("alpha",),
           "generalized_alpha": ("rho_inf",), "houbolt": ()}


def make_integrator(name: str, **params: float) -> Integrator:
    """Integrator from its name and parameters, e.g. ``make_integrator("hht", alpha=-0.1)``.

    Raises
    ------
    ValueError
        Unknown name (the message lists the allowed names), unknown parameter (lists the
        scheme's parameters) or out-of-range value (names the parameter and its range).

    Parameters
    ----------
    name : str
        Scheme name, a key of :data:`INTEGRATORS` (``"newmark"``, ``"hht"``, …).
    **params : float
        The scheme's parameters (dimensionless), e.g. ``alpha``, ``beta``, ``gamma``.

    Returns
    -------
    Integrator
        A :class:`NewmarkFamily` or :class:`Houbolt` scheme.
    """
    if name not in INTEGRATORS:
        raise ValueError(f"unknown integrator {name!r}; allowed: {', '.join(sorted(INTEGRATORS))}")
    unknown = sorted(set(params) - set(_PARAMS[name]))
    if unknown:
        allowed = ", ".join(_PARAMS[name]) or "none"
        raise ValueError(f"{name}: unknown parameter(s) {', '.join(unknown)}; allowed: {allowed}")
    return INTEGRATORS[name](**params)


def integrator_for(time: Mapping) -> Integrator:
    """The integrator a normalized scene's ``time`` block asks for (its scheme and the
    parameters that scheme uses), e.g. ``{"integrator": "hht", "alpha": -0.1, …}``.

    Parameters
    ----------
    time : Mapping
        The ``time`` block of a normalized scene.

    Returns
    -------
    Integrator
        See :func:`make_integrator`.
    """
    name = time["integrator"]
    return make_integrator(name, **{key: time[key] for key in _PARAMS[name]})


class EffectiveCoefficients(NamedTuple):
    """Scalars of the step matrix S = c_M M + c_C C + c_K K (M, C, K at t_{n+1}).

    The unknown is the true acceleration ẍ_{n+1} for every scheme, and
    q_{n+1} = q̂ + c_K ẍ_{n+1}, v_{n+1} = v̂ + c_C ẍ_{n+1} with predictors q̂, v̂ from the
    known state, so c_M = 1 [1], c_C = ∂v_{n+1}/∂ẍ_{n+1} [s], c_K = ∂q_{n+1}/∂ẍ_{n+1} [s²]:

    * Newmark family: c_C = γ h (1 − αf)/(1 − αm), c_K = β h² (1 − αf)/(1 − αm).
    * Houbolt: c_C = 11 h/12, c_K = h²/2.
    """

    c_M: float | np.ndarray
    c_C: float | np.ndarray
    c_K: float | np.ndarray


def effective_coefficients(integrator: Integrator, h: float | np.ndarray) -> EffectiveCoefficients:
    """Coefficients (c_M, c_C, c_K) of the step matrix S = c_M M + c_C C + c_K K.

    Parameters
    ----------
    integrator : NewmarkFamily or Houbolt
    h : float or array
        Time step, s (an array gives per-case coefficients; shape it to broadcast).

    Returns
    -------
    EffectiveCoefficients
        See its docstring. For Houbolt these are the coefficients of steps n >= 2; the first
        two steps use ``integrator.starter``.
    """
    h = np.asarray(h, dtype=float) if np.ndim(h) else float(h)
    if isinstance(integrator, Houbolt):
        return EffectiveCoefficients(1.0 + 0.0 * h, 11.0 * h / 12.0, 0.5 * h**2)
    s = integrator
    w = (1.0 - s.alpha_f) / (1.0 - s.alpha_m)
    return EffectiveCoefficients(1.0 + 0.0 * h, w * s.gamma * h, w * s.beta * h**2)


# --- linear algebra on either layout -------------------------------------------------------

def _mul(A: np.ndarray, x: np.ndarray, columns: bool) -> np.ndarray:
    """A x for x of shape (..., n) (vector layout) or (..., n, r) (column layout)."""
    return A @ x if columns else (A @ x[..., None])[..., 0]


def _solve(solve: Solve, A: np.ndarray, b: np.ndarray, columns: bool) -> np.ndarray:
    """Solve A x = b; ``solve`` always receives a (..., n, k) right-hand side (numpy >= 2
    treats a 1-D trailing b as a single vector, not as a batch)."""
    return solve(A, b) if columns else solve(A, b[..., None])[..., 0]


def _correct(terms1: Terms, q_hat, v_hat, c: EffectiveCoefficients, solve: Solve,
             columns: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Solve M₁ẍ₁ + C₁(v̂ + c_C ẍ₁) + K₁(q̂ + c_K ẍ₁) = F₁ for ẍ₁; return (q₁, v₁, ẍ₁)."""
    M1, C1, K1, F1 = terms1
    rhs = -_mul(K1, q_hat, columns)
    S = c.c_M * M1 + c.c_K * K1
    if C1 is not None:
        rhs = rhs - _mul(C1, v_hat, columns)
        S = S + c.c_C * C1
    if F1 is not None:
        rhs = rhs + F1
    acc = _solve(solve, S, rhs, columns)
    return q_hat + c.c_K * acc, v_hat + c.c_C * acc, acc


def alpha_step(
    method: NewmarkFamily,
    h: float,
    q: np.ndarray,
    v: np.ndarray,
    acc: np.ndarray,
    a: np.ndarray,
    terms1: Terms,
    solve: Solve = np.linalg.solve,
    columns: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One step of the Newmark family in Arnold & Brüls (2007) form (module docstring).

    Parameters
    ----------
    method : NewmarkFamily
    h : float or ndarray
        Time step, s. A per-case array must broadcast against both q and M, e.g. shape
        (case, 1, 1) with the column layout.
    q, v, acc : ndarray
        Displacement, velocity and true acceleration ẍ at t_n.
    a : ndarray
        Algorithmic acceleration at t_n (start with a = ẍ at t = 0; equal to ẍ for Newmark).
    terms1 : tuple
        (M, C, K, F) at t_{n+1}; C or F may be None (zero).
    solve : callable
        ``solve(S, B)`` for S (..., n, n), B (..., n, k).
    columns : bool
        True for the column layout (..., n, r), False for (..., n).

    Returns
    -------
    q1, v1, acc1, a1 : ndarray
        The same four quantities at t_{n+1}.
    """
    am, af, beta, gamma = method.alpha_m, method.alpha_f, method.beta, method.gamma
    # a₁ = (1 − αf)/(1 − αm) ẍ₁ + a_known; the predictors hold everything but the ẍ₁ terms.
    a_known = (af * acc - am * a) / (1.0 - am)
    q_hat = q + h * v + h * h * ((0.5 - beta) * a + beta * a_known)
    v_hat = v + h * ((1.0 - gamma) * a + gamma * a_known)
    q1, v1, acc1 = _correct(terms1, q_hat, v_hat, effective_coefficients(method, h), solve,
                            columns)
    return q1, v1, acc1, a_known + (1.0 - af) / (1.0 - am) * acc1


def houbolt_step(
    h: float,
    q: np.ndarray,
    q_m1: np.ndarray,
    q_m2: np.ndarray,
    terms1: Terms,
    solve: Solve = np.linalg.solve,
    columns: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One Houbolt (1950) step: the equation of motion at t_{n+1} with

        ẍ_{n+1} = (2q_{n+1} − 5q_n + 4q_{n−1} − q_{n−2}) / h²,
        v_{n+1} = (11q_{n+1} − 18q_n + 9q_{n−1} − 2q_{n−2}) / (6h).

    Parameters
    ----------
    h : float or ndarray
        Time step, s (per-case array allowed, as in :func:`alpha_step`).
    q, q_m1, q_m2 : ndarray
        q_n, q_{n−1}, q_{n−2}.
    terms1 : tuple
        (M, C, K, F) at t_{n+1}; C or F may be None.
    solve, columns
        As in :func:`alpha_step`.

    Returns
    -------
    q1, v1, acc1 : ndarray
        Displacement at t_{n+1} and its backward-difference velocity and acceleration.
    """
    # q_{n+1} = q̂ + (h²/2) ẍ_{n+1}; v̂ is the velocity formula evaluated at q_{n+1} = q̂.
    q_hat = 0.5 * (5.0 * q - 4.0 * q_m1 + q_m2)
    v_hat = (11.0 * q_hat - 18.0 * q + 9.0 * q_m1 - 2.0 * q_m2) / (6.0 * h)
    return _correct(terms1, q_hat, v_hat, effective_coefficients(Houbolt(), h), solve, columns)


# --- the marching loop ---------------------------------------------------------------------

class State(NamedTuple):
    """Discrete state at one time level, column layout (..., n, r).

    Attributes
    ----------
    q, v, acc : ndarray or None
        Displacement, velocity and true acceleration ẍ (ẍ satisfies the equation of motion).
        A Houbolt state rebuilt from its history (:func:`from_independent`) has no v, acc.
    a : ndarray or None
        Algorithmic acceleration of the Newmark family (also during Houbolt's start).
    past : tuple or None
        (q_{n−1}, q_{n−2}) of Houbolt once its start is over; None otherwise.
    """

    q: np.ndarray
    v: np.ndarray | None
    acc: np.ndarray | None
    a: np.ndarray | None = None
    past: tuple[np.ndarray, np.ndarray] | None = None


def _acceleration(terms0: Terms, q: np.ndarray, v: np.ndarray, solve: Solve) -> np.ndarray:
    """ẍ from the equation of motion: M ẍ = F − C v − K q (column layout)."""
    M, C, K, F = terms0
    rhs = -(K @ q) if F is None else F - K @ q
    if C is not None:
        rhs = rhs - C @ v
    return solve(M, rhs)


def start(terms: Callable[[int], Terms], q0: np.ndarray, v0: np.ndarray,
          solve: Solve = np.linalg.solve) -> State:
    """State at step 0 from q0, v0 (column layout): ẍ₀ from the equation of motion and the
    algorithmic acceleration a₀ = ẍ₀ (Chung & Hulbert).

    Parameters
    ----------
    terms : callable
        ``terms(k)`` → (M, C, K, F) at step k (C may be None); only step 0 is used.
    q0 : numpy.ndarray
        Initial displacements, m, column layout (case, n, r).
    v0 : numpy.ndarray
        Initial velocities, m/s, shape of ``q0``.
    solve : callable, optional
        Linear solver ``solve(A, B)``; default :func:`numpy.linalg.solve`.

    Returns
    -------
    State
        (q, v, ẍ₀, a₀) at step 0.
    """
    acc = _acceleration(terms(0), q0, v0, solve)
    return State(q0, v0, acc, acc)


def from_independent(terms: Callable[[int], Terms], scheme: Integrator, x0, x1, x2,
                     solve: Solve = np.linalg.solve) -> State:
    """State at step 0 from its independent part: (q, v, a) of the Newmark family, or the
    history (q_n, q_{n−1}, q_{n−2}) of Houbolt (:func:`independent` inverted).

    Parameters
    ----------
    terms : callable
        ``terms(k)`` → (M, C, K, F) at step k; only step 0 is used (Newmark family).
    scheme : Integrator
        The scheme.
    x0, x1, x2 : numpy.ndarray
        The independent part, each (case, n, r): q (m), v (m/s), a (m/s²) for the Newmark family;
        q_n, q_{n−1}, q_{n−2} (m) for Houbolt.
    solve : callable, optional
        Linear solver ``solve(A, B)``; default :func:`numpy.linalg.solve`.

    Returns
    -------
    State
        The state to march from.
    """
    if isinstance(scheme, Houbolt):
        return State(x0, None, None, None, (x1, x2))
    return State(x0, x1, _acceleration(terms(0), x0, x1, solve), x2)


def independent(scheme: Integrator, state: State) -> np.ndarray:
    """The independent part of a state stacked along axis −2: (case, 3n, r). Newmark family:
    (q, v, a); Houbolt: (q_n, q_{n−1}, q_{n−2}). One period of :func:`march` maps it linearly
    (the monodromy matrix of the periodic steady state).

    Parameters
    ----------
    scheme : Integrator
        The scheme.
    state : State
        A state in column layout (case, n, r).

    Returns
    -------
    numpy.ndarray
        Shape (case, 3n, r).
    """
    if isinstance(scheme, Houbolt):
        return np.concatenate([state.q, *state.past], axis=-2)
    return np.concatenate([state.q, state.v, state.a], axis=-2)


def forced_columns(terms: Callable[[int], Terms], r: int) -> Callable[[int], Terms]:
    """``terms`` with its load vector F (..., n) moved into column 0 of r columns: the other
    columns are homogeneous solutions sharing each step's factorization (shooting).

    Parameters
    ----------
    terms : callable
        ``terms(k)`` → (M, C, K, F) at step k, F (..., n) in N.
    r : int
        Number of columns.

    Returns
    -------
    callable
        ``columns(k)`` → (M, C, K, loads) with loads (..., n, r).
    """
    def columns(k: int) -> Terms:
        M, C, K, F = terms(k)
        loads = np.zeros(F.shape + (r,))
        loads[..., 0] = F
        return M, C, K, loads
    return columns


def march(
    scheme: Integrator,
    terms: Callable[[int], Terms],
    h: float | np.ndarray,
    n_steps: int,
    state: State,
    record: Callable[[int, State], None] | None = None,
    solve: Solve = np.linalg.solve,
) -> State:
    """Advance ``state`` from step 0 to ``n_steps``; ``record(k, state)`` sees every step.

    The one time-marching loop of ced: the KED response, the periodic shooting and
    :func:`integrate` all run through it.

    Parameters
    ----------
    scheme : NewmarkFamily or Houbolt
    terms : callable
        ``terms(k) -> (M, C, K, F)`` at t_k = k h in column layout: M, C, K (..., n, n), F
        (..., n, r) or None; C may be None. Called once per step, in increasing order.
    h : float or ndarray
        Time step, s: one value, or one per case (shape (case,)).
    n_steps : int
        Number of steps.
    state : State
        From :func:`start` or :func:`from_independent`. A Houbolt run from a state without
        history first takes two average-acceleration Newmark steps (``scheme.starter``),
        self-starting and second-order.
    record : callable, optional
        Called with (k, state) for k = 0 … n_steps.
    solve : callable
        ``solve(S, B)`` for S (..., n, n), B (..., n, k); injectable.

    Returns
    -------
    State
        The state at step ``n_steps``.
    """
    hh = h if np.ndim(h) == 0 else np.asarray(h, float).reshape(-1, 1, 1)
    if record is not None:
        record(0, state)
    started: list[np.ndarray] = []  # Houbolt's start: the displacements so far
    for k in range(n_steps):
        terms1 = terms(k + 1)
        if isinstance(scheme, NewmarkFamily):
            state = State(*alpha_step(scheme, hh, state.q, state.v, state.acc, state.a, terms1,
                                      solve, columns=True))
        elif state.past is None:  # Houbolt's start: average-acceleration Newmark steps
            step = alpha_step(scheme.starter, hh, state.q, state.v, state.acc, state.a, terms1,
                              solve, columns=True)
            started.append(state.q)
            past = (started[-1], started[-2]) if len(started) == 2 else None
            state = State(*step, past)
        else:
            step = houbolt_step(hh, state.q, *state.past, terms1, solve, columns=True)
            state = State(*step, None, (state.q, state.past[0]))
        if record is not None:
            record(k + 1, state)
    return state


def integrate(
    system: Callable[[int], Terms],
    h: float,
    n_steps: int,
    q0: np.ndarray,
    v0: np.ndarray,
    integrator: Integrator,
    solve: Solve | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate M ẍ + C v + K q = F from t = 0 over ``n_steps`` steps of size ``h``, keeping
    the whole history (:func:`march` with a recorder).

    Parameters
    ----------
    system : callable
        ``system(k) -> (M, C, K, F)`` at t_k = k h; M, C, K of shape (..., n, n), F of shape
        (..., n) or (..., n, r) like q; C None means no damping, F None means no load.
        Called once per time level, in increasing order.
    h : float
        Time step, s.
    n_steps : int
        Number of steps (>= 0).
    q0, v0 : array_like
        Initial displacement and velocity. The layout follows from the number of dimensions:
        ``q0.ndim == M.ndim − 1`` is the vector layout (..., n), ``q0.ndim == M.ndim`` the
        column layout (..., n, r). Batch dimensions of q0 line up with those of M (use
        ``M[None]`` to share one matrix among cases of q0).
    integrator : NewmarkFamily or Houbolt
    solve : callable, optional
        ``solve(S, B)`` with S (..., n, n), B (..., n, k); default :func:`numpy.linalg.solve`.

    Returns
    -------
    q, v, acc : ndarray
        Each of shape (n_steps + 1,) + shape, shape being q0's broadcast with v0, F and the
        batch dimensions of M (q0.shape when q0 already carries them). ``acc`` satisfies the
        equation of motion at every t_k.

    Examples
    --------
    >>> M, K = np.eye(1), np.array([[4.0]])
    >>> q, v, acc = integrate(lambda k: (M, None, K, None), 0.01, 100, np.ones(1),
    ...                       np.zeros(1), newmark())
    >>> round(float(q[-1, 0]), 3)   # cos(2 t) at t = 1
    -0.416
    """
    if not (h > 0 and math.isfinite(h)):
        raise ValueError(f"h = {h!r} must be a positive finite time step")
    if int(n_steps) != n_steps or n_steps < 0:
        raise ValueError(f"n_steps = {n_steps!r} must be a non-negative integer")
    solve = np.linalg.solve if solve is None else solve
    M0, _, _, F0 = system(0)
    M0 = np.asarray(M0)
    q0, v0 = np.asarray(q0, dtype=float), np.asarray(v0, dtype=float)
    if q0.ndim == M0.ndim - 1:
        columns, tail = False, (M0.shape[-1],)
    elif q0.ndim == M0.ndim:
        columns, tail = True, (M0.shape[-1], 1)
    else:
        raise ValueError(f"q0 of shape {q0.shape} does not match M of shape {M0.shape}: "
                         "q0.ndim must be M.ndim − 1 (vectors) or M.ndim (columns)")
    shapes = [q0.shape, v0.shape, M0.shape[:-2] + tail]
    if F0 is not None:
        shapes.append(np.shape(F0))
    shape = np.broadcast_shapes(*shapes)
    if shape[-len(tail)] != M0.shape[-1]:
        raise ValueError(f"q0 of shape {q0.shape} has not n = {M0.shape[-1]} rows")

    def as_columns(x: np.ndarray) -> np.ndarray:
        return x if columns else x[..., None]

    def terms(k: int) -> Terms:
        M, C, K, F = system(k)
        return M, C, K, None if F is None else as_columns(np.asarray(F, dtype=float))

    out = np.empty((3, n_steps + 1, *shape))

    def record(k: int, state: State) -> None:
        for i, x in enumerate((state.q, state.v, state.acc)):
            out[i, k] = x if columns else x[..., 0]

    q0, v0 = (as_columns(np.broadcast_to(x, shape)) for x in (q0, v0))
    march(integrator, terms, h, n_steps, start(terms, q0, v0, solve), record, solve)
    return out[0], out[1], out[2]


def amplification_matrix(integrator: Integrator, omega_h: float | np.ndarray,
                         xi: float | np.ndarray = 0.0) -> np.ndarray:
    """One-step amplification matrix for q̈ + 2ξω q̇ + ω² q = 0.

    Parameters
    ----------
    integrator : NewmarkFamily or Houbolt
    omega_h : float or array
        ω h, dimensionless (rad per step).
    xi : float or array
        Damping ratio ξ, dimensionless.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        A with x_{n+1} = A x_n. Newmark family: x = (q, h v, h² a), a the algorithmic
        acceleration (= ẍ for Newmark; module docstring). Houbolt: the three-level
        state x = (q_n, q_{n−1}, q_{n−2}) (companion matrix of the recurrence).
    """
    W, xi = np.broadcast_arrays(np.asarray(omega_h, float), np.asarray(xi, float))
    z, o = np.zeros_like(W), np.ones_like(W)
    if isinstance(integrator, Houbolt):
        # h² × equation of motion at t_{n+1} with Houbolt's differences, solved for q_{n+1}.
        d = 2.0 + 11.0 / 3.0 * xi * W + W**2
        first = [(5.0 + 6.0 * xi * W) / d, -(4.0 + 3.0 * xi * W) / d,
                 (1.0 + 2.0 / 3.0 * xi * W) / d]
        return np.stack([np.stack(first, -1), np.stack([o, z, z], -1), np.stack([z, o, z], -1)], -2)
    s = integrator
    am, af, b, g = s.alpha_m, s.alpha_f, s.beta, s.gamma
    # L x_{n+1} = R x_n: the two Newmark updates and h² × the weighted residual.
    L = np.stack([np.stack([o, z, -b * o], -1),
                  np.stack([z, o, -g * o], -1),
                  np.stack([(1 - af) * W**2, (1 - af) * 2 * xi * W, (1 - am) * o], -1)], -2)
    R = np.stack([np.stack([o, o, (0.5 - b) * o], -1),
                  np.stack([z, o, (1 - g) * o], -1),
                  np.stack([-af * W**2, -af * 2 * xi * W, -am * o], -1)], -2)
    return np.linalg.solve(L, R)


def spectral_radius(integrator: Integrator, omega_h: float | np.ndarray,
                    xi: float | np.ndarray = 0.0) -> np.ndarray:
    """Largest eigenvalue modulus of :func:`amplification_matrix` (dimensionless).

    Parameters
    ----------
    integrator : Integrator
        The scheme.
    omega_h : float or numpy.ndarray
        Mode frequency times step size, ω h, rad per step.
    xi : float or numpy.ndarray, optional
        Physical damping ratio ξ of the mode (dimensionless).

    Returns
    -------
    numpy.ndarray
        Spectral radius ρ (dimensionless), broadcast shape of ``omega_h`` and ``xi``.
    """
    # Accurate up to ωh ~ 1e6 without balancing: the entries stay O(1) there.
    return np.abs(np.linalg.eigvals(amplification_matrix(integrator, omega_h, xi))).max(axis=-1)


def stability_limit(integrator: Integrator) -> float:
    """Largest ω h (rad per step) for which the scheme is stable on an undamped mode.

    Newmark with 2β ≥ γ ≥ ½, HHT-α, generalized-α and Houbolt are unconditionally stable
    (``inf``). Newmark with 2β < γ is stable for ω h ≤ 1/√(γ/2 − β) (Hughes, *The Finite
    Element Method*, 2000, §9.1.2): 2 for the central-difference member β = 0, γ = ½.

    Examples
    --------
    >>> stability_limit(newmark(0.0, 0.5)), stability_limit(newmark())
    (2.0, inf)

    Parameters
    ----------
    integrator : Integrator
        The scheme.

    Returns
    -------
    float
        The limit on ω h, rad per step (``inf`` when unconditionally stable).
    """
    if isinstance(integrator, NewmarkFamily) and integrator.alpha_m == integrator.alpha_f == 0.0:
        margin = 0.5 * integrator.gamma - integrator.beta
        if margin > 0.0:
            return 1.0 / math.sqrt(margin)
    return math.inf

