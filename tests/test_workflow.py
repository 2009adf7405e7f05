"""The Snakemake pipeline (docs/guide/first_study.md): dry runs of every config, lint, and the tiny test study
run end to end in a temporary directory (nothing lands in the repository's results/)."""
import re
import subprocess
import sys
from pathlib import Path

import pytest
import xarray as xr
import yaml
from snakemake.utils import validate

from ced.study.convergence import load_sweep
from ced.study.cases import chunks
from ced.io import open_dataset

ROOT = Path(__file__).resolve().parents[1]
SNAKEFILE = ROOT / "Snakefile"
PROFILE = ROOT / "workflow" / "profiles" / "default"
SCHEMA = ROOT / "workflow" / "schemas" / "config.schema.yaml"
CONFIGS = [ROOT / "config" / "config.yaml", *sorted((ROOT / "config" / "studies").glob("*.yaml"))]
TEST_STUDY = ROOT / "config" / "studies" / "test.yaml"
FAMILIES = ("crank_rocker", "change_point", "slider_crank")


def snakemake(*args, directory: Path, timeout=900) -> subprocess.CompletedProcess:
    """Run Snakemake on the repository's workflow with ``directory`` as working directory."""
    cmd = [sys.executable, "-m", "snakemake", "--snakefile", str(SNAKEFILE),
           "--directory", str(directory), "--profile", str(PROFILE), "--cores", "2", *args]
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=directory)
    assert result.returncode == 0, f"{' '.join(cmd)}\n{result.stdout}\n{result.stderr}"
    return result


def job_counts(output: str) -> dict[str, int]:
    """The 'Job stats' table of a Snakemake run."""
    table = output.split("Job stats:")[1]
    return {m[1]: int(m[2]) for m in re.finditer(r"^(\w+)\s+(\d+)\s*$", table, re.M)}


def load(path: Path) -> dict:
    config = yaml.safe_load(path.read_text())
    validate(config, str(SCHEMA))
    return config


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: p.name)
def test_dry_run(path, tmp_path):
    result = snakemake("-n", "--configfile", str(path), directory=tmp_path)
    output = result.stdout + result.stderr
    config = load(path)
    counts = job_counts(output)
    n_chunks = chunks(config)
    assert counts["simulate_chunk"] == sum(n_chunks.values())
    assert counts["reduce_family"] == len(n_chunks)
    assert counts["overview_figure"] == 1
    assert counts["fidelity_ladder"] == 1
    assert counts["resonance_map"] == len(n_chunks)
    assert counts["worst_case_figure"] == len(n_chunks)
    assert counts["safe_speed_table"] == 1
    expected = len(n_chunks) if config["base_scene"].get("modal") else 0
    assert counts.get("campbell_figure", 0) == expected
    assert f"results/{config['study']}/maps/" in output
    # Convergence study: one job per family of the sweep (config key `convergence`, a path
    # relative to the repository root or the block itself) and one summary; none without it.
    sweep = load_sweep(config, root=ROOT)
    families = list(sweep["families"]) if sweep else []
    assert counts.get("convergence_family", 0) == len(families)
    assert counts.get("convergence_summary", 0) == (1 if families else 0)
    assert counts.get("pareto_figure", 0) == len(families)
    for family in families:
        assert f"results/{config['study']}/convergence/{family}.nc" in output
        assert f"results/{config['study']}/figures/accuracy/{family}.png" in output
    assert not (tmp_path / "results").exists()  # a dry run writes nothing


def test_default_config_runs_the_convergence_study():
    """The default study points at the convergence sweep, whose families are study families
    (test_dry_run checks one convergence_family job for each)."""
    sweep = load_sweep(load(CONFIGS[0]), root=ROOT)
    assert sweep is not None and len(sweep["families"]) >= 1
    known = yaml.safe_load(SCHEMA.read_text())["properties"]["families"]["items"]["anyOf"][0]["enum"]
    assert set(sweep["families"]) <= set(known)


def test_accuracy_under_one_heading():
    """The fidelity ladder and the convergence study (Pareto plots, accuracy table) are in one
    report category: what accuracy costs in time."""
    rules = ROOT / "workflow" / "rules"
    heading = 'category="What accuracy costs in time"'
    assert heading in (rules / "ladder.smk").read_text()
    convergence = (rules / "convergence.smk").read_text()
    assert convergence.count(heading) >= 4  # csv, md, Pareto png per family, estimate png
    assert "category=" not in convergence.replace(heading, "")


def test_study_replaces_default_config(tmp_path):
    """--configfile replaces config/config.yaml (profile: replace-workflow-config), so a study
    does not inherit the default study's grids (Snakemake would merge nested keys)."""
    (tmp_path / "config").mkdir()
    (tmp_path / "config" / "config.yaml").write_text((CONFIGS[0]).read_text())
    result = snakemake("-n", "--configfile", str(TEST_STUDY), directory=tmp_path)
    output = result.stdout + result.stderr
    assert "is replaced by additional config" in output
    counts = job_counts(output)
    assert counts["simulate_chunk"] == sum(chunks(load(TEST_STUDY)).values())


