import numpy as np

from inkray.numerics.grid import edge_weights, grid_degree, grid_laplacian, grid_operator


def test_laplacian_energy_is_the_sum_over_edges():
    rng = np.random.default_rng(2)
    wx, wy = rng.random((5, 6)), rng.random((4, 7))
    d = rng.standard_normal((5, 7))
    L = grid_laplacian(wx, wy)
    energy = (wx * np.diff(d, axis=1) ** 2).sum() + (wy * np.diff(d, axis=0) ** 2).sum()
    assert np.isclose(d.ravel() @ (L @ d.ravel()), energy)
    assert np.allclose(L.sum(axis=1), 0) and np.allclose(L.diagonal(), grid_degree(wx, wy).ravel())


def test_operator_is_symmetric_with_its_stencil():
    diag, east, south = np.full((3, 4), 5.0), -np.ones((3, 3)), -2 * np.ones((2, 4))
    A = grid_operator(diag, east, south)
    assert (A != A.T).nnz == 0 and A[0, 1] == -1 and A[0, 4] == -2 and A[5, 5] == 5


def test_weights_are_small_across_ink_and_floored():
    gray = np.ones((6, 8))
    gray[:, 4] = 0.0
    wx, wy, sigma = edge_weights(gray, sigma=0.1, floor=1e-5)
    assert np.allclose(wx[:, 3], np.exp(-10.0)) and wx[:, 0].min() == 1.0 and wy.min() == 1.0
    assert edge_weights(gray, sigma=0.01, floor=1e-5)[0].min() == 1e-5
    # by default sigma is the mean squared contrast of the edges
    assert np.isclose(edge_weights(gray)[2], 12 / (6 * 7 + 5 * 8))
