"""Stiff axial modes integrated with steps far beyond their period (h ω_axial ≥ 100)."""
import math

import numpy as np
import pytest

from ced.simulation.simulate import simulate
from tests.hard_cases.helpers import assert_finite

L, H, E, RHO = 0.5, 0.005, 2.1e11, 7850.0
#: Clamped–free rod and cantilever: ω_axial = (π/2) √(E/ρ)/L, ω_bend = 3.516 √(EI/ρA)/L².
OMEGA_AXIAL = 0.5 * math.pi * math.sqrt(E / RHO) / L
OMEGA_BEND = 3.516 * math.sqrt(E * H**2 / 12 / RHO) / L**2
SPEED, STEPS = 7.5, 128  # h = 2π/(Ω·128) = 6.5 ms


def scene(integrator, steps=STEPS, start="periodic", revolutions=1):
    # A cantilever turning at 7.5 rad/s in the vertical plane: gravity, rotating in the link
    # frame, bends it once per revolution (Ω/ω_bend ≈ 0.07) and loads it axially.
    return {"mechanism": {"type": "single_link", "length": L},
            "links": {"default": {"material": {"E": E, "rho": RHO, "nu": 0.3},
                                  "section": {"shape": "rectangle", "height": H,
                                              "width": 0.01}}},
            "drive": {"speed": SPEED},
            "effects": ["inertia", "elastic_inertia", "gravity", "coriolis", "centrifugal",
                        "axial_stiffening"],
            "discretization": {"elements_per_link": 4},
            "time": {"revolutions": revolutions, "steps_per_revolution": steps,
                     "integrator": integrator, "start": start},
            "outputs": {"stations": 5}}


def test_the_case_is_stiff():
    h = 2 * math.pi / SPEED / STEPS
    assert OMEGA_AXIAL / OMEGA_BEND >= 100  # ≈ 155
    assert h * OMEGA_AXIAL >= 100  # ≈ 106


@pytest.fixture(scope="module")
def reference():
    # Resolved in time (h ω_axial ≈ 2.5, Ω h ≈ 1.5e-3): the periodic bending response.
    return simulate(scene("newmark", steps=4096)).deflection.values[0, ::4096 // STEPS, 0, 2]


@pytest.mark.parametrize("integrator", ["generalized_alpha", "hht", "houbolt", "newmark"])
def test_large_steps_keep_bending_accurate(integrator, reference):
    ds = simulate(scene(integrator))
    assert_finite(ds)
    mid = ds.deflection.values[0, :, 0, 2]  # mid-span deflection from the chord, m
    error = np.abs(mid - reference).max() / np.abs(reference).max()
    # The dissipative schemes damp the unresolved axial mode and keep the bending response;
    # Newmark's trapezoidal rule keeps it undamped but bounded.
    assert error < (0.01 if integrator != "newmark" else 0.05), error
    assert float(ds.floquet_multiplier_max[0]) <= 1.0 + 1e-6
    assert int(ds.status[0]) == 0


@pytest.mark.parametrize("integrator", ["generalized_alpha", "hht", "houbolt", "newmark"])
def test_undeformed_start_stays_bounded(integrator):
    # Released undeformed, the centrifugal and gravity loads hit the axial mode as a step; no
    # scheme may amplify it. Bound: twice the static axial stretch of the centrifugal load,
    # u(L) = ρΩ²L³/(3E) (the dynamic overshoot of a suddenly applied load is at most 2×),
    # plus the gravity stretch ρgL²/(2E).
    ds = simulate(scene(integrator, start="undeformed", revolutions=4))
    assert_finite(ds)
    tip = np.abs(ds.axial_displacement.values[0, :, 0, -1]).max()
    static = RHO * SPEED**2 * L**3 / (3 * E) + RHO * 9.81 * L**2 / (2 * E)
    assert tip < 2.0 * static * 1.05
