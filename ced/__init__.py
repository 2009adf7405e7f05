"""ced — kineto-elasto-dynamics of flexible planar linkages.

High-level API: :func:`simulate` (scenes → xarray dataset), :func:`load_scene`,
:func:`classify`, :func:`input_limits`, :func:`write_dataset`, :func:`open_dataset` (labels
of ``link``, ``joint``, ``axis`` restored as indexes), :func:`open_study` (a whole study as one
lazily loaded dataset), :class:`SceneError`. Heavy
modules (xarray, the FE machinery) are imported on first use, so ``import ced`` stays light
for Snakefile parsing.

The package is layered the way the data flows; each layer imports only the layers below it
(checked by the import-linter contract in ``pyproject.toml``, see ``docs/architecture.md``):

=============  ==================================================================
``cli``        the ``ced`` command
``study``      case tables and chunk jobs, config validation, maps, figures,
               convergence study, fidelity ladder
``io``         netCDF files: atomic writes
``simulation`` ``simulate``: scenes in, one CF dataset out
``auto``       automatic choices: effects, discretization, error estimates
``response``   the time response of a batch: the KED model, integrators, periodic
               steady state and Floquet, modal analysis over the cycle, recovery
``fem``        finite elements: link formulations, joint coupling, effect terms,
               component modes, eigenproblems, strain recovery operators
``rigid``      rigid motion: kinematics and inverse dynamics
``problem``    what is asked: scenes, materials, mechanism geometry, errors, status
=============  ==================================================================
"""
from __future__ import annotations

__version__ = "0.1.0"

from .problem.mechanism import classify, input_limits  # noqa: E402

__all__ = ["__version__", "classify", "input_limits", "simulate", "load_scene",
           "write_dataset", "open_dataset", "open_study", "SceneError"]

_LAZY = {
    "simulate": ("ced.simulation.simulate", "simulate"),
    "load_scene": ("ced.problem.scene", "load_scene"),
    "write_dataset": ("ced.io", "write_dataset"),
    "open_dataset": ("ced.io", "open_dataset"),
    "open_study": ("ced.study.browse", "open_study"),
    "SceneError": ("ced.problem.errors", "SceneError"),
}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    raise AttributeError(f"module 'ced' has no attribute {name!r}")
