"""The compiled batched LU of ced.rigid.small_systems against numpy."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.rigid.small_systems import block_order, solve_batch


@settings(max_examples=25, deadline=None)
@given(n=st.integers(1, 12), seed=st.integers(0, 2**31 - 1))
def test_solutions_and_hadamard_ratio_match_numpy(n, seed):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((3, 4, n, n)) * 10.0 ** rng.uniform(-3, 3, (3, 4, 1, 1))
    b = rng.standard_normal((3, 4, n))
    x, ratio = solve_batch(A, b)
    assert x.shape == b.shape and ratio.shape == (3, 4)
    expected = np.abs(np.linalg.det(A)) / np.prod(np.linalg.norm(A, axis=-1), axis=-1)
    np.testing.assert_allclose(ratio, expected, rtol=1e-8)
    well = ratio > 1e-6  # the residual test is only meaningful on well-conditioned matrices
    residual = np.einsum("...ij,...j->...i", A, x) - b
    scale = np.abs(A).max(axis=(-1, -2)) * np.abs(x).max(axis=-1) + np.abs(b).max(axis=-1)
    assert (np.abs(residual).max(axis=-1)[well] <= 1e-10 * scale[well]).all()


def test_singular_matrix_has_ratio_zero_and_leaves_others_alone():
    A = np.stack([np.eye(3), [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 1.0]]])
    b = np.ones((2, 3))
    x, ratio = solve_batch(A, b)
    assert ratio[0] == pytest.approx(1.0) and ratio[1] == 0.0
    np.testing.assert_array_equal(x[0], np.ones(3))


def test_non_finite_matrix_counts_as_singular():
    A = np.array([[[1.0, np.nan], [0.0, 1.0]]])
    _, ratio = solve_batch(A, np.ones((1, 2)))
    assert ratio[0] == 0.0


@settings(max_examples=25, deadline=None)
@given(sizes=st.lists(st.integers(1, 5), min_size=1, max_size=4), seed=st.integers(0, 2**31 - 1))
def test_block_solve_matches_the_dense_one(sizes, seed):
    """A block lower triangular pattern, rows and columns shuffled: block_order finds blocks
    no larger than those, and the block solve gives the dense solution and Hadamard ratio."""
    rng = np.random.default_rng(seed)
    n = sum(sizes)
    pattern = np.zeros((n, n), bool)
    start = 0
    for m in sizes:
        pattern[start : start + m, : start + m] = True
        start += m
    rows, cols = rng.permutation(n), rng.permutation(n)
    pattern = pattern[rows][:, cols]
    A = rng.standard_normal((3, 4, n, n)) * pattern + 3.0 * np.eye(n)[rows][:, cols]
    b = rng.standard_normal((3, 4, n))
    order = block_order(pattern)
    assert order is not None and np.diff(order[2]).max() <= max(sizes)
    block_rows, block_cols, starts = order
    for k in range(len(starts) - 1):  # nothing right of a block's columns
        later = block_cols[starts[k + 1] :]
        assert not pattern[np.ix_(block_rows[starts[k] : starts[k + 1]], later)].any()
    x, ratio = solve_batch(A, b, order)
    x_dense, ratio_dense = solve_batch(A, b)
    np.testing.assert_allclose(ratio, ratio_dense, rtol=1e-10)
    np.testing.assert_allclose(x, x_dense, rtol=1e-9, atol=1e-9 * np.abs(x_dense).max())


def test_structurally_singular_pattern_has_no_block_order():
    pattern = np.array([[True, True], [False, False]])
    assert block_order(pattern) is None
