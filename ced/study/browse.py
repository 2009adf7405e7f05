"""A whole study as one lazily loaded dataset (``ced.open_study``).

A study is one netCDF file per chunk (``results/<study>/chunks/<family>/<i>.nc``) and two map
files per family (``maps/<family>.nc`` per case, ``maps/<family>_grid.nc`` on the grid).
:func:`open_study` opens every chunk with dask, one dask chunk per 64 cases (the files' own
chunking along ``case``), and joins the per-case results of the maps, so that selecting a few
cases of a large study reads only their blocks:

>>> import ced                                              # doctest: +SKIP
>>> ds = ced.open_study("results/default")                  # doctest: +SKIP
>>> steel = ds.case[(ds.family == "crank_rocker") & (ds.material == "steel")]  # doctest: +SKIP
>>> ds.stress.sel(case=steel[:10], link="coupler").max().compute()             # doctest: +SKIP

The families' chunks are read through :func:`open_family`, which the reduction to maps uses
too (:func:`ced.study.maps.reduce_family`), block by block.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import xarray as xr

from ..io import from_cf, open_dataset
from .fatigue import link_strengths

__all__ = ["open_family", "open_study", "CASE_BLOCK"]

#: Cases per dask chunk: the files' chunking along ``case`` (:mod:`ced.io`).
CASE_BLOCK = 64


def _prepare(ds: xr.Dataset) -> xr.Dataset:
    """One chunk file as read: labels restored, the material strengths of each case and link
    taken out of the ``scenes`` attribute (which differs from chunk to chunk) as variables."""
    ds = from_cf(ds)
    strengths = link_strengths(ds)
    if strengths is not None:
        ds = ds.assign({name: strengths[name].chunk({"case": CASE_BLOCK})
                        for name in strengths.data_vars})
    ds.attrs = {k: v for k, v in ds.attrs.items() if k not in ("scenes", "chunk")}
    return ds


def open_family(paths: list[str | Path]) -> xr.Dataset:
    """A family's chunk files as one lazily loaded dataset along ``case`` (dask).

    Parameters
    ----------
    paths : list of str or Path
        The family's chunk files, in any order.

    Returns
    -------
    xarray.Dataset
        Every variable of the chunks with dask arrays chunked by :data:`CASE_BLOCK` cases,
        sorted by case id; the material strengths per case and link
        (:data:`ced.study.fatigue.STRENGTHS`, Pa) added; the case coordinates loaded (small),
        so that selecting by them reads nothing else.
    """
    ds = xr.open_mfdataset(
        [str(p) for p in paths], engine="netcdf4", combine="nested", concat_dim="case",
        preprocess=_prepare, data_vars="minimal", coords="minimal", compat="override",
        join="outer", combine_attrs="drop_conflicts", chunks={"case": CASE_BLOCK})
    case_coords = {k: v.load() for k, v in ds.coords.items() if v.dims == ("case",)}
    ds = ds.assign_coords(case_coords)
    order = np.argsort(ds.case.values, kind="stable")
    if (np.diff(ds.case.values[order]) == 0).any():
        raise ValueError("open_family: case ids repeat across the chunk files")
    return ds if (order == np.arange(len(order))).all() else ds.isel(case=order)


def _chunk_paths(root: Path, family: str) -> list[Path]:
    return sorted((root / "chunks" / family).glob("*.nc"), key=lambda p: int(p.stem))


def open_study(path: str | Path) -> xr.Dataset:
    """Every case of a study as one lazily loaded dataset: the time histories of the chunks
    and the per-case results of the maps, with each case's family and grid coordinates.

    Parameters
    ----------
    path : str or Path
        The study's results directory (``results/<study>``: its ``chunks/`` and ``maps/``).

    Returns
    -------
    xarray.Dataset
        Dimension ``case`` = 0 … N−1 over the whole study (families one after the other);
        ``case_id`` the case's id within its family (the ``case`` of its chunk and map files),
        ``family`` and the grid coordinates (lengths, ``speed``, ``material``, ``section``) on
        ``case``, loaded; every other variable a dask array read on demand. ``link`` and
        ``joint`` are the union over the families (a slider-crank has no ``rocker``: NaN
        there). The per-case results of ``maps/<family>.nc`` that the chunks lack (fatigue,
        utilisation, natural-frequency bands, …) are joined on ``case_id``.

    Raises
    ------
    FileNotFoundError
        If ``path`` holds no chunk files.
    """
    root = Path(path)
    families = sorted(d.name for d in (root / "chunks").glob("*") if d.is_dir()
                      and any(d.glob("*.nc")))
    if not families:
        raise FileNotFoundError(f"open_study: no chunk files under {root / 'chunks'} (give "
                                "the study's results directory, e.g. results/default)")
    parts = []
    for family in families:
        ds = open_family(_chunk_paths(root, family))
        summary_path = root / "maps" / f"{family}.nc"
        if summary_path.exists():
            summary = open_dataset(summary_path, chunks={"case": CASE_BLOCK})
            extra = [n for n in summary.data_vars if n not in ds]
            ds = ds.assign({n: summary[n].reindex(case=ds.case) for n in extra})
        parts.append(ds.assign_coords(case_id=("case", ds.case.values, {
            "units": "1", "long_name": "case id within the family"})).drop_vars("case"))
    # a case coordinate one family lacks (a slider-crank has no ground): NaN for its cases
    coords = {k: v for p in parts for k, v in p.coords.items() if v.dims == ("case",)}
    parts = [p.assign_coords({k: ("case", np.full(p.sizes["case"], np.nan), v.attrs)
                              for k, v in coords.items() if k not in p.coords})
             for p in parts]
    study = xr.concat(parts, dim="case", data_vars="minimal", coords="minimal",
                      compat="override", join="outer", combine_attrs="drop_conflicts")
    for dim in ("link", "joint"):  # the union in the mechanisms' order, not alphabetical
        if dim in study.dims:
            study = study.reindex({dim: list(dict.fromkeys(
                label for p in parts if dim in p.dims for label in p[dim].values))})
    study = study.assign_coords(case=("case", np.arange(study.sizes["case"]), {
        "units": "1", "long_name": "case index within the study"}))
    study = study.assign_coords({k: v.load() for k, v in study.coords.items()
                                 if v.dims == ("case",)})
    study.attrs["families"] = json.dumps(families)
    return study
