"""What a run asks of the machine (ced.simulation.size): the estimate ced check uses, applied
by ced.simulate and ced run before any work."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

from ced.problem.errors import SceneError
from ced.problem.scene import load_scene
from ced.simulation.simulate import simulate
from ced.simulation.size import BASE_MEMORY_BYTES, check_run_memory, run_memory

FOUR_BAR = {"mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                          "rocker": 0.35}}
#: Every key is within its allowed range, but the products are not: 10⁹ steps (the time axis
#: alone is 8 GB), 2·10⁶ steps × 10,001 stations, 1,000 modes × 10⁵ modal angles of a
#: 512-element model.
ABSURD = [
    ("time.steps_per_revolution", {"time": {"revolutions": 1000, "steps_per_revolution": 10**6}}),
    ("time.steps_per_revolution", {"time": {"revolutions": 2, "steps_per_revolution": 10**6},
                                   "outputs": {"stations": 10001}}),
    ("modal.angles", {"modal": {"modes": 1000, "angles": 100000},
                      "discretization": {"elements_per_link": 512}}),
]


@pytest.mark.parametrize("key, scene", ABSURD, ids=["steps", "steps_and_stations", "modal"])
def test_absurd_products_are_refused_before_any_work(key, scene, monkeypatch):
    import ced.simulation.simulate as module

    def forbidden(*args, **kwargs):
        raise AssertionError("a batch was solved")
    monkeypatch.setattr(module, "solve_batch", forbidden)
    with pytest.raises(SceneError) as err:
        simulate({**FOUR_BAR, **scene})
    assert err.value.path == key
    assert "of memory, more than the" in err.value.message


def test_ced_run_refuses_in_bounded_memory(tmp_path):
    scene = tmp_path / "absurd.yaml"
    scene.write_text("mechanism: {type: four_bar, ground: 0.5, crank: 0.1, coupler: 0.45, "
                     "rocker: 0.35}\ntime: {revolutions: 1000, steps_per_revolution: 1000000}\n")

    def limited():
        import resource
        resource.setrlimit(resource.RLIMIT_AS, (2**30, 2**30))
    exe = Path(sys.executable).with_name("ced")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    result = subprocess.run([str(exe), "run", str(scene), "-o", str(tmp_path / "out.nc")],
                            capture_output=True, text=True, preexec_fn=limited, env=env,
                            timeout=300)
    assert result.returncode == 2, result.stderr
    assert result.stderr.startswith("ced: error: time.steps_per_revolution: the run needs")
    assert sorted(tmp_path.iterdir()) == [scene]


def test_a_modest_run_fits_and_the_limit_is_the_given_memory():
    scene = load_scene({**FOUR_BAR, "modal": {"modes": 3, "angles": 12}})
    need, _ = run_memory([scene] * 10)
    assert BASE_MEMORY_BYTES < need < 2 * 10**9
    assert check_run_memory([scene] * 10, memory=need) == need
    with pytest.raises(SceneError, match="more than the"):
        check_run_memory([scene] * 10, memory=need - 1)


@pytest.mark.parametrize("family", ["crank_rocker", "slider_crank"])
def test_case_bytes_is_the_size_of_a_chunk_dataset(family):
    from ced.simulation.size import case_bytes
    from ced.study.cases import chunk_rows
    from tests.study.test_cases import ROOT, load

    rows = chunk_rows(load(ROOT / "config" / "studies" / "test.yaml"), family, 0)
    ds = simulate([r["scene"] for r in rows])
    per_case = sum(v.nbytes for v in ds.variables.values() if "case" in v.dims) / len(rows)
    assert case_bytes(load_scene(rows[0]["scene"])) == pytest.approx(per_case, rel=0.1)


def test_solver_arrays_are_bounded_per_part_not_per_run():
    # The solver's working arrays count once, for the largest part; outputs count per case.
    from ced.simulation.size import cases_per_solve, case_memory, solver_bytes
    scene = load_scene({"mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1,
                                      "coupler": 0.45, "rocker": 0.35},
                        "time": {"steps_per_revolution": 1024}})
    part = cases_per_solve(scene)
    assert 1 <= part <= 256 and part * solver_bytes(scene) <= 256 * 2**20
    small, _ = run_memory([scene] * part)
    large, _ = run_memory([scene] * (10 * part))
    assert large - small == 9 * part * case_memory(scene)


def test_case_seconds_grows_with_the_model():
    from ced.problem.scene import load_scene
    from ced.simulation.size import case_seconds

    def seconds(**blocks):
        return case_seconds(load_scene({"mechanism": {"type": "four_bar", "ground": 0.5,
                                                      "crank": 0.1, "coupler": 0.45,
                                                      "rocker": 0.35}, **blocks}))

    rigid = seconds(discretization={"formulation": "rigid"})
    coarse = seconds(discretization={"elements_per_link": 2})
    fine = seconds(discretization={"elements_per_link": 16})
    assert 0 < rigid < coarse < fine
    assert seconds(time={"steps_per_revolution": 1024}) > seconds()
    assert seconds(time={"start": "periodic"}) > seconds()
    assert seconds(modal={"angles": 72}) > seconds()
    assert seconds(outputs={"error_estimate": False}) < seconds()


def test_a_thinned_history_counts_the_displacements_at_every_step():
    # The peaks are over every step (ced.response.elastic): with outputs.every > 1 the
    # displacements of every step are held although only every n-th is written.
    from ced.response.batch import step_count
    from ced.simulation.size import elastic_dofs, solver_bytes
    scenes = [load_scene({"mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1,
                                        "coupler": 0.45, "rocker": 0.35},
                          "outputs": {"every": every}}) for every in (1, 8)]
    n, steps = elastic_dofs(scenes[0]), step_count(scenes[0])
    assert solver_bytes(scenes[1]) - solver_bytes(scenes[0]) == 16 * (steps + 1) * n > 0


def test_modal_damping_counts_its_table():
    # ζ > 0 holds a table of C over the period (ced.response.modal_damping): the estimate
    # counts its largest, which bounds the change point's (its phases most refined).
    from ced.response.batch import make_batch
    from ced.response.model import build_model
    from ced.simulation.size import elastic_dofs, solver_bytes
    from tests.response.test_modal_damping import _scene
    damped, undamped = _scene(), _scene(damping={"model": "modal", "ratio": 0.0})
    table = solver_bytes(damped) - solver_bytes(undamped)
    assert table == 8 * (16 * 2**6 + 1) * elastic_dofs(damped) ** 2
    model = build_model(make_batch([damped]))
    assert model.modal_damping.matrix.nbytes <= table
