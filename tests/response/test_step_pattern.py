"""The step matrices' common sparsity (ced.response.step_pattern) and the march that uses it."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.response.integrators import generalized_alpha, newmark, start
from ced.response.marching import Marcher
from ced.response.period_terms import PeriodTerms
from ced.response.period_terms import with_sparsity
from ced.response.step_pattern import (MAX_FILL, nonzero_pattern, pack, packed_factor,
                                       packed_solve, step_order, unpack)


def _linkage_pattern(links: int, dofs: int, joints: int) -> np.ndarray:
    """A linkage's pattern: each link's DOFs banded (element neighbours), every link coupled
    with the joint coordinates; the joint coordinates first, as in ced's layout."""
    n = joints + links * dofs
    pattern = np.zeros((n, n), bool)
    pattern[:joints, :] = pattern[:, :joints] = True
    for link in range(links):
        s = joints + link * dofs
        i = np.arange(dofs)
        pattern[s:s + dofs, s:s + dofs] = np.abs(i[:, None] - i[None, :]) <= 3
    return pattern


def _spd(rng, pattern: np.ndarray, shape=()) -> np.ndarray:
    """Random symmetric, diagonally dominant (so positive definite) matrices on ``pattern``."""
    n = pattern.shape[0]
    A = rng.standard_normal(shape + (n, n)) * pattern
    A = A + np.swapaxes(A, -1, -2)
    return A + (np.abs(A).sum(axis=-1, keepdims=True) + 1.0) * np.eye(n)


def _factor(order, S):
    """S's packed factors in ``order`` (fill-ins start at 0)."""
    n = len(S)
    LU = np.where(order.lu_source >= 0, pack(S, order)[np.maximum(order.lu_source, 0)], 0.0)
    ok = packed_factor(LU, order.lu_ptr, order.lu_idx, order.diagonal, np.empty(n))
    return ok, LU


def _dense_factors(order, LU, n):
    """The packed factors as one (n, n) matrix (L below the diagonal, U on and above)."""
    out = np.zeros((n, n))
    rows = np.repeat(np.arange(n), np.diff(order.lu_ptr))
    out[rows, order.lu_idx] = LU
    return out


@pytest.mark.parametrize("columns", [1, 5])
def test_ordered_lu_without_pivoting_solves_a_linkage_system(columns):
    rng = np.random.default_rng(1)
    pattern = _linkage_pattern(links=3, dofs=11, joints=3)
    order = step_order(pattern)
    assert order is not None and order.fill < MAX_FILL
    assert sorted(order.perm) == list(range(len(pattern)))
    S = _spd(rng, pattern)
    S[0, 5] += 0.3  # slightly nonsymmetric, as the step matrices are
    ok, LU = _factor(order, S)
    assert ok
    B = rng.standard_normal((len(S), columns))
    X = B.copy()
    packed_solve(LU, order.perm, order.lu_ptr, order.lu_idx, order.diagonal, X,
                 np.empty_like(X))
    assert np.allclose(X, np.linalg.solve(S, B), rtol=1e-12, atol=1e-12)
    assert np.array_equal(unpack(pack(S, order), order, len(S)), S)


@settings(max_examples=30, deadline=None)
@given(links=st.integers(1, 4), dofs=st.integers(2, 12), joints=st.integers(1, 4),
       seed=st.integers(0, 10_000))
def test_the_symbolic_factors_hold_every_nonzero_of_the_numeric_ones(links, dofs, joints, seed):
    """Elimination without pivoting never creates a nonzero outside the symbolic pattern: the
    factorization, run densely, equals the one run on the pattern."""
    rng = np.random.default_rng(seed)
    pattern = _linkage_pattern(links, dofs, joints)
    order = step_order(pattern, max_fill=1.0)
    n = len(pattern)
    S = _spd(rng, pattern)
    dense = S[np.ix_(order.perm, order.perm)]
    for k in range(n):  # plain dense elimination, no pivoting
        dense[k + 1:, k] /= dense[k, k]
        dense[k + 1:, k + 1:] -= np.outer(dense[k + 1:, k], dense[k, k + 1:])
    symbolic = _dense_factors(order, np.ones(len(order.lu_idx)), n) != 0
    assert symbolic.diagonal().all()
    assert not (dense[~symbolic] != 0).any()
    ok, LU = _factor(order, S)
    assert ok
    assert np.allclose(_dense_factors(order, LU, n), dense, rtol=1e-10, atol=1e-12)


def test_an_indefinite_matrix_is_refused_and_a_dense_pattern_gets_no_order():
    rng = np.random.default_rng(2)
    pattern = _linkage_pattern(links=2, dofs=8, joints=2)
    order = step_order(pattern, max_fill=1.0)
    S = -_spd(rng, pattern)  # negative definite: its first pivot is negative
    ok, _ = _factor(order, S)
    assert not ok
    assert step_order(np.ones((10, 10), bool)) is None


