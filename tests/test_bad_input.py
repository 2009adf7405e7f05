"""Bad input is refused clearly (issue 7): a corpus of malformed scenes and study configs, each
refused with its key path, exit code 2 and nothing written; a fuzz test of the config
validator (the scene parser has its own in tests/test_scene.py)."""
from __future__ import annotations

import copy
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ced.study.cases
import ced.study.config
from ced.cli import main
from ced.problem.errors import SceneError
from ced.study.config import (MAX_GRID_POINTS, check_config, load_config, study_estimate,
                              validate_config)
from ced.study.cases import chunks
from tests.conftest import corpus_header, mutate_container

HERE = Path(__file__).parent
ROOT = HERE.parent
BAD_CONFIGS = sorted((HERE / "bad_configs").glob("*.yaml"))
BAD_SCENES = sorted((HERE / "bad_scenes").glob("*.yaml"))
TEST_STUDY = ROOT / "config" / "studies" / "test.yaml"


def test_corpus_is_large_enough():
    assert len(BAD_CONFIGS) >= 20
    assert len(BAD_CONFIGS) + len(BAD_SCENES) >= 65
    for path in BAD_CONFIGS:
        assert path.read_text().startswith("# expect: "), path.name


# ------------------------------------------------------------------------------ configs
@pytest.mark.parametrize("path", BAD_CONFIGS, ids=lambda p: p.stem)
def test_bad_config_names_the_key(path):
    with pytest.raises(SceneError) as err:
        validate_config(load_config(path))
    assert err.value.path == corpus_header(path, "expect"), str(err.value)
    assert corpus_header(path, "mentions") in err.value.message, str(err.value)
    assert str(err.value) == f"{err.value.path}: {err.value.message}"


