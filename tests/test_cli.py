"""``ced run`` and ``ced classify`` as a user runs them."""
import subprocess
import sys
from pathlib import Path

import xarray as xr

from ced.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_run_writes_dataset(tmp_path, capsys):
    out = tmp_path / "slider.nc"
    assert main(["run", str(ROOT / "config/scenes/slider_crank.yaml"), "-o", str(out)]) == 0
    with xr.open_dataset(out, engine="netcdf4") as ds:
        assert ds.sizes["case"] == 1
        assert "guide_force" in ds and "input_torque" in ds
    assert "slider_crank status=ok" in capsys.readouterr().out


def test_bad_scene_exits_2_names_key_and_writes_nothing(tmp_path):
    scene = tmp_path / "bad.yaml"
    scene.write_text("mechanism: {type: four_bar, ground: 0.5, crank: 0.1, coupler: 0.45, "
                     "rocker: 0.35}\nlinks: {coupler: {section: {shape: rectangle, "
                     "height: -0.005, width: 0.01}}}\n")
    out = tmp_path / "out.nc"
    result = subprocess.run([sys.executable, "-m", "ced.cli", "run", str(scene), "-o", str(out)],
                            capture_output=True, text=True)
    assert result.returncode == 2
    assert "links.coupler.section.height" in result.stderr
    assert not out.exists() and list(tmp_path.iterdir()) == [scene]


def test_console_script_classify():
    exe = Path(sys.executable).with_name("ced")
    result = subprocess.run([str(exe), "classify", "--ground", "1", "--crank", "3",
                             "--coupler", "2", "--rocker", "2"], capture_output=True, text=True)
    assert result.returncode == 0 and result.stdout.startswith("change_point")


def test_check_prints_the_study_size(capsys):
    assert main(["check", str(ROOT / "config/config.yaml")]) == 0
    out = capsys.readouterr().out
    assert "cases: 11536 (12176 grid points" in out
    assert "chunk jobs: 27 (" in out
    assert "estimated output: 0.661 GB uncompressed" in out
    assert "estimated peak memory per chunk job: " in out
