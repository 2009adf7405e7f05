"""The block-arrow reduction of the frozen eigenproblem against the dense one."""
import numpy as np
import pytest

from ced.fem import eigenproblem
from ced.fem.eigenproblem import natural_frequencies

#: Two joint coordinates first, then three links' interior DOFs (a six-bar's layout).
BLOCKS = [(2, 7), (7, 13), (13, 17)]


def _arrow_pencil(seed: int, shape=(3, 4)):
    """Symmetric K (indefinite) and positive definite M, (…, 17, 17), coupling the blocks
    only through the first two DOFs."""
    rng = np.random.default_rng(seed)
    n = BLOCKS[-1][1]
    allowed = np.zeros((n, n), bool)
    allowed[:2, :] = allowed[:, :2] = True
    for a, b in BLOCKS:
        allowed[a:b, a:b] = True
    X = rng.standard_normal(shape + (n, n)) * allowed
    M = X @ np.swapaxes(X, -1, -2) * allowed + n * np.eye(n)  # diagonally dominant: SPD
    K = rng.standard_normal(shape + (n, n)) * allowed
    return K + np.swapaxes(K, -1, -2), M


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_blocks_give_the_dense_frequencies_and_shapes(seed):
    K, M = _arrow_pencil(seed)
    dense, dense_shapes = natural_frequencies(K, M, 5, shapes=True)
    blocked, shapes = natural_frequencies(K, M, 5, shapes=True, blocks=BLOCKS)
    np.testing.assert_allclose(blocked, dense, rtol=1e-12)
    # The same modes up to sign, mass-normalised.
    sign = np.sign(np.sum(shapes * dense_shapes, axis=-2, keepdims=True))
    np.testing.assert_allclose(shapes * sign, dense_shapes, atol=1e-10)
    gram = np.swapaxes(shapes, -1, -2) @ M @ shapes
    np.testing.assert_allclose(gram, np.broadcast_to(np.eye(5), gram.shape), atol=1e-12)
    # Frequencies alone (eigenvalues without vectors: another LAPACK path) to round-off.
    np.testing.assert_allclose(natural_frequencies(K, M, 5, blocks=BLOCKS), blocked,
                               rtol=1e-12)
    np.testing.assert_allclose(natural_frequencies(K, M, 5), dense, rtol=1e-12)


def test_a_coupling_between_blocks_or_an_indefinite_mass_takes_the_dense_path(monkeypatch):
    K, M = _arrow_pencil(3, shape=(2,))
    K[1, 4, 10] = K[1, 10, 4] = 0.5  # links 1 and 2 coupled directly in one matrix
    assert eigenproblem._by_blocks(K, M, 3, False, BLOCKS) is None
    np.testing.assert_array_equal(natural_frequencies(K, M, 3, blocks=BLOCKS),
                                  natural_frequencies(K, M, 3))
    K, M = _arrow_pencil(4, shape=(2,))
    M[0, 5, 5] = -1.0
    assert eigenproblem._by_blocks(K, M, 3, False, BLOCKS) is None
    with pytest.raises(np.linalg.LinAlgError):
        natural_frequencies(K, M, 3, blocks=BLOCKS)  # as the dense path refuses it