def test_nonzero_pattern_is_the_symmetric_union_with_the_diagonal():
    M = np.zeros((2, 3, 4, 4))
    K = np.zeros((2, 3, 4, 4))
    M[1, 2, 0, 3] = 1.0
    K[0, 0, 2, 1] = -2.0
    pattern = nonzero_pattern(M, None, K)
    want = np.eye(4, dtype=bool)
    want[0, 3] = want[3, 0] = want[2, 1] = want[1, 2] = True
    assert np.array_equal(pattern, want)


def _sparse_system(rng, ncase, period, damped, indefinite_steps=()):
    pattern = _linkage_pattern(links=3, dofs=7, joints=2)
    n = len(pattern)
    M = _spd(rng, pattern, (ncase, period))
    K = 1e4 * _spd(rng, pattern, (ncase, period))
    for j in indefinite_steps:  # a softening stiffness that makes case 1's step indefinite
        K[1, j] *= -1e5
    C = 0.1 * rng.standard_normal((ncase, period, n, n)) * pattern if damped else None
    F = rng.standard_normal((ncase, period, n))
    return PeriodTerms(mass=M, damping=C, stiffness=K, force=F,
                       projection=np.zeros((ncase, period, 1, 1)), samples=period,
                       interpolation_error=np.zeros(ncase))


@pytest.mark.parametrize("scheme", [newmark(), generalized_alpha(0.7)])
@pytest.mark.parametrize("damped", [False, True])
@pytest.mark.parametrize("columns", [1, 4])
@pytest.mark.parametrize("indefinite", [(), (2, 5)])
def test_sparse_compiled_march_equals_numpy_march(scheme, damped, columns, indefinite):
    """On a linkage-like pattern the compiled march runs on the packed terms, ordered and
    factorized without pivoting; a case with an indefinite step matrix is marched densely
    with pivoting, the others stay packed; all agree with the numpy loop (np.linalg.solve) to
    round-off, and again when the factorizations are reused."""
    rng = np.random.default_rng(5)
    ncase, period, n_steps = 3, 7, 23
    terms = with_sparsity(_sparse_system(rng, ncase, period, damped, indefinite))
    assert terms.order is not None and terms.stiffness.ndim == 3  # packed
    h = np.array([1e-3, 2e-3, 5e-4])
    n = terms.n
    q0 = rng.standard_normal((ncase, n, columns))
    v0 = rng.standard_normal((ncase, n, columns))
    compiled, reference = Marcher(scheme, terms, h), Marcher(scheme, terms, h, compiled=False)
    assert compiled.packed
    first = start(compiled.columns(columns), q0, v0)
    end_c, rec_c = compiled.march(first, n_steps, record_every=2)
    end_n, rec_n = reference.march(first, n_steps, record_every=2)
    # An indefinite step matrix sends its case, and only it, to the dense march with pivoting.
    assert compiled.packed
    assert list(compiled.dense_cases) == [False, bool(indefinite), False]
    assert np.abs(rec_c - rec_n).max() <= 1e-11 * np.abs(rec_n).max()
    for x, y in zip(end_c[:4], end_n[:4]):
        assert np.allclose(x, y, rtol=1e-10, atol=1e-11 * np.abs(y).max())
    again_c, _ = compiled.march(end_c, n_steps)  # the factorizations reused
    again_n, _ = reference.march(end_n, n_steps)
    assert np.allclose(again_c.q, again_n.q, rtol=1e-9, atol=1e-11 * np.abs(again_n.q).max())


@pytest.mark.parametrize("indefinite", [False, True])
def test_packed_quasi_static_solve_equals_numpy(indefinite):
    """K y = F at every step from packed K; an indefinite K (refused without pivoting) is
    solved densely with pivoting."""
    from ced.response.kernels import static_period_packed
    rng = np.random.default_rng(6)
    pattern = _linkage_pattern(links=3, dofs=7, joints=2)
    K = _spd(rng, pattern, (2, 5))
    if indefinite:
        K[1, 3] *= -1.0
    F = rng.standard_normal((2, 5, len(pattern)))
    order = step_order(pattern)
    y, ok = np.empty_like(F), np.ones(2, bool)
    o = order
    static_period_packed(pack(K, order), F, y, ok, o.perm, o.rows_ptr, o.rows_idx, o.lu_ptr,
                         o.lu_idx, o.diagonal, o.lu_source)
    assert ok.all()
    assert np.allclose(y, np.linalg.solve(K, F[..., None])[..., 0], rtol=1e-12, atol=1e-12)


def test_a_pattern_seen_before_gets_its_kept_order_read_only():
    pattern = _linkage_pattern(links=2, dofs=8, joints=2)
    order = step_order(pattern, max_fill=1.0)
    assert order is not None
    assert step_order(pattern.copy(), max_fill=1.0) is order
    assert step_order(pattern, max_fill=0.99) is not order  # another limit: found afresh
    other = pattern.copy()
    i, j = np.argwhere(~pattern)[0]
    other[i, j] = other[j, i] = True
    assert step_order(other, max_fill=1.0) is not order
    with pytest.raises(ValueError, match="read-only"):
        order.perm[0] = 1
