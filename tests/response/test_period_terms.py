"""Terms over one period from samples (ced.response.period_terms): exact where it must be,
accurate to its tolerance where it interpolates, and honest about its error."""
import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.problem.scene import load_scene
from ced.response.batch import make_batch
from ced.response.model import build_model
from ced.response.elastic import _solve_static, _static
from ced.response.period_terms import (STENCIL, TOLERANCE, interpolate_periodic,
                                       interpolation_weights, period_terms)

FOUR_BAR = {"mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                          "rocker": 0.35},
            "links": {"crank": {"flexible": False}, "rocker": {"flexible": False}},
            "effects": ["inertia", "elastic_inertia", "gravity", "coriolis", "centrifugal",
                        "axial_stiffening", "damping"],
            "damping": {"model": "rayleigh", "alpha": 1.0, "beta": 1e-5},
            "discretization": {"elements_per_link": 4}}


@settings(max_examples=30, deadline=None)
@given(degree=st.integers(0, STENCIL - 1), shift=st.floats(0, 1))
def test_stencil_is_exact_on_polynomials_of_its_degree(degree, shift):
    # Away from the periodic wrap a polynomial of degree ≤ 5 is reproduced to round-off.
    samples = 64
    x = np.arange(samples, dtype=float)
    points = 20.0 + shift + np.arange(10)
    index, weight = interpolation_weights(points, samples)
    values = (x / samples) ** degree
    assert np.allclose((weight * values[index]).sum(axis=1), (points / samples) ** degree,
                       atol=1e-13)


def test_stencil_converges_at_its_order_on_a_harmonic():
    # Degree-5 interpolation of a harmonic: error ∝ (2πk/samples)⁶.
    errors = []
    for samples in (32, 64, 128):
        points = np.linspace(0, samples, 997, endpoint=False)
        index, weight = interpolation_weights(points, samples)
        values = np.cos(2 * np.pi * 3 * np.arange(samples) / samples)
        exact = np.cos(2 * np.pi * 3 * points / samples)
        errors.append(np.abs((weight * values[index]).sum(axis=1) - exact).max())
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(rates - STENCIL) < 0.3)


@pytest.mark.parametrize("steps", [512, 1280])
def test_sampled_terms_match_exact_terms_within_their_estimate(steps):
    scenes = [load_scene({**FOUR_BAR, "drive": {"speed": speed},
                          "time": {"steps_per_revolution": steps}})
              for speed in (50.0, 150.0)]
    batch = make_batch(scenes)
    model = build_model(batch)
    sampled = period_terms(model, batch.step_size, steps)
    exact = period_terms(model, batch.step_size, steps, exact=True)
    assert sampled.samples < steps and exact.samples == steps
    assert np.all(sampled.interpolation_error <= TOLERANCE)
    for name in ("mass", "damping", "stiffness", "force", "projection"):
        a, b = sampled.dense(name), exact.dense(name)
        axes = tuple(range(1, b.ndim))
        error = np.abs(a - b).max(axis=axes) / np.abs(b).max(axis=axes)
        # The estimate bounds the true error (it carries a safety factor of 4).
        assert np.all(error <= sampled.interpolation_error), name
    # Step k of a later period is step k mod P.
    for got, want in zip(exact(steps + 5), exact(5)):
        assert np.array_equal(got, want)


def test_a_sparse_model_is_held_packed_and_reads_as_its_dense_terms():
    """Two flexible links of 8 elements (every FE DOF): 17 % nonzero, held packed; the
    matrices read back (dense) equal the same terms held dense."""
    from ced.response.period_terms import with_sparsity
    scene = {**FOUR_BAR, "links": {"crank": {"flexible": False}},
             "discretization": {"elements_per_link": 8}, "time": {"steps_per_revolution": 512}}
    batch = make_batch([load_scene(scene)])
    terms = period_terms(build_model(batch), batch.step_size, 512)
    assert terms.order is not None and terms.stiffness.ndim == 3 and terms.order.fill < 0.5
    dense = terms.dense("stiffness")
    assert dense.shape == (1, 512, terms.n, terms.n)
    assert np.array_equal(terms(7)[2], dense[:, 7])
    again = with_sparsity(dataclasses.replace(terms, mass=terms.dense("mass"),
                                              damping=terms.dense("damping"),
                                              stiffness=dense, pattern=None, order=None))
    for name in ("mass", "damping", "stiffness"):
        assert np.array_equal(getattr(again, name), getattr(terms, name))


def test_packed_interpolation_gives_the_bits_of_the_dense_one():
    """Interpolating only the nonzeros changes nothing: every entry is interpolated alone."""
    from ced.response.period_terms import _interpolate_terms
    from ced.response.step_pattern import pack, step_order, unpack
    rng = np.random.default_rng(8)
    n = 12
    pattern = np.abs(np.subtract.outer(np.arange(n), np.arange(n))) <= 2
    order = step_order(pattern)
    values = rng.standard_normal((2, 16, n, n)) * pattern
    points = np.arange(64) * 0.25
    dense = _interpolate_terms({"stiffness": values}, points, 16)["stiffness"]
    packed = _interpolate_terms({"stiffness": pack(values, order)}, points, 16)["stiffness"]
    assert np.array_equal(unpack(packed, order, n), dense)


