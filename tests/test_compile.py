"""ced.compile: the warm-up scene reaches every kernel with the one signature other scenes use."""
import json
import subprocess
import sys

from ced.compile import WARM_UP_SCENE, kernels

#: Scenes unlike the warm-up scene: other starts, solvers, integrators, formulations,
#: mechanisms, damping and the automatic discretization.
_OTHERS = """
import json
from ced.compile import WARM_UP_SCENE, compile_kernels, kernels
from ced.simulation.simulate import simulate

def signatures():
    return {name: sorted(map(str, k.signatures)) for name, k in kernels().items()}

compile_kernels()
warm = signatures()
base = {**WARM_UP_SCENE, "time": {"revolutions": 1, "steps_per_revolution": 64}}
four_bar = WARM_UP_SCENE["mechanism"]
variants = [
    {"time": {"revolutions": 1, "steps_per_revolution": 64, "start": "undeformed"}},
    {"time": {"revolutions": 1, "steps_per_revolution": 64, "start": "quasi_static",
              "integrator": "houbolt"}},
    {"time": {"revolutions": 1, "steps_per_revolution": 512, "start": "periodic",
              "integrator": "hht"}},
    {"time": {"revolutions": 1, "steps_per_revolution": 64, "start": "periodic",
              "periodic_solver": "spectral"}},
    {"discretization": {"formulation": "timoshenko", "elements_per_link": 3}},
    {"discretization": {"formulation": "euler_bernoulli", "elements_per_link": 3,
                        "modes_per_link": 0}},
    {"discretization": {"formulation": "plane_stress", "elements_per_link": 4}},
    {"effects": ["inertia", "elastic_inertia", "damping"],
     "damping": {"model": "modal", "ratio": 0.01}},
    {"mechanism": {"type": "slider_crank", "crank": 0.1, "rod": 0.3}},
    {"mechanism": {"type": "watt_ii", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                   "rocker": 0.35, "rocker_arm": 0.25, "rocker_arm_angle": 2.5,
                   "coupler2": 0.4, "rocker2": 0.3, "pivot2_x": 0.2, "pivot2_y": -0.3},
     "links": {"crank": {"flexible": False}, "rocker": {"flexible": False}}},
    {"discretization": "auto", "tolerance": 0.05},
]
for variant in variants:
    simulate({**base, **variant})
print(json.dumps({"warm": warm, "after": signatures()}))
"""


def test_the_warm_up_scene_compiles_every_kernel_other_scenes_call():
    # A fresh process: the signatures seen are those of the warm-up and of these scenes only
    # (compiled or loaded from numba's cache; either way the same list).
    out = subprocess.run([sys.executable, "-c", _OTHERS], capture_output=True, text=True,
                         timeout=900, check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    warm, after = result["warm"], result["after"]
    # Kernels called from Python hold one signature after the warm-up; those called only
    # from other kernels hold one if compiled here, none if their callers came from the cache.
    assert {name for name, s in warm.items() if s} >= {
        "ced.response.spectral._solve_batch", "ced.response.kernels.newmark_march",
        "ced.response.kernels.newmark_march_packed",
        "ced.response.period_terms._interpolate", "ced.fem.recovery_kernel._recover"}
    assert all(len(s) <= 1 for s in warm.values())
    # No other scene needs a signature the warm-up did not compile.
    assert after == warm


def test_kernels_finds_the_compiled_functions_of_the_package():
    found = kernels()
    assert "ced.response.spectral._solve_batch" in found
    assert all(hasattr(k, "signatures") for k in found.values())
    # The warm-up scene is the default study's kind of solve.
    assert WARM_UP_SCENE["time"]["periodic_solver"] == "spectral"
