"""Sparse symmetric positive definite systems: factor once, solve many.

``spd_factor`` is SuperLU in its symmetric mode (minimum-degree ordering of
``A^T + A``, no pivoting), many times faster than its general mode on the
Laplacians of pixel grids and meshes. ``min_quad_with_fixed`` minimizes a
quadratic with some variables fixed, named and defined as in libigl
(Jacobson et al., libigl's ``min_quad_with_fixed``); its solver object is
factored once and solves for any linear term and fixed values, as
gpytoolbox's ``fixed_dof_solve``.
"""

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

__all__ = ["spd_factor", "MinQuadWithFixed", "min_quad_with_fixed"]


def spd_factor(A, *, ordered=False):
    """Factor a sparse symmetric positive definite matrix.

    Parameters
    ----------
    A : (n, n) sparse matrix
        Symmetric positive definite.
    ordered : bool, default False
        ``A``'s rows and columns are already in a fill-reducing order (a
        nested dissection of the caller's); otherwise SuperLU orders them by
        minimum degree.

    Returns
    -------
    scipy.sparse.linalg.SuperLU
        Its ``solve(b)`` takes one right-hand side or a column stack.

    Raises
    ------
    numpy.linalg.LinAlgError
        ``A`` is singular.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> spd_factor(sp.diags([2.0, 4.0])).solve(np.array([2.0, 2.0])).tolist()
    [1.0, 0.5]
    """
    try:
        return splu(sp.csc_matrix(A), permc_spec="NATURAL" if ordered else "MMD_AT_PLUS_A",
                    diag_pivot_thresh=0.0,
                    options={"SymmetricMode": True})
    except RuntimeError as e:  # SuperLU reports an exactly singular matrix this way
        raise np.linalg.LinAlgError(str(e)) from None


class MinQuadWithFixed:
    """``argmin_x 1/2 x^T Q x + x^T B`` subject to ``x[known] = Y``, factored once.

    Parameters
    ----------
    Q : (n, n) sparse matrix
        Symmetric; positive definite on the unknowns.
    known : (n,) bool array or int array of indices
        The fixed variables.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> Q = sp.csr_matrix(np.array([[1.0, -1, 0], [-1, 2, -1], [0, -1, 1]]))  # a path's Laplacian
    >>> solver = MinQuadWithFixed(Q, [0, 2])
    >>> solver.solve(np.zeros(3), [0.0, 2.0]).tolist()                      # the middle: 1
    [0.0, 1.0, 2.0]
    """

    def __init__(self, Q, known):
        Q = sp.csr_matrix(Q)
        n = Q.shape[0]
        mask = np.zeros(n, bool)
        mask[np.asarray(known)] = True
        self.n = n
        self.known = np.flatnonzero(mask)
        self.unknown = np.flatnonzero(~mask)
        rows = Q[self.unknown]
        self._coupling = rows[:, self.known]
        self._factor = spd_factor(rows[:, self.unknown]) if len(self.unknown) else None

    def solve(self, B=None, Y=None):
        """The minimizer for linear term ``B`` and fixed values ``Y``.

        Parameters
        ----------
        B : (n,) or (n, k) array, optional
            Linear term (zero when omitted).
        Y : (len(known),) or (len(known), k) array, optional
            Values of the fixed variables (zero when omitted).

        Returns
        -------
        (n,) or (n, k) float array
        """
        k = None
        for a in (B, Y):
            if a is not None and np.ndim(a) == 2:
                k = np.shape(a)[1]
        shape = (self.n,) if k is None else (self.n, k)
        x = np.zeros(shape)
        if Y is not None:
            x[self.known] = np.asarray(Y, float)
        if self._factor is None:
            return x
        rhs = -(self._coupling @ x[self.known])
        if B is not None:
            rhs = rhs - np.broadcast_to(np.asarray(B, float), shape)[self.unknown]
        x[self.unknown] = self._factor.solve(rhs)
        return x


def min_quad_with_fixed(Q, B, known, Y):
    """``argmin_x 1/2 x^T Q x + x^T B`` subject to ``x[known] = Y`` (one solve).

    Parameters
    ----------
    Q : (n, n) sparse matrix
    B : (n,) array
    known : (n,) bool array or int indices
    Y : (len(known),) array

    Returns
    -------
    (n,) float array

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> Q = sp.csr_matrix(np.array([[2.0, -1], [-1, 2]]))
    >>> min_quad_with_fixed(Q, np.array([0.0, -1.0]), [0], [1.0]).tolist()
    [1.0, 1.0]
    """
    return MinQuadWithFixed(Q, known).solve(B, Y)