def test_short_periods_are_evaluated_exactly():
    batch = make_batch([load_scene({**FOUR_BAR, "time": {"steps_per_revolution": 100}})])
    terms = period_terms(build_model(batch), batch.step_size, 100)
    assert terms.samples == 100 and not terms.interpolation_error.any()


def test_failed_check_falls_back_to_every_step_reusing_the_samples():
    # tolerance 0 cannot be met: every step is evaluated, the samples on the step grid reused.
    batch = make_batch([load_scene({**FOUR_BAR, "time": {"steps_per_revolution": 512}})])
    model = build_model(batch)
    fallback = period_terms(build_model(batch), batch.step_size, 512, tolerance=0.0)
    exact = period_terms(model, batch.step_size, 512, exact=True)
    assert fallback.samples == 512
    for name in ("mass", "damping", "stiffness", "force", "projection"):
        a, b = fallback.dense(name), exact.dense(name)
        assert np.allclose(a, b, rtol=1e-13, atol=1e-13 * np.abs(b).max()), name


def test_periodic_quantity_interpolates_when_smooth_and_refuses_when_not():
    samples, period = 64, 1024
    phase = 2 * np.pi * np.arange(samples) / samples
    smooth = np.stack([np.cos(phase), np.sin(3 * phase)], axis=-1)[None]  # (1, 64, 2)
    out = interpolate_periodic(smooth, period)
    fine = 2 * np.pi * np.arange(period) / period
    assert np.abs(out - np.stack([np.cos(fine), np.sin(3 * fine)], axis=-1)).max() < TOLERANCE
    rough = smooth.copy()
    rough[0, 17, 0] += 1.0  # a feature narrower than the samples' spacing
    assert interpolate_periodic(rough, period) is None


def test_quasi_static_response_from_the_samples_matches_every_step():
    steps = 1024
    batch = make_batch([load_scene({**FOUR_BAR, "drive": {"speed": speed},
                                    "time": {"steps_per_revolution": steps}})
                        for speed in (50.0, 150.0)])
    terms = period_terms(build_model(batch), batch.step_size, steps)
    assert terms.sampled is not None
    exact = _solve_static(terms.dense("stiffness"), terms.force)
    sampled = _static(terms)
    scale = np.abs(exact).max(axis=(1, 2))
    assert (np.abs(sampled - exact).max(axis=(1, 2)) <= 10 * TOLERANCE * scale).all()


def test_written_out_ten_point_sum_equals_the_generic_loop():
    """The compiled interpolation writes the 10-point stencil's sum out (one store per entry);
    the generic loop, given the same stencil and a zero-weight eleventh point, gives the same
    bits, and both are the stencil's sum."""
    from ced.response.period_terms import _interpolate
    assert STENCIL == 10
    rng = np.random.default_rng(7)
    samples, points = 16, np.sort(rng.uniform(0.0, 16.0, 40))
    values = rng.standard_normal((3, samples, 23))
    index, weight = interpolation_weights(points, samples)
    written, generic = np.empty((3, 40, 23)), np.empty((3, 40, 23))
    _interpolate(values, index, weight, written)
    _interpolate(values, np.concatenate([index, index[:, :1]], axis=1),
                 np.concatenate([weight, np.zeros((40, 1))], axis=1), generic)
    assert np.array_equal(written, generic)
    want = np.einsum("mj,cmjd->cmd", weight, values[:, index])
    assert np.allclose(written, want, rtol=1e-13, atol=1e-13)


def test_a_stencil_seen_before_is_kept_read_only():
    points = np.arange(100) * (64 / 100)
    index, weight = interpolation_weights(points, 64)
    again = interpolation_weights(list(points), 64)
    assert again[0] is index and again[1] is weight
    other = interpolation_weights(points + 0.25, 64)
    assert not np.array_equal(other[1], weight)
    assert interpolation_weights(points, 128)[0] is not index
    with pytest.raises(ValueError, match="read-only"):
        weight[0, 0] = 1.0


def test_modal_damping_is_added_from_its_table_not_sampled():
    # The modal damping's table is piecewise linear in time: sampled with the rest, the
    # check would have every step evaluated. It is added at every step from the table, the
    # rest sampled as without it; the terms are those of every step to the tolerance.
    from ced.response.model import terms_at
    steps = 512
    scenes = [load_scene({**FOUR_BAR, "damping": {"model": "modal", "ratio": 0.02},
                          "drive": {"speed": speed}, "time": {"steps_per_revolution": steps}})
              for speed in (50.0, 150.0)]
    batch = make_batch(scenes)
    model = build_model(batch)
    period = period_terms(model, batch.step_size, steps)
    assert period.samples < steps
    times = batch.step_size[:, None] * np.arange(steps)[None, :]
    terms, _ = terms_at(model, times)
    for name in ("mass", "damping", "stiffness"):
        want = getattr(terms, name)
        error = np.abs(period.dense(name) - want).max() / np.abs(want).max()
        assert error <= TOLERANCE, name
    # and the samples kept for the terms' other users carry it too
    n = period.sampled["force"].shape[1]
    at = np.arange(n) * (steps // n)
    np.testing.assert_allclose(period.sampled["damping"], terms.damping[:, at],
                               rtol=0, atol=TOLERANCE * np.abs(terms.damping).max())
