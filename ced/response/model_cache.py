"""Models reused between the small batches of one call that share their links.

:func:`ced.response.model.build_model` costs a few milliseconds a call whatever the batch's
size (element matrices, component modes, recovery operators: many small numpy calls). The
``discretization: auto`` pilots and the error estimate's companions solve many small batches
of cases already seen, at other steps per revolution: the pilot ladders of the benchmark sweep
built 50 models in 31 calls, a third of the pilots' time, each of the same links as the
first (a ladder changes the steps, never the links; its climbers are a subset of the batch
before). :func:`model_for` keeps the last few models of small batches and serves a batch
whose every case has the links and start configuration of some case of a kept model,
whatever their speed, time grid, outputs other than the stations, or names, none of which a
model depends on (:func:`model_key`): its model is the kept one's at those cases (every model
array but the stations has a leading case axis). That is a fresh build's bit for bit
(``tests/response/test_model_cache.py``) except where a Craig–Bampton basis depends on the
batch: a static load vector that is dependent in one case is dropped for all of the batch's
cases (:mod:`ced.fem.component_modes`), so a subset served keeps its batch's basis where a
build of the subset alone could keep the vector (a default-study chunk: 3 of 500
companions, their error estimates moved by up to 7e-4). A sub-batch of the spectral solver's
climbing cases (:mod:`ced.response.collocation`) needs exactly that: its reduced coordinates
must be the whole batch's. Likewise the modal damping's phase grid is halved where any case of
the batch needs it (:mod:`ced.response.modal_damping`): a subset served keeps the finer grid
of its batch, the same table at the subset's own phases (to round-off: a midpoint is
evaluated among other phases) and at least as close to the exact damping between them.

A kept model's cases also keep the system terms evaluated for them (:func:`kept_terms`): a
ladder's rungs are evaluated at the same phases of the period, so each phase is evaluated once
per case and speed (the benchmark sweep's pilots evaluated 17,184 case-phases, not 24,960,
with every result the same bit for bit). Where four or more speeds of a case's family are
kept at the phases wanted, its terms at another speed are not evaluated but interpolated:
they are exactly quadratic in the speed at a fixed phase, and a fourth speed checks that
they are (:func:`_from_family`). So ``discretization: auto``'s first climbers, solved
together, give the terms of a sweep's later climbers and of its final batch at a setting they
measured, to round-off (1e-12 of each term's largest entry; the damped 100-speed sweep's
results within 3e-9 of its stresses' largest).

:func:`ced.simulation.simulate.simulate` starts each call with none kept (:func:`clear`), so
that a call's time and results do not depend on what the process solved before.

A kept model's arrays are shared with the batches it serves: nothing writes into a model
(the whole test suite ran with them read-only). They are left writable because the compiled
kernels they reach would otherwise hold a second, read-only signature of each.
"""
from __future__ import annotations

import dataclasses
import itertools
import marshal
from collections import OrderedDict
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from .batch import Batch
from .model import Model, build_model

__all__ = ["model_for", "model_key", "at_cases", "kept_terms", "clear", "MAX_CASES",
           "MAX_MODELS", "MAX_TERM_BYTES", "MAX_TERM_ENTRY_BYTES"]

#: Batches of more cases are built afresh: their build is a small part of their solve, and
#: their models are large.
MAX_CASES = 256
#: Models kept (the least recently used is dropped first).
MAX_MODELS = 8
#: Scene keys a model depends on (:func:`ced.response.model.build_model` reads the
#: mechanism, links, point masses, discretization, effects, damping and output stations, and
#: modal damping the configurations over the period from t = 0, from the drive's initial
#: angle and amplitude;
#: gravity is kept too: a key that says too much only costs a rebuild). Not the speed: the
#: configuration, not its rates, enters a model (checked bit for bit across speeds in
#: ``tests/response/test_model_cache.py``).
_MODEL_KEYS = ("mechanism", "links", "point_masses", "discretization", "effects", "damping",
               "gravity")

