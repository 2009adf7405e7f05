"""netCDF files: atomic CF writes of ced's datasets and reads that restore their labels, and
output paths checked before any work.

Write with ``engine="netcdf4"``, zlib level 4 with shuffle, chunks along ``case``; a temporary
file in the same directory is renamed over the target, so a reader sees either the old file
or the complete new one. A temporary file is named after its writer (host and process id),
so that the sweep of temporary files left by killed writes never removes the live one of a
concurrent writer of the same path.
"""
from __future__ import annotations

import os
import socket
import tempfile
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import xarray as xr

from .problem.errors import SceneError

__all__ = ["write_dataset", "check_output", "open_dataset", "to_cf", "from_cf", "LABEL_SUFFIX"]

#: A dimension labelled by text (``link``, ``joint``, ``axis``, a grid's ``material``) is
#: written as an integer index coordinate (CF: coordinate variables are numeric and monotonic)
#: with the labels as the auxiliary coordinate ``<dim>_name``; :func:`open_dataset` restores
#: the labels as the dimension's index, so ``ds.sel(link="coupler")`` stays one call.
LABEL_SUFFIX = "_name"


def to_cf(ds: xr.Dataset) -> xr.Dataset:
    """Text-valued dimension coordinates as an integer index plus ``<dim>_name`` labels.

    Parameters
    ----------
    ds : xarray.Dataset
        A dataset whose dimension coordinates may hold text (``link``: crank, coupler, …).

    Returns
    -------
    xarray.Dataset
        The same data; each text dimension coordinate ``d`` replaced by ``d`` = 0, 1, …
        (``units`` 1) and the auxiliary coordinate ``d_name`` (the labels, with the
        original attributes).

    Examples
    --------
    >>> ds = xr.Dataset(coords={"link": ("link", ["crank", "coupler"], {"long_name": "link"})})
    >>> cf = to_cf(ds)
    >>> cf.link.values.tolist(), cf.link_name.values.tolist()
    ([0, 1], ['crank', 'coupler'])
    >>> from_cf(cf).link.values.tolist()
    ['crank', 'coupler']
    """
    labels = {}
    for dim in ds.dims:
        if dim in ds.coords and ds[dim].dtype.kind in "OUS":
            labels[dim] = ds[dim]
    if not labels:
        return ds
    out = ds.assign_coords({
        dim: (dim, np.arange(coord.size, dtype="int32"),
              {"units": "1", "long_name": f"index along {dim}",
               "comment": f"labels in {dim}{LABEL_SUFFIX}; ced.io.open_dataset restores them "
                          f"as the index of {dim}"})
        for dim, coord in labels.items()})
    return out.assign_coords({
        f"{dim}{LABEL_SUFFIX}": (dim, coord.values.astype(object),
                                 {"long_name": dim.replace("_", " "), **coord.attrs})
        for dim, coord in labels.items()})


def from_cf(ds: xr.Dataset) -> xr.Dataset:
    """Undo :func:`to_cf`: every ``<dim>_name`` coordinate on an integer ``dim`` becomes the
    index of ``dim`` again (with its attributes), so that selecting by label is one call.

    Parameters
    ----------
    ds : xarray.Dataset
        A dataset as written by :func:`write_dataset`.

    Returns
    -------
    xarray.Dataset
        The dataset with text dimension coordinates.
    """
    restore = {}
    for dim in ds.dims:
        name = f"{dim}{LABEL_SUFFIX}"
        if name in ds.coords and ds[name].dims == (dim,) and dim in ds.coords \
                and ds[dim].dtype.kind in "iu":
            restore[dim] = (dim, ds[name].values.astype(object), dict(ds[name].attrs))
    if not restore:
        return ds
    return ds.drop_vars([f"{d}{LABEL_SUFFIX}" for d in restore]).assign_coords(restore)


def open_dataset(path: str | os.PathLike, **kwargs) -> xr.Dataset:
    """Open a netCDF file written by ced, with the text labels of ``link``, ``joint``,
    ``axis`` (and a grid's ``material``) restored as indexes (:func:`from_cf`).

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    **kwargs
        Passed to :func:`xarray.open_dataset` (engine netcdf4).

    Returns
    -------
    xarray.Dataset
        Lazily loaded; close it (or use ``with``) when done.

    Examples
    --------
    >>> ds = ced.io.open_dataset("result.nc")          # doctest: +SKIP
    >>> ds.stress.sel(link="coupler", station=0.5)     # doctest: +SKIP
    """
    ds = xr.open_dataset(path, engine="netcdf4", **kwargs)
    out = from_cf(ds)
    out.set_close(ds._close)
    return out


def check_output(path: str | os.PathLike, inputs: Iterable[str | os.PathLike] = ()) -> Path:
    """Refuse an output path that cannot take a dataset, before any work is done.

    The path must be a file path (not empty, not a directory) in an existing, writable
    directory, and not one of the ``inputs`` (the run would replace its own scene). A missing
    directory is not created: a typo must not make a tree.

    Parameters
    ----------
    path : str or os.PathLike
        The output file the run would write.
    inputs : iterable of str or os.PathLike
        The run's input files (scenes), which the output must not replace.

    Returns
    -------
    pathlib.Path
        ``path`` as a :class:`~pathlib.Path`.

    Raises
    ------
    SceneError
        At ``output``, saying what is wrong.
    """
    if not str(path):
        raise SceneError("output", "must be the path of a netCDF file, got ''")
    out = Path(path)
    if out.is_dir():
        raise SceneError("output", f"{str(out)!r} is a directory; give a file path such as "
                                   f"{str(out / 'result.nc')!r}")
    parent = out.resolve().parent
    if not parent.exists():
        raise SceneError("output", f"the directory {str(parent)!r} does not exist (it is not "
                                   "created for you: create it, or correct the path)")
    if not parent.is_dir():
        raise SceneError("output", f"{str(parent)!r} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise SceneError("output", f"cannot write in {str(parent)!r}: permission denied")
    for source in inputs:
        if out.exists() and Path(source).exists() and os.path.samefile(out, source):
            raise SceneError("output", f"{str(out)!r} is the input {str(source)!r}; it would be "
                                       "replaced by the dataset")
    return out


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
    """Write ``ds`` to ``path`` atomically (temporary file in the same directory, then rename),
    its text dimension coordinates as CF wants them (:func:`to_cf`; read back with
    :func:`open_dataset`).

    Overwriting an open file in place can truncate it (xarray #10679); a reader either sees the
    old file or the complete new one, and a write killed half way leaves only a temp file,
    which the next successful write of the same path removes.

    Parameters
    ----------
    ds : xarray.Dataset
        The dataset (as made by :func:`ced.simulate`).
    path : str or os.PathLike
        Target netCDF file (netCDF4 engine); its directory must exist.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}~{_HOST}~{os.getpid()}~", suffix=".tmp",
                               dir=path.parent)
    os.close(fd)
    try:
        ds = to_cf(ds)
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
    # A write killed earlier (SIGKILL) left its temp file; the complete file now exists, so it
    # is garbage. Only temp files of dead writers on this host are removed: a live one belongs
    # to a concurrent writer of the same path, and another host's process cannot be checked.
    for stale in path.parent.glob(f".{path.name}~{_HOST}~*~*.tmp"):
        pid = stale.name[len(f".{path.name}~{_HOST}~"):].split("~")[0]
        if pid.isdigit() and not _alive(int(pid)):
            stale.unlink(missing_ok=True)
    return path


#: This machine's name in temporary file names ("~" separates the fields).
_HOST = socket.gethostname().replace("~", "-") or "localhost"


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists on this host."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # exists, owned by someone else
    return True
