"""Progress of long runs: solve many scenes in parts and say how far along the run is.

:func:`simulate_in_parts` is :func:`ced.simulate` for a long list of scenes: it solves them in
parts of at least :data:`MIN_PART` cases (each part still vectorized across its cases) and
joins the parts into the one dataset a single call would give. Between parts it reports:

- on a terminal, a progress bar with the estimated time left (``tqdm``; nothing at all when
  the stream is not a terminal, so logs and pipes stay clean);
- in a log (``log=``, the study's chunk jobs), one line per part: cases done, time spent,
  estimated time left.

The hook sits here, at the loop over parts, and never inside the solver. Scenes that a single
call would put in one dataset only with some variables missing from some cases (a mix of rigid
and elastic, ``auto`` choices, …) are solved in one part: the result is the same either way.
"""
from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Callable
from typing import IO

import numpy as np
import xarray as xr

from ..problem.scene import EFFECTS, load_scene

__all__ = ["simulate_in_parts", "split", "MIN_PART", "MAX_PARTS", "eta_text"]

#: Fewest cases per part: smaller parts would lose the speed of vectorizing across cases.
MIN_PART = 32
#: Most parts of one run: enough for a smooth estimate of the time left.
MAX_PARTS = 10


def _shape(scene: dict) -> tuple:
    """What decides which variables a case's dataset holds, and whether cases can share one:
    scenes that differ here are solved in one part (as a single call would be)."""
    disc, time_ = scene["discretization"], scene["time"]
    if disc == "auto" or scene["effects"] == "auto":
        return ("auto", object())  # the choices are made per run: never split
    return (scene["mechanism"]["type"], disc["formulation"], scene["modal"] is None,
            scene["outputs"]["error_estimate"], time_["start"],
            "elastic_inertia" in scene["effects"],
            round(time_["revolutions"] * time_["steps_per_revolution"])
            // scene["outputs"]["every"])


def split(scenes: list[dict]) -> list[slice]:
    """Parts of a list of normalized scenes: at least :data:`MIN_PART` cases each, at most
    :data:`MAX_PARTS` parts; one part when the scenes cannot be split safely.

    Parameters
    ----------
    scenes : list of dict
        Normalized scenes.

    Returns
    -------
    list of slice
        Consecutive parts covering the list.

    Examples
    --------
    >>> scene = load_scene({"mechanism": {"type": "single_link", "length": 0.5}})
    >>> split([scene] * 100)
    [slice(0, 34, None), slice(34, 68, None), slice(68, 100, None)]
    >>> split([scene] * 10)
    [slice(0, 10, None)]
    """
    n = len(scenes)
    if n < 2 * MIN_PART or len({_shape(s) for s in scenes}) > 1:
        return [slice(0, n)]
    parts = min(MAX_PARTS, n // MIN_PART)
    size = math.ceil(n / parts)
    return [slice(i, min(i + size, n)) for i in range(0, n, size)]


def _join(parts: list[xr.Dataset]) -> xr.Dataset:
    """One dataset from the datasets of consecutive parts, as one call would have made it."""
    if len(parts) == 1:
        return parts[0]
    ds = xr.concat(parts, dim="case", data_vars="minimal", coords="minimal",
                   compat="override", join="exact", combine_attrs="override")
    ds = ds.assign_coords(case=("case", np.arange(ds.sizes["case"]), parts[0].case.attrs))
    scenes = [s for part in parts for s in json.loads(part.attrs["scenes"])]
    effects = {e for part in parts for e in part.attrs["effects"].split()}
    ds.attrs["scenes"] = json.dumps(scenes, sort_keys=True, separators=(",", ":"))
    ds.attrs["effects"] = " ".join(e for e in EFFECTS if e in effects)
    return ds


def eta_text(done: int, total: int, elapsed: float) -> str:
    """``64/250 cases in 12.3 s, about 36 s left`` (linear in the cases done).

    Parameters
    ----------
    done, total : int
        Cases solved so far, and in all.
    elapsed : float
        Time since the start, s.

    Returns
    -------
    str
        One line for a log.

    Examples
    --------
    >>> eta_text(50, 200, 10.0)
    '50/200 cases in 10 s, about 30 s left'
    >>> eta_text(200, 200, 12.34)
    '200/200 cases in 12.3 s'
    """
    text = f"{done}/{total} cases in {elapsed:.3g} s"
    if 0 < done < total:
        text += f", about {elapsed / done * (total - done):.2g} s left"
    return text


def simulate_in_parts(scenes, *, desc: str = "ced", stream: IO[str] | None = None,
                      log: Callable[[str], None] | None = None) -> xr.Dataset:
    """Simulate scenes in parts, reporting progress; the dataset of :func:`ced.simulate`.

    Parameters
    ----------
    scenes : list of paths, mappings or normalized scenes
        As for :func:`ced.simulate`.
    desc : str
        Label of the progress bar and of the log lines (``crank_rocker/3``).
    stream : text stream, optional
        Where the progress bar goes (default ``sys.stderr``); the bar is shown only when it is
        a terminal.
    log : callable, optional
        Called with one line of text after each part (for logs: no bar, no control
        characters).

    Returns
    -------
    xarray.Dataset
        One entry per scene along ``case``, in the order given.
    """
    from tqdm import tqdm

    from ..simulation import simulate as _simulate  # looked up at call time (tests patch it)

    normalized = [load_scene(s) for s in scenes]
    parts = split(normalized)
    stream = sys.stderr if stream is None else stream
    total = len(normalized)
    start = time.perf_counter()
    results = []
    with tqdm(total=total, desc=desc, unit="case", file=stream, leave=False,
              disable=None if len(parts) > 1 else True) as bar:
        for part in parts:
            results.append(_simulate.simulate(normalized[part]))
            bar.update(part.stop - part.start)
            if log is not None and len(parts) > 1:
                log(f"{desc}: {eta_text(part.stop, total, time.perf_counter() - start)}")
    return _join(results)
