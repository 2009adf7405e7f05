"""The layout of ced (docs/architecture.md): layers that import only downward, one documented
concern per module, no private names across modules, one stand-in for the workflow scripts."""
from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "ced"
MODULES = sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")


def lint_imports(directory: Path) -> subprocess.CompletedProcess:
    """import-linter with the contracts of pyproject.toml, on the ``ced`` found in
    ``directory``."""
    env = {**os.environ, "PYTHONPATH": str(directory)}
    return subprocess.run([str(LINT_IMPORTS), "--config", str(ROOT / "pyproject.toml"),
                           "--no-cache"], cwd=directory, env=env, capture_output=True,
                          text=True, timeout=300)


def test_layers_are_kept():
    result = lint_imports(ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "Contracts: 2 kept, 0 broken." in result.stdout


def test_an_import_back_up_fails(tmp_path):
    """The contract bites: the scene parser importing the study layer breaks it."""
    shutil.copytree(PACKAGE, tmp_path / "ced", ignore=shutil.ignore_patterns("__pycache__"))
    scene = tmp_path / "ced" / "problem" / "scene.py"
    scene.write_text(scene.read_text() + "\nfrom ..study import cases  # noqa: E402\n")
    result = lint_imports(tmp_path)
    assert result.returncode != 0
    assert "ced.problem.scene -> ced.study.cases" in result.stdout


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_every_module_says_what_it_holds(path):
    docstring = ast.get_docstring(ast.parse(path.read_text()))
    assert docstring and len(docstring) > 40, f"{path}: no module docstring"
    if path.name == "__init__.py" and path.parent.parent == PACKAGE:
        assert "Imports:" in docstring, f"{path}: the layer's docstring names what it imports"


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_private_name_is_imported_from_another_module(path):
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and (node.level or (node.module or "") == "ced"
                                                 or (node.module or "").startswith("ced.")):
            private = [a.name for a in node.names
                       if a.name.startswith("_") and not a.name.startswith("__")]
            assert not private, f"{path}: imports private {private} from {node.module}"


def test_workflow_scripts_share_one_stand_in():
    scripts = sorted((ROOT / "workflow" / "scripts").glob("[!_]*.py"))
    assert len(scripts) >= 10
    for script in scripts:
        text = script.read_text()
        assert f'mock_snakemake("{script.stem}", *sys.argv[1:])' in text, script.name
        assert "SimpleNamespace" not in text, script.name


def test_a_script_runs_on_its_own(tmp_path):
    """The stand-in gives a script what Snakemake would: the rule's own output path for the
    wildcards, the case config as params. Run in a copy of the workflow so that nothing lands
    in the repository's results/."""
    for name in ("Snakefile", "workflow", "config"):
        copy = shutil.copytree if (ROOT / name).is_dir() else shutil.copy
        copy(ROOT / name, tmp_path / name)
    script = tmp_path / "workflow" / "scripts" / "simulate_chunk.py"
    result = subprocess.run(
        [sys.executable, str(script), "config/studies/test.yaml", "family=change_point",
         "chunk=0"], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    chunk = tmp_path / "results" / "test" / "chunks" / "change_point" / "0.nc"
    log = tmp_path / "results" / "test" / "logs" / "simulate" / "change_point" / "0.log"
    assert chunk.stat().st_size > 0
    assert "change_point/0:" in log.read_text()
