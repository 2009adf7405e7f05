"""Compare two study result trees bit for bit: every chunk and map dataset of one against the
same file of the other.

    python benchmarks/compare_studies.py results/default /elsewhere/results/default

Every variable and coordinate must have the same dtype, shape and bytes (NaN where NaN), and
the same attributes; so must the global attributes. Excluded, because they change from run
to run by design: the variable ``solve_time`` (wall time), and the global attributes
``history`` (creation time) and ``source`` (git revision). Exit status 1 on any difference,
listing each one.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import xarray as xr

VOLATILE_VARIABLES = {"solve_time"}
VOLATILE_ATTRS = {"history", "source"}


def _attrs_equal(a: dict, b: dict) -> bool:
    if set(a) != set(b):
        return False
    for key in a:
        x, y = a[key], b[key]
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            if not np.array_equal(np.asarray(x), np.asarray(y)):
                return False
        elif x != y and not (isinstance(x, float) and np.isnan(x) and np.isnan(y)):
            return False
    return True


def differences(first: Path, second: Path) -> list[str]:
    """What differs between two netCDF files (empty when bitwise equal, volatile fields
    excluded)."""
    out = []
    with xr.open_dataset(first, decode_cf=False) as a, xr.open_dataset(second,
                                                                       decode_cf=False) as b:
        names = set(a.variables) | set(b.variables)
        for name in sorted(names - VOLATILE_VARIABLES):
            if name not in a.variables or name not in b.variables:
                out.append(f"{name}: only in one file")
                continue
            x, y = a[name].values, b[name].values
            if x.dtype != y.dtype or x.shape != y.shape:
                out.append(f"{name}: {x.dtype}{x.shape} vs {y.dtype}{y.shape}")
            elif x.dtype.kind in "OSU":
                count = sum(p != q for p, q in zip(x.ravel(), y.ravel()))
                if count:
                    out.append(f"{name}: {count} of {x.size} string values differ")
            elif x.tobytes() != y.tobytes():
                diff = np.abs(x.astype(float) - y.astype(float))
                out.append(f"{name}: values differ (max |Δ| {np.nanmax(diff):.3g})")
            if not _attrs_equal(a[name].attrs, b[name].attrs):
                out.append(f"{name}: attributes differ")
        ga = {k: v for k, v in a.attrs.items() if k not in VOLATILE_ATTRS}
        gb = {k: v for k, v in b.attrs.items() if k not in VOLATILE_ATTRS}
        if not _attrs_equal(ga, gb):
            keys = sorted(k for k in set(ga) | set(gb) if json.dumps(str(ga.get(k)))
                          != json.dumps(str(gb.get(k))))
            out.append(f"global attributes differ: {', '.join(keys)}")
    return out


def main(argv: list[str]) -> int:
    first, second = (Path(p) for p in argv)
    files = sorted(p.relative_to(first) for sub in ("chunks", "maps")
                   for p in (first / sub).rglob("*.nc"))
    others = sorted(p.relative_to(second) for sub in ("chunks", "maps")
                    for p in (second / sub).rglob("*.nc"))
    status = 0
    if files != others:
        print(f"different files: {sorted(set(files) ^ set(others))}")
        status = 1
    for path in files:
        found = differences(first / path, second / path) if path in others else ["missing"]
        for line in found:
            print(f"{path}: {line}")
        status |= bool(found)
    print(f"{len(files)} datasets compared: " + ("identical (solve_time, history and source "
                                                  "excluded)" if not status else "DIFFERENT"))
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
