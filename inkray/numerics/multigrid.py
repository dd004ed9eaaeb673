"""Large grid systems solved by conjugate gradients with a multigrid preconditioner.

The unknowns are pixels of a grid and the matrix couples grid neighbours (a
Laplacian on a pixel set, with Dirichlet values folded into the right-hand
side). The preconditioner is one V-cycle of the correction scheme of Briggs,
Henson and McCormick, *A Multigrid Tutorial* (SIAM, 2nd ed. 2000, chapters 3
and 5): damped Jacobi sweeps, the residual restricted to a grid of half the
resolution, corrected there in the same way, and as many sweeps again; the
coarser operators are the Galerkin products ``P^T A P`` with ``P`` bilinear
interpolation from the 2 x 2 cells' centres (so the cells along the pixel
set's outline need no boundary rule of their own), the coarsest factored.
The cycle is symmetric, so it preconditions conjugate gradients (Saad,
*Iterative Methods for Sparse Linear Systems*, 2nd ed. 2003, algorithm 9.1):
a few iterations reach the direct solution's answer to rounding, for a
fraction of a factorization's time on a large grid.
"""

import numpy as np
import scipy.sparse as sp

from inkray.numerics.spd import nested_dissection, spd_factor

__all__ = ["multigrid_solve"]


def multigrid_solve(A, b, ys, xs, *, rtol=1e-10, maxiter=60, sweeps=2, omega=0.8,
                   direct_below=2000):
    """Solve ``A x = b`` for a symmetric positive definite grid system by multigrid-
    preconditioned conjugate gradients.

    Parameters
    ----------
    A : (n, n) sparse matrix
        Symmetric positive definite, coupling unknowns that are grid
        neighbours (a 5- or 9-point Laplacian on a pixel set).
    b : (n,) or (n, k) array
        Right-hand side, or ``k`` of them solved together.
    ys, xs : (n,) int arrays
        The pixel (row, column; non-negative) of each unknown.
    rtol : float, default 1e-10
        Stop when every column's residual norm is below ``rtol`` times its
        right-hand side's.
    maxiter : int, default 60
        Most conjugate-gradient iterations.
    sweeps : int, default 2
        Damped Jacobi sweeps before and after the coarse correction.
    omega : float, default 0.8
        Jacobi damping.
    direct_below : int, default 2000
        The coarsening stops at a grid of at most this many cells, which is
        factored.

    Returns
    -------
    x : array like ``b``

    Raises
    ------
    numpy.linalg.LinAlgError
        The coarse operator is singular, or the iterations do not reach
        ``rtol`` (the caller may then factor ``A`` directly).

    Examples
    --------
    A 60 x 60 square with value 0 beyond its left side and 1 beyond its
    right side, no flux across the others: the answer is linear across.

    >>> import numpy as np, scipy.sparse as sp
    >>> n = 60
    >>> ys, xs = np.divmod(np.arange(n * n), n)
    >>> fixed = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    >>> free = fixed - sp.diags(np.r_[1.0, np.zeros(n - 2), 1.0])
    >>> A = sp.kron(free, sp.eye(n)) + sp.kron(sp.eye(n), fixed)
    >>> x = multigrid_solve(A, (xs == n - 1).astype(float), ys, xs)
    >>> bool(np.allclose(x, (xs + 1) / (n + 1)))
    True
    """
    A = sp.csr_matrix(A)
    b = np.asarray(b, float)
    one = b.ndim == 1
    B = b[:, None] if one else b
    levels = _levels(A, np.asarray(ys), np.asarray(xs), direct_below)

    def cycle(rhs, level=0):
        """One symmetric V-cycle on ``A e = rhs`` from ``e = 0``."""
        A, inv_diag, P, coarse = levels[level]
        if P is None:
            return coarse.solve(rhs)
        e = np.zeros_like(rhs)
        r = rhs
        for _ in range(sweeps):
            e = e + omega * inv_diag[:, None] * r
            r = rhs - A @ e
        e = e + P @ cycle(P.T @ r, level + 1)
        for _ in range(sweeps):
            e = e + omega * inv_diag[:, None] * (rhs - A @ e)
        return e

    x = np.zeros_like(B)
    r = B.copy()
    scale = np.linalg.norm(B, axis=0)
    scale[scale == 0] = 1.0
    z = cycle(r)
    p = z.copy()
    rz = np.einsum("ij,ij->j", r, z)
    for _ in range(maxiter):
        if (np.linalg.norm(r, axis=0) <= rtol * scale).all():
            return x[:, 0] if one else x
        q = A @ p
        pq = np.einsum("ij,ij->j", p, q)
        alpha = np.divide(rz, pq, out=np.zeros_like(rz), where=pq != 0)
        x = x + alpha * p
        r = r - alpha * q
        z = cycle(r)
        rz_new = np.einsum("ij,ij->j", r, z)
        beta = np.divide(rz_new, rz, out=np.zeros_like(rz), where=rz != 0)
        p = z + beta * p
        rz = rz_new
    if (np.linalg.norm(r, axis=0) <= rtol * scale).all():
        return x[:, 0] if one else x
    raise np.linalg.LinAlgError(f"multigrid conjugate gradients: no convergence to {rtol} "
                                f"in {maxiter} iterations")


