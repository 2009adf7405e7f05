"""Peak memory of the reduction to maps (``ced.study.maps.reduce_family``) and of a selection
through ``ced.open_study`` as the number of cases grows tenfold.

Run ``python benchmarks/reduce_memory.py`` (part of ``make bench``); results go to
``benchmarks/reduce_memory.json``. A chunk of the default study's output size (11 stations,
128 steps per revolution, three links, a modal analysis) is simulated once and copied into
families of 500 and 5,000 cases (chunks of 250 cases, the case ids and scenes renumbered);
each family is then reduced, and a few cases selected from the opened study, in a fresh
process whose peak resident memory (``ru_maxrss``) is recorded. Flat: the 5,000-case peak
within 25 % of the 500-case one (the reduction reads one block of cases at a time; the
per-case summaries it keeps are a few hundred bytes a case).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
CHUNK = 250
SIZES = tuple(int(n) for n in os.environ.get("CED_MEMORY_SIZES", "500 5000").split())

#: The test study with the default study's output sizes (not its accuracy: the numbers do
#: not matter here, only the shapes).
CONFIG = {
    "study": "memory", "grids": {"four_bar": {"ground": 0.25, "crank": [0.05],
                                              "coupler": [0.2], "rocker": [0.15, 0.2]}},
    "speeds": [100.0, 150.0, 200.0, 250.0], "materials": ["steel", "aluminium"],
    "sections": [{"shape": "rectangle", "height": 0.02, "width": 0.01}],
    "families": ["crank_rocker"], "chunk_size": 16,
    "base_scene": {"links": {"crank": {"flexible": False}},
                   "discretization": {"formulation": "euler_bernoulli", "elements_per_link": 4},
                   "time": {"revolutions": 1, "steps_per_revolution": 128, "start": "periodic"},
                   "modal": {"modes": 3, "angles": 12}, "outputs": {"stations": 11, "every": 1}},
}

_CHILD = """
import resource, sys, time
from pathlib import Path
import ced
from ced.study.maps import reduce_family
root = Path(sys.argv[1])
paths = sorted((root / "chunks" / "crank_rocker").glob("*.nc"), key=lambda p: int(p.stem))
start = time.perf_counter()
reduce_family(paths, root / "maps" / "crank_rocker.nc", root / "maps" / "crank_rocker_grid.nc", 2.0)
reduce_seconds = time.perf_counter() - start
reduce_peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
ds = ced.open_study(root)
pick = ds.case[ds.case_id % 97 == 0]
peak = float(abs(ds.stress.sel(case=pick, link="coupler")).max().compute())
print(reduce_peak, reduce_seconds, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
      int(pick.size), peak)
"""


def _template(directory: Path):
    """One simulated chunk (16 cases) of CONFIG, loaded."""
    from ced.io import open_dataset
    from ced.study.chunk_job import run_chunk

    path = run_chunk(CONFIG, "crank_rocker", 0, directory / "template.nc")
    with open_dataset(path) as ds:
        return ds.load()


def _family(template, root: Path, cases: int) -> None:
    """``cases`` cases in chunks of CHUNK, tiled from the template, written as the pipeline
    writes them."""
    from ced.io import write_dataset

    n = template.sizes["case"]
    scenes = json.loads(template.attrs["scenes"])
    for index, first in enumerate(range(0, cases, CHUNK)):
        ids = np.arange(first, min(first + CHUNK, cases))
        # distinct speeds keep the grid points distinct (the grid map needs them unique)
        chunk = template.isel(case=ids % n).assign_coords(
            case=("case", ids, template.case.attrs),
            speed=("case", 100.0 + 0.01 * ids, template.speed.attrs))
        chunk.attrs["scenes"] = json.dumps([scenes[i % n] for i in ids])
        chunk.attrs["chunk"] = f"crank_rocker/{index}"
        write_dataset(chunk, root / "chunks" / "crank_rocker" / f"{index}.nc")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default=str(HERE / "reduce_memory.json"))
    args = parser.parse_args()
    results = {"machine": platform.platform(), "python": platform.python_version(),
               "chunk_cases": CHUNK, "runs": []}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        template = _template(tmp)
        for cases in SIZES:
            root = tmp / f"study_{cases}"
            start = time.perf_counter()
            _family(template, root, cases)
            written = time.perf_counter() - start
            out = subprocess.run([sys.executable, "-c", _CHILD, str(root)],
                                 capture_output=True, text=True, timeout=3600, cwd=ROOT)
            if out.returncode:
                sys.exit(f"the reduction of {cases} cases failed:\n{out.stderr}")
            reduce_kb, seconds, total_kb, picked, peak = out.stdout.split()
            on_disk = sum(p.stat().st_size for p in (root / "chunks").rglob("*.nc"))
            run = {"cases": cases, "chunk_files_mb": round(on_disk / 1e6, 1),
                   "write_seconds": round(written, 1),
                   "reduce_peak_rss_mb": round(int(reduce_kb) / 1024, 1),
                   "reduce_seconds": round(float(seconds), 1),
                   "open_study_select_peak_rss_mb": round(int(total_kb) / 1024, 1),
                   "selected_cases": int(picked), "selected_peak_stress_mpa":
                       round(float(peak) / 1e6, 3)}
            print(json.dumps(run), flush=True)
            results["runs"].append(run)
    small, large = results["runs"][0], results["runs"][-1]
    ratio = large["reduce_peak_rss_mb"] / small["reduce_peak_rss_mb"]
    results["reduce_peak_ratio"] = round(ratio, 3)
    results["flat"] = ratio <= 1.25
    Path(args.output).write_text(json.dumps(results, indent=2) + "\n")
    print(f"reduction peak memory: {small['reduce_peak_rss_mb']} MB at {small['cases']} cases, "
          f"{large['reduce_peak_rss_mb']} MB at {large['cases']} ({ratio:.2f}x)")
    if not results["flat"]:
        sys.exit("the reduction's peak memory grows with the number of cases")


if __name__ == "__main__":
    main()