#: Fewest speeds of a case's family, kept at the phases wanted, from which its terms at
#: another speed are interpolated (:func:`_from_family`): three fix the quadratic, the fourth
#: checks it.
FAMILY_SPEEDS = 4
#: Largest misfit of that quadratic at the checking speed, relative to each term's largest
#: entry (round-off is ~1e-15; a term not quadratic in the speed is evaluated instead).
FAMILY_TOLERANCE = 1e-9
#: Largest sum of the interpolation's |weights| (its round-off gain): a speed far outside the
#: kept ones is evaluated.
FAMILY_GAIN = 100.0
#: Bytes of system terms kept at most (:func:`kept_terms`), over every kept model, and for one
#: evaluation: a ladder's are a few MB each (64 MB in all on the benchmark sweep); a part of
#: a study's chunk, up to 256 cases at 64 phases, is larger and not solved again.
MAX_TERM_BYTES, MAX_TERM_ENTRY_BYTES = 128e6, 16e6

#: Kept models by a serial number: (model, {model key: a case of it}).
_MODELS: OrderedDict[int, tuple[Model, dict]] = OrderedDict()
_SERIAL = itertools.count()
#: Terms of the kept models by serial, newest last (:class:`_KeptTerms`).
_TERMS: dict[int, list] = {}
_TERM_BYTES = [0]


def model_key(scene: dict) -> bytes:
    """What a normalized scene's model depends on, as bytes: equal keys, equal models.

    :mod:`marshal`'s format 2 of the parts (no back-references, floats as their eight
    bytes): equal bytes are equal structures of equal types and float bits. It says more
    than their value where two scenes hold the same value differently (another key order,
    1 against 1.0, −0.0 against 0.0): such a scene is built, not served, which costs a build
    only (:func:`ced.problem.scene.load_scene` writes every normalized scene in one key
    order). A sixth of the JSON's time (:func:`ced.problem.scene.dump_scene`, which writes
    every float as text: 57 against 10 µs a Watt II scene of
    ``benchmarks/six_bar_cost.py``, 36 against 7 µs a four-bar's; every scene of a batch
    of up to :data:`MAX_CASES` is keyed).

    Parameters
    ----------
    scene : dict
        A normalized scene (:func:`ced.problem.scene.load_scene`).
    """
    drive = {k: v for k, v in scene["drive"].items() if k != "speed"}
    return marshal.dumps([[scene.get(k) for k in _MODEL_KEYS], drive,
                          scene["outputs"]["stations"]], 2)


def _cases(value, cases: np.ndarray, size: int):
    """``value`` (a model field) at ``cases`` of its leading case axis of ``size``."""
    if isinstance(value, np.ndarray):
        if value.ndim == 0 or value.shape[0] != size:
            raise ValueError(f"a model array of shape {value.shape} has no case axis")
        return value[cases]
    if isinstance(value, dict):
        return {k: _cases(v, cases, size) for k, v in value.items()}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.replace(value, **{f.name: _cases(getattr(value, f.name), cases, size)
                                             for f in dataclasses.fields(value)})
    return value  # None, numbers, strings, sets: no case axis


def at_cases(model: Model, batch: Batch, cases: np.ndarray) -> Model:
    """``model`` at ``cases`` of its batch, as the model of ``batch``.

    Parameters
    ----------
    model : Model
        A model of some batch (kept, with its ``origin``, or built for its batch alone).
    batch : Batch
        The batch the cases make up.
    cases : numpy.ndarray
        The cases of ``model``'s batch, one per case of ``batch``, int.
    """
    if len(cases) == model.batch.size and np.array_equal(cases, np.arange(len(cases))):
        return dataclasses.replace(model, batch=batch)
    size = model.batch.size
    fields = {f.name: _cases(getattr(model, f.name), cases, size)
              for f in dataclasses.fields(model)
              if f.name not in ("batch", "layout", "stations", "effects", "origin")}
    origin = None if model.origin is None else (model.origin[0], model.origin[1][cases])
    return dataclasses.replace(model, batch=batch, origin=origin, **fields)


