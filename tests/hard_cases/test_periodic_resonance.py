"""Exact resonance without damping, and a parametrically unstable mechanism (|μ| > 1)."""
import math

import numpy as np
from scipy.integrate import solve_ivp

from ced.response.periodic import INSTABILITY_MARGIN
from ced.simulation.simulate import simulate
from tests.hard_cases.helpers import assert_finite, flags

STEPS = 64


def link(effects, speed, modal=None, **extra):
    s = {"mechanism": {"type": "single_link", "length": 0.5},
         "drive": {"speed": speed}, "effects": effects,
         "discretization": {"elements_per_link": 2},
         "time": {"revolutions": 1, "steps_per_revolution": STEPS, "start": "periodic",
                  "integrator": "newmark"},
         "outputs": {"stations": 3}, **extra}
    if modal:
        s["modal"] = modal
    return s


def test_exact_resonance_without_damping_is_flagged_and_finite():
    # Without motion-induced terms the cantilever's matrices are constant and gravity, turning
    # in the link frame, forces it at Ω. The trapezoidal rule turns a mode ω by 2 atan(ωh/2)
    # per step, so Ω = ω π/(N tan(π/N)) is an exact resonance of the discrete system:
    # I − Φ is singular and the minimum-norm periodic state keeps the results finite.
    effects = ["inertia", "elastic_inertia", "gravity"]
    probe = simulate(link(effects, 10.0, modal={"modes": 1, "angles": 1}))
    omega = 2 * math.pi * float(probe.natural_frequency.values[0, 0, 0])
    speed = omega * math.pi / (STEPS * math.tan(math.pi / STEPS))
    ds = simulate(link(effects, speed, damping={"model": "modal", "ratio": 0.0}))
    assert_finite(ds)
    # Exact resonance: the true response grows without bound, so the linear model's validity
    # limit is also reported; never an instability (the undamped multipliers are on |μ| = 1).
    assert flags(ds) == {"resonant", "large_deflection"}
    assert abs(float(ds.floquet_multiplier_max[0]) - 1) < 1e-9  # undamped, stable
    detuned = simulate(link(effects, 0.8 * speed))
    assert flags(detuned) == set()
    assert_finite(detuned)


def test_tip_mass_pendulum_at_twice_its_frequency_is_parametrically_unstable():
    # A 10 kg tip mass on a cantilever turning in the vertical plane: gravity modulates the
    # axial force by ±mg once per revolution, and with it the geometric stiffness ±mg/L of
    # the in-plane mode: ω² varies by about ±30 % over the cycle. The mean ω grows with Ω
    # (centrifugal stiffening of the distributed link), so Ω = 2ω̄(Ω) is found by fixed-point
    # iteration (contraction factor ≈ 0.6). Driven there this is Mathieu's principal tongue:
    # a multiplier > 1. Reference: Hill's equation q̈ + ω²(t) q = 0 with ω(t) the solver's
    # own frozen frequency over the cycle.
    effects = ["inertia", "elastic_inertia", "gravity", "centrifugal", "axial_stiffening"]
    mass = {"point_masses": {"B": 10.0}}
    speed = 10.0
    for _ in range(8):
        probe = simulate(link(effects, speed, modal={"modes": 1, "angles": 16},
                              time={"revolutions": 0.125, "steps_per_revolution": 64}, **mass))
        speed = 4 * math.pi * float(probe.natural_frequency.values[0, :, 0].mean())
    ds = simulate(link(effects, speed, modal={"modes": 1, "angles": 64},
                       time={"revolutions": 1, "steps_per_revolution": 1024, "start": "periodic",
                             "integrator": "newmark"}, **mass))
    assert_finite(ds)
    mu = float(ds.floquet_multiplier_max[0])
    assert "parametrically_unstable" in flags(ds) and mu > 1 + INSTABILITY_MARGIN
    w2 = (2 * math.pi * ds.natural_frequency.values[0, :, 0]) ** 2
    phase = 2 * math.pi * np.arange(64) / 64
    period = 2 * math.pi / speed

    def rhs(t, y):
        k = np.interp((speed * t) % (2 * math.pi), phase, w2, period=2 * math.pi)
        return [y[1], -k * y[0]]
    cols = [solve_ivp(rhs, (0, period), y0, rtol=1e-10, atol=1e-12).y[:, -1]
            for y0 in ([1.0, 0.0], [0.0, 1.0])]
    mu_hill = np.abs(np.linalg.eigvals(np.array(cols).T)).max()
    assert mu_hill > 1.1
    assert abs(mu / mu_hill - 1) < 0.05, (mu, mu_hill)
