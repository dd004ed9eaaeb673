"""Open joins: where a part's outline stroke stops short inside the part behind it.

Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for Adding Global
Illumination Effects to Hand-Drawn Characters" (TOG 2014, section 4) inflate
a region with a Neumann condition where its outline is not covered by ink,
and stitch it there to the region it meets, so that the two surfaces join
instead of standing one above the other. A leg drawn with one open stroke
that ends inside the body, or a leg open at the top between two stroke tips,
is such a join: the segmentation cuts leg from body across the paper
between the strokes, and that cut must become a seam, not a cliff.

This module finds those cuts in the segmentation: the runs of the common
outline of two regions where neither side is ink, long enough not to be a
mere gap in a drawn line (at least :data:`OPEN_WIDTHS` stroke widths and
:data:`OPEN_MIN` px), each as a smooth polyline along the cut. Each becomes
a ``graft`` seam (:class:`OpenJoin`) that the outline, triangulation and
stitching stages take like a ``graft`` entry of the annotations: the part in
front grows out of the part behind with its height and slope. Stretches
already marked by a ``boundaries`` entry are left to that entry.
"""

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import find_objects, gaussian_filter1d, label
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from inkray.errors import InputError
from inkray.numerics.polyline import arc_length, point_polyline_distance, resample_polyline
from inkray.relief.outline import DEFAULT_SNAP
from inkray.relief.silhouette import ink_pixels, stroke_width

__all__ = ["OpenJoin", "open_joins", "OPEN_WIDTHS", "OPEN_MIN"]

#: An ink-free cut this many stroke widths long is an open join; a shorter one is a gap.
OPEN_WIDTHS = 1.5
#: And at least this long (px): a pen lifted for a moment leaves a gap, not an opening.
OPEN_MIN = 20.0
_SMOOTH = 2.0  # px (Gaussian sigma along the cut): the cut's pixel steps smoothed away


@dataclass(frozen=True)
class OpenJoin:
    """An ink-free stretch of the outline between two regions, taken as a ``graft`` seam.

    Attributes
    ----------
    type : str
        ``"graft"``: the stages treat it as a graft entry.
    path : (k, 2) float array
        ``[x, y]`` along the cut, from one stroke to the other.
    index : int
        Its index among the seams, after the annotation's ``boundaries``
        (so it marks outlines and stations as an entry of that index does).
    regions : (int, int)
        The two regions it joins.
    label : str
        How messages name it.
    """

    type: str
    path: np.ndarray
    index: int
    regions: tuple
    label: str