def model_for(batch: Batch) -> Model:
    """The model of ``batch``: a kept model's at the cases that have the same links
    (:func:`model_key`), where one holds every case of ``batch``; else
    :func:`ced.response.model.build_model`'s, kept when the batch is small
    (:data:`MAX_CASES`).

    Parameters
    ----------
    batch : Batch
        Structurally identical cases.

    Returns
    -------
    Model
        As :func:`ced.response.model.build_model` builds it, with ``batch`` as its batch.
    """
    if batch.size > MAX_CASES:
        return build_model(batch)
    keys = [model_key(scene) for scene in batch.scenes]
    for kept in reversed(_MODELS):
        model, where = _MODELS[kept]
        if all(k in where for k in keys):
            _MODELS.move_to_end(kept)
            return at_cases(model, batch, np.array([where[k] for k in keys]))
    serial = next(_SERIAL)
    where: dict = {}
    for i, k in enumerate(keys):
        where.setdefault(k, i)
    # A case is known by the first case of its model key: the model is the same at both.
    model = dataclasses.replace(build_model(batch),
                                origin=(serial, np.array([where[k] for k in keys])))
    _MODELS[serial] = (model, where)
    _TERMS[serial] = []
    while len(_MODELS) > MAX_MODELS:
        dropped, _ = _MODELS.popitem(last=False)
        _TERM_BYTES[0] -= sum(_nbytes(entry) for entry in _TERMS.pop(dropped))
    return model


class _KeptTerms(NamedTuple):
    """Terms of some cases of a kept model at some phases of their period."""

    cases: dict[tuple[int, float], int]  # (case of the kept model, speed) -> row
    per_revolution: int  # steps per revolution of the batch they were evaluated for
    fractions: np.ndarray  # (fraction,) of the period, sorted
    times: np.ndarray  # (row, fraction) s
    values: dict[str, np.ndarray]  # name -> (row, fraction, ...)
    #: (rows of three nodes and a check) -> whether the terms are quadratic in the speed
    #: there (:func:`_from_family`), filled as asked
    quadratic: dict[tuple, bool]
    #: case of the kept model -> its kept (speed, row)s, by speed: the speed families
    families: dict[int, list[tuple[float, int]]]


