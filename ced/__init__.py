"""ced — kineto-elasto-dynamics of flexible planar linkages.

High-level API: :func:`simulate` (scenes → xarray dataset), :func:`load_scene`,
:func:`classify`, :func:`input_limits`, :func:`write_dataset`. Heavy modules (xarray, the FE
machinery) are imported on first use, so ``import ced`` stays light for Snakefile parsing.
"""
from __future__ import annotations

__version__ = "0.1.0"

from .mechanism import classify, input_limits  # noqa: E402

__all__ = ["__version__", "classify", "input_limits", "simulate", "load_scene",
           "write_dataset", "SceneError"]

_LAZY = {
    "simulate": ("ced.simulation", "simulate"),
    "load_scene": ("ced.scene", "load_scene"),
    "write_dataset": ("ced.io", "write_dataset"),
    "SceneError": ("ced.errors", "SceneError"),
}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    raise AttributeError(f"module 'ced' has no attribute {name!r}")
