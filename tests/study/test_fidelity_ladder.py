"""The fidelity ladder on Simeon's slider-crank rod."""
import json

import numpy as np

from ced.study.fidelity_ladder import run_ladder, write_ladder
from tests.conftest import simeon


def test_ladder_orders_the_models_as_physics_says(tmp_path):
    scene = simeon(time={"steps_per_revolution": 256})
    rungs = ["rigid", "quasi_static_euler_bernoulli", "euler_bernoulli", "timoshenko",
             "seed_lame"]
    results = run_ladder(scene, link="rod", rungs=rungs)
    assert all(results[r]["available"] and results[r]["converged"] for r in rungs)
    eb, ti, seed = (results[r] for r in ("euler_bernoulli", "timoshenko", "seed_lame"))
    assert results["rigid"]["peak_stress"] == 0.0
    # Slender rod (L/h = 37.5): shear adds O((h/L)²) — Timoshenko within 1 % of EB.
    assert abs(ti["first_frequency"] / eb["first_frequency"] - 1) < 0.01
    # The thesis's II.5 model takes transverse load by shear: far too stiff (seed README).
    assert seed["first_frequency"] > 10 * eb["first_frequency"]
    assert seed["peak_deflection"] < 0.1 * eb["peak_deflection"]
    write_ladder(results, tmp_path)
    table = (tmp_path / "ladder.md").read_text()
    assert all(r in table for r in rungs)
    assert (tmp_path / "ladder.png").exists() and (tmp_path / "ladder.svg").exists()
    assert np.isfinite(json.loads((tmp_path / "ladder.json").read_text())["timoshenko"]
                       ["peak_stress"])
