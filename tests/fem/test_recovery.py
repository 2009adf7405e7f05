"""Peak values between samples (ced.fem.recovery.peaks)."""
import numpy as np
import pytest
from hypothesis import given, strategies as st

from ced.fem.recovery import peaks


def _history(n_steps: int, phase: float) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n_steps + 1)
    return (2.0 * np.sin(2 * np.pi * t + phase))[None, :, None, None]  # (case, step, link, station)


@given(st.floats(0.2, 1.3))  # both peaks of |sin| interior
def test_interpolated_peak_converges_at_third_order(phase):
    errors = [abs(peaks(_history(n, phase))[0, 0] - 2.0) for n in (32, 64, 128)]
    assert errors[2] <= 2.0 * (2.0 * np.pi / 128) ** 3
    assert errors[1] <= 2.0 * (2.0 * np.pi / 64) ** 3


def test_peak_never_below_the_largest_sample_and_exact_for_parabolas():
    t = np.linspace(-1.0, 1.0, 11) + 0.03
    field = (5.0 - (t - 0.0) ** 2)[None, :, None, None]
    assert peaks(field)[0, 0] == pytest.approx(5.0, abs=1e-12)
    rng = np.random.default_rng(0)
    noisy = rng.normal(size=(3, 20, 2, 5))
    assert (peaks(noisy) >= np.abs(noisy).max(axis=(1, 3)) - 1e-15).all()


def test_peak_at_the_first_or_last_sample_is_the_sample():
    field = np.linspace(0.0, 1.0, 9)[None, :, None, None]
    assert peaks(field)[0, 0] == 1.0


def test_stress_is_signed_at_both_fibres_and_never_jumps_sign():
    """Axial strain swinging ±1e-4 and bending ±3e-4 a quarter period apart: the stress of
    larger magnitude takes the sign of the axial strain, so it jumps by 2 E ε_b = 120 MPa where
    the axial strain crosses zero; each fibre's history stays smooth (its step-to-step change
    is bounded by the strains' own), and the pair is E(ε_a ± ε_b) with the bending adding at
    y = -h/2 (the sign of plane_stress's curvature, ced.fem.elements.plane_stress)."""
    from ced.fem.recovery import FIBRES, link_fields

    steps = np.linspace(0.0, 1.0, 201)
    bending = 3e-4 * np.cos(2 * np.pi * steps)
    axial = 1e-4 * np.sin(2 * np.pi * steps)
    height, E = 0.02, 2e11
    # one DOF per operator output: q = (v, curvature, axial strain, u) at one station pair
    q = np.stack([np.zeros_like(steps), bending / (0.5 * height), axial,
                  np.zeros_like(steps)], axis=-1)[None]
    eye = np.eye(4)
    operators = {name: np.repeat(eye[i][None, None], 2, axis=1)
                 for i, name in enumerate(("v", "curvature", "axial_strain", "u"))}
    out = link_fields(q, operators, np.array([0.0, 1.0]), np.array([height]), np.array([E]))
    stress = out["stress"][0, :, 0]  # (step, fibre)
    assert FIBRES == (-0.5, 0.5)
    assert np.allclose(stress[:, 0], E * (axial + bending), rtol=1e-6)
    assert np.allclose(stress[:, 1], E * (axial - bending), rtol=1e-6)
    jump = np.abs(np.diff(stress, axis=0)).max()
    assert jump < E * 4e-4 * 2 * np.pi / 200  # bounded by the slopes: no sign flip
    # the old "fibre of larger magnitude" history jumps by about 2 E ε_b = 120 MPa
    larger = np.where(np.abs(stress[:, 0]) >= np.abs(stress[:, 1]), stress[:, 0], stress[:, 1])
    assert np.abs(np.diff(larger)).max() > 100e6 > 20 * jump
