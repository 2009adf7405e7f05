"""Forced resonance: a crank harmonic inside a mode's frequency band, carrying load.

The KED system of a linkage is periodic in the input cycle: its load F(t) is a sum of crank
harmonics kΩ, and the frozen natural frequency ω_i(t) of each mode sweeps a band
[ω_i,min, ω_i,max] over the cycle (the configuration, centrifugal and axial effects change the
stiffness). Harmonic k drives mode i resonantly when kΩ lies inside that band, widened by the
mode's half-power width ±ζ_i ω_i. Whether it matters depends on how much of the mode's load
the harmonic carries: with g_i(t) = φ_i(t)ᵀ F(t) the load on the mass-normalised mode and a_ik
the share of harmonic k in its spectrum (Σ_k a_ik = 1), the resonant response of that harmonic
is a_ik / (2 ζ) times its quasi-static one, so it dominates the mode's response when

    a_ik ≥ 2 ζ_eff,      ζ_eff = max(ζ_i, ZETA_FLOOR).                                  (1)

ZETA_FLOOR (0.5 %) stands for the damping no linkage is without (joints, material) and for
the limited build-up of a resonance that the sweeping frequency crosses twice per cycle; an
undamped scene is thus flagged when the harmonic carries at least 1 % of the mode's load.

This holds whatever the start (``undeformed``, ``quasi_static``, ``periodic``), for the
dynamic and the quasi-static model alike (a quasi-static result at a resonant speed is
wrong, and the flag says so). On the reference four-bar the first mode's load is 62 % first
harmonic, 25 % second, 6.4 % third, 1.9 % fourth, 0.47 % fifth, 0.12 % sixth: the first four
harmonics are resonant inside the band, the higher ones not. Parametric resonance (a Floquet
multiplier outside the unit circle) is the separate flag ``parametrically_unstable`` of a
periodic start (:mod:`ced.response.periodic`).
"""
from __future__ import annotations

import math

import numpy as np

from ..fem.eigenproblem import natural_frequencies
from .model import Model, terms_at
from .period_terms import PeriodTerms

__all__ = ["cycle_modes", "cycle_spectrum", "forced_resonance", "resonance_weight", "SAMPLES",
           "HARMONICS", "MODES", "ZETA_FLOOR", "ZETA_LEAST"]

#: Samples of one input period (harmonics up to SAMPLES/2 = 16 resolved).
SAMPLES = 32
#: Crank harmonics k = 1 … HARMONICS searched (the reference four-bar's first mode carries
#: 0.12 % of its load at k = 6, far below eq. (1)'s 1 %).
HARMONICS = 12
#: Lowest modes searched (at most the model's DOFs).
MODES = 4
#: Damping ratio assumed at least, eq. (1).
ZETA_FLOOR = 0.005
#: Damping ratio below which :func:`resonance_weight` does not go (an undamped mode's weight
#: would be infinite where a harmonic meets it exactly): far below any linkage's, so an
#: undamped resonance keeps its full sharpness on a speed grid.
ZETA_LEAST = 1e-4
#: Bytes of system terms held at once.
_BLOCK_BYTES = 50e6


