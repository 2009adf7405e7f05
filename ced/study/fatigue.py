"""Fatigue of the links: rainflow-counted cycles of the periodic stress history, Goodman's
mean-stress correction, a fatigue safety factor against the endurance limit.

Links of high-speed machinery see millions of cycles, so the check is for infinite life: every
cycle of one period of the steady-state stress history must lie inside the Goodman line
through the endurance limit S_e and the tensile strength S_u (Budynas & Nisbett, Shigley's
Mechanical Engineering Design, 10th ed., §6-12). A cycle of amplitude σ_a and mean σ_m has the
safety factor

    n = 1 / (σ_a / S_e + σ_m / S_u)   for σ_m ≥ 0,     n = S_e / σ_a   for σ_m < 0

(a compressive mean earns no credit); the link's factor is the smallest over its cycles and
its two outer fibres at its critical station (the station of its peak absolute stress). The
cycles are counted by the ``rainflow`` package (ASTM E1049-85 four-point method) on the history
rotated to start at its largest value, so that one period closes every cycle.

The endurance limits of the material library (``ced/problem/data/materials.yaml``) are
polished-specimen values without surface, size or reliability factors: the required fatigue
safety factor must cover those.

Examples
--------
A fully reversed ±100 MPa cycle on steel (S_e 180 MPa): n = 180 / 100.

>>> import numpy as np
>>> round(fatigue_safety_factor(1e8 * np.sin(np.linspace(0, 2 * np.pi, 65)), 180e6, 360e6), 3)
1.8
"""
from __future__ import annotations

import json

import numpy as np
import rainflow
import xarray as xr

__all__ = ["MEAN_STRESS_CORRECTION", "STRENGTHS", "periodic_cycles", "goodman_safety_factor",
           "fatigue_safety_factor", "link_strengths", "whole_periods", "thinned",
           "case_fatigue"]

#: The mean-stress correction applied (the ``mean_stress_correction`` attribute of the result).
MEAN_STRESS_CORRECTION = "goodman"


