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


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), signs=st.lists(st.sampled_from([-1.0, 1.0]),
                                                      min_size=8, max_size=8))
def test_dyad_block_in_closed_form_is_the_lu_solution(seed, signs):
    """A dyad's block (two bodies' x, y, moment rows in three joint forces: F_p on body a, F_m
    on both, F_q on body b; unit signs in the force rows) under a block solved by LU: the
    closed form gives the LU's solution and Hadamard ratio to round-off, and fails as the LU
    does where the two bodies' arms across the middle joint are parallel (a toggle)."""
    rng = np.random.default_rng(seed)
    n = 7  # rows 0…5 the dyad, row 6 an input torque solved after it
    A = np.zeros((2, 5, n, n))
    sa_p, sa_m, sb_m, sb_q = signs[:4]
    for r, (p, m) in ((0, (sa_p, sa_m)), (3, (sb_m, sb_q))):
        cols = (0, 2) if r == 0 else (2, 4)
        A[..., r, cols[0]], A[..., r, cols[1]] = p, m
        A[..., r + 1, cols[0] + 1], A[..., r + 1, cols[1] + 1] = p, m
        A[..., r + 2, cols[0]:cols[1] + 2] = rng.uniform(-0.5, 0.5, (2, 5, 4))
    A[..., 6, :6] = rng.standard_normal((2, 5, 6))
    A[..., 6, 6] = signs[4] * rng.uniform(0.5, 2.0, (2, 5))
    # One toggle: no moment of F_p, F_q, and the two moment rows' F_m entries parallel.
    A[1, 2, 2, 0:2] = A[1, 2, 5, 4:6] = 0.0
    A[1, 2, 5, 2:4] = 0.5 * A[1, 2, 2, 2:4]
    b = rng.standard_normal((2, 5, n))
    pattern = (A != 0).any(axis=(0, 1))
    order = block_order(pattern)
    assert order is not None and list(np.diff(order[2])) == [6, 1]
    dyads = np.array([[0, 3, 0, 2, 4], [-1] * 5], np.int64)
    x, ratio = solve_batch(A, b, (*order, dyads))
    x_lu, ratio_lu = solve_batch(A, b, order)
    regular = ratio_lu > 1e-12
    assert ratio[1, 2] < 1e-12 and ratio_lu[1, 2] < 1e-12
    np.testing.assert_allclose(ratio[regular], ratio_lu[regular], rtol=1e-12)
    np.testing.assert_allclose(x[regular], x_lu[regular], rtol=1e-10,
                               atol=1e-12 * np.abs(x_lu[regular]).max())
