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
must be the whole batch's.

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

import numpy as np

from .batch import Batch
from .model import Model, build_model

__all__ = ["model_for", "model_key", "clear", "MAX_CASES", "MAX_MODELS"]

#: Batches of more cases are built afresh: their build is a small part of their solve, and
#: their models are large.
MAX_CASES = 256
#: Models kept (the least recently used is dropped first).
MAX_MODELS = 8
#: Scene keys a model depends on (:func:`ced.response.model.build_model` reads the
#: mechanism, links, point masses, discretization, effects, damping and output stations, and
#: modal damping the configuration at t = 0, from the drive's initial angle and amplitude;
#: gravity is kept too: a key that says too much only costs a rebuild). Not the speed: the
#: configuration, not its rates, enters a model (checked bit for bit across speeds in
#: ``tests/response/test_model_cache.py``).
_MODEL_KEYS = ("mechanism", "links", "point_masses", "discretization", "effects", "damping",
               "gravity")

#: Kept models by a serial number: (model, {model key: a case of it}).
_MODELS: OrderedDict[int, tuple[Model, dict]] = OrderedDict()
_SERIAL = itertools.count()


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


def _at_cases(model: Model, batch: Batch, cases: np.ndarray) -> Model:
    """``model`` at ``cases`` of its batch, as the model of ``batch``."""
    if len(cases) == model.batch.size and np.array_equal(cases, np.arange(len(cases))):
        return dataclasses.replace(model, batch=batch)
    size = model.batch.size
    fields = {f.name: _cases(getattr(model, f.name), cases, size)
              for f in dataclasses.fields(model)
              if f.name not in ("batch", "layout", "stations", "effects")}
    return dataclasses.replace(model, batch=batch, **fields)


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
            return _at_cases(model, batch, np.array([where[k] for k in keys]))
    model = build_model(batch)
    where: dict = {}
    for i, k in enumerate(keys):
        where.setdefault(k, i)
    _MODELS[next(_SERIAL)] = (model, where)
    while len(_MODELS) > MAX_MODELS:
        _MODELS.popitem(last=False)
    return model


def clear() -> None:
    """Forget every kept model."""
    _MODELS.clear()