def periodic_cycles(history) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rainflow cycles of one period of a periodic history.

    The history is rotated to start (and end) at its largest value, so that the count of one
    period closes every cycle: the counts add up to whole cycles per period.

    Parameters
    ----------
    history : array_like, (step,)
        One period of a stress history, Pa (or any unit); the last sample may repeat the first.

    Returns
    -------
    amplitude, mean, count : numpy.ndarray
        Stress amplitude (half the range) and mean of each cycle, in the history's unit, and
        its count per period (1, or 0.5 for the two halves of the largest range, which
        together make one cycle).

    Examples
    --------
    >>> a, m, n = periodic_cycles([0.0, 3.0, 1.0, 2.0, -1.0])
    >>> [(float(x), float(y), float(z)) for x, y, z in zip(a, m, n)]
    [(0.5, 1.5, 1.0), (2.0, 1.0, 0.5), (2.0, 1.0, 0.5)]
    """
    values = np.asarray(history, float)
    start = int(np.argmax(values))
    closed = np.concatenate([values[start:], values[:start + 1]])
    cycles = np.array([(rng, mean, count) for rng, mean, count, _, _ in
                       rainflow.extract_cycles(closed)], float).reshape(-1, 3)
    return 0.5 * cycles[:, 0], cycles[:, 1], cycles[:, 2]


def goodman_safety_factor(amplitude, mean, endurance_limit: float,
                          ultimate_strength: float) -> np.ndarray:
    """Goodman fatigue safety factor of cycles for infinite life.

    n = 1 / (σ_a/S_e + σ_m/S_u) for a tensile mean σ_m ≥ 0 and n = S_e/σ_a for a compressive
    one (no credit taken for compression); infinite for a cycle without amplitude or mean.

    Parameters
    ----------
    amplitude, mean : array_like
        Stress amplitude σ_a (≥ 0) and mean σ_m of each cycle, Pa.
    endurance_limit : float
        Fully reversed endurance limit S_e, Pa.
    ultimate_strength : float
        Tensile strength S_u, Pa.

    Returns
    -------
    numpy.ndarray
        Safety factor of each cycle (dimensionless).

    Examples
    --------
    >>> float(goodman_safety_factor(50e6, 90e6, 180e6, 360e6))   # 1/(50/180 + 90/360)
    1.894736842105263
    >>> round(float(goodman_safety_factor(50e6, -90e6, 180e6, 360e6)), 6)
    3.6
    """
    amplitude, mean = np.asarray(amplitude, float), np.asarray(mean, float)
    load = amplitude / endurance_limit + np.maximum(mean, 0.0) / ultimate_strength
    with np.errstate(divide="ignore"):
        return np.where(load > 0.0, 1.0 / np.where(load > 0.0, load, 1.0), np.inf)


def fatigue_safety_factor(history, endurance_limit: float, ultimate_strength: float) -> float:
    """Goodman safety factor of the worst rainflow cycle of one period of a stress history.

    Parameters
    ----------
    history : array_like, (step,)
        One period of the stress at a point, Pa, signed.
    endurance_limit : float
        Fully reversed endurance limit S_e, Pa.
    ultimate_strength : float
        Tensile strength S_u, Pa.

    Returns
    -------
    float
        The smallest safety factor over the cycles (dimensionless); for a constant history
        the static S_u/σ (infinite for zero or compressive stress).
    """
    amplitude, mean, _ = periodic_cycles(history)
    if not len(amplitude):  # constant: no cycle, the static mean alone
        amplitude, mean = np.zeros(1), np.asarray(history, float)[:1]
    return float(goodman_safety_factor(amplitude, mean, endurance_limit,
                                       ultimate_strength).min())


#: Material strengths carried per case and link (:func:`link_strengths`), Pa.
STRENGTHS = ("yield_strength", "ultimate_strength", "endurance_limit")


def link_strengths(ds: xr.Dataset) -> xr.Dataset | None:
    """Material strengths of every case and link, from the dataset's variables of that name
    (a study opened by :func:`ced.study.browse.open_study`) or else from the scenes stored
    with a chunk (its ``scenes`` attribute).

    Parameters
    ----------
    ds : xarray.Dataset
        A chunk dataset (or a block of cases of an opened study).

    Returns
    -------
    xarray.Dataset or None
        :data:`STRENGTHS`, each (case, link), Pa, NaN where the material has none; None
        without either source.
    """
    if all(name in ds for name in STRENGTHS):
        return ds[list(STRENGTHS)]
    if "scenes" not in ds.attrs or "link" not in ds.dims:
        return None
    scenes = json.loads(ds.attrs["scenes"])
    if len(scenes) != ds.sizes["case"]:
        return None
    links = [str(n) for n in ds.link.values]
    meaning = {"yield_strength": "yield strength", "ultimate_strength": "tensile strength",
               "endurance_limit": "endurance limit"}
    return xr.Dataset({
        name: (("case", "link"), np.array(
            [[s["links"][n]["material"].get(name) or np.nan for n in links] for s in scenes],
            float), {"units": "Pa", "long_name": f"{meaning[name]} of the link material"})
        for name in STRENGTHS}, coords={"case": ds.case, "link": ds.link})


def whole_periods(ds: xr.Dataset) -> np.ndarray:
    """(case,) bool: the stored history spans a whole number of the rigid motion's periods
    (``motion_turns`` input turns of 2π/Ω s each, Ω the ``speed``), short of it by less than
    one stored interval (``outputs.every`` not dividing the steps); True where the dataset
    cannot tell (no ``motion_turns``, ``time`` or ``speed``: a dataset written before
    ``motion_turns`` existed, whose motions all repeated every turn).

    Parameters
    ----------
    ds : xarray.Dataset
        A chunk dataset.
    """
    if not all(name in ds for name in ("motion_turns", "time", "speed")):
        return np.ones(ds.sizes["case"], bool)
    time = ds.time.transpose("case", "step").values
    period = 2.0 * np.pi * ds.motion_turns.values / ds.speed.values
    span = time[:, -1] - time[:, 0]
    interval = time[:, 1] - time[:, 0] if time.shape[1] > 1 else np.zeros(len(span))
    whole = np.round(span / period) * period
    slack = 1e-9 * period  # round-off of the stored times
    return (whole > 0.0) & (span <= whole + slack) & (whole - span < interval + slack)


def thinned(ds: xr.Dataset) -> np.ndarray:
    """(case,) bool: the stored history is every ``outputs.every``-th step of the solve, more
    than one apart (from the ``scenes`` attribute; False where a dataset has none).

    Parameters
    ----------
    ds : xarray.Dataset
        A chunk dataset.
    """
    if "scenes" not in ds.attrs:
        return np.zeros(ds.sizes["case"], bool)
    scenes = json.loads(ds.attrs["scenes"])
    if len(scenes) != ds.sizes["case"]:
        return np.zeros(ds.sizes["case"], bool)
    return np.array([s.get("outputs", {}).get("every", 1) > 1 for s in scenes])


def _bound(peak: float, strength: float) -> float:
    """min(S_e, S_u)/σ_peak (``strength`` the smaller), inf without stress, NaN where the
    peak is unknown."""
    if not np.isfinite(peak):
        return np.nan
    return np.inf if peak == 0.0 else strength / peak


def case_fatigue(ds: xr.Dataset) -> xr.Dataset | None:
    """Fatigue safety factor of every case and link of a chunk dataset.

    The stress history at each link's critical station (the station of its peak absolute
    stress over time and both fibres) is taken as one period of the steady state (the
    stored cycle: ``time.revolutions`` revolutions from ``time.start``), both outer fibres are
    rainflow counted and the smaller Goodman factor (:func:`fatigue_safety_factor`) is kept.

    Where the stored history is not a whole number of the motion's periods (a motion that
    repeats only every two turns, ``motion_turns`` 2, stored over one: its other turn, on the
    other assembly branch, is not in it), no cycle count is possible; the factor is then the
    lower bound min(S_e, S_u)/σ_peak with σ_peak the link's peak stress over the whole period
    (``peak_stress``): every cycle between −σ_peak and σ_peak has a Goodman factor at least
    that (the worst, fully reversed ±σ_peak, has S_e/σ_peak).

    Where the stored history is every n-th step of the solve (``outputs.every`` > 1,
    :func:`thinned`), its cycles' extremes between stored steps are missed, and the count
    would be unconservative by that much (up to 1–4 % of the peak of an undamped transient at
    8 and 64 steps apart). The factor is then divided by ``peak_stress`` (over every step)
    over the link's largest stored stress: Goodman's factor of a history scaled by λ is
    1/λ of the history's, so the worst stored cycle is taken as if it reached the solver's
    peak — a first-order correction, not a bound.

    Parameters
    ----------
    ds : xarray.Dataset
        A chunk dataset with ``stress`` (case, step, link, station, fibre), Pa, and the
        ``scenes`` attribute (each link's material).

    Returns
    -------
    xarray.Dataset or None
        ``fatigue_safety_factor`` (case, link), dimensionless: NaN where the material has no
        endurance limit or tensile strength, or the case failed; infinite for a link without
        stress (rigid). ``fatigue_critical_station`` (case, link), the station analysed.
        None without ``stress``.
    """
    if "stress" not in ds or "fibre" not in ds.stress.dims:
        return None
    strengths = link_strengths(ds)
    stress = ds.stress.transpose("case", "link", "station", "step", "fibre").values
    ncase, nlink = stress.shape[:2]
    endurance, ultimate = ((strengths.endurance_limit.values, strengths.ultimate_strength.values)
                           if strengths is not None else (np.full((ncase, nlink), np.nan),) * 2)
    peak = np.abs(stress).max(axis=(3, 4))  # (case, link, station)
    critical = np.nan_to_num(peak, nan=-1.0).argmax(axis=2)
    factor = np.full((ncase, nlink), np.nan)
    whole = whole_periods(ds)
    # A thinned history misses the extremes between its steps; the solver's peak is over
    # every step. Its cycles are scaled so that the worst reaches that peak (Goodman's
    # factor is inversely proportional to a common scale of the stresses).
    scale = np.ones((ncase, nlink))
    if "peak_stress" in ds:
        written = np.nan_to_num(peak, nan=0.0).max(axis=2)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(written > 0.0,
                             ds.peak_stress.transpose("case", "link").values / written, 1.0)
        scale = np.where(thinned(ds)[:, None] & np.isfinite(ratio), np.maximum(ratio, 1.0),
                         1.0)
    for c in range(ncase):
        for k in range(nlink):
            history = stress[c, k, critical[c, k]]
            if not (np.isfinite(endurance[c, k]) and np.isfinite(ultimate[c, k])
                    and np.isfinite(history).all()):
                continue
            if not whole[c]:
                link_peak = ds.peak_stress.values[c, k] if "peak_stress" in ds else np.nan
                factor[c, k] = _bound(float(link_peak), min(endurance[c, k], ultimate[c, k]))
                continue
            factor[c, k] = min(fatigue_safety_factor(history[:, f], endurance[c, k],
                                                     ultimate[c, k])
                               for f in range(2)) / scale[c, k]
    station = ds.station.values[critical]
    coords = {"case": ds.case, "link": ds.link}
    return xr.Dataset({
        "fatigue_safety_factor": (("case", "link"), factor, {
            "units": "1", "long_name": "fatigue safety factor for infinite life (Goodman) of "
            "the worst rainflow cycle at the link's critical station",
            "mean_stress_correction": MEAN_STRESS_CORRECTION,
            "comment": "n = 1/(amplitude/endurance_limit + max(mean, 0)/ultimate_strength), "
                       "minimum over the rainflow cycles of one period at both outer fibres "
                       "(min(endurance_limit, ultimate_strength)/peak_stress, a lower bound, "
                       "where the stored history is not a whole number of the motion's "
                       "periods; where it is every outputs.every-th step only, divided by "
                       "peak_stress over the largest stored stress of the link, so that "
                       "the worst cycle reaches the peak of every step); "
                       "NaN where the material has no endurance limit or tensile strength; "
                       "inf for a link without stress"}),
        "fatigue_critical_station": (("case", "link"), station, {
            "units": "1", "long_name": "station of the fatigue check (peak absolute stress), "
                                       "normalized position along the link"}),
    }, coords=coords)
