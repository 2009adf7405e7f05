"""Status flags of a case: what ced reports about the credibility of each result.

A case's ``status`` is a bit field (CF ``flag_masks``); ``ok`` is the absence of every bit.
The rigid analysis sets ``near_singular``; the elastic response sets ``large_deflection``,
``resonant``, ``parametrically_unstable``, ``buckled`` and ``thick_link``; ``discretization: auto`` sets
``tolerance_unmet``; a case that raises is ``failed``.

Examples
--------
>>> status_code(["resonant", "large_deflection"])
5
>>> status_names(5), status_names(0)
(['large_deflection', 'resonant'], ['ok'])
"""
from __future__ import annotations

from collections.abc import Iterable

__all__ = ["STATUS_FLAGS", "STATUS_MEANINGS", "STATUS_ADVICE", "STATUS_DTYPE", "STATUS_FILL",
           "status_code", "status_names"]

#: Bit of each status flag; "ok" is the absence of every other bit (CF flag_masks+flag_values).
STATUS_FLAGS = {
    "large_deflection": 1,
    "near_singular": 2,
    "resonant": 4,
    "parametrically_unstable": 8,
    "failed": 16,
    "not_assemblable": 32,
    # The frozen structure K_eff has a negative eigenvalue at some phase (a link compressed
    # beyond its Euler load, or centrifugal softening of a near-mechanism mode): reported as
    # a negative natural_frequency, −√|λ|/2π (ced.fem.eigenproblem, ced.response.frequencies).
    "buckled": 64,
    # discretization: auto could not reach the scene's tolerance within its ladders' limits
    # (ced.auto.discretization): the error estimate says by how much.
    "tolerance_unmet": 128,
    # A flexible link modelled as a beam (euler_bernoulli, timoshenko, seed_lame) is shorter
    # than THICK_LINK_RATIO times its in-plane section height: beam theory does not hold
    # there (docs/fidelity.md: below 3, plane_stress), whatever the mesh.
    "thick_link": 256,
}
#: What each flag means, in one line (for the dataset reference and ``ced run``'s summary).
STATUS_MEANINGS = {
    "large_deflection": "a link's peak elastic deflection exceeds 1 % of its length, or the "
                        "iteration of elastic_axial_force did not settle: the linear "
                        "(small-deflection) model is stretched",
    "near_singular": "the linkage passes near a toggle or change point (|sin| of the "
                     "transmission angle below 0.1): stiffness and results are sensitive there",
    "resonant": "a crank harmonic falls in a mode's frequency band over the cycle, a "
                "Floquet multiplier near 1 dominates the periodic state, or the spectral "
                "periodic state could not be resolved",
    "parametrically_unstable": "the periodic state's largest Floquet multiplier exceeds 1: "
                               "vibrations grow from cycle to cycle",
    "failed": "the case could not be solved or its results are not finite; `message` says why",
    "not_assemblable": "the geometry cannot be assembled (study grid maps: no case there)",
    "buckled": "the frozen structure has a negative eigenvalue at some phase (reported as a "
               "negative natural_frequency)",
    "tolerance_unmet": "discretization: auto could not reach the scene's tolerance; "
                       "error_estimate says how far",
    "thick_link": "a flexible beam link is shorter than 3 × its section height: beam theory "
                  "does not hold",
}
#: What to do about each flag, in one line (the user guide's table).
STATUS_ADVICE = {
    "large_deflection": "stiffen the link (larger section) or lower the speed; the results "
                        "are indicative only",
    "near_singular": "avoid running at that geometry; check transmission angles, or read "
                     "results near the toggle with care",
    "resonant": "move the speed away from the resonance (Campbell diagram) or add damping",
    "parametrically_unstable": "change speed or stiffness; add damping; the steady state "
                               "does not exist",
    "failed": "read `message`; CED_TRACEBACK=1 with `ced run` shows where",
    "not_assemblable": "nothing: the grid point is not a linkage",
    "buckled": "a link is compressed beyond its Euler load: stiffen it or lower the speed "
               "(with near_singular, at a change point or toggle: the linkage itself loses "
               "its stiffness there, as near_singular says)",
    "tolerance_unmet": "loosen `tolerance` or set `discretization` by hand (finer elements "
                       "and steps)",
    "thick_link": "use `discretization.formulation: plane_stress` for that link geometry",
}
#: Integer type of ``status`` (the flags need 9 bits).
STATUS_DTYPE = "uint16"
#: ``status`` of a grid point without a case in the family maps (CF _FillValue).
STATUS_FILL = 65535


def status_code(flags: Iterable[str]) -> int:
    """Combine flag names into a status code (0 is ok).

    Parameters
    ----------
    flags : iterable of str
        Flag names from :data:`STATUS_FLAGS`.

    Returns
    -------
    int
        The bit field (dimensionless).
    """
    code = 0
    for name in flags:
        code |= STATUS_FLAGS[name]
    return code


def status_names(code: int) -> list[str]:
    """Flag names set in a status code; ``["ok"]`` for 0.

    Parameters
    ----------
    code : int
        A case's ``status`` value.

    Returns
    -------
    list of str
        The names of the bits set, in the order of :data:`STATUS_FLAGS`.
    """
    names = [n for n, bit in STATUS_FLAGS.items() if code & bit]
    return names or ["ok"]