def _levels(A, ys, xs, direct_below):
    """Per level ``(A, 1 / diag A, P, None)``, the last ``(A, None, None, factor)``."""
    levels = []
    while A.shape[0] > direct_below:
        P, cy, cx = _interpolation(ys, xs)
        if P.shape[1] > 0.7 * P.shape[0]:  # scattered pixels: coarsening gains nothing
            break
        levels.append((A, 1.0 / A.diagonal(), P, None))
        A, ys, xs = (P.T @ A @ P).tocsr(), cy, cx
    levels.append((A, None, None, _Ordered(A, ys, xs)))
    return levels


class _Ordered:
    """The Galerkin operator factored in the nested-dissection order of its cells."""

    def __init__(self, Ac, cy, cx):
        self.order = nested_dissection(Ac, cy, cx)
        self.factor = spd_factor(Ac[self.order][:, self.order], ordered=True)

    def solve(self, r):
        out = np.empty_like(r)
        out[self.order] = self.factor.solve(r[self.order])
        return out


def _interpolation(ys, xs):
    """Bilinear interpolation (n, m) from the centres of the 2 x 2 cells holding a pixel,
    and the cells' rows and columns.

    A cell's centre lies at ``2 j + 0.5``: a pixel takes 3/4 of its own cell
    and 1/4 of the next one towards it along each axis, where that cell holds
    a pixel of the set too (beyond the set the correction is zero).
    """
    cy, cx = ys // 2, xs // 2
    ny, nx = ys - 2 * cy, xs - 2 * cx  # 0: the cell above / left is the nearer other one
    # The cells in raster order, found through an image of their numbers (-1: none).
    number = np.full((int(cy.max()) + 3, int(cx.max()) + 3), -1, np.int64)
    number[cy + 1, cx + 1] = 0
    held = number >= 0
    number[held] = np.arange(int(held.sum()))
    rows, cols, vals = [], [], []
    for sy, wy in ((0, 0.75), (1, 0.25)):
        for sx, wx in ((0, 0.75), (1, 0.25)):
            j = number[cy + 1 + sy * (2 * ny - 1), cx + 1 + sx * (2 * nx - 1)]
            hit = j >= 0
            rows.append(np.flatnonzero(hit))
            cols.append(j[hit])
            vals.append(np.full(int(hit.sum()), wy * wx))
    r, c, v = (np.concatenate(t) for t in (rows, cols, vals))
    cell_y, cell_x = np.nonzero(held)
    return sp.csr_matrix((v, (r, c)), shape=(ys.size, cell_y.size)), cell_y - 1, cell_x - 1