def test_lint():
    """No lint other than 'specify a conda environment or container' (the environment is the
    project's venv, see Makefile)."""
    result = subprocess.run([sys.executable, "-m", "snakemake", "--lint"], cwd=ROOT,
                            capture_output=True, text=True, timeout=600)
    text = result.stdout + result.stderr
    lints = re.findall(r"^\s+\* (.+?):?$", text, re.M)
    assert "Lints for" in text or result.returncode == 0, text
    others = [lint for lint in lints if "conda environment or container" not in lint]
    assert not others, text
    rules = re.findall(r"^Lints for rule (\w+)", text, re.M)
    assert set(rules) <= {"simulate_chunk", "reduce_family", "overview_figure",
                          "estimate_figure", "campbell_figure", "fidelity_ladder", "resonance_map",
                          "worst_case_figure", "safe_speed_table", "convergence_family",
                          "convergence_summary", "pareto_figure"}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The tiny test study, run end to end with its report, in a temporary directory."""
    directory = tmp_path_factory.mktemp("workflow")
    before = sorted((ROOT / "results").rglob("*")) if (ROOT / "results").exists() else []
    snakemake("--configfile", str(TEST_STUDY), directory=directory)
    report = directory / "results" / "test" / "report.html"
    snakemake("--configfile", str(TEST_STUDY), "--report", str(report), directory=directory)
    again = snakemake("-n", "--configfile", str(TEST_STUDY), directory=directory)
    after = sorted((ROOT / "results").rglob("*")) if (ROOT / "results").exists() else []
    return directory / "results" / "test", again.stdout + again.stderr, before == after


def test_run_leaves_repository_results_alone(run):
    _, _, unchanged = run
    assert unchanged
    assert not (ROOT / "results" / "test").exists()


def test_rerun_has_nothing_to_do(run):
    """Params are a pure function of the config: a second run rebuilds nothing."""
    _, output, _ = run
    assert "Nothing to be done" in output


def cf_problems(ds: xr.Dataset, index_units: bool = True) -> list[str]:
    """Missing global CF attributes, long_name on any variable, units on numeric ones
    (integer index coordinates such as step and mode excepted unless ``index_units``)."""
    problems = [f"global {k}" for k in ("Conventions", "title", "source", "history")
                if k not in ds.attrs]
    for name, var in ds.variables.items():
        if "long_name" not in var.attrs:
            problems.append(f"{name}: long_name")
        index = name in ds.dims and var.dtype.kind in "iu"
        if var.dtype.kind in "fiu" and "units" not in var.attrs and (index_units or not index):
            problems.append(f"{name}: units")
    return problems


@pytest.mark.parametrize("family", FAMILIES)
def test_outputs_open_with_cf_attributes(run, family):
    results, _, _ = run
    config = load(TEST_STUDY)
    n_chunks = chunks(config)[family]
    for i in range(n_chunks):
        with open_dataset(results / "chunks" / family / f"{i}.nc") as ds:
            assert ds.attrs["Conventions"] == "CF-1.12"
            assert not cf_problems(ds, index_units=False)
            assert ds.case.attrs["units"] == "1"
            assert "deflection" in ds and "natural_frequency" in ds
    with open_dataset(results / "maps" / f"{family}.nc") as cases:
        assert not cf_problems(cases)
        assert cases.case.values.tolist() == list(range(cases.sizes["case"]))
        assert set(cases.family.values.tolist()) == {family}
        assert {"peak_input_torque", "peak_stress", "natural_frequency_min",
                "natural_frequency_max", "status"} <= set(cases.data_vars)
        assert "flag_meanings" in cases.status.attrs
    with open_dataset(results / "maps" / f"{family}_grid.nc") as grid:
        assert not cf_problems(grid)
        assert {"speed", "material"} <= set(grid.dims)
        assert grid.attrs["Conventions"] == "CF-1.12"
    assert (results / "benchmarks" / "simulate" / family / "0.tsv").stat().st_size > 0
    assert (results / "logs" / "simulate" / family / "0.log").exists()
    for ext in ("png", "svg"):
        assert (results / "figures" / "campbell" / f"{family}.{ext}").stat().st_size > 1000


def test_figures_and_report(run):
    results, _, _ = run
    for ext in ("png", "svg"):
        assert (results / "figures" / f"overview.{ext}").stat().st_size > 1000
    report = (results / "report.html").read_text()
    assert "Campbell diagram of the" in report and "crank_rocker" in report
    assert "{{" not in report.split("<body", 1)[-1][:2000]


SIX_BAR_STUDY = ROOT / "config" / "studies" / "six_bar.yaml"


@pytest.fixture(scope="module")
def six_bar_run(tmp_path_factory):
    """The small six-bar study, run end to end in a temporary directory (about a minute)."""
    directory = tmp_path_factory.mktemp("six_bar")
    snakemake("--configfile", str(SIX_BAR_STUDY), directory=directory)
    return directory / "results" / "six_bar"


def test_six_bar_study_end_to_end(six_bar_run):
    """Every six-bar family reduced onto its own grid, figured, and in the safe-speed table."""
    import pandas as pd

    from ced.study.cases import family_sizes, kept_geometries

    config = load(SIX_BAR_STUDY)
    sizes = family_sizes(config)
    assert len(sizes) == 3 and all(f.startswith(("watt_ii-", "stephenson_iii-")) for f in sizes)
    for family, n in sizes.items():
        with xr.open_dataset(six_bar_run / "maps" / f"{family}.nc") as cases:
            assert not cf_problems(cases)
            assert cases.sizes["case"] == n
            assert set(cases.family.values.tolist()) == {family}
            assert cases.sizes["link"] == 5  # crank, coupler, rocker, coupler2, rocker2
        with xr.open_dataset(six_bar_run / "maps" / f"{family}_grid.nc") as grid:
            assert not cf_problems(grid)
            assert int((grid["case"] >= 0).sum()) == n  # every case on its own grid point
        for kind in ("campbell", "resonance", "worst_case"):
            assert (six_bar_run / "figures" / kind / f"{family}.png").stat().st_size > 1000
    table = pd.read_csv(six_bar_run / "tables" / "safe_speed.csv")
    assert len(table) == len(kept_geometries(config))
    assert set(table.family) == set(sizes)
