"""netCDF files: atomic writes of ced's datasets.

Write with ``engine="netcdf4"``, zlib level 4 with shuffle, chunks along ``case``; a temporary
file in the same directory is renamed over the target, so a reader sees either the old file
or the complete new one.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import xarray as xr

__all__ = ["write_dataset"]


def _encoding(ds: xr.Dataset) -> dict:
    encoding = {}
    for name, var in ds.variables.items():
        if var.dtype.kind in "OUS":
            continue  # variable-length strings cannot be compressed in netCDF4
        enc = {"zlib": True, "complevel": 4, "shuffle": True}
        if "case" in var.dims and var.ndim > 0:
            enc["chunksizes"] = tuple(
                min(64, n) if d == "case" else n for d, n in zip(var.dims, var.shape)
            )
        if var.dtype.kind == "f":
            enc["_FillValue"] = None  # no silent NaN fill: every value is computed
        encoding[name] = enc
    return encoding


def write_dataset(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write ``ds`` to ``path`` atomically (temporary file in the same directory, then rename).

    Overwriting an open file in place can truncate it (xarray #10679); a reader either sees the
    old file or the complete new one, and a write killed half way leaves only a temp file,
    which the next successful write of the same path removes.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=_encoding(ds))
        # mkstemp creates 0600; give the result the permissions a plain open() would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    # A write killed earlier (SIGKILL, node failure) left its temp file; the complete file now
    # exists, so those leftovers are garbage. One job writes a given output, so none is live.
    for stale in path.parent.glob(f".{path.name}.*.tmp"):
        stale.unlink(missing_ok=True)
    return path
