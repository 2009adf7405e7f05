"""``error_estimate`` shared along a speed sweep from a start transient.

From a start transient (``undeformed``, ``quasi_static``) a case's estimate needs two
companion solutions, one of them at twice its steps (:mod:`ced.auto.error_estimate`): about
three times the cost of the case itself. A sweep's cases that differ only in their drive
speed share them as ``discretization: auto`` shares its pilots (:mod:`ced.auto.discretization`,
stage 5): every :data:`STRIDE`-th case in the order of speed and the last solve their
companions ("climbers"), and a case between two climbers is estimated at
:data:`MARGIN` × the larger of their estimates (:func:`ced.auto.discretization.
interpolated_error`). The rule is checked where it can fail, and where it is not trusted the
middle case of the gap solves its own companions (bisection, until every gap is trusted or has
no case left in it):

* at every inner climber, leave-one-out: its own estimate above the rule's prediction from its
  climbing neighbours (the estimate varies faster in speed than the climbers resolve);
* where a gap spans more than :data:`MAX_GAP` of its lower climber's speed (what was measured);
* next to a climber with no estimate (its companions failed).

A case flagged as one whose error its neighbours need not bound (:data:`OWN_FLAGS`: near a
toggle or change point, parametrically unstable, buckled, failed; not ``resonant``, a start
transient's resonance being broad in speed) solves its own.
So do sweeps of fewer than :data:`MIN_CASES` cases, periodic starts (a resonance of the
steady state is narrower than the climbers' spacing and need not be flagged: on the reference
four-bar's undamped 40–160 rad/s series sweep, two unflagged cases between climbers erred 1.4
and 3.2 % where their neighbours' estimates said 0.05–0.1 %), and the cases
``discretization: auto`` resolved (their ladders are their estimate).

Measured (2026-11-30, ``benchmarks/estimate_sharing.py``: every case's own estimate, the
shared one and the true error against a converged value, six sweeps of 100 speeds from rest,
2 or 3 settings each, the estimates' safety factor 2.5, every 16th case climbing). On the three
the margin was chosen on — the benchmark's reference four-bar over 90–110 rad/s (8 cases solve
companions) and over 40–160, Sung and Thompson's crank-rocker over 15–45 — the true error is
within the shared estimate at 98–100 % of the speeds (own: 95–100 %). On the three that came
after: the slider-crank, 100 % (own 96–98 %); the four-bar with every link flexible, whose
estimates vary by 20 times between neighbouring speeds, 98–99 % (own 98–99 %), the worst case
between climbers 1.8 times its shared estimate; the four-bar from ``quasi_static``, 100 % (own
94–100 %). The shared estimates are 1.5–4 times the case's own at the median.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..problem.status import STATUS_FLAGS
from .discretization import (sweep_key, bracket, interpolated_error, representatives, sweeps,
                             unverified)

__all__ = ["sweep_estimates", "shared_sweeps", "stride", "STRIDE", "MARGIN", "MIN_CASES",
           "MAX_GAP", "OWN_FLAGS"]

#: Every STRIDE-th case of a sweep solves its companions (closer in a small sweep:
#: :func:`stride`). Chosen 2026-11-30 by replaying the rule on the own estimates and true errors
#: of 24 sweep × setting pairs (the first five sweeps of the module docstring at 2 to 10
#: settings, their estimates solved at the safety factor 4 and rescaled to 2.5, and two sweeps
#: solved for the choice: the reference four-bar from ``quasi_static`` over 60–140 rad/s, the
#: sixth below, and with an aluminium 4 × 12 mm coupler over 40–100 rad/s). At 8, 12 and
#: 16 the shared estimate bounded the true error at 96–100 %, 97–100 % and 98–100 % of each
#: pair's speeds; at 20, 90–100 %; 16 solves companions for 11–12 cases of 100 on average
#: against 18–22 at 8 (``discretization: auto``'s stride, used until then).
STRIDE = 16

#: A case between two climbers is estimated at MARGIN × the larger of their estimates. Less
#: than ``discretization: auto``'s :data:`~ced.auto.discretization.INTERPOLATION_MARGIN` (3),
#: which covers a prediction with no safety factor of its own: an estimate carries
#: :data:`ced.auto.error_estimate.SAFETY` (2.5) already. Chosen on the first three sweeps of
#: the module docstring (13 sweep × setting pairs, the safety factor then 4): at 1.5 every true
#: error of a case between climbers was at most 0.73 of its shared estimate, the shared
#: estimates 1.4–2.2 times the case's own at the median; at 3, 3.1–4.6 times; at 1, bisection
#: had a quarter to three quarters of the cases solve companions.
MARGIN = 1.5
#: Fewest cases of a sweep that share: three climbers at every 8th case, so that leave-one-out
#: can check one.
MIN_CASES = 17
#: Widest gap between two climbers, relative to the lower one's speed: the measured sweeps'
#: gaps reached 24 % at every 8th case (40–160 rad/s, 100 speeds); wider gaps at
#: :data:`STRIDE` are bisected.
MAX_GAP = 0.25
#: Status flags of a case that solves its own companions: its error need not be like its
#: neighbours' in speed. Not ``resonant``: over two revolutions from rest a resonance builds
#: up over a band of speeds wider than the climbers' spacing, and the flag marks 40–85 % of the
#: measured sweeps' cases (44 of the benchmark's 100), which would all pay their companions.
#: With every 8th case climbing, three of the four shared estimates below their true error
#: (the every-link-flexible four-bar, module docstring) were such cases. A scene that wants
#: its own sets ``outputs.error_estimate_sharing: false``.
OWN_FLAGS = (STATUS_FLAGS["near_singular"] | STATUS_FLAGS["parametrically_unstable"]
             | STATUS_FLAGS["buckled"] | STATUS_FLAGS["failed"]
             | STATUS_FLAGS["not_assemblable"])


def stride(n: int) -> int:
    """Every how many cases of a sweep of ``n`` cases solve their companions.

    Parameters
    ----------
    n : int
        Cases of the sweep, at least :data:`MIN_CASES`.

    Returns
    -------
    int
        :data:`STRIDE`, or less so that at least three cases climb (leave-one-out needs one
        between two others).
    """
    return min(STRIDE, (n - 1) // 2)


def shared_sweeps(scenes: list[dict], status: np.ndarray, known) -> list[np.ndarray]:
    """The sweeps whose cases may share their companions.

    Parameters
    ----------
    scenes : list of dict
        Normalized scenes of the run.
    status : (case,) int array
        Each case's status flags.
    known : collection of int
        Cases that do not share: those with their estimate already, and those whose
        companions must be their own (``discretization: auto``'s).

    Returns
    -------
    list of numpy.ndarray
        Per sweep its cases (indices into ``scenes``) by increasing speed; only sweeps of at
        least :data:`MIN_CASES` cases of distinct speeds that ask for an estimate and let it
        be shared (``outputs.error_estimate_sharing``), start from
        a transient, are not resolved by ``discretization: auto`` and carry none of
        :data:`OWN_FLAGS`.
    """
    eligible = [i for i, s in enumerate(scenes)
                if s["outputs"]["error_estimate"] and s["outputs"]["error_estimate_sharing"]
                and i not in known
                and isinstance(s["discretization"], dict)
                and s["discretization"]["formulation"] != "rigid"
                and s["time"]["start"] != "periodic" and not int(status[i]) & OWN_FLAGS]
    if len(eligible) < MIN_CASES:
        return []
    speeds = np.array([scenes[i]["drive"]["speed"] for i in eligible], float)
    groups = sweeps([sweep_key(scenes[i]) for i in eligible], speeds)
    # Repeated speeds (a batch of identical cases) are no sweep: a case between two equal
    # climbers would be estimated at MARGIN times their estimate.
    return [np.asarray(eligible)[g] for g in groups
            if len(g) >= MIN_CASES and len(np.unique(speeds[g])) == len(g)]


def _untrusted(speeds: np.ndarray, climbed: list[int], errors: np.ndarray) -> set[int]:
    """Positions of a sweep to climb next: leave-one-out failures and gaps too wide in speed
    or next to a climber without an estimate, each gap's middle."""
    finite = np.isfinite(errors)
    out = set(unverified(climbed, np.where(finite, errors, 0.0), np.zeros(len(climbed)),
                         np.zeros(len(speeds)), np.inf, MARGIN).tolist())
    for k, (low, high) in enumerate(zip(climbed[:-1], climbed[1:])):
        wide = speeds[high] - speeds[low] > MAX_GAP * abs(speeds[low])
        if high - low >= 2 and (wide or not (finite[k] and finite[k + 1])):
            out.add((low + high) // 2)
    return out


def sweep_estimates(scenes: list[dict], status: np.ndarray, known: dict[int, float],
                    estimate: Callable[[dict[int, float]], np.ndarray], alone=()
                    ) -> tuple[np.ndarray, np.ndarray]:
    """``error_estimate`` of every case, companions shared along speed sweeps.

    Parameters
    ----------
    scenes : list of dict
        Normalized scenes of the run.
    status : (case,) int array
        Each case's status flags.
    known : dict
        Case → estimate of cases that have one already (``discretization: auto``).
    estimate : callable
        known (case → value) → (case,) estimates, solving the companions of every case that
        asks for one and is not in ``known``
        (:func:`ced.auto.error_estimate.error_estimates`).
    alone : collection of int
        Cases that solve their own companions whatever their sweep (those of
        ``discretization: auto`` whose prediction is a floor under them: outside what was
        measured).

    Returns
    -------
    estimate : (case,) array
        As :func:`ced.auto.error_estimate.error_estimates` returns it.
    interpolated : (case,) bool array
        Cases estimated from their neighbours in speed, with no companion of their own.
    """
    groups = shared_sweeps(scenes, status, set(known) | set(alone))
    speeds = [np.array([scenes[i]["drive"]["speed"] for i in g], float) for g in groups]
    climbed = [set(representatives(len(g), stride(len(g))).tolist()) for g in groups]
    solved = dict(known)
    while True:
        waiting = {int(g[p]): np.nan for g, c in zip(groups, climbed)
                   for p in range(len(g)) if p not in c}
        out = estimate({**solved, **waiting})
        solved.update({i: float(out[i]) for i in range(len(scenes)) if i not in waiting})
        more = [_untrusted(v, sorted(c), out[g[sorted(c)]]) - c
                for g, v, c in zip(groups, speeds, climbed)]
        if not any(more):
            break
        for c, m in zip(climbed, more):
            c.update(m)
    interpolated = np.zeros(len(scenes), bool)
    for g, c in zip(groups, climbed):
        at = sorted(c)
        below, above = bracket(at, len(g))
        for p in range(len(g)):
            if p not in c:
                out[g[p]] = interpolated_error(out[g[[below[p], above[p]]]], margin=MARGIN)
                interpolated[g[p]] = True
    return out, interpolated
