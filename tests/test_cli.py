"""``ced run`` and ``ced classify`` as a user runs them."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import xarray as xr

from ced.cli import main
from ced.io import open_dataset

ROOT = Path(__file__).resolve().parents[1]


def test_run_writes_dataset(tmp_path, capsys):
    out = tmp_path / "slider.nc"
    assert main(["run", str(ROOT / "config/scenes/slider_crank.yaml"), "-o", str(out)]) == 0
    with open_dataset(out) as ds:
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
    assert "estimated output: 1.5 GB uncompressed" in out  # stress at two fibres
    assert "estimated peak memory per chunk job: " in out


SCENE = ROOT / "config/scenes/sung_thompson_rigid.yaml"


def refused(args, capsys, monkeypatch) -> str:
    """``ced run`` exits 2 before any work: simulate is never called."""
    import ced.simulation.simulate

    def forbidden(*a, **k):
        raise AssertionError("simulate ran")
    monkeypatch.setattr(ced.simulation.simulate, "simulate", forbidden)
    assert main(["run", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("ced: error: output: "), err
    return err


def test_output_directory_empty_or_missing_parent_is_refused(tmp_path, capsys, monkeypatch):
    assert "is a directory" in refused([str(SCENE), "-o", str(tmp_path)], capsys, monkeypatch)
    assert "got ''" in refused([str(SCENE), "-o", ""], capsys, monkeypatch)
    typo = tmp_path / "resluts" / "out.nc"
    assert "does not exist" in refused([str(SCENE), "-o", str(typo)], capsys, monkeypatch)
    assert not typo.parent.exists()  # no tree made from a typo
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert "not a directory" in refused([str(SCENE), "-o", str(blocker / "out.nc")], capsys,
                                        monkeypatch)


def test_output_equal_to_the_input_scene_is_refused(tmp_path, capsys, monkeypatch):
    scene = tmp_path / "scene.yaml"
    scene.write_bytes(SCENE.read_bytes())
    assert "is the input" in refused([str(scene), "-o", str(scene)], capsys, monkeypatch)
    assert scene.read_bytes() == SCENE.read_bytes()


def test_write_failure_exits_2_naming_output_and_keeps_the_old_file(tmp_path, capsys,
                                                                     monkeypatch):
    out = tmp_path / "out.nc"
    out.write_bytes(b"earlier result")

    def disk_full(*args, **kwargs):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(xr.Dataset, "to_netcdf", disk_full)
    assert main(["run", str(SCENE), "-o", str(out)]) == 2
    assert "ced: error: output: cannot write" in capsys.readouterr().err
    assert out.read_bytes() == b"earlier result"
    assert sorted(tmp_path.iterdir()) == [out]


def test_concurrent_writers_of_one_path_never_crash_each_other(tmp_path):
    """Two processes write the same file 20 times each: neither fails (a writer's live
    temporary file is not swept by the other), and the file left is one complete dataset."""
    out = tmp_path / "shared.nc"
    writer = ("import sys, numpy as np, xarray as xr; from ced.io import write_dataset\n"
              "ds = xr.Dataset({'x': (('case', 'step'), np.full((64, 4096), float(sys.argv[2])),"
              " {'units': '1', 'long_name': 'x'})})\n"
              "for _ in range(20): write_dataset(ds, sys.argv[1])\n")
    procs = [subprocess.Popen([sys.executable, "-c", writer, str(out), str(v)],
                              stderr=subprocess.PIPE, text=True) for v in (1.0, 2.0)]
    for proc in procs:
        _, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err
    with open_dataset(out) as ds:
        values = np.unique(ds.x.values)
    assert values.tolist() in ([1.0], [2.0])
    assert sorted(tmp_path.iterdir()) == [out]


def test_unwritable_output_directory_is_refused(tmp_path, capsys, monkeypatch):
    # CI runs as root, for whom every directory is writable: the permission test itself is
    # stood in for (os.access is what check_output asks).
    import ced.io

    monkeypatch.setattr(ced.io.os, "access", lambda path, mode: False)
    err = refused([str(SCENE), "-o", str(tmp_path / "out.nc")], capsys, monkeypatch)
    assert "permission denied" in err


def test_a_failed_solve_is_a_message_not_a_traceback(tmp_path, capsys, monkeypatch):
    import ced.simulation.simulate

    def broken(*args, **kwargs):
        raise np.linalg.LinAlgError("Singular matrix")
    monkeypatch.setattr(ced.simulation.simulate, "solve_batch", broken)
    monkeypatch.delenv("CED_TRACEBACK", raising=False)
    assert main(["run", str(SCENE), "-o", str(tmp_path / "out.nc")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("ced: error: the run failed: LinAlgError: Singular matrix")
    assert not (tmp_path / "out.nc").exists()


def test_version(capsys):
    import ced

    try:
        main(["--version"])
    except SystemExit as exit_:
        assert exit_.code == 0
    assert capsys.readouterr().out.strip() == f"ced {ced.__version__}"


def test_run_without_output_writes_the_scene_name_here(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(SCENE)]) == 0
    assert (tmp_path / "sung_thompson_rigid.nc").exists()
    assert "wrote sung_thompson_rigid.nc" in capsys.readouterr().out


def test_every_help_has_an_example(capsys):
    for args in ([], ["run"], ["check"], ["classify"], ["ladder"]):
        try:
            main([*args, "--help"])
        except SystemExit:
            pass
        out = capsys.readouterr().out
        assert "examples:\n  ced " in out, args


def test_check_prints_an_estimated_run_time(capsys):
    assert main(["check", str(ROOT / "config/studies/test.yaml"), "--cores", "4"]) == 0
    out = capsys.readouterr().out
    assert "estimated run time on 4 cores: " in out


def test_compile_solves_the_warm_up_scenes_and_says_so(capsys, monkeypatch):
    # ced compile solves the warm-up scenes through simulate (which compiles, or loads from
    # numba's cache, every kernel) and reports it; exit 0.
    import ced.simulation.simulate as simulation
    from ced.compile import WARM_UP_SCENE, WARM_UP_SIX_BAR, WARM_UP_SPARSE

    solved = []
    real = simulation.simulate
    monkeypatch.setattr(simulation, "simulate",
                        lambda scenes: solved.append(scenes) or real(scenes))
    assert main(["compile"]) == 0
    assert solved == [WARM_UP_SCENE, WARM_UP_SPARSE, WARM_UP_SIX_BAR]
    assert "kernels compiled, or loaded from numba's cache, in" in capsys.readouterr().out