def kept_terms(model: Model, h: np.ndarray, phases: np.ndarray,
               evaluate: Callable[[np.ndarray], dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """The system terms of ``model``'s cases at ``phases``: those evaluated before in this
    call where they were, the others by ``evaluate`` (and kept).

    A discretization ladder solves its cases at 32, 64, 128, … steps per revolution. The
    terms of a rung are evaluated at its steps (up to 128) or at 64 phases of the period
    (:mod:`ced.response.period_terms`): all of them phases of the 128-step grid, at the same
    times to the bit whatever the rung (the steps are powers of two apart), so a ladder need
    evaluate each phase once. Kept are the terms of models from :func:`model_for`
    (``model.origin``), whose cases are known by their kept model's case and their speed
    (the cases of one model key differ at most in speed, :func:`model_key`), at most
    :data:`MAX_TERM_BYTES` of them (an evaluation larger than :data:`MAX_TERM_ENTRY_BYTES`
    is not kept); reused are terms at the very same times only, of step grids a power of two
    apart (:func:`_same_phases`).

    Parameters
    ----------
    model, h, phases
        As :func:`ced.response.period_terms.evaluate_terms`'s: the batch's model, the step
        per case (s) and where, in steps.
    evaluate : callable
        ``evaluate(columns)`` → the terms at ``phases[columns]`` of every case, each
        (case, len(columns), …).

    Returns
    -------
    dict of str to numpy.ndarray
        ``evaluate``'s terms at every phase, bit for bit; or, where four speeds of each case's
        family are kept at these phases, their quadratic in the speed (:func:`_from_family`,
        to round-off, and not kept).
    """
    steps = {s["time"]["steps_per_revolution"] for s in model.batch.scenes}
    entries = _TERMS.get(model.origin[0]) if model.origin is not None else None
    if entries is None or len(steps) != 1:
        return evaluate(np.arange(len(phases)))
    per_revolution = steps.pop()
    fractions = phases / per_revolution
    times = h[:, None] * phases[None, :]
    cases = [(int(row), float(scene["drive"]["speed"]))
             for row, scene in zip(model.origin[1], model.batch.scenes)]
    best, have = None, np.zeros(len(phases), bool)
    for entry in reversed(entries):
        rows = [entry.cases.get(c) for c in cases]
        if None in rows or not _same_phases(entry.per_revolution, per_revolution):
            continue
        at = np.minimum(np.searchsorted(entry.fractions, fractions), len(entry.fractions) - 1)
        found = (entry.fractions[at] == fractions) & (entry.times[rows][:, at] == times).all(0)
        if found.sum() > have.sum():
            best, have, best_rows, best_at = entry, found, rows, at
            if found.all():
                break
    if not have.all():
        # Not kept: every interpolation is then from evaluated terms, its nodes the same
        # whichever part of a batch asks (:func:`_from_family`).
        family = _from_family(entries, cases, per_revolution, fractions)
        if family is not None:
            return family
    missing = np.flatnonzero(~have)
    if len(missing):
        new = evaluate(missing)
    if best is None:
        out = new
    else:
        known = np.flatnonzero(have)
        ix = (np.array(best_rows)[:, None], best_at[known][None, :])
        out = {}
        for name, x in best.values.items():
            out[name] = np.empty((len(cases), len(phases)) + x.shape[2:])
            out[name][:, known] = x[ix]
            if len(missing):
                out[name][:, missing] = new[name]
    if len(missing):
        _keep(model.origin[0], cases, per_revolution, fractions, times, out)
    return out


def _from_family(entries: list, cases: list, per_revolution: int,
                 fractions: np.ndarray) -> dict[str, np.ndarray] | None:
    """The terms of ``cases`` at ``fractions`` of the period from one kept entry holding
    every fraction and, for each case, its own speed or :data:`FAMILY_SPEEDS` other speeds of
    its family; None where no entry does, or where the quadratic misses its check.

    At a fixed phase of the input a case's configuration does not depend on its speed Ω,
    its rates go as Ω and Ω² (:mod:`ced.rigid.speed_family`), and so every system term is
    T₀ + Ω T₁ + Ω² T₂ (M; the gyroscopic and Rayleigh damping; K₀ + Ω² K₂; F₀ + Ω² F₂; the
    projection): three kept speeds of the family (its slowest, fastest and middle) fix it
    exactly, and a fourth checks it to :data:`FAMILY_TOLERANCE` of each term's largest
    entry, so that a term that is not quadratic in the speed is evaluated instead. The cases
    of a kept model's row share everything but the speed (:func:`model_key`). A sweep's
    first climbers, solved together, so give the terms of its later climbers and of its
    final batch (the damped 100-speed sweep's: 28 ms evaluated, 5 ms interpolated)."""
    for entry in reversed(entries):
        family = entry.families
        # Most entries hold too few speeds of the family: told by their keys alone, before
        # any array is compared (a sweep's pilots scan tens of entries a solve).
        if not all(c in entry.cases or len(family.get(c[0], ())) >= FAMILY_SPEEDS
                   for c in cases):
            continue
        if not _same_phases(entry.per_revolution, per_revolution):
            continue
        at = np.minimum(np.searchsorted(entry.fractions, fractions), len(entry.fractions) - 1)
        if not np.array_equal(entry.fractions[at], fractions):
            continue
        plan: dict[int, tuple] = {}  # row -> (its three nodes, the cases it gives)
        own: list[tuple[int, int]] = []  # (case, index) of a case whose speed is kept
        for c, (row, speed) in enumerate(cases):
            index = entry.cases.get((row, speed))
            if index is not None:
                own.append((c, index))
            elif len(family.get(row, ())) < FAMILY_SPEEDS:
                break
            else:
                if row not in plan:
                    known = family[row]
                    middle = min(known[1:-1], key=lambda k: abs(k[0] - 0.5 * (known[0][0]
                                                                                + known[-1][0])))
                    nodes = (known[0], middle, known[-1])
                    check = next(k for k in known if k not in nodes)
                    test = tuple(i for _, i in nodes + (check,))
                    if test not in entry.quadratic:
                        entry.quadratic[test] = _quadratic(entry.values, nodes + (check,))
                    if not entry.quadratic[test]:
                        break
                    plan[row] = (nodes, [])
                plan[row][1].append(c)
        else:
            weights = {row: np.array([_lagrange([k[0] for k in nodes], cases[c][1])
                                      for c in given]) for row, (nodes, given) in plan.items()}
            if all(np.abs(w).sum(axis=1).max() <= FAMILY_GAIN for w in weights.values()):
                return _combine(entry.values, plan, weights, own, at, len(cases))
    return None


def _lagrange(speeds: list[float], speed: float) -> np.ndarray:
    """Weights of the quadratic through three ``speeds`` at ``speed``."""
    a, b, c = speeds
    return np.array([(speed - b) * (speed - c) / ((a - b) * (a - c)),
                     (speed - a) * (speed - c) / ((b - a) * (b - c)),
                     (speed - a) * (speed - b) / ((c - a) * (c - b))])


#: Cases combined at a time by :func:`_combine` (its temporaries stay in cache).
_COMBINE_CASES = 8


def _combine(values: dict, plan: dict, weights: dict, own: list, at: np.ndarray,
             ncase: int) -> dict:
    """Every term at the entry's fractions ``at`` for ``ncase`` cases: a case of ``own``
    copied, the others Σ_j w_cj values[node_j] of their row's three nodes, summed in that
    order element by element (not by a matrix product, whose rounding may depend on how
    many cases it multiplies: a case's terms are the same bits whatever its batch)."""
    out = {}
    for name, x in values.items():
        y = np.empty((ncase, len(at)) + x.shape[2:])
        flat = y.reshape(ncase, -1)
        for row, (nodes, given) in plan.items():
            X = np.stack([x[i][at] for _, i in nodes]).reshape(3, -1)
            given, w = np.asarray(given), weights[row]
            for start in range(0, len(given), _COMBINE_CASES):
                part = slice(start, start + _COMBINE_CASES)
                block = w[part, 0:1] * X[0]
                block += w[part, 1:2] * X[1]
                block += w[part, 2:3] * X[2]
                flat[given[part]] = block
        for c, i in own:
            y[c] = x[i][at]
        out[name] = y
    return out


def _quadratic(values: dict, known: tuple) -> bool:
    """Whether the quadratic through the first three of ``known`` ((speed, index) × 4)
    gives every term at the fourth to :data:`FAMILY_TOLERANCE` of its largest entry."""
    (s0, i0), (s1, i1), (s2, i2), (s3, i3) = known
    w = _lagrange([s0, s1, s2], s3)
    for x in values.values():
        fit = w[0] * x[i0] + w[1] * x[i1] + w[2] * x[i2]
        scale = max(np.abs(x[[i0, i1, i2, i3]]).max(), np.finfo(float).tiny)
        if not np.abs(fit - x[i3]).max() <= FAMILY_TOLERANCE * scale:
            return False
    return True


def _same_phases(kept: int, wanted: int) -> bool:
    """Whether the step grids of ``kept`` and ``wanted`` steps per revolution put the input
    at the same phases, bit for bit, at their common times: a power of two apart. The grid
    motion is solved at the phases (2π/N) k (:mod:`ced.rigid.speed_family`); (2π/2N)(2k)
    is (2π/N) k exactly, (2π/96)(3k) is not (2π/64)(2k)."""
    ratio = max(kept, wanted) // min(kept, wanted)
    return max(kept, wanted) % min(kept, wanted) == 0 and ratio & (ratio - 1) == 0


def _keep(serial: int, cases: list, per_revolution: int, fractions: np.ndarray,
          times: np.ndarray, values: dict) -> None:
    """Keep terms at ``fractions`` of ``cases``, the oldest dropped beyond the bytes allowed."""
    size = sum(x.nbytes for x in values.values())
    if size > min(MAX_TERM_ENTRY_BYTES, MAX_TERM_BYTES):
        return
    while _TERM_BYTES[0] + size > MAX_TERM_BYTES:
        oldest = next(k for k, v in _TERMS.items() if v)
        _TERM_BYTES[0] -= _nbytes(_TERMS[oldest].pop(0))
    order = np.argsort(fractions, kind="stable")
    rows = {c: i for i, c in enumerate(cases)}
    families: dict[int, list[tuple[float, int]]] = {}
    for (row, speed), i in rows.items():
        families.setdefault(row, []).append((speed, i))
    _TERMS[serial].append(_KeptTerms(rows, per_revolution,
                                     fractions[order], times[:, order],
                                     {k: x[:, order] for k, x in values.items()}, {},
                                     {row: sorted(known) for row, known in families.items()}))
    _TERM_BYTES[0] += size


def _nbytes(entry: _KeptTerms) -> int:
    return sum(x.nbytes for x in entry.values.values())


def clear() -> None:
    """Forget every kept model and its terms."""
    _MODELS.clear()
    _TERMS.clear()
    _TERM_BYTES[0] = 0
