"""Crossings of two sets of segments in the plane."""

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["segment_crossings"]


def segment_crossings(a, b):
    """Points where a segment of ``a`` crosses a segment of ``b``.

    Candidate pairs are segments whose midpoints are closer than half their
    longest lengths summed (a k-d tree), so the cost grows with the crossings,
    not with the product of the sets' sizes. Parallel and collinear pairs
    have no single crossing and are left out; a crossing at a segment's end
    counts.

    Parameters
    ----------
    a, b : (n, 2, 2) and (m, 2, 2) arrays
        Segments as their two end points ``[[x0, y0], [x1, y1]]``.

    Returns
    -------
    (k, 2) float array
        The crossings, ordered by the pair's index in ``a``, then in ``b``.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([[[0.0, 0.0], [2.0, 2.0]], [[5.0, 0.0], [6.0, 0.0]]])
    >>> b = np.array([[[0.0, 2.0], [2.0, 0.0]]])
    >>> segment_crossings(a, b).tolist()
    [[1.0, 1.0]]
    """
    a = np.asarray(a, float).reshape(-1, 2, 2)
    b = np.asarray(b, float).reshape(-1, 2, 2)
    if len(a) == 0 or len(b) == 0:
        return np.zeros((0, 2))
    la = np.linalg.norm(a[:, 1] - a[:, 0], axis=1)
    lb = np.linalg.norm(b[:, 1] - b[:, 0], axis=1)
    reach = 0.5 * (la.max() + lb.max()) * (1.0 + 1e-9)
    pairs = cKDTree(a.mean(axis=1)).sparse_distance_matrix(
        cKDTree(b.mean(axis=1)), reach, output_type="ndarray")
    i = np.asarray(pairs["i"], np.int64)
    j = np.asarray(pairs["j"], np.int64)
    keep = np.lexsort((j, i))  # the tree's pair order is no contract
    i, j = i[keep], j[keep]
    p, r = a[i, 0], a[i, 1] - a[i, 0]
    q, s = b[j, 0], b[j, 1] - b[j, 0]
    den = r[:, 0] * s[:, 1] - r[:, 1] * s[:, 0]
    qp = q - p
    ok = np.abs(den) > 1e-12 * la[i] * lb[j]
    den = np.where(ok, den, 1.0)
    t = (qp[:, 0] * s[:, 1] - qp[:, 1] * s[:, 0]) / den
    u = (qp[:, 0] * r[:, 1] - qp[:, 1] * r[:, 0]) / den
    ok &= (t >= 0.0) & (t <= 1.0) & (u >= 0.0) & (u <= 1.0)
    return p[ok] + t[ok, None] * r[ok]
