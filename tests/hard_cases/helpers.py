"""Shared helpers of the hard-case suite (hard cases are flagged, never NaN: docs/guide/status.md)."""
from __future__ import annotations

import numpy as np

from ced.problem.status import status_names


def assert_finite(ds) -> None:
    """Every floating-point variable of the dataset is finite (no NaN, no inf)."""
    bad = [name for name, var in ds.data_vars.items()
           if var.dtype.kind == "f" and not np.all(np.isfinite(var.values))]
    assert not bad, f"non-finite values in {bad}"


def flags(ds, case: int = 0) -> set[str]:
    """Names of the status flags set for ``case``."""
    return set(status_names(int(ds.status.values[case]))) - {"ok"}
