"""The test study through SLURM (workflow/profiles/slurm, snakemake-executor-plugin-slurm) gives
the same results as the local profile: every variable of every chunk and map file bitwise
equal (NaN-aware), measured wall times excepted.

Needs a running SLURM and the plugin: `make cluster-test` (tests/cluster/run.sh) starts a
single-node cluster, installs the plugin and runs this with CED_CLUSTER=1; otherwise skipped."""
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from ced.study.cases import chunks
from ced.io import open_dataset

pytestmark = pytest.mark.skipif(os.environ.get("CED_CLUSTER") != "1",
                                reason="needs a SLURM cluster: make cluster-test")

ROOT = Path(__file__).resolve().parents[1]
SNAKEFILE = ROOT / "Snakefile"
TEST_STUDY = ROOT / "config" / "studies" / "test.yaml"


def snakemake(profile: str, directory: Path, *args: str) -> str:
    cmd = [sys.executable, "-m", "snakemake", "--snakefile", str(SNAKEFILE), "--directory",
           str(directory), "--profile", str(ROOT / "workflow" / "profiles" / profile), *args,
           "--configfile", str(TEST_STUDY)]
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=1800, cwd=directory)
    output = result.stdout + result.stderr
    (directory / f"{profile}.log").write_text(output)
    assert result.returncode == 0, f"{' '.join(cmd)}\n{output}"
    return output


def files() -> list[str]:
    n_chunks = chunks(yaml.safe_load(TEST_STUDY.read_text()))
    out = []
    for family, n in sorted(n_chunks.items()):
        out += [f"results/test/chunks/{family}/{i}.nc" for i in range(n)]
        out += [f"results/test/maps/{family}.nc", f"results/test/maps/{family}_grid.nc"]
    return out


def variables(path: Path) -> dict[str, np.ndarray]:
    with open_dataset(path) as ds:
        return {n: v.values.copy() for n, v in ds.variables.items()
                if "wall time" not in v.attrs.get("long_name", "")}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    slurm = tmp_path_factory.mktemp("slurm")
    # Poll the local single-node cluster often (the profile keeps the plugin's defaults, which
    # suit a shared cluster): the run is then bound by the jobs, not by waiting.
    slurm_output = snakemake("slurm", slurm, "--slurm-init-seconds-before-status-checks", "2",
                             "--seconds-between-status-checks", "2")
    local = tmp_path_factory.mktemp("local")
    snakemake("default", local, "--cores", "2")
    return slurm, local, slurm_output


def test_jobs_went_through_slurm(runs):
    _, _, output = runs
    submitted = re.findall(r"has been submitted with SLURM jobid (\d+)", output)
    n_chunks = sum(chunks(yaml.safe_load(TEST_STUDY.read_text())).values())
    assert len(submitted) >= n_chunks, output


@pytest.mark.parametrize("name", files(), ids=lambda p: p.split("results/test/")[1])
def test_slurm_equals_local(runs, name):
    slurm, local, _ = runs
    a, b = variables(slurm / name), variables(local / name)
    assert a.keys() == b.keys()
    for var, x in a.items():
        y = b[var]
        assert x.dtype == y.dtype and x.shape == y.shape, var
        assert np.array_equal(x, y, equal_nan=x.dtype.kind in "fc"), var
