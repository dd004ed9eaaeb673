"""Images as graphs: 4-neighbour edge weights, weighted grid Laplacians, 5-point operators.

The depth maps of Sýkora et al. (CGF 2010) minimize ``sum_pq w_pq (d_p -
d_q)^2`` over the pixel grid, with ``w_pq = exp(-(I_p - I_q)^2 / sigma)``
small across ink; the same Laplacian fills and extends values over pixel
masks (completion under occluders, the fast depth method's fill). Pixels are
in raster order, ``y * W + x``.
"""

import numpy as np
import scipy.sparse as sp

from inkray.errors import InputError

__all__ = ["edge_weights", "grid_laplacian", "grid_degree", "grid_operator", "WEIGHT_FLOOR",
           "SIGMA_FLOOR"]

#: Smallest edge weight: keeps the pixel graph connected and L well enough
#: conditioned for a 1e-6 KKT check, while a step across ink still costs
#: 1e5 times less than the same step across paper.
WEIGHT_FLOOR = 1e-5
#: Smallest sigma, so a blank or nearly blank image gives uniform weights
#: instead of turning paper noise into walls.
SIGMA_FLOOR = 1e-4


def edge_weights(gray, *, sigma=None, floor=WEIGHT_FLOOR):
    """4-neighbour edge weights ``w_pq = max(exp(-(I_p - I_q)^2 / sigma), floor)``.

    Parameters
    ----------
    gray : (H, W) float array in [0, 1]
        Paper 1, ink near 0.
    sigma : float, optional
        Contrast scale. Default: the mean contrast of the image's edges,
        ``mean((I_p - I_q)^2)`` over all 4-neighbour pairs (at least
        :data:`SIGMA_FLOOR`), so only edges much stronger than the typical
        one (ink outlines) become weak.
    floor : float, default :data:`WEIGHT_FLOOR`
        Smallest weight (> 0).

    Returns
    -------
    wx : (H, W-1) float64 array
        Weights between ``(y, x)`` and ``(y, x+1)``.
    wy : (H-1, W) float64 array
        Weights between ``(y, x)`` and ``(y+1, x)``.
    sigma : float
        The sigma used.

    Examples
    --------
    >>> import numpy as np
    >>> wx, wy, s = edge_weights(np.ones((3, 4)))
    >>> float(wx.min()), wx.shape, wy.shape
    (1.0, (3, 3), (2, 4))
    """
    g = np.asarray(gray, np.float64)
    if g.ndim != 2 or min(g.shape) < 1:
        raise InputError(f"gray: expected an (H, W) image, got shape {g.shape}")
    if not np.isfinite(g).all():
        y, x = np.argwhere(~np.isfinite(g))[0]
        raise InputError(f"gray: pixel ({x}, {y}) is not a finite number")
    if not floor > 0:
        raise InputError(f"floor: expected a positive weight floor, got {floor}")
    dx2 = np.diff(g, axis=1) ** 2
    dy2 = np.diff(g, axis=0) ** 2
    if sigma is None:
        n = dx2.size + dy2.size
        sigma = (dx2.sum() + dy2.sum()) / n if n else 0.0
        sigma = max(float(sigma), SIGMA_FLOOR)
    elif not sigma > 0:
        raise InputError(f"sigma: expected a positive contrast scale, got {sigma}")
    wx = np.maximum(np.exp(-dx2 / sigma), floor)
    wy = np.maximum(np.exp(-dy2 / sigma), floor)
    return wx, wy, float(sigma)


def grid_laplacian(wx, wy):
    """Weighted graph Laplacian ``L = D - W`` of the 4-neighbour grid.

    Parameters
    ----------
    wx : (H, W-1) array
        Horizontal edge weights.
    wy : (H-1, W) array
        Vertical edge weights.

    Returns
    -------
    (H*W, H*W) scipy.sparse.csr_matrix
        Pixels in raster order (``y * W + x``); ``d^T L d`` is the sum over
        edges of ``w_pq (d_p - d_q)^2``.

    Examples
    --------
    >>> import numpy as np
    >>> L = grid_laplacian(np.ones((1, 1)), np.zeros((0, 2)))
    >>> L.toarray().tolist()
    [[1.0, -1.0], [-1.0, 1.0]]
    """
    wx = np.asarray(wx, np.float64)
    wy = np.asarray(wy, np.float64)
    return grid_operator(grid_degree(wx, wy), -wx, -wy)


def grid_degree(wx, wy):
    """Weighted degree of every pixel: the sum of its edges' weights (``L``'s diagonal).

    Parameters
    ----------
    wx : (H, W-1) array
    wy : (H-1, W) array

    Returns
    -------
    (H, W) float64 array

    Examples
    --------
    >>> import numpy as np
    >>> grid_degree(np.ones((2, 1)), np.ones((1, 2))).tolist()
    [[2.0, 2.0], [2.0, 2.0]]
    """
    wx = np.asarray(wx, np.float64)
    wy = np.asarray(wy, np.float64)
    h, w = wx.shape[0], wx.shape[1] + 1
    deg = np.zeros((h, w))
    deg[:, :-1] += wx
    deg[:, 1:] += wx
    deg[:-1, :] += wy
    deg[1:, :] += wy
    return deg


def grid_operator(diagonal, east, south):
    """The 5-point operator of :class:`GridCholesky` as a sparse matrix.

    Parameters
    ----------
    diagonal : (H, W) array
    east : (H, W-1) array
    south : (H-1, W) array

    Returns
    -------
    (H*W, H*W) scipy.sparse.csr_matrix

    Examples
    --------
    >>> import numpy as np
    >>> grid_operator(np.full((1, 2), 2.0), -np.ones((1, 1)), np.zeros((0, 2))).toarray().tolist()
    [[2.0, -1.0], [-1.0, 2.0]]
    """
    diagonal = np.asarray(diagonal, np.float64)
    h, w = diagonal.shape
    idx = np.arange(h * w).reshape(h, w)
    i = np.concatenate([idx[:, :-1].ravel(), idx[:-1, :].ravel()])
    j = np.concatenate([idx[:, 1:].ravel(), idx[1:, :].ravel()])
    v = np.concatenate([np.asarray(east, np.float64).ravel(),
                        np.asarray(south, np.float64).ravel()])
    rows = np.concatenate([i, j, idx.ravel()])
    cols = np.concatenate([j, i, idx.ravel()])
    return sp.csr_matrix((np.concatenate([v, v, diagonal.ravel()]), (rows, cols)),
                         shape=(h * w, h * w))
