"""Faults lose nothing (issue 7): a case that raises is recorded and its chunk completes; a
write killed half way leaves no partial file under the final name; reruns are bitwise equal.

Killing a whole study (Snakemake and its jobs) and resuming it is tests/test_resume.py.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import ced.simulation.simulate
from ced.io import write_dataset
from ced.problem.status import STATUS_FLAGS, status_names
from ced.study.cases import chunk_rows
from ced.study.chunk_job import run_chunk
from ced.study.config import load_config, validate_config
from ced.io import open_dataset

ROOT = Path(__file__).resolve().parents[2]
FAMILY, CHUNK = "crank_rocker", 0
#: Variables that legitimately differ between two runs (wall-clock time).
TIMING = {"solve_time"}
#: Global attributes that record when a file was made.
WHEN = {"history", "date_created"}


@pytest.fixture(scope="module")
def config():
    return validate_config(load_config(ROOT / "config" / "studies" / "test.yaml"))


@pytest.fixture(scope="module")
def clean(config, tmp_path_factory):
    """The chunk run without any fault."""
    path = run_chunk(config, FAMILY, CHUNK, tmp_path_factory.mktemp("clean") / "0.nc")
    with open_dataset(path) as ds:
        return ds.load()


def same_values(a: xr.DataArray, b: xr.DataArray) -> bool:
    """Bitwise equality (NaN equal to NaN in the same place; strings compared as strings)."""
    if a.dims != b.dims or a.shape != b.shape:
        return False
    if a.dtype.kind in "OUS":  # netCDF strings come back with the width of the longest
        return a.values.tolist() == b.values.tolist()
    return a.dtype == b.dtype and a.values.tobytes() == b.values.tobytes()


# ------------------------------------------------------------------------ a failing case
def test_a_failing_case_is_recorded_and_the_chunk_completes(config, clean, tmp_path,
                                                           monkeypatch):
    rows = chunk_rows(config, FAMILY, CHUNK, scenes=False)
    victim = rows[1]
    real = ced.simulation.simulate.solve_batch

    def solve_batch(batch, peaks_only=False, allocate=None, guesses=None):
        for scene in batch.scenes:
            material = scene["links"]["coupler"]["material"]["name"]
            if (scene["drive"]["speed"], material) == (victim["speed"], victim["material"]):
                raise FloatingPointError("injected fault in the victim case")
        return real(batch, peaks_only, allocate, guesses)

    monkeypatch.setattr(ced.simulation.simulate, "solve_batch", solve_batch)
    path = run_chunk(config, FAMILY, CHUNK, tmp_path / "0.nc")
    with open_dataset(path) as ds:
        assert ds.sizes["case"] == len(rows) == clean.sizes["case"]
        assert list(ds.case.values) == [r["case"] for r in rows]
        failed = (ds.status.values & STATUS_FLAGS["failed"]) > 0
        assert failed.tolist() == [r["case"] == victim["case"] for r in rows]
        message = str(ds.message.values[1])
        assert "FloatingPointError" in message and "injected fault" in message
        others = [i for i in range(len(rows)) if i != 1]
        # no empty text: the others' message is their status flags ("ok" when none)
        assert [str(m) for m in ds.message.values[others]] == [
            ", ".join(status_names(int(code))) for code in ds.status.values[others]]
        # The other cases, re-solved one by one after their batch failed, are bitwise those of
        # the run without the fault (the solver's arithmetic is per case, not across cases).
        different = [name for name, var in clean.data_vars.items()
                     if name not in TIMING and "case" in var.dims
                     and not same_values(ds[name].isel(case=others), var.isel(case=others))]
        assert not different


# ------------------------------------------------------------------------ killed writes
WRITER = textwrap.dedent("""
    import sys
    import numpy as np
    import xarray as xr
    from ced.io import write_dataset

    # ~100 MB of incompressible float64: zlib takes seconds over it.
    values = np.random.default_rng(0).standard_normal((1500, 8000))
    ds = xr.Dataset({"x": (("case", "step"), values, {"units": "1", "long_name": "noise"})})
    print("writing", flush=True)
    write_dataset(ds, sys.argv[1])
    print("done", flush=True)
""")


def small_dataset(value: float) -> xr.Dataset:
    return xr.Dataset({"x": (("case", "step"), np.full((3, 4), value),
                             {"units": "1", "long_name": "marker"})})


def temp_files(directory: Path, name: str) -> list[Path]:
    return [p for p in directory.iterdir() if p.name.startswith(f".{name}~")
            and p.name.endswith(".tmp")]


@pytest.mark.parametrize("previous", [None, 1.0], ids=["new_file", "overwrite"])
def test_write_killed_half_way_leaves_no_partial_file(tmp_path, previous):
    final = tmp_path / "chunk.nc"
    if previous is not None:
        write_dataset(small_dataset(previous), final)
    writer = subprocess.Popen([sys.executable, "-c", WRITER, str(final)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert writer.stdout.readline().strip() == "writing"
        deadline = time.monotonic() + 60
        while not any(p.stat().st_size > 2**20 for p in temp_files(tmp_path, final.name)):
            assert writer.poll() is None, "the writer finished before it could be killed"
            assert time.monotonic() < deadline, "no temporary file appeared"
            time.sleep(0.01)
        os.kill(writer.pid, signal.SIGKILL)
    finally:
        writer.kill()
        writer.wait()
    assert writer.returncode == -signal.SIGKILL  # killed mid-write, not finished
    leftovers = sorted(set(tmp_path.iterdir()) - {final})
    assert leftovers and leftovers == sorted(temp_files(tmp_path, final.name))
    if previous is None:
        assert not final.exists()
    else:  # the old file is intact
        with open_dataset(final) as ds:
            assert float(ds.x.max()) == float(ds.x.min()) == previous
    # A rerun writes the complete file under the final name and removes the leftovers.
    write_dataset(small_dataset(2.0), final)
    with open_dataset(final) as ds:
        assert ds.x.values.tolist() == small_dataset(2.0).x.values.tolist()
    assert list(tmp_path.iterdir()) == [final]


def test_write_that_raises_removes_its_temporary_file(tmp_path, monkeypatch):
    final = tmp_path / "chunk.nc"
    real = xr.Dataset.to_netcdf

    def to_netcdf(self, path, *args, **kwargs):
        real(self, path, *args, **kwargs)  # the bytes are on disk ...
        raise OSError("disk full")           # ... then the writer dies

    monkeypatch.setattr(xr.Dataset, "to_netcdf", to_netcdf)
    with pytest.raises(OSError, match="disk full"):
        write_dataset(small_dataset(1.0), final)
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------ reproducibility
def test_two_runs_of_a_chunk_are_bitwise_identical(config, clean, tmp_path):
    path = run_chunk(config, FAMILY, CHUNK, tmp_path / "0.nc")
    with open_dataset(path) as again:
        assert set(again.variables) == set(clean.variables)
        different = [name for name in clean.variables
                     if name not in TIMING and not same_values(again[name], clean[name])]
        assert not different
        np.testing.assert_equal({k: v for k, v in again.attrs.items() if k not in WHEN},
                                {k: v for k, v in clean.attrs.items() if k not in WHEN})
        for name in clean.variables:
            np.testing.assert_equal(again[name].attrs, clean[name].attrs, err_msg=name)
