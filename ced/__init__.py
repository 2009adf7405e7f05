"""ced — kineto-elasto-dynamics of flexible planar linkages."""
from __future__ import annotations

__version__ = "0.1.0"

from .mechanism import classify, input_limits  # noqa: E402

__all__ = ["__version__", "classify", "input_limits"]
