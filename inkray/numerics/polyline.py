"""Polylines in the plane: arc length, resampling and point distances."""

import math

import numpy as np

__all__ = ["arc_length", "resample_polyline", "point_polyline_distance"]


def arc_length(p, *, closed=False):
    """Cumulative arc length at each vertex (and, when ``closed``, back at the first).

    Parameters
    ----------
    p : (n, 2) array
    closed : bool, default False

    Returns
    -------
    (n,) or (n + 1,) float array
        Starting at 0.

    Examples
    --------
    >>> import numpy as np
    >>> arc_length(np.array([[0.0, 0], [3, 4], [3, 0]]), closed=True).tolist()
    [0.0, 5.0, 9.0, 12.0]
    """
    p = np.asarray(p, float)
    q = np.vstack([p, p[:1]]) if closed else p
    return np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))]


def resample_polyline(p, step):
    """Evenly spaced points along an open polyline, at most ``step`` apart, ends kept.

    Parameters
    ----------
    p : (n, 2) array
    step : float

    Returns
    -------
    (k, 2) float array, k >= 2

    Examples
    --------
    >>> import numpy as np
    >>> resample_polyline(np.array([[0.0, 0], [4, 0]]), 1.5).tolist()
    [[0.0, 0.0], [1.3333333333333333, 0.0], [2.6666666666666665, 0.0], [4.0, 0.0]]
    """
    p = np.asarray(p, float)
    s = arc_length(p)
    n = max(2, math.ceil(s[-1] / step) + 1)
    t = np.linspace(0, s[-1], n)
    return np.stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])], axis=1)


def point_polyline_distance(points, line):
    """Distance of each point to an open polyline (segments between its vertices).

    Parameters
    ----------
    points : (k, 2) or (2,) array
    line : (n, 2) array, n >= 1

    Returns
    -------
    (k,) float array (a float for one point)

    Examples
    --------
    >>> import numpy as np
    >>> point_polyline_distance(np.array([[1.0, 2.0], [5.0, 0.0]]), np.array([[0.0, 0], [3, 0]])).tolist()
    [2.0, 2.0]
    >>> point_polyline_distance((0.0, 1.0), [[0.0, 0.0]])
    1.0
    """
    single = np.ndim(points) == 1
    p = np.asarray(points, float).reshape(-1, 2)
    line = np.asarray(line, float).reshape(-1, 2)
    if len(line) == 1:
        d = np.hypot(*(p - line[0]).T)
    else:
        a, b = line[:-1], line[1:]
        ab = b - a
        t = ((p[:, None, :] - a[None]) * ab[None]).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-12)[None]
        closest = a[None] + np.clip(t, 0.0, 1.0)[..., None] * ab[None]
        d = np.sqrt(((p[:, None, :] - closest) ** 2).sum(-1)).min(axis=1)
    return float(d[0]) if single else d