def cycle_modes(model: Model, modes: int = MODES, samples: int = SAMPLES,
                period: PeriodTerms | None = None, turns: int = 1):
    """Frozen modes over one period of the motion and the load they carry.

    Parameters
    ----------
    model : Model
        The batch's model.
    modes : int, optional
        Number of modes (at most ny).
    samples : int, optional
        Number of phases sampled over the period.
    period : PeriodTerms, optional
        The batch's terms over one period of its step grid: where its steps hold the sample
        phases and its mass, stiffness and load are those of the frozen system (as they are with
        ``elastic_inertia``: velocity terms only enter the damping), they are taken from it
        instead of being evaluated again.
    turns : int, optional
        Input turns of the motion's period (two where it passes a change point once a turn:
        :attr:`ced.response.batch.Batch.motion_turns`); the samples span them all.

    Returns
    -------
    frequency : (case, sample, mode) rad/s, negative for a negative eigenvalue
    share : (case, harmonic, mode), k = 0 … samples/2: a_ik, the share of harmonic k of the
        period (k/turns of the input speed) in the
        spectrum of the modal load g_i(t) = φ_i(t)ᵀ F(t) (mass-normalised shapes whose signs
        are carried continuously around the cycle)
    """
    modes = min(modes, model.layout.ny)
    phases = 2.0 * math.pi * turns * np.arange(samples) / samples
    times = phases[None, :] / model.batch.speed[:, None]
    effects = model.effects - {"damping", "coriolis"}  # K and F only: no velocity terms
    ncase, ny = model.batch.size, model.layout.ny
    # A few samples at a time: the system terms of a whole period of a large batch would not
    # fit in memory (SAMPLES × cases × ny² values per matrix).
    block = int(max(1, _BLOCK_BYTES // (8 * 4 * ncase * ny * ny)))
    frequency = np.empty((ncase, samples, modes))
    load = np.empty((ncase, samples, modes))
    previous = None
    stride = _sample_stride(period, samples)
    for start in range(0, samples, block):
        if stride:
            steps = stride * np.arange(start, min(start + block, samples))
            mass, stiffness, force = (period.dense(name, steps) for name in
                                      ("mass", "stiffness", "force"))
        else:
            terms, _ = terms_at(model, times[:, start:start + block], effects,
                                frozenset({"elastic_mass"}))
            mass, stiffness, force = terms.elastic_mass, terms.stiffness, terms.force
        f, shapes = natural_frequencies(stiffness, mass, modes, shapes=True,
                                        blocks=model.layout.link_blocks)
        for j in range(shapes.shape[1]):  # eigenvectors come with arbitrary signs: follow
            if previous is not None:      # each mode from sample to sample
                # φ_jᵀ M φ_prev by a matmul, then the sum over n: the three-operand einsum
                # loops over every (c, i, n, m), 7× the time (only its sign is read).
                overlap = np.sum(shapes[:, j] * (mass[:, j] @ previous), axis=1)
                shapes[:, j] *= np.where(overlap < 0.0, -1.0, 1.0)[:, None, :]
            previous = shapes[:, j]
        frequency[:, start:start + block] = f
        load[:, start:start + block] = np.einsum("ctni,ctn->cti", shapes, force)
    spectrum = np.abs(np.fft.rfft(load, axis=1))
    spectrum[:, 1:] *= 2.0  # one-sided amplitudes
    total = spectrum.sum(axis=1, keepdims=True)
    share = np.divide(spectrum, total, out=np.zeros_like(spectrum), where=total > 0)
    return 2.0 * math.pi * frequency, share


def _sample_stride(period: PeriodTerms | None, samples: int) -> int:
    """Steps between the sample phases on the period's step grid, or 0 where the period's
    terms cannot stand for the frozen system's there (no mass, or samples off the grid)."""
    if period is None or period.mass is None or period.period % samples:
        return 0
    return period.period // samples


def _damping_ratio(model: Model, omega: np.ndarray) -> np.ndarray:
    """ζ of each mode, (case, mode): the scene's modal ratio, or Rayleigh's α/2ω + βω/2."""
    if "damping" not in model.effects:
        return np.zeros_like(omega)
    damping = model.batch.scenes[0]["damping"]
    if damping["model"] == "modal":
        return np.full_like(omega, damping["ratio"])
    w = np.maximum(np.abs(omega), 1e-300)
    return damping["alpha"] / (2.0 * w) + damping["beta"] * w / 2.0


def forced_resonance(model: Model, period: PeriodTerms | None = None,
                     turns: int = 1) -> np.ndarray:
    """(case,) bool: some harmonic k ≤ :data:`HARMONICS` lies in some mode's band and carries
    load enough to dominate it, eq. (1) of the module docstring.

    A motion that repeats every two turns loads at half the crank harmonics too,
    kΩ/2: they are searched alike up to the same frequency.

    Parameters
    ----------
    model : Model
        The batch's model (input speed Ω in rad/s, effects, damping).
    period : PeriodTerms, optional
        The batch's terms over one period (:func:`cycle_modes`).
    turns : int, optional
        Input turns of the period (:func:`cycle_modes`).

    Returns
    -------
    numpy.ndarray
        Shape (case,), bool.
    """
    if model.layout.ny == 0:
        return np.zeros(model.batch.size, bool)
    omega, share = cycle_modes(model, samples=SAMPLES * turns, period=period, turns=turns)
    low, high = omega.min(axis=1), omega.max(axis=1)  # (case, mode)
    zeta = _damping_ratio(model, 0.5 * (low + high))
    k = np.arange(1, HARMONICS * turns + 1)[None, :, None] / turns
    harmonic = k * model.batch.speed[:, None, None]  # (case, k, 1) rad/s
    inside = ((harmonic >= (low * (1.0 - zeta))[:, None, :])
              & (harmonic <= (high * (1.0 + zeta))[:, None, :]))
    strong = (share[:, 1:HARMONICS * turns + 1]
              >= 2.0 * np.maximum(zeta, ZETA_FLOOR)[:, None, :])
    return (inside & strong).any(axis=(1, 2))


def cycle_spectrum(model: Model, modes: int = MODES, samples: int = SAMPLES
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each mode's mean frozen frequency over the cycle, its load's harmonics and its damping.

    A periodic state of the linear time-periodic KED system is singular where a Floquet
    exponent meets a crank harmonic. Over a cycle slow beside the mode (the frozen frequency
    ω_i(t) changes little in one of its periods) the exponent is the mean of ω_i(t) over the
    cycle (WKB); on the reference four-bar ω̄₁/4 puts the 4:1 resonance at 90.9 rad/s, where the
    periodic sweep's error is largest (90.81–91.01 rad/s at every mesh).

    Parameters
    ----------
    model : Model
        The batch's model.
    modes, samples : int, optional
        As for :func:`cycle_modes`.

    Returns
    -------
    frequency : (case, mode) rad/s, ω̄_i
    share : (case, harmonic, mode), a_ik (:func:`cycle_modes`), k = 0 … samples/2
    damping_ratio : (case, mode), ζ_i at ω̄_i
    """
    omega, share = cycle_modes(model, modes, samples)
    mean = omega.mean(axis=1)
    return mean, share, _damping_ratio(model, mean)


def resonance_weight(speed, frequency, share, damping_ratio,
                     harmonics: int = HARMONICS) -> np.ndarray:
    """How strongly a periodic state's peak depends on its natural frequencies, per case.

    Harmonic k of mode i's load, carrying a share a_ik of it, is amplified by
    1/|1 − r² + 2iζr| with r = kΩ/ω̄_i; a relative error ε on ω̄_i (the mesh's) changes that
    amplification by about 2ε/((1 − r²)² + (2ζr)²) of the mode's quasi-static response. So

        W = Σ_i Σ_{k=1…harmonics} a_ik / ((1 − r_ik²)² + (2 ζ_i r_ik)²)

    is, up to ε, the part of the peak's discretization error that a resonance drives: of
    order 1 far from any resonance, and up to a_ik / (2ζ)² on one (ζ at least
    :data:`ZETA_LEAST`). Its use is
    to compare cases of one speed sweep, whose ε is the same
    (:func:`ced.auto.discretization.unverified`).

    Parameters
    ----------
    speed : (case,) array_like
        Input speed Ω, rad/s.
    frequency : (case, mode) array_like
        Mean frozen frequency ω̄_i, rad/s (:func:`cycle_spectrum`).
    share : (case, harmonic, mode) array_like
        a_ik, k = 0, 1, … (:func:`cycle_spectrum`).
    damping_ratio : (case, mode) array_like
        ζ_i.
    harmonics : int, optional
        Harmonics k = 1 … harmonics summed (at most those of ``share``).

    Returns
    -------
    numpy.ndarray
        W, shape (case,), dimensionless.
    """
    speed = np.asarray(speed, float)
    frequency = np.asarray(frequency, float)
    share = np.asarray(share, float)
    zeta = np.maximum(np.asarray(damping_ratio, float), ZETA_LEAST)
    k = np.arange(1, min(harmonics, share.shape[1] - 1) + 1)
    with np.errstate(divide="ignore"):
        r = k[None, :, None] * speed[:, None, None] / np.abs(frequency)[:, None, :]
    denominator = (1.0 - r**2) ** 2 + (2.0 * zeta[:, None, :] * r) ** 2
    return (share[:, 1:len(k) + 1] / denominator).sum(axis=(1, 2))
