"""Periodic steady state by Fourier collocation (spectral), solved by compiled GMRES (numba).

The elastic system is linear and periodic in the input period T = 2π/Ω,

    M(t) q̈ + C(t) q̇ + K(t) q = F(t),

so its periodic solution is collocated at P equally spaced phases θ_j = 2πj/P of the period
(t = θ/Ω): q̈ and q̇ are the derivatives of the trigonometric interpolant of the samples, and
the P·n equations read, with d/dt = Ω d/dθ,

    Ω² M_j (D2 q)_j + Ω C_j (D1 q)_j + K_j q_j = F_j,        j = 0 … P−1,

D1, D2 the Fourier differentiation matrices of the period 2π. For even P the Nyquist harmonic
is the real cos(Pθ/2) (sin(Pθ/2) vanishes at every point): D1 has no Nyquist term, D2 keeps
−(P/2)². Smooth periodic terms make the error fall exponentially with P (docs/performance.md,
"Fourier collocation of the periodic steady state"), where the generalized-α shooting
converges at second order and mis-resolves the resonance of a mode with a high crank harmonic
(its period error (ωh)²/12 turns into an amplitude error).

:func:`solve_periodic` solves the collocation system without forming it: right-preconditioned
restarted GMRES (modified Gram–Schmidt, Givens rotations) on the time samples, the operator
applied through the discrete Fourier transform (derivatives are ik, −k² on the coefficients;
a radix-2 FFT when P is a power of two, a dense DFT otherwise), preconditioned by the
time-averaged system M̄, C̄, K̄: constant coefficients make the collocation system
block-diagonal in frequency, one complex n × n block K̄ − k²Ω²M̄ + ikΩC̄ per harmonic
0 ≤ k ≤ P/2, LU-factorized once per case. For constant coefficients the preconditioner is the
exact inverse (one iteration); for a linkage's terms the experiment needed a median ~12.5
iterations at rtol 1e-6. Right preconditioning keeps the residual that GMRES minimizes the
residual of the true (unpreconditioned) system; the final one is recomputed explicitly.

One compiled call solves the whole batch, case after case (serial), allocating its work arrays
once. :func:`solve_periodic_dense` assembles the (P n)² matrix in numpy and solves it densely:
the reference the compiled path is tested against (``tests/response/test_spectral.py``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from ..rigid.small_systems import lu_factor, lu_solve

__all__ = ["PeriodicSolution", "solve_periodic", "solve_periodic_dense", "evaluate",
           "diff_matrices", "RTOL", "MAXITER", "RESTART"]

_JIT = dict(cache=True, nogil=True, fastmath={"reassoc", "contract"})

#: GMRES stops at ‖F − A q‖ ≤ RTOL ‖F‖ (the true residual of the collocation system).
#: Measured on 500 triple-rocker cases of the default study (adaptive P): 1e-6 takes 21 % fewer
#: iterations than 1e-8 and moves no peak stress by more than 0.16 % (where the spectral tail
#: crossed the ladder's threshold and P changed, 0.6 % of the cases; elsewhere far less);
#: 1e-5 saves only 14 % more.
RTOL = 1e-6
#: Iterations allowed per case (restarts included). The experiment's near-resonant cases needed
#: up to ~120 at rtol 1e-6; cases that need more (near a change point GMRES stalls) are better
#: handed to the shooting fallback than iterated further: one iteration at P = 64, n = 20 costs
#: about 1/20 of the shooting.
MAXITER = 500
#: Krylov vectors kept before a restart: enough that the experiment's near-resonant cases
#: (30-120 iterations) restart at most once or twice, while the (RESTART + 1) P n work array
#: stays small (P = 256, n = 200: 21 MB) and Gram–Schmidt's cost (∝ the iteration index)
#: stays below the operator's.
RESTART = 60
#: A restart cycle that reduces the true residual by less than this factor has stalled (a
#: singular or nearly singular system, or the rounding floor): the case stops unconverged.
_STALL = 0.999
#: A block of the averaged system whose LU meets a pivot below _SINGULAR × its scale (the
#: largest row sum of |K̄| + k²Ω²|M̄| + kΩ|C̄|) is exactly resonant; it is factorized with
#: the imaginary shift i·_SHIFT·scale added to its diagonal so that the preconditioner stays
#: finite (GMRES still solves the true system; a singular true system ends unconverged).
_SINGULAR = 1e-13
_SHIFT = 1e-8


@dataclass
class PeriodicSolution:
    """Periodic solution at the collocation phases θ_j = 2πj/P.

    Attributes
    ----------
    displacement : (case, P, n) m
        q at the collocation phases.
    iterations : (case,) int
        GMRES iterations used (0 when F = 0).
    converged : (case,) bool
        True when the relative residual is at most ``rtol``; False when GMRES stalled, hit
        ``maxiter`` or met a singular system (the displacement is then finite, the best
        iterate; the caller falls back to shooting).
    residual : (case,) float
        Final relative residual ‖F − A q‖ / ‖F‖ of the unpreconditioned collocation system.
    """

    displacement: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    residual: np.ndarray


# ---------------------------------------------------------------------------------------------
# Wavenumbers, differentiation matrices (numpy; also the dense reference)
# ---------------------------------------------------------------------------------------------

def _wavenumbers(P: int):
    """Wavenumbers of the DFT on P points, for the second derivative (k) and the first (k1:
    the Nyquist harmonic of an even P has no first derivative)."""
    k = np.fft.fftfreq(P, 1.0 / P)
    k1 = k.copy()
    if P % 2 == 0:
        k[P // 2] = P // 2  # fftfreq gives −P/2; the sign is immaterial for k² and k1 = 0
        k1[P // 2] = 0.0
    return k, k1


def diff_matrices(P: int):
    """Fourier differentiation matrices D1, D2 (P, P) of the period 2π (multiply by Ω, Ω²
    for d/dt, d²/dt²). Even P: D1 has no Nyquist term, D2 keeps −(P/2)².

    Parameters
    ----------
    P : int
        Number of collocation points.

    Returns
    -------
    D1, D2 : numpy.ndarray
        Real (P, P) matrices: (D q)_i = Σ_j D_ij q_j.
    """
    k, k1 = _wavenumbers(P)
    E = np.fft.fft(np.eye(P), axis=0)
    D1 = np.real(np.fft.ifft(1j * k1[:, None] * E, axis=0))
    D2 = np.real(np.fft.ifft(-(k[:, None] ** 2) * E, axis=0))
    return D1, D2


def _check(stiffness, force, speed, mass, damping):
    K = np.ascontiguousarray(stiffness, dtype=np.float64)
    F = np.ascontiguousarray(force, dtype=np.float64)
    w = np.ascontiguousarray(np.broadcast_to(np.asarray(speed, np.float64), (K.shape[0],)))
    if K.ndim != 4 or K.shape[2] != K.shape[3] or F.shape != K.shape[:3]:
        raise ValueError(f"stiffness (case, P, n, n) and force (case, P, n) expected, got "
                         f"{K.shape} and {F.shape}")
    P = K.shape[1]
    if P < 4 or P % 2:
        raise ValueError(f"an even number of collocation points P >= 4 is expected, got {P}")
    M = None if mass is None else np.ascontiguousarray(mass, dtype=np.float64)
    C = None if damping is None else np.ascontiguousarray(damping, dtype=np.float64)
    for name, X in (("mass", M), ("damping", C)):
        if X is not None and X.shape != K.shape:
            raise ValueError(f"{name} has shape {X.shape}, stiffness {K.shape}")
    return M, C, K, F, w


def solve_periodic_dense(stiffness, force, speed, mass=None, damping=None) -> np.ndarray:
    """Periodic solution by assembling the (P n)² collocation matrix and solving it densely,
    case by case (numpy; the reference of :func:`solve_periodic`).

    Row block i, column block j of the matrix is Ω² M_i D2_ij + Ω C_i D1_ij + δ_ij K_i. A
    singular matrix (exact resonance without damping) is solved by least squares (minimum
    norm), so the result stays finite.

    Parameters
    ----------
    stiffness : (case, P, n, n) N/m
    force : (case, P, n) N
    speed : (case,) rad/s
        Ω, the input speed: d/dt = Ω d/dθ.
    mass, damping : (case, P, n, n) or None
        kg, N s/m; None drops the term.

    Returns
    -------
    numpy.ndarray
        q (case, P, n) at the phases θ_j = 2πj/P, m.
    """
    M, C, K, F, w = _check(stiffness, force, speed, mass, damping)
    ncase, P, n = F.shape
    D1, D2 = diff_matrices(P)
    out = np.empty((ncase, P, n))
    idx = np.arange(P)
    for c in range(ncase):
        A = np.zeros((P, n, P, n))
        if M is not None:
            A += np.einsum("ij,iab->iajb", (w[c] ** 2) * D2, M[c])
        if C is not None:
            A += np.einsum("ij,iab->iajb", w[c] * D1, C[c])
        A[idx, :, idx, :] += K[c]
        A = A.reshape(P * n, P * n)
        b = F[c].reshape(-1)
        try:
            x = np.linalg.solve(A, b)
        except np.linalg.LinAlgError:
            x = np.linalg.lstsq(A, b, rcond=None)[0]
        out[c] = x.reshape(P, n)
    return out


def evaluate(displacement, phases) -> np.ndarray:
    """Trigonometric interpolant of samples at the phases θ_j = 2πj/P, evaluated anywhere.

    Even P: the Nyquist coefficient is split evenly between ±P/2 (a real cos(Pθ/2) term), so
    the interpolant reproduces the samples at θ_j exactly and is real.

    Parameters
    ----------
    displacement : (case, P, n)
        Samples at θ_j = 2πj/P.
    phases : (m,) rad
        Where to evaluate (any real values; the interpolant has period 2π).

    Returns
    -------
    numpy.ndarray
        (case, m, n).
    """
    y = np.asarray(displacement, dtype=np.float64)
    theta = np.asarray(phases, dtype=np.float64).reshape(-1)
    P = y.shape[1]
    Y = np.fft.rfft(y, axis=1) / P  # (case, P//2 + 1, n): c_k, k = 0 … ⌊P/2⌋
    kmax = Y.shape[1] - 1
    weight = np.full(kmax + 1, 2.0)  # c_k and c_−k = conj(c_k) together: 2 Re(c_k e^{ikθ})
    weight[0] = 1.0
    if P % 2 == 0:
        weight[kmax] = 1.0  # Nyquist: ½ c e^{iPθ/2} + ½ c e^{−iPθ/2} = c cos(Pθ/2), c real
    k = np.arange(kmax + 1)
    E = np.exp(1j * np.outer(theta, k)) * weight  # (m, kmax + 1)
    return np.real(np.einsum("mk,ckn->cmn", E, Y))


# ---------------------------------------------------------------------------------------------
# Compiled kernels
# ---------------------------------------------------------------------------------------------

def _plan(P: int):
    """Bit-reversal permutation and twiddles e^{−2πim/P} of a radix-2 FFT when P is a power of
    two; else the dense DFT matrix W_km = e^{−2πikm/P} (P, P). Returns (radix2, perm, tw, W)."""
    radix2 = P & (P - 1) == 0
    tw = np.exp(-2j * np.pi * np.arange(P // 2) / P)
    if radix2:
        bits = P.bit_length() - 1
        perm = np.array([int(format(i, f"0{bits}b")[::-1], 2) for i in range(P)], np.int64)
        W = np.zeros((1, 1), np.complex128)
    else:
        perm = np.arange(P, dtype=np.int64)
        m = np.arange(P)
        W = np.exp(-2j * np.pi * np.outer(m, m) / P)
    return radix2, perm, tw, W


@nb.njit(**_JIT)
def _fft(X, inverse, radix2, perm, tw, W, work):
    """Unnormalized DFT of X (P, n) complex along axis 0, in place: X_k = Σ_m x_m e^{∓2πikm/P}
    (− forward, + ``inverse``). The inner loops run along the n contiguous columns."""
    P, n = X.shape
    if not radix2:
        for k in range(P):
            for s in range(n):
                work[k, s] = 0.0
            for m in range(P):
                f = W[k, m]
                if inverse:
                    f = f.conjugate()
                for s in range(n):
                    work[k, s] += f * X[m, s]
        for k in range(P):
            for s in range(n):
                X[k, s] = work[k, s]
        return
    for i in range(P):
        j = perm[i]
        if j > i:
            for s in range(n):
                t = X[i, s]
                X[i, s] = X[j, s]
                X[j, s] = t
    size = 2
    while size <= P:
        half = size // 2
        step = P // size
        for start in range(0, P, size):
            for k in range(half):
                f = tw[k * step]
                if inverse:
                    f = f.conjugate()
                fr, fi = f.real, f.imag
                a = X[start + k]
                b = X[start + k + half]
                for s in range(n):
                    br, bi = b[s].real, b[s].imag
                    t = complex(fr * br - fi * bi, fr * bi + fi * br)
                    u = a[s]
                    a[s] = u + t
                    b[s] = u - t
        size *= 2


@nb.njit(**_JIT)
def _min_pivot(A) -> float:
    n = A.shape[0]
    m = np.inf
    for i in range(n):
        m = min(m, abs(A[i, i]))
    return m


@nb.njit(**_JIT)
def _factor_blocks(Mb, Cb, Kb, has_mass, has_damping, w, P, LU, piv):
    """LU of the averaged system's frequency blocks B_k = K̄ − k²Ω²M̄ + ikΩC̄, k = 0 … P/2
    (Nyquist: no ik term), into LU (P/2 + 1, n, n) complex; an exactly singular block gets
    the shift i·_SHIFT·scale. Returns the number of shifted blocks."""
    n = Kb.shape[0]
    half = P // 2
    shifted = 0
    for k in range(half + 1):
        d2 = -(k * w) ** 2
        d1 = 0.0 if k == half else k * w
        B = LU[k]
        scale = 0.0
        for i in range(n):
            row = 0.0
            for j in range(n):
                re = Kb[i, j]
                im = 0.0
                row += abs(Kb[i, j])
                if has_mass:
                    re += d2 * Mb[i, j]
                    row += -d2 * abs(Mb[i, j])
                if has_damping:
                    im = d1 * Cb[i, j]
                    row += d1 * abs(Cb[i, j])
                B[i, j] = complex(re, im)
            scale = max(scale, row)
        ok = lu_factor(B, piv[k])
        if not ok or _min_pivot(B) <= _SINGULAR * scale:
            shifted += 1
            sigma = _SHIFT * max(scale, 1e-300)
            for i in range(n):
                for j in range(n):
                    re = Kb[i, j]
                    im = 0.0
                    if has_mass:
                        re += d2 * Mb[i, j]
                    if has_damping:
                        im = d1 * Cb[i, j]
                    B[i, j] = complex(re, im)
                B[i, i] += complex(0.0, sigma)
            if not lu_factor(B, piv[k]):  # only non-finite terms get here
                for i in range(n):
                    for j in range(n):
                        B[i, j] = 0.0
                    B[i, i] = complex(0.0, sigma)
                    piv[k, i] = i
    return shifted


@nb.njit(**_JIT)
def _precondition(v, LU, piv, plan, Z, work):
    """Z = spectrum (P, n) of B̄⁻¹ v (v time samples (P, n) real): forward DFT, one block solve
    per harmonic 0 … P/2, the negative harmonics by conjugate symmetry."""
    radix2, perm, tw, W = plan
    P, n = v.shape
    for j in range(P):
        for s in range(n):
            Z[j, s] = v[j, s]
    _fft(Z, False, radix2, perm, tw, W, work)
    half = P // 2
    for k in range(half + 1):
        lu_solve(LU[k], piv[k], Z[k])
    for k in range(1, half):
        for s in range(n):
            Z[P - k, s] = Z[k, s].conjugate()


@nb.njit(**_JIT)
def _operator(Z, M, C, K, has_mass, has_damping, w, plan, Y1, Y2, work, out):
    """out = A z for the samples z whose (unnormalized) spectrum is Z (P, n), Hermitian:
    out_j = Ω² M_j z''_j + Ω C_j z'_j + K_j z_j. One inverse DFT gives z + i z'/(Ω P/2) (both
    real: the spectrum (1 − k1/(P/2)) Z; scaled so that the two parts are of one magnitude and
    neither's rounding swamps the other), a second z'' (−Ω² k² Z)."""
    radix2, perm, tw, W = plan
    P, n = Z.shape
    half = P // 2
    inv = 1.0 / P
    dscale = w * half  # z' = dscale × Im(inverse DFT of Y1)
    for j in range(P):
        kk = j if j <= half else j - P
        k1 = 0.0 if j == half else kk / half
        a = 1.0 - k1 if has_damping else 1.0
        b = -(kk * w) ** 2
        for s in range(n):
            Y1[j, s] = a * Z[j, s]
            Y2[j, s] = b * Z[j, s]
    _fft(Y1, True, radix2, perm, tw, W, work)
    if has_mass:
        _fft(Y2, True, radix2, perm, tw, W, work)
    for j in range(P):
        y1 = Y1[j]
        y2 = Y2[j]
        Kj = K[j]
        for i in range(n):
            t = 0.0
            Ki = Kj[i]
            for s in range(n):
                t += Ki[s] * y1[s].real
            if has_mass:
                Mi = M[j, i]
                for s in range(n):
                    t += Mi[s] * y2[s].real
            if has_damping:
                Ci = C[j, i]
                d = 0.0
                for s in range(n):
                    d += Ci[s] * y1[s].imag
                t += dscale * d
            out[j, i] = t * inv


@nb.njit(**_JIT)
def _norm(x):
    t = 0.0
    for i in range(x.shape[0]):
        t += x[i] * x[i]
    return np.sqrt(t)


@nb.njit(**_JIT)
def _fill(out, x, scale):
    """out (P, n) = scale × x (P n,), element by element: an array assignment would compile
    numba's broadcasting with its formatted error messages (seconds of compile time)."""
    P, n = out.shape
    for j in range(P):
        for s in range(n):
            out[j, s] = scale * x[j * n + s]


@nb.njit(**_JIT)
def _solve_batch(M, C, K, F, has_mass, has_damping, speed, rtol, maxiter, restart,
                 radix2, perm, tw, W, q, iterations, converged, residual, warm):
    """GMRES per case (see :func:`solve_periodic`) from the initial guesses q (zero: a cold
    start); fills q, iterations, converged, residual and warm (the case started from its
    guess)."""
    ncase, P, n = F.shape
    N = P * n
    half = P // 2
    plan = (radix2, perm, tw, W)
    m = restart
    # work arrays, once for the batch
    LU = np.empty((half + 1, n, n), np.complex128)
    piv = np.empty((half + 1, n), np.int64)
    Mb = np.zeros((n, n))
    Cb = np.zeros((n, n))
    Kb = np.zeros((n, n))
    Z = np.empty((P, n), np.complex128)
    Y1 = np.empty((P, n), np.complex128)
    Y2 = np.empty((P, n), np.complex128)
    work = np.empty((P, n), np.complex128)
    V = np.empty((m + 1, N))
    H = np.zeros((m + 1, m))
    cs = np.empty(m)
    sn = np.empty(m)
    g = np.empty(m + 1)
    yv = np.empty(m)
    r = np.empty(N)
    x = np.empty(N)
    t = np.empty(N)
    u = np.empty(N)
    for c in range(ncase):
        b = F[c].reshape(N)
        Mc, Cc, Kc = M[c % M.shape[0]], C[c % C.shape[0]], K[c]
        w = speed[c]
        # time-averaged system and its frequency blocks
        for i in range(n):
            for j in range(n):
                Kb[i, j] = 0.0
                Mb[i, j] = 0.0
                Cb[i, j] = 0.0
        for p in range(P):
            for i in range(n):
                for j in range(n):
                    Kb[i, j] += Kc[p, i, j]
                    if has_mass:
                        Mb[i, j] += Mc[p, i, j]
                    if has_damping:
                        Cb[i, j] += Cc[p, i, j]
        for i in range(n):
            for j in range(n):
                Kb[i, j] /= P
                Mb[i, j] /= P
                Cb[i, j] /= P
        _factor_blocks(Mb, Cb, Kb, has_mass, has_damping, w, P, LU, piv)

        beta = _norm(b)
        guessed = False
        for j in range(P):
            for s in range(n):
                x[j * n + s] = q[c, j, s]
                guessed = guessed or q[c, j, s] != 0.0
        warm[c] = False
        its = 0
        if beta == 0.0:
            _fill(q[c], x, 0.0)
            iterations[c] = 0
            converged[c] = True
            residual[c] = 0.0
            continue
        if not np.isfinite(beta):
            _fill(q[c], x, 0.0)
            iterations[c] = 0
            converged[c] = False
            residual[c] = np.inf
            continue
        rnorm = beta
        if guessed:  # from the initial guess, where it is nearer the solution than zero
            _fft_time_operator(x, Mc, Cc, Kc, has_mass, has_damping, w, plan, Z, Y1, Y2,
                               work, u)
            rnorm = 0.0
            for s in range(N):
                r[s] = b[s] - u[s]
                rnorm += r[s] * r[s]
            rnorm = np.sqrt(rnorm)
            warm[c] = rnorm < beta  # False for a non-finite guess too
        if not warm[c]:
            for i in range(N):
                x[i] = 0.0
                r[i] = b[i]
            rnorm = beta
        target = rtol * beta
        ok = False
        while True:
            if rnorm <= target:
                ok = True
                break
            if its >= maxiter:
                break
            # one restart cycle: Arnoldi on A B̄⁻¹ from the true residual
            cycle_start = its
            for i in range(N):
                V[0, i] = r[i] / rnorm
            g[0] = rnorm
            k_used = 0
            for j in range(m):
                vj = V[j].reshape(P, n)
                _precondition(vj, LU, piv, plan, Z, work)
                wv = V[j + 1]
                _operator(Z, Mc, Cc, Kc, has_mass, has_damping, w, plan, Y1, Y2, work,
                          wv.reshape(P, n))
                w0 = _norm(wv)
                for i in range(j + 1):  # modified Gram–Schmidt
                    vi = V[i]
                    h = 0.0
                    for s in range(N):
                        h += wv[s] * vi[s]
                    H[i, j] = h
                    for s in range(N):
                        wv[s] -= h * vi[s]
                hn = _norm(wv)
                H[j + 1, j] = hn
                for i in range(j):  # earlier rotations on the new column
                    h0 = cs[i] * H[i, j] + sn[i] * H[i + 1, j]
                    H[i + 1, j] = -sn[i] * H[i, j] + cs[i] * H[i + 1, j]
                    H[i, j] = h0
                d = np.hypot(H[j, j], H[j + 1, j])
                if d > 0.0 and np.isfinite(d):
                    cs[j] = H[j, j] / d
                    sn[j] = H[j + 1, j] / d
                else:
                    cs[j] = 1.0
                    sn[j] = 0.0
                    d = H[j, j]
                H[j, j] = d
                H[j + 1, j] = 0.0
                g[j + 1] = -sn[j] * g[j]
                g[j] = cs[j] * g[j]
                its += 1
                k_used = j + 1
                # breakdown: the Krylov space is invariant (exact solution in it, or singular)
                if not (hn > 1e-14 * w0) or not np.isfinite(hn):
                    break
                inv = 1.0 / hn
                for s in range(N):
                    wv[s] *= inv
                if abs(g[j + 1]) <= target or its >= maxiter:
                    break
            # least squares in the Krylov space: triangular R y = g (a zero pivot: y_i = 0)
            hmax = 0.0
            for i in range(k_used):
                hmax = max(hmax, abs(H[i, i]))
            for i in range(k_used - 1, -1, -1):
                s0 = g[i]
                for l in range(i + 1, k_used):
                    s0 -= H[i, l] * yv[l]
                if abs(H[i, i]) > 1e-14 * hmax and np.isfinite(s0 / H[i, i]):
                    yv[i] = s0 / H[i, i]
                else:
                    yv[i] = 0.0
            for s in range(N):
                u[s] = 0.0
            for i in range(k_used):
                f = yv[i]
                vi = V[i]
                for s in range(N):
                    u[s] += f * vi[s]
            # x += B̄⁻¹ u, then the true residual b − A x
            _precondition(u.reshape(P, n), LU, piv, plan, Z, work)
            for j in range(P):
                for s in range(n):
                    Y1[j, s] = Z[j, s]
            _fft(Y1, True, radix2, perm, tw, W, work)
            for j in range(P):
                for s in range(n):
                    t[j * n + s] = x[j * n + s] + Y1[j, s].real / P
            _fft_time_operator(t, Mc, Cc, Kc, has_mass, has_damping, w, plan, Z, Y1, Y2,
                               work, u)
            new = 0.0
            for s in range(N):
                d = b[s] - u[s]
                new += d * d
            new = np.sqrt(new)
            if not np.isfinite(new):
                break  # keep the last finite iterate
            for s in range(N):
                x[s] = t[s]
                r[s] = b[s] - u[s]
            stalled = new > _STALL * rnorm
            if not stalled and new > target and its < maxiter:
                # Restarted GMRES converges about linearly from cycle to cycle: where the
                # rate of this cycle would not reach the target within the iterations left,
                # even twice as fast, the case ends now instead of at maxiter.
                rate = np.log(new / rnorm) / (its - cycle_start)
                stalled = its + 0.5 * np.log(target / new) / rate > maxiter
            rnorm = new
            if stalled:
                ok = rnorm <= target
                break
        _fill(q[c], x, 1.0)
        iterations[c] = its
        converged[c] = ok
        residual[c] = rnorm / beta


@nb.njit(**_JIT)
def _fft_time_operator(x, M, C, K, has_mass, has_damping, w, plan, Z, Y1, Y2, work, out):
    """out = A x for time samples x (P n,) (flat): forward DFT, then :func:`_operator`."""
    radix2, perm, tw, W = plan
    P, n = Z.shape
    for j in range(P):
        for s in range(n):
            Z[j, s] = x[j * n + s]
    _fft(Z, False, radix2, perm, tw, W, work)
    _operator(Z, M, C, K, has_mass, has_damping, w, plan, Y1, Y2, work, out.reshape(P, n))


def solve_periodic(stiffness, force, speed, mass=None, damping=None, rtol=RTOL,
                   maxiter=MAXITER, initial=None) -> PeriodicSolution:
    """Periodic solution of M q̈ + C q̇ + K q = F at P collocation phases, by compiled GMRES.

    Parameters
    ----------
    stiffness : (case, P, n, n) N/m
        K at the phases θ_j = 2πj/P of the input period.
    force : (case, P, n) N
        F at the same phases.
    speed : (case,) rad/s
        Ω: d/dt = Ω d/dθ.
    mass, damping : (case, P, n, n) or None
        M (kg; symmetric positive definite) and C (N s/m; any real, gyroscopic terms
        included). None drops the term (no inertia: K q + C q̇ = F, pointwise K q = F
        without damping either).
    rtol : float, optional
        Relative residual ‖F − A q‖ / ‖F‖ to reach (:data:`RTOL`).
    maxiter : int, optional
        GMRES iterations allowed per case (:data:`MAXITER`).
    initial : (case, P, n) m, optional
        Initial guesses of q (default zero). A case starts from its guess where the guess's
        residual is below ‖F‖ (a guess farther from the solution than zero is dropped); the
        stopping test stays ‖F − A q‖ ≤ rtol ‖F‖, so a good guess saves the iterations that
        would have brought the residual down to its own. A case that does not converge from
        its guess is solved again from zero (its iterations add up): restarted GMRES can
        stall from a guess where it converges from zero (2 of 3 double cranks of a
        default-study chunk at P = 256), and a guess is to save iterations, never to change
        which cases converge.

    Returns
    -------
    PeriodicSolution
        q (case, P, n) m, iterations, converged and the final relative residual per case.
        F = 0 gives q = 0, converged, 0 iterations. Unconverged cases (stalled, singular,
        ``maxiter`` reached) hold their best finite iterate.
    """
    M, C, K, F, w = _check(stiffness, force, speed, mass, damping)
    ncase, P, n = F.shape
    dummy = np.zeros((1, 1, 1, 1))
    radix2, perm, tw, W = _plan(P)
    q = (np.zeros((ncase, P, n)) if initial is None
         else np.array(np.broadcast_to(initial, (ncase, P, n)), dtype=np.float64, order="C"))
    iterations = np.zeros(ncase, np.int64)
    converged = np.zeros(ncase, bool)
    residual = np.zeros(ncase)
    warm = np.zeros(ncase, bool)
    _solve_batch(dummy if M is None else M, dummy if C is None else C, K, F, M is not None,
                 C is not None, w, float(rtol), int(maxiter), int(RESTART), radix2, perm, tw,
                 W, q, iterations, converged, residual, warm)
    again = np.flatnonzero(~converged & warm)
    if len(again):
        cold = solve_periodic(K[again], F[again], w[again], None if M is None else M[again],
                              None if C is None else C[again], rtol, maxiter)
        q[again] = cold.displacement
        iterations[again] += cold.iterations
        converged[again] = cold.converged
        residual[again] = cold.residual
    return PeriodicSolution(q, iterations, converged, residual)
