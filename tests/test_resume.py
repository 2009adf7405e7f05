"""Resume (docs/guide/first_study.md, default profile: rerun-incomplete): a study interrupted after some chunks
finishes on the next plain run, reruns only the chunks it lacks, leaves no partial or temporary
file behind, and gives bitwise the same chunk data as an uninterrupted run. Two uninterrupted
runs give bitwise the same data too.

Each run happens in its own temporary directory with Snakemake as a subprocess in its own
process group, so the interruption hits Snakemake and its jobs together (Ctrl-C, or a killed
node for SIGKILL)."""
import base64
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from ced.study.cases import chunks
from tests.conftest import shared
from ced.io import open_dataset

ROOT = Path(__file__).resolve().parents[1]
SNAKEFILE = ROOT / "Snakefile"
PROFILE = ROOT / "workflow" / "profiles" / "default"
TEST_STUDY = ROOT / "config" / "studies" / "test.yaml"


def study_config(directory: Path) -> tuple[Path, dict[str, int]]:
    """The test study with two cases per chunk (8 chunks of about a second each), written to
    ``directory``; returns its path and the number of chunks per family."""
    config = yaml.safe_load(TEST_STUDY.read_text())
    config["chunk_size"] = 2
    path = directory / "resume.yaml"
    path.write_text(yaml.safe_dump(config))
    return path, chunks(config)


def command(directory: Path, configfile: Path, *args: str) -> list[str]:
    return [sys.executable, "-m", "snakemake", "--snakefile", str(SNAKEFILE), "--directory",
            str(directory), "--profile", str(PROFILE), "--cores", "2", *args,
            "--configfile", str(configfile)]  # last: it takes several values


def run(directory: Path, configfile: Path, *args: str, timeout=900) -> str:
    cmd = command(directory, configfile, *args)
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=directory)
    output = result.stdout + result.stderr
    assert result.returncode == 0, f"{' '.join(cmd)}\n{output}"
    return output


def chunk_targets(n_chunks: dict[str, int]) -> list[str]:
    return [f"results/test/chunks/{family}/{i}.nc"
            for family, n in sorted(n_chunks.items()) for i in range(n)]


def job_counts(output: str) -> dict[str, int]:
    """The 'Job stats' table of a Snakemake run (empty if it had nothing to do)."""
    if "Job stats:" not in output:
        return {}
    table = output.split("Job stats:")[1]
    return {m[1]: int(m[2]) for m in re.finditer(r"^(\w+)\s+(\d+)\s*$", table, re.M)}


def simulated(output: str) -> set[str]:
    """Chunk files whose simulate_chunk job started in a run's log."""
    return set(re.findall(r"^\s*output: (results/test/chunks/\S+\.nc)\s*$", output, re.M))


def incomplete_marks(directory: Path) -> set[str]:
    """Outputs that Snakemake's metadata marks incomplete (.snakemake/incomplete/<base64>)."""
    marks = set()
    for p in (directory / ".snakemake" / "incomplete").glob("*"):
        try:
            marks.add(base64.urlsafe_b64decode(p.name.encode()).decode())
        except ValueError:
            continue
    return marks


def stray_files(directory: Path) -> list[Path]:
    """Temporary files of atomic writes (ced.io.write_dataset:
    '.<name>~<host>~<pid>~<random>.tmp') and other partial netCDF files anywhere in the run
    directory."""
    return [p for p in (directory / "results").rglob("*")
            if p.is_file() and (p.name.endswith(".tmp") or (p.name.startswith(".")
                                                             and ".nc" in p.name))]


def data_vars(directory: Path, n_chunks: dict[str, int]) -> dict[str, dict[str, np.ndarray]]:
    """Every variable (data and coordinates) of every chunk file, loaded, except measured wall
    times (a clock reading, not a result: differs from run to run by nature)."""
    out = {}
    for target in chunk_targets(n_chunks):
        with open_dataset(directory / target) as ds:
            measured = {n for n, v in ds.variables.items()
                        if "wall time" in v.attrs.get("long_name", "")}
            assert measured == {"solve_time"}, measured
            out[target] = {name: var.values.copy() for name, var in ds.variables.items()
                           if name not in measured}
    return out


