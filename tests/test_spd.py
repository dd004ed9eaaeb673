import numpy as np
import pytest
import scipy.sparse as sp

from inkray.numerics.grid import grid_laplacian
from inkray.numerics.spd import (MinQuadWithFixed, min_quad_with_fixed, nested_dissection,
                                 nested_dissection_of_edges, spd_factor)


def test_factor_solves_many_right_hand_sides():
    rng = np.random.default_rng(0)
    m = sp.random(40, 40, density=0.1, random_state=1)
    A = (m @ m.T + 40 * sp.eye(40)).tocsc()
    b = rng.standard_normal((40, 3))
    assert np.allclose(A @ spd_factor(A).solve(b), b)


def test_singular_matrix_raises_linalg_error():
    with pytest.raises(np.linalg.LinAlgError):
        spd_factor(sp.csc_matrix(np.array([[1.0, 1.0], [1.0, 1.0]])))


def test_harmonic_interpolation_between_fixed_ends_is_linear():
    # A 1 x 11 path: fixed 0 at the left end and 10 at the right, nothing in between.
    L = grid_laplacian(np.ones((1, 10)), np.zeros((0, 11)))
    x = MinQuadWithFixed(L, [0, 10]).solve(None, [0.0, 10.0])
    assert np.allclose(x, np.arange(11.0))


def test_poisson_with_a_source_matches_the_closed_form():
    # -u'' = 2 on [0, n] with u(0) = u(n) = 0: u = x (n - x) (exact on the 3-point stencil).
    n = 20
    L = grid_laplacian(np.ones((1, n)), np.zeros((0, n + 1)))
    x = min_quad_with_fixed(L, -2.0 * np.ones(n + 1), [0, n], [0.0, 0.0])
    t = np.arange(n + 1.0)
    assert np.allclose(x, t * (n - t))


def test_columns_solve_together():
    L = grid_laplacian(np.ones((1, 4)), np.zeros((0, 5)))
    solver = MinQuadWithFixed(L, np.array([True, False, False, False, True]))
    both = solver.solve(None, np.array([[0.0, 1.0], [4.0, 1.0]]))
    assert np.allclose(both[:, 0], np.arange(5.0)) and np.allclose(both[:, 1], 1.0)


def test_nested_dissection_is_a_permutation_that_fills_less_than_the_grid_order():
    n = 48
    lap1 = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1])
    K = (sp.kron(lap1, sp.eye(n)) + sp.kron(sp.eye(n), lap1)).tocsc()
    rows, cols = np.divmod(np.arange(n * n), n)
    order = nested_dissection(K, rows, cols)
    assert sorted(order.tolist()) == list(range(n * n))
    dissected = spd_factor(K[order][:, order], ordered=True)
    natural = spd_factor(K, ordered=True)
    assert dissected.L.nnz < 0.7 * natural.L.nnz
    b = np.random.default_rng(0).normal(size=n * n)
    x = np.empty(n * n)
    x[order] = dissected.solve(b[order])
    np.testing.assert_allclose(K @ x, b, atol=1e-9)


def test_nested_dissection_of_edges_in_any_direction_and_repeated_is_the_matrix_one():
    n = 20
    lap1 = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1])
    K = (sp.kron(lap1, sp.eye(n)) + sp.kron(sp.eye(n), lap1)).tocoo()
    rows, cols = np.divmod(np.arange(n * n), n)
    off = K.row != K.col  # every edge twice, once each way
    order = nested_dissection_of_edges(K.row[off], K.col[off], rows, cols)
    assert order.tolist() == nested_dissection(K, rows, cols).tolist()


def test_without_equilibration_a_well_scaled_system_has_the_same_factor():
    m = sp.random(60, 60, density=0.1, random_state=2)
    A = (m @ m.T + 60 * sp.eye(60)).tocsc()
    b = np.random.default_rng(1).normal(size=60)
    x = spd_factor(A, equilibrate=False).solve(b)
    assert np.array_equal(x, spd_factor(A).solve(b))
    np.testing.assert_allclose(A @ x, b, atol=1e-10)
