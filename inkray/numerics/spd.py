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

__all__ = ["spd_factor", "nested_dissection", "nested_dissection_of_edges", "MinQuadWithFixed",
           "min_quad_with_fixed"]


def spd_factor(A, *, ordered=False, equilibrate=True):
    """Factor a sparse symmetric positive definite matrix.

    Parameters
    ----------
    A : (n, n) sparse matrix
        Symmetric positive definite.
    ordered : bool, default False
        ``A``'s rows and columns are already in a fill-reducing order (a
        nested dissection of the caller's); otherwise SuperLU orders them by
        minimum degree.
    equilibrate : bool, default True
        Let SuperLU scale the rows and columns of a badly scaled ``A``; a
        caller whose systems it leaves as they are saves the pass that
        measures them.

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
                    options={"SymmetricMode": True, "Equil": bool(equilibrate)})
    except RuntimeError as e:  # SuperLU reports an exactly singular matrix this way
        raise np.linalg.LinAlgError(str(e)) from None


def nested_dissection(K, rows, cols):
    """A nested-dissection order of a grid system's variables from their lattice positions.

    The grid is halved along its rows and its columns in turn (the bits of
    the positions' Morton code, most significant first); a variable with an
    edge to the other half of its cell at some halving is a separator there,
    ordered after both halves (George, "Nested dissection of a regular finite
    element mesh", 1973). On the reduced systems of 1 Mpx drawings the
    factor is about twice SuperLU's minimum-degree one, and ordering and
    factoring take about half the time.

    Parameters
    ----------
    K : (n, n) sparse matrix
        Symmetric; its off-diagonal entries are the edges between variables.
    rows, cols : (n,) int arrays
        Each variable's lattice position (non-negative).

    Returns
    -------
    (n,) int array
        The permutation: ``K[order][:, order]`` is factored with
        ``spd_factor(..., ordered=True)``.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> path = sp.diags([-np.ones(3), 2 * np.ones(4), -np.ones(3)], [-1, 0, 1])
    >>> nested_dissection(path, np.zeros(4, int), np.arange(4)).tolist()  # 1 parts 0 from 2, 3
    [0, 3, 2, 1]
    """
    upper = sp.triu(K, 1).tocoo()
    return nested_dissection_of_edges(upper.row, upper.col, rows, cols)


def nested_dissection_of_edges(i, j, rows, cols):
    """:func:`nested_dissection` of the variables joined by the edges ``(i[k], j[k])``.

    Parameters
    ----------
    i, j : (m,) int arrays
        The edges' two variables, each edge once or more (``i != j``).
    rows, cols : (n,) int arrays
        Each variable's lattice position (non-negative).

    Returns
    -------
    (n,) int array
        The permutation.

    Examples
    --------
    >>> nested_dissection_of_edges([0, 1, 2], [1, 2, 3], np.zeros(4, int), np.arange(4)).tolist()
    [0, 3, 2, 1]
    """
    rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
    bits = max(int(rows.max()), int(cols.max()), 1).bit_length()
    top = 2 * bits
    m = np.zeros(len(rows), np.int64)
    for b in range(bits):
        m |= ((rows >> b) & 1) << (2 * b + 1) | ((cols >> b) & 1) << (2 * b)
    i, j = np.asarray(i, np.int64), np.asarray(j, np.int64)
    # The halving that parts an edge's two ends: the highest bit where their codes differ.
    level = top - np.frexp((m[i] ^ m[j]).astype(np.float64))[1]
    low = np.where(m[i] < m[j], i, j)
    # one dtype for both (np.minimum.at casting between them is some fifty times slower)
    depth = np.full(len(rows), top, level.dtype)
    np.minimum.at(depth, low, level)
    end = ((m >> (top - depth)) + 1) << (top - depth)
    return np.lexsort((-depth, end))


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
