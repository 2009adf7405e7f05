"""Compile the numerical kernels once, ahead of the first solve (``ced compile``).

numba compiles a kernel the first time a process calls it and keeps the machine code in its
on-disk cache (``__pycache__`` beside the source, or ``NUMBA_CACHE_DIR``); later processes
load it in milliseconds. Without this step the first jobs of a study each compile every
kernel themselves, at the same time: about 15 s per process on this project's reference
machine (measured on a default-study chunk: 16.2 s cold, 0.8 s with the cache), twice over
on two cores. The Makefile's install step runs it, as a package with a C extension compiles
at install.

Every kernel is called with one type signature whatever the scene (checked by
``tests/test_compile.py`` on the default study's scene, a start transient, the other
integrators, formulations and mechanisms): one small periodic scene solved by the spectral
solver with its error estimate reaches all of them but those on sparse step matrices, which
the same scene with every FE DOF reaches, and a coarse six-bar those of a linkage of dyads.
"""
from __future__ import annotations

import importlib
import pkgutil

__all__ = ["compile_kernels", "kernels", "WARM_UP_SCENE", "WARM_UP_SPARSE", "WARM_UP_SIX_BAR"]

#: Solved by :func:`compile_kernels`: the default study's base scene (spectral periodic state,
#: Craig–Bampton links, Floquet analysis by shooting, forced-resonance check, modal analysis,
#: error estimate) on the reference four-bar; 256 steps per revolution so that the period's
#: terms are sampled and interpolated (:mod:`ced.response.period_terms`).
WARM_UP_SCENE = {
    "mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                  "rocker": 0.35},
    "links": {"crank": {"flexible": False}},
    "drive": {"speed": 100.0},
    "effects": ["inertia", "elastic_inertia", "coriolis", "centrifugal", "axial_stiffening"],
    "discretization": {"formulation": "euler_bernoulli", "elements_per_link": 4,
                       "modes_per_link": 2},
    "time": {"revolutions": 1, "steps_per_revolution": 256, "start": "periodic",
             "periodic_solver": "spectral", "collocation_points": 8},
    "modal": {"modes": 1, "angles": 2},
    "outputs": {"stations": 3},
}
#: The same with every FE DOF, whose step matrices are sparse (the kernels on packed terms,
#: :mod:`ced.response.step_pattern`), at 128 steps per revolution: the terms evaluated at every
#: step; with Rayleigh damping, whose elastic stiffness is formed link by link apart
#: (:func:`ced.fem.sandwich.sandwich_add`).
WARM_UP_SPARSE = {**WARM_UP_SCENE,
                  "effects": [*WARM_UP_SCENE["effects"], "damping"],
                  "damping": {"model": "rayleigh", "alpha": 1.0, "beta": 1e-5},
                  "discretization": {**WARM_UP_SCENE["discretization"], "modes_per_link": 0},
                  "time": {**WARM_UP_SCENE["time"], "steps_per_revolution": 128}}

#: A six-bar (a linkage of dyads with a ternary link), coarse: the compiled loops of its
#: kinematics (:mod:`ced.rigid.dyads`) and of its ternary link's loads
#: (:mod:`ced.response.model`), which the four-bars do not reach.
WARM_UP_SIX_BAR = {
    "mechanism": {"type": "watt_ii", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                  "rocker": 0.35, "rocker_arm": 0.25, "rocker_arm_angle": 2.5, "coupler2": 0.4,
                  "rocker2": 0.3, "pivot2_x": 0.2, "pivot2_y": -0.3},
    "discretization": {"formulation": "euler_bernoulli", "elements_per_link": 2},
    "time": {"revolutions": 1, "steps_per_revolution": 64},
}


def kernels() -> dict[str, object]:
    """Every compiled kernel of the package (numba dispatchers), by qualified name.

    Returns
    -------
    dict
        ``{"ced.response.spectral._solve_batch": dispatcher, …}``; a dispatcher's
        ``signatures`` lists the type signatures compiled (or loaded from the cache) so far.
    """
    from numba.core.registry import CPUDispatcher

    import ced

    found = {}
    for info in pkgutil.walk_packages(ced.__path__, "ced."):
        if info.name in (__name__, "ced.cli") or ".study" in info.name:
            continue  # no kernels there; the study modules pull in plotting
        module = importlib.import_module(info.name)
        for name, value in vars(module).items():
            if isinstance(value, CPUDispatcher) and value.__module__ == info.name:
                found[f"{info.name}.{name}"] = value
    return found


def compile_kernels() -> dict[str, int]:
    """Compile (or load from numba's cache) every kernel a solve calls.

    Returns
    -------
    dict
        Kernel name → number of type signatures it holds afterwards. A kernel called only
        from other kernels holds one where it was compiled in this process and none where its
        callers came from the cache (they carry it compiled in).
    """
    from .simulation.simulate import simulate

    simulate(WARM_UP_SCENE)
    simulate(WARM_UP_SPARSE)
    simulate(WARM_UP_SIX_BAR)
    return {name: len(kernel.signatures) for name, kernel in kernels().items()}
