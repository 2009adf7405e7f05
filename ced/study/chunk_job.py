"""The job that simulates one chunk of a study and writes its dataset.

One Snakemake job per (family, chunk) of many cases (rule ``simulate_chunk``). Its log (stderr)
gets one line per part of the chunk solved, with the estimated time left
(:func:`ced.study.progress.simulate_in_parts`), and a summary line at the end.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from ..io import write_dataset
from ..problem.status import STATUS_FLAGS
from .cases import chunk_rows
from .progress import simulate_in_parts

__all__ = ["run_chunk"]


def run_chunk(config: dict, family: str, index: int, output: str | Path,
              study: str | None = None) -> Path:
    """Simulate one chunk and write its dataset atomically.

    The dataset's ``case`` coordinate is the case id within the family; ``section`` (index
    into the config's sections) is added as a case coordinate beside the section sizes;
    ``family`` is the study family (:func:`ced.study.cases.six_bar_family` for a six-bar,
    whose simulated dataset names only its first loop's Grashof type).

    Parameters
    ----------
    config : dict
        The study config (or its case part, :func:`ced.study.cases.case_config`).
    family : str
        The family of the chunk.
    index : int
        The chunk's index within the family, from 0.
    output : str or Path
        The chunk's netCDF file.
    study : str, optional
        The study's name for the dataset's ``study`` attribute (default: ``config["study"]``).

    Returns
    -------
    Path
        The file written.
    """
    rows = chunk_rows(config, family, index)
    start = time.perf_counter()
    ds = simulate_in_parts([r["scene"] for r in rows], desc=f"{family}/{index}",
                           log=lambda line: print(line, file=sys.stderr, flush=True))
    elapsed = time.perf_counter() - start
    ds = ds.assign_coords(
        case=("case", np.array([r["case"] for r in rows]), ds.case.attrs),
        section=("case", np.array([r["section"] for r in rows], dtype="int32"),
                 {"units": "1", "long_name": "index of the section in the study's sections"}),
        family=("case", np.array([r["family"] for r in rows], dtype=object),
                {"long_name": "mechanism family (a six-bar's: its type and the Grashof type "
                              "of each four-bar loop)"}),
    )
    ds.case.attrs.update(units="1", long_name="case id within the family")
    ds.attrs["study"] = str(study if study is not None else config.get("study", "study"))
    ds.attrs["chunk"] = f"{family}/{index}"
    ds.attrs["study_sections"] = json.dumps(config["sections"], sort_keys=True)
    path = write_dataset(ds, output)
    status = ds.status.values.astype(int)
    counts = {"ok": int((status == 0).sum())}
    counts.update({name: int((status & bit > 0).sum()) for name, bit in STATUS_FLAGS.items()})
    print(f"{family}/{index}: {len(rows)} cases (ids {rows[0]['case']}-{rows[-1]['case']}) "
          f"in {elapsed:.1f} s; status: " + ", ".join(f"{k} {v}" for k, v in counts.items() if v),
          file=sys.stderr)
    return path
