"""The compiled march (ced.response.kernels) against the numpy reference loop, to round-off."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.response.integrators import (State, generalized_alpha, hht, march, newmark, start)
from ced.response.kernels import expand, lu_factor, lu_solve, static_period
from ced.response.marching import Marcher
from ced.response.period_terms import PeriodTerms


def _system(rng, ncase, period, n, damped):
    """Random time-varying SPD mass and stiffness, nonsymmetric damping, over one period."""
    A = rng.standard_normal((ncase, period, n, n))
    B = rng.standard_normal((ncase, period, n, n))
    M = A @ np.swapaxes(A, -1, -2) + n * np.eye(n)
    K = 1e4 * (B @ np.swapaxes(B, -1, -2) + n * np.eye(n))
    C = 0.1 * rng.standard_normal((ncase, period, n, n)) if damped else None
    F = rng.standard_normal((ncase, period, n))
    return PeriodTerms(mass=M, damping=C, stiffness=K, force=F,
                       projection=np.zeros((ncase, period, 1, 1)), samples=period,
                       interpolation_error=np.zeros(ncase))


@pytest.mark.parametrize("scheme", [newmark(), hht(-0.1), generalized_alpha(0.7),
                                    newmark(0.3, 0.6)])
@pytest.mark.parametrize("damped", [False, True])
@pytest.mark.parametrize("columns", [1, 4])
def test_compiled_march_equals_numpy_march(scheme, damped, columns):
    rng = np.random.default_rng(3)
    ncase, period, n, n_steps = 3, 7, 5, 23  # n_steps > period: the factorizations are reused
    terms = _system(rng, ncase, period, n, damped)
    h = np.array([1e-3, 2e-3, 5e-4])
    q0 = rng.standard_normal((ncase, n, columns))
    v0 = rng.standard_normal((ncase, n, columns))
    compiled, reference = Marcher(scheme, terms, h), Marcher(scheme, terms, h, compiled=False)
    assert compiled.compiled and not reference.compiled
    first = start(compiled.columns(columns), q0, v0)
    end_c, rec_c = compiled.march(first, n_steps, record_every=2)
    end_n, rec_n = reference.march(first, n_steps, record_every=2)
    scale = np.abs(rec_n).max()
    assert np.abs(rec_c - rec_n).max() <= 1e-12 * scale
    for x, y in zip(end_c[:4], end_n[:4]):
        assert np.allclose(x, y, rtol=1e-11, atol=1e-12 * np.abs(y).max())
    # A second march over the same terms reuses every factorization and agrees as well.
    again_c, _ = compiled.march(end_c, n_steps)
    again_n, _ = reference.march(end_n, n_steps)
    assert np.allclose(again_c.q, again_n.q, rtol=1e-10, atol=1e-12 * np.abs(again_n.q).max())


def test_marcher_uses_the_numpy_loop_for_houbolt_and_agrees_with_march():
    from ced.response.integrators import houbolt
    rng = np.random.default_rng(4)
    terms = _system(rng, 2, 5, 3, True)
    h = np.array([1e-3, 1e-3])
    marcher = Marcher(houbolt(), terms, h)
    assert not marcher.compiled
    state = start(marcher.columns(1), np.zeros((2, 3, 1)), np.zeros((2, 3, 1)))
    end, _ = marcher.march(state, 12)
    ref = march(houbolt(), marcher.columns(1), h, 12, state)
    assert np.array_equal(end.q, ref.q)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 12), seed=st.integers(0, 10**6))
def test_lu_solves_like_numpy(n, seed):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) + n * np.eye(n) * rng.choice([0.0, 1.0])
    b = rng.standard_normal(n)
    if abs(np.linalg.det(A)) < 1e-8:
        return
    LU, piv, x = A.copy(), np.empty(n, np.int64), b.copy()
    assert lu_factor(LU, piv)
    lu_solve(LU, piv, x)
    assert np.allclose(A @ x, b, atol=1e-9 * np.linalg.cond(A) * np.abs(b).max())


def test_singular_matrix_is_reported_not_divided_by():
    A = np.array([[1.0, 2.0], [2.0, 4.0]])
    assert not lu_factor(A.copy(), np.empty(2, np.int64))
    assert not lu_factor(np.full((2, 2), np.nan), np.empty(2, np.int64))


def test_singular_step_matrix_raises_like_numpy():
    terms = _system(np.random.default_rng(5), 2, 3, 2, False)
    terms.mass[1] = 0.0
    terms.stiffness[1] = 0.0
    marcher = Marcher(newmark(), terms, np.array([1e-3, 1e-3]))
    state = State(*(np.zeros((2, 2, 1)) for _ in range(4)))
    with pytest.raises(np.linalg.LinAlgError, match="case 1"):
        marcher.march(state, 4)


def test_diverging_case_is_recorded_as_not_finite():
    # Explicit central differences far beyond their stability limit: the response explodes to
    # inf and the record says so instead of keeping zeros.
    terms = _system(np.random.default_rng(6), 1, 4, 2, False)
    marcher = Marcher(newmark(0.0, 0.5), terms, np.array([10.0]))
    state = start(marcher.columns(1), np.ones((1, 2, 1)), np.zeros((1, 2, 1)))
    _, record = marcher.march(state, 2000, record_every=1)
    assert not marcher.ok[0]
    assert not np.isfinite(record[0, -1]).all()


def test_static_period_and_expand():
    rng = np.random.default_rng(7)
    terms = _system(rng, 2, 4, 3, False)
    y = np.empty((2, 4, 3))
    ok = np.ones(2, bool)
    static_period(terms.stiffness, terms.force, y, ok)
    assert ok.all()
    assert np.allclose(y, np.linalg.solve(terms.stiffness, terms.force[..., None])[..., 0])
    # z = P0 y[:nfree] with the interior DOFs y[nfree:] on their own rows, P0 given by its
    # rows that can be nonzero (here 0, 2, 3 of 5); an infinite y makes the zero rows NaN,
    # as their products 0 · inf would.
    P0 = rng.standard_normal((2, 4, 5, 2))
    P0[:, :, [1, 4]] = 0.0
    steps = np.array([0, 3, 5, 9])
    rows = np.array([4, 1])
    ys = rng.standard_normal((2, 4, 4))
    ys[1, 2, 0] = np.inf
    z = np.empty((2, 4, 5))
    written = np.array([0, 2, 3])
    expand(np.ascontiguousarray(P0[:, :, written]), ys, steps, written, rows, z)
    want = (P0[:, steps % 4] @ ys[..., :2, None])[..., 0]
    want[..., rows] += ys[..., 2:]
    np.testing.assert_allclose(z, want, rtol=1e-14, atol=1e-14)
    assert np.isnan(z[1, 2, [1, 4]]).all()
    assert np.isfinite(np.delete(z.reshape(8, 5), 6, axis=0)).all()


def test_a_whole_simulation_through_the_numpy_loop_agrees(monkeypatch):
    # CED_KERNEL=numpy: every march through the numpy reference loop; the dataset agrees with
    # the compiled run to round-off (shooting, response, recovery).
    from ced.simulation.simulate import simulate
    scene = {"mechanism": {"type": "four_bar", "ground": 0.5, "crank": 0.1, "coupler": 0.45,
                           "rocker": 0.35},
             "links": {"crank": {"flexible": False}},
             "discretization": {"elements_per_link": 3},
             "time": {"revolutions": 1, "steps_per_revolution": 128, "start": "periodic"},
             "outputs": {"error_estimate": False}}
    compiled = simulate(scene)
    monkeypatch.setenv("CED_KERNEL", "numpy")
    reference = simulate(scene)
    for name in ("deflection", "stress", "floquet_multiplier_max"):
        a, b = compiled[name].values, reference[name].values
        assert np.allclose(a, b, rtol=1e-6, atol=1e-9 * np.abs(b).max()), name