def open_joins(labels, gray, *, boundaries=(), names=None, start=None, widths=OPEN_WIDTHS,
               min_length=OPEN_MIN, snap=DEFAULT_SNAP):
    """Find the open joins of a segmentation.

    Parameters
    ----------
    labels : (H, W) int array
        ``-1`` background, ``0..R-1`` regions (the parts the meshes outline).
    gray : (H, W) float array
        The drawing, paper 1, ink near 0.
    boundaries : sequence of Boundary, default ()
        The annotation's ``boundaries`` entries: the cut within ``2 snap``
        px of their paths is theirs.
    names : sequence of str, optional
        Region names, for the joins' labels.
    start : int, optional
        Index of the first join; default ``len(boundaries)``.
    widths : float, default :data:`OPEN_WIDTHS`
        Shortest join, in stroke widths (:func:`inkray.relief.silhouette.stroke_width`).
    min_length : float, default :data:`OPEN_MIN`
        Shortest join in px.
    snap : float, default :data:`inkray.relief.outline.DEFAULT_SNAP`

    Returns
    -------
    list of OpenJoin
        Ordered by region pair, then by position.

    Raises
    ------
    InputError
        Arrays of different shapes.

    Examples
    --------
    A leg (region 1) drawn with two strokes that stop short of the body
    (region 0): the cut between the stroke tips is an open join.

    >>> gray = np.ones((80, 80)); gray[38:78, 20:23] = 0.0; gray[38:78, 57:60] = 0.0
    >>> labels = np.zeros((80, 80), int); labels[38:, 20:60] = 1
    >>> [(j.regions, round(float(np.ptp(j.path[:, 0])))) for j in open_joins(labels, gray)]
    [((0, 1), 33)]
    """
    labels = np.asarray(labels)
    gray = np.asarray(gray, float)
    if labels.shape != gray.shape:
        raise InputError(f"gray: expected the labels' shape {labels.shape}, got {gray.shape}")
    ink = ink_pixels(gray)
    shortest = max(widths * stroke_width(ink), min_length)
    taken = [np.asarray(b.path, float) for b in boundaries]
    joins = []
    for (a, b), points in sorted(_cuts(labels, ink).items()):
        if taken:
            near = np.min([point_polyline_distance(points, p) for p in taken], axis=0)
            points = points[near > 2.0 * snap]
        for run in _runs(points):
            path = _path(run)
            if len(path) < 2 or arc_length(path)[-1] < shortest:
                continue
            joins.append((a, b, path))
    first = len(boundaries) if start is None else int(start)
    out = []
    for k, (a, b, path) in enumerate(joins):
        na, nb = (f"region{i}" if names is None else names[i] for i in (a, b))
        x, y = np.rint(path[len(path) // 2]).astype(int)
        out.append(OpenJoin(type="graft", path=path, index=first + k, regions=(a, b),
                            label=f"the open join of {na!r} and {nb!r} at ({x}, {y})"))
    return out


def _cuts(labels, ink):
    """Per region pair ``(a, b)``, ``a < b``: the midpoints (k, 2) ``[x, y]`` of the
    4-neighbour pixel pairs across their common outline where neither pixel is ink."""
    out = {}
    for axis in (0, 1):
        lo = [slice(None), slice(None)]
        hi = [slice(None), slice(None)]
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        la, lb = labels[tuple(lo)], labels[tuple(hi)]
        cut = (la >= 0) & (lb >= 0) & (la != lb) & ~ink[tuple(lo)] & ~ink[tuple(hi)]
        ys, xs = np.nonzero(cut)
        mid = np.column_stack([xs, ys]).astype(float)
        mid[:, 1 - axis] += 0.5
        pa, pb = np.minimum(la[cut], lb[cut]), np.maximum(la[cut], lb[cut])
        for key in set(zip(pa.tolist(), pb.tolist())):
            sel = (pa == key[0]) & (pb == key[1])
            out.setdefault(key, []).append(mid[sel])
    return {k: np.concatenate(v) for k, v in out.items()}


def _runs(points):
    """The connected runs of cut midpoints (neighbours at most a pixel's diagonal apart)."""
    if len(points) == 0:
        return []
    grid = np.floor(points).astype(int)
    grid -= grid.min(axis=0)
    img = np.zeros(tuple(grid.max(axis=0)[::-1] + 1), np.int32)
    img[grid[:, 1], grid[:, 0]] = 1
    comp, _ = label(img, structure=np.ones((3, 3), bool))
    which = comp[grid[:, 1], grid[:, 0]]
    return [points[which == k] for k in range(1, len(find_objects(comp)) + 1)]


def _path(points):
    """A smooth polyline through a run of cut midpoints, from one end to the other.

    The run's two ends are those of its longest shortest path (the graph of
    midpoints within a pixel's diagonal); the polyline follows that path,
    resampled every half pixel and smoothed by :data:`_SMOOTH` px with its
    ends kept.
    """
    if len(points) < 2:
        return points
    pairs = cKDTree(points).query_pairs(1.5, output_type="ndarray")
    if len(pairs) == 0:
        return points[:1]
    w = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1)
    graph = coo_matrix((w, (pairs[:, 0], pairs[:, 1])), shape=(len(points),) * 2).tocsr()
    far = dijkstra(graph, directed=False, indices=0)
    u = int(np.argmax(np.where(np.isfinite(far), far, -1.0)))
    dist, pred = dijkstra(graph, directed=False, indices=u, return_predecessors=True)
    v = int(np.argmax(np.where(np.isfinite(dist), dist, -1.0)))
    chain = [v]
    while chain[-1] != u:
        chain.append(int(pred[chain[-1]]))
    path = resample_polyline(points[chain[::-1]], 0.5)
    if len(path) < 3:
        return path
    # Odd reflection at both ends: the smoothing keeps the ends and the end directions.
    k = min(len(path) - 1, int(np.ceil(3 * _SMOOTH / 0.5)))
    ext = np.vstack([2 * path[0] - path[k:0:-1], path, 2 * path[-1] - path[-2:-k - 2:-1]])
    return gaussian_filter1d(ext, _SMOOTH / 0.5, axis=0, mode="nearest")[k:k + len(path)]