def assert_bitwise_equal(a: dict, b: dict):
    assert a.keys() == b.keys()
    for target in a:
        assert a[target].keys() == b[target].keys(), target
        for name, x in a[target].items():
            y = b[target][name]
            assert x.dtype == y.dtype and x.shape == y.shape, (target, name)
            equal_nan = x.dtype.kind in "fc"
            assert np.array_equal(x, y, equal_nan=equal_nan), (target, name)
            if equal_nan:  # same bits, not only same values (signed zeros, NaN payloads)
                assert x.tobytes() == y.tobytes(), (target, name)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """Two uninterrupted runs of every chunk of the study, in separate directories."""
    results = []
    for name in ("ced-resume-reference-1", "ced-resume-reference-2"):

        def build(directory):
            configfile, n_chunks = study_config(directory)
            run(directory, configfile, *chunk_targets(n_chunks))

        directory = shared(tmp_path_factory, name, build)
        results.append(data_vars(directory, study_config(directory)[1]))
    return results


def test_uninterrupted_runs_are_bitwise_identical(reference):
    first, second = reference
    assert_bitwise_equal(first, second)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL], ids=["SIGINT", "SIGKILL"])
def test_interrupted_run_resumes(tmp_path, reference, sig):
    configfile, n_chunks = study_config(tmp_path)
    total = sum(n_chunks.values())
    chunk_dir = tmp_path / "results" / "test" / "chunks"
    log = tmp_path / "interrupted.log"
    with open(log, "w") as out:  # a file, not a pipe: jobs may outlive Snakemake a moment
        # SIGINT back to its default in the child: a test run started in the background by a
        # non-interactive shell (`make test &`) ignores SIGINT, and the ignored disposition is
        # inherited across exec, so Snakemake would never see the interruption.
        proc = subprocess.Popen(command(tmp_path, configfile), cwd=tmp_path,
                                start_new_session=True, stdout=out, stderr=subprocess.STDOUT,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 600
    try:
        # A chunk file, and Snakemake done with its job (a file whose job Snakemake has not yet
        # seen finish is rightly treated as incomplete).
        while not (list(chunk_dir.rglob("*.nc"))
                   and "(Rule: simulate_chunk)" in log.read_text()):
            assert proc.poll() is None, f"run ended before any chunk:\n{log.read_text()}"
            assert time.monotonic() < deadline, "no chunk file after 600 s"
            time.sleep(0.05)
        os.killpg(proc.pid, sig)
        proc.wait(timeout=300)
    finally:
        try:  # whatever is left of the group (nothing, normally)
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait()
    first_output = log.read_text()
    if sig == signal.SIGKILL:  # the jobs are in the group too; let them die before looking
        time.sleep(0.5)
    present = {str(p.relative_to(tmp_path)) for p in chunk_dir.rglob("*.nc")}
    missing = set(chunk_targets(n_chunks)) - present
    assert missing, f"the run finished every chunk before the interruption:\n{first_output}"
    assert "Finished jobid" in first_output or present, first_output
    expected = missing | (incomplete_marks(tmp_path) & set(chunk_targets(n_chunks)))

    if sig == signal.SIGKILL:
        # A killed Snakemake leaves its lock; the documented first step is --unlock.
        locked = subprocess.run(command(tmp_path, configfile), cwd=tmp_path, text=True,
                                capture_output=True, timeout=600)
        assert locked.returncode != 0 and "cannot be locked" in locked.stdout + locked.stderr
        run(tmp_path, configfile, "--unlock")
    output = run(tmp_path, configfile)  # the default profile: rerun-incomplete

    counts = job_counts(output)
    assert counts.get("simulate_chunk", 0) == len(expected), output
    assert simulated(output) == expected, output
    assert len(expected) < total
    assert "Nothing to be done" in run(tmp_path, configfile, "-n")
    strays = stray_files(tmp_path)
    if sig == signal.SIGKILL:
        # A job killed while writing leaves its temporary file (ced.io.write_dataset: nothing
        # can clean up after SIGKILL); never a file under the output's own name.
        strays = [p for p in strays if not re.fullmatch(r"\.\d+\.nc\.\w+\.tmp", p.name)]
    assert not strays, strays
    for path in (tmp_path / "results").rglob("*.nc"):  # no partial netCDF under a final name
        open_dataset(path).close()
    assert not incomplete_marks(tmp_path)
    assert_bitwise_equal(data_vars(tmp_path, n_chunks), reference[0])
