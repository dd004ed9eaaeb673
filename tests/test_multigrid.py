import numpy as np
import pytest
import scipy.sparse as sp

from inkray.numerics.grid import grid_laplacian
from inkray.numerics.multigrid import _interpolation, multigrid_solve
from inkray.numerics.spd import spd_factor


def _dirichlet_laplacian(mask):
    """The unit-weight Laplacian on the pixels of ``mask``, every other pixel fixed at 0."""
    h, w = mask.shape
    L = grid_laplacian(np.ones((h, w - 1)), np.ones((h - 1, w)))
    # Dirichlet outside the mask: each pixel's degree stays 4 (the frame's missing
    # neighbours count as fixed too), the fixed pixels' columns leave the system.
    deg = sp.diags(4.0 - L.diagonal())
    idx = np.flatnonzero(mask.ravel())
    return (L + deg)[idx][:, idx].tocsr(), *np.divmod(idx, w)


def test_matches_the_factorization_on_an_irregular_pixel_set():
    yy, xx = np.mgrid[:150, :170]
    mask = ((yy - 75) ** 2 + (xx - 85) ** 2 < 70 ** 2) & ~((abs(yy - xx) < 3) & (xx > 60))
    mask[40:45, 20:150] = False  # a wall with the disc on both sides
    A, ys, xs = _dirichlet_laplacian(mask)
    rng = np.random.default_rng(0)
    b = rng.standard_normal((A.shape[0], 2))
    exact = spd_factor(A.tocsc()).solve(b)
    x = multigrid_solve(A, b, ys, xs, direct_below=500)  # three levels coarser
    assert np.abs(x - exact).max() < 1e-7 * np.abs(exact).max()
    one = multigrid_solve(A, b[:, 0], ys, xs, direct_below=500)
    assert one.shape == (A.shape[0],)
    np.testing.assert_array_equal(one, multigrid_solve(A, b[:, 0], ys, xs, direct_below=500))


def test_interpolation_reproduces_linear_functions_inside_and_sums_to_one():
    ys, xs = np.divmod(np.arange(40 * 50), 50)
    P, cy, cx = _interpolation(ys, xs)
    # the cells' centres lie at 2 j + 0.5: a linear function there interpolates exactly
    f = 0.3 * (2 * cx + 0.5) - 0.7 * (2 * cy + 0.5)
    inner = (ys > 0) & (ys < 39) & (xs > 0) & (xs < 49)
    np.testing.assert_allclose((P @ f)[inner], (0.3 * xs - 0.7 * ys)[inner], atol=1e-12)
    np.testing.assert_allclose(np.asarray(P.sum(axis=1)).ravel()[inner], 1.0)


def test_no_convergence_is_an_error():
    mask = np.ones((90, 90), bool)
    A, ys, xs = _dirichlet_laplacian(mask)
    with pytest.raises(np.linalg.LinAlgError):
        multigrid_solve(A, np.ones(A.shape[0]), ys, xs, maxiter=1, rtol=1e-14, direct_below=100)