@pytest.mark.parametrize("path", BAD_CONFIGS, ids=lambda p: p.stem)
def test_ced_check_exits_2_and_writes_nothing(path, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["check", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.startswith(f"ced: error: {corpus_header(path, 'expect')}: "), err
    assert list(tmp_path.iterdir()) == []


def test_ced_check_console_script(tmp_path):
    exe = Path(sys.executable).with_name("ced")
    bad = HERE / "bad_configs" / "nan_in_grid.yaml"
    result = subprocess.run([str(exe), "check", str(bad)], capture_output=True, text=True,
                            cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.strip() == ("ced: error: grids.four_bar.crank[1]: must be a finite "
                                     "number, got nan")
    assert result.stdout == "" and list(tmp_path.iterdir()) == []
    good = subprocess.run([str(exe), "check", str(TEST_STUDY)], capture_output=True, text=True,
                          cwd=tmp_path)
    assert good.returncode == 0, good.stderr
    assert "cases: 16 (20 grid points" in good.stdout
    assert "chunk jobs: 4 (crank_rocker 2, change_point 1, slider_crank 1)" in good.stdout
    assert list(tmp_path.iterdir()) == []


def test_missing_config_file(tmp_path, capsys):
    assert main(["check", str(tmp_path / "nowhere.yaml")]) == 2
    assert capsys.readouterr().err.startswith("ced: error: <config>: cannot read")


def test_huge_grid_is_refused_without_building_it(monkeypatch):
    """The size is estimated from the axis lengths: nothing of the grid is enumerated."""
    def forbidden(*args, **kwargs):
        raise AssertionError("the grid was built")

    for module in (ced.study.cases, ced.study.config):
        monkeypatch.setattr(module, "grid_values", forbidden)
        monkeypatch.setattr(module, "split_geometries", forbidden)
    config = load_config(HERE / "bad_configs" / "absurdly_large_grid.yaml")
    with pytest.raises(SceneError) as err:
        validate_config(config)
    assert f"more than the limit of {MAX_GRID_POINTS:.4g}" in err.value.message
    assert "estimated output at most 1.04 PB" in err.value.message  # stress at two fibres
    assert "peak memory per chunk job about" in err.value.message


def test_chunk_memory_limit_is_the_given_memory():
    config = load_config(TEST_STUDY)
    estimate = study_estimate(config)
    # The largest chunk (4 cases) must fit; one byte less than its estimate does not.
    assert estimate.largest_chunk == 4
    validate_config(config, memory=estimate.chunk_memory_bytes)
    with pytest.raises(SceneError) as err:
        validate_config(config, memory=estimate.chunk_memory_bytes - 1)
    assert err.value.path == "chunk_size" and "a chunk of 4 cases" in err.value.message


def test_validate_config_is_pure_and_check_config_fills_in_place():
    config = load_config(TEST_STUDY)
    before = copy.deepcopy(config)
    filled = validate_config(config)
    assert config == before  # not mutated
    assert filled["stress_safety_factor"] == 2.0 and filled["grids"]["slider_crank"][
        "offset"] == [0.0]
    assert check_config(config) == chunks(filled)
    assert config == filled


# ------------------------------------------------------------------------------ scenes
@pytest.mark.parametrize("path", BAD_SCENES, ids=lambda p: p.stem)
def test_ced_run_bad_scene_exits_2_and_writes_nothing(path, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    good = ROOT / "config" / "scenes" / "slider_crank.yaml"
    # The bad scene second: every scene is validated before anything is solved or written.
    assert main(["run", str(good), str(path), "-o", str(tmp_path / "run.nc")]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.startswith(f"ced: error: {corpus_header(path, 'expect')}: "), err
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------ snakemake
def test_snakemake_refuses_a_bad_config_before_any_job(tmp_path):
    bad = HERE / "bad_configs" / "unknown_effect_in_base_scene.yaml"
    cmd = [sys.executable, "-m", "snakemake", "--snakefile", str(ROOT / "Snakefile"),
           "--directory", str(tmp_path), "--profile", str(ROOT / "workflow/profiles/default"),
           "--cores", "1", "-n", "--configfile", str(bad)]
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    output = result.stdout + result.stderr
    assert result.returncode != 0
    assert "base_scene.effects[1]: unknown effect 'magnetism'" in output
    assert "Job stats" not in output and "rule " not in output
    assert not (tmp_path / "results").exists()


# ------------------------------------------------------------------------------ fuzz
#: Values a hand-written or generated config might hold where something else was meant.
junk = st.recursive(
    st.one_of(
        st.none(), st.booleans(),
        st.integers(-1000, 1000), st.sampled_from([0, -1, 10**7, 10**18, 2**63, -(10**30)]),
        st.floats(allow_nan=True, allow_infinity=True),
        st.sampled_from([0.0, -0.0, 1e-320, 1e308, -1e308, float("nan"), float("inf")]),
        st.text(max_size=8),
        st.sampled_from(["steel", "crank_rocker", "rectangle", "1e-3", "2.1e+11", "auto",
                         "inertia", "", "NaN"]),
    ),
    lambda children: st.one_of(st.lists(children, max_size=4),
                               st.dictionaries(st.one_of(st.text(max_size=6), st.sampled_from(
                                   ["start", "stop", "num", "shape", "height", "name", "E",
                                    "crank", "rod", "offset", "time", "effects"])),
                                   children, max_size=4)),
    max_leaves=8,
)

_SLIDER = {"study": "s", "grids": {"slider_crank": {"crank": [0.05, 0.1], "rod": [0.3],
                                                    "offset": {"start": 0.0, "stop": 0.02,
                                                               "num": 2}}},
           "speeds": {"start": 50.0, "stop": 100.0, "num": 2},
           "materials": ["steel", {"name": "soft", "E": 1e9, "rho": 1000.0, "nu": 0.3}],
           "sections": [{"shape": "circle", "diameter": 0.01}], "chunk_size": 3,
           "base_scene": {"time": {"revolutions": 1, "steps_per_revolution": 32},
                          "discretization": {"formulation": "rigid"}}}
VALID = [load_config(TEST_STUDY), load_config(ROOT / "config/studies/sung_thompson.yaml"),
         _SLIDER]


def _mutate(data, config):
    """Replace, delete or add one entry at a random place of ``config`` (in place)."""
    target = config
    while True:
        children = list(target.items()) if isinstance(target, dict) else list(
            enumerate(target))
        containers = [(k, v) for k, v in children if isinstance(v, (dict, list)) and v]
        if not containers or not data.draw(st.booleans(), label="descend"):
            break
        target = data.draw(st.sampled_from(containers), label="into")[1]
    mutate_container(data, target, junk, st.one_of(st.text(max_size=6), st.sampled_from(
        ["families", "chunk_size", "offset", "slider_mass", "num", "modal"])))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_fuzz_validator_raises_only_scene_errors(data):
    config = copy.deepcopy(data.draw(st.sampled_from(VALID), label="config"))
    for _ in range(data.draw(st.integers(1, 3), label="mutations")):
        _mutate(data, config)
    try:
        filled = validate_config(config, memory=2**40)
    except SceneError as err:
        assert isinstance(err.path, str) and err.path
        assert isinstance(err.message, str) and err.message
        assert str(err) == f"{err.path}: {err.message}"
        return
    # Accepted: the case table can be built and is what the estimate counted.
    sizes = chunks(filled)
    assert sizes and all(n > 0 for n in sizes.values())
    assert json.loads(json.dumps(filled, allow_nan=False)) == filled  # no NaN/inf slipped by
    assert all(math.isfinite(r["speed"]) and r["speed"] > 0
               for r in ced.study.cases.case_table(filled, scenes=False))


@settings(max_examples=60, deadline=None)
@given(st.text(max_size=120) | st.lists(st.sampled_from(
    ["study: x\n", "grids:\n", "  four_bar: {ground: 0.25, crank: [0.05], coupler: [0.2], "
     "rocker: [0.15]}\n", "speeds: [1.0e+2]\n", "materials: [steel]\n", "sections: [{shape: "
     "circle, diameter: 0.01}]\n", "- ", "{", "}", ": ", ".nan", "&a ", "*a ", "!!python/name:os"
     ".system ", "\t", "'"]), max_size=12).map("".join))
def test_fuzz_config_text_gives_a_config_or_a_scene_error(text):
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "config.yaml"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        try:
            validate_config(load_config(path), memory=2**40)
        except SceneError as err:
            assert err.path


def test_yaml_tags_are_not_executed(tmp_path):
    path = tmp_path / "config.yaml"
    path.write_text("study: !!python/object/apply:os.system ['touch hacked']\n")
    with pytest.raises(SceneError) as err:
        load_config(path)
    assert err.value.path == "<config>" and "invalid YAML" in err.value.message
    assert not (tmp_path / "hacked").exists() and not Path("hacked").exists()


# ------------------------------------------------------------------ bounded time and memory
def _limited():
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (2**30, 2**30))  # 1 GiB of address space


@pytest.mark.parametrize("args, key", [
    (["run", str(HERE / "bad_scenes" / "alias_bomb.yaml")], "<scene>"),
    (["run", "/dev/zero"], "<scene>"),
    (["check", str(HERE / "bad_configs" / "alias_bomb.yaml")], "<config>"),
    (["check", str(HERE / "bad_configs" / "deeply_nested.yaml")], "<config>"),
], ids=["scene_alias_bomb", "dev_zero", "config_alias_bomb", "config_nesting"])
def test_hostile_input_is_refused_in_bounded_memory(args, key, tmp_path):
    """Alias bombs, endless files and deep nesting exit 2 naming the document, in a process
    limited to 1 GiB of address space (the timeout only guards against a hang)."""
    exe = Path(sys.executable).with_name("ced")
    if args[0] == "run":
        args = [*args, "-o", str(tmp_path / "out.nc")]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    result = subprocess.run([str(exe), *args], capture_output=True, text=True, cwd=tmp_path,
                            preexec_fn=_limited, env=env, timeout=300)
    assert result.returncode == 2, result.stderr
    assert result.stderr.startswith(f"ced: error: {key}: "), result.stderr
    assert "Traceback" not in result.stderr and list(tmp_path.iterdir()) == []


def test_two_scenes_name_the_file_of_the_error(tmp_path, capsys):
    good = ROOT / "config" / "scenes" / "slider_crank.yaml"
    bad = HERE / "bad_scenes" / "zero_height.yaml"
    assert main(["run", str(good), str(bad), "-o", str(tmp_path / "run.nc")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"ced: error: {corpus_header(bad, 'expect')}: ")
    assert f"(in {bad})" in err
