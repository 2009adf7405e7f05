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
