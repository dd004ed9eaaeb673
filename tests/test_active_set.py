import numpy as np

from inkray.numerics.active_set import dual_active_set, psd_lstsq


def test_kkt_conditions_of_a_random_bound_constrained_qp():
    rng = np.random.default_rng(4)
    C = rng.standard_normal((12, 30))
    H = C @ C.T
    b = rng.standard_normal(12)
    ineq = rng.random(12) < 0.7
    x, iterations = dual_active_set(H, b, ineq, return_iterations=True)
    g = H @ x - b
    assert iterations >= 1
    assert (x[ineq] >= -1e-12).all()
    assert np.allclose(g[~ineq], 0, atol=1e-8)                  # free rows: stationary
    assert (g[ineq] >= -1e-8).all()                              # bounds: no descent left
    assert np.allclose(x[ineq] * g[ineq], 0, atol=1e-8)          # complementarity


def test_dependent_rows_give_the_minimum_norm_solution():
    H = np.array([[1.0, 1.0], [1.0, 1.0]])
    assert np.allclose(psd_lstsq(H, np.array([2.0, 2.0])), [1.0, 1.0])
    x = dual_active_set(H, np.array([2.0, 2.0]), np.array([False, False]))
    assert np.allclose(H @ x, [2.0, 2.0])
