"""Orthographic z-buffer rasterization of a relief, seen from the front.

The front view of an Ink-and-Ray bas-relief reproduces the drawing (Sýkora et
al., "Ink-and-Ray", TOG 2014, section 6): every drawing pixel sees the front
surface of the part on top. This module computes, per output pixel, which part
and triangle is visible there, its depth, its interpolated normal and its
planar texture coordinates, for shading, normal/depth maps, stereo pairs and
texture-registration checks.

Frames. Input vertices are in drawing pixels (``x`` right, ``y`` down, ``z``
toward the viewer, see :mod:`inkray.relief`). An optional affine ``view``
matrix moves the camera (e.g. a turntable angle or a stereo shear); the output
pixel of a view point ``q`` is ``((q_x + 0.5) * scale + offset_x, (q_y + 0.5) *
scale + offset_y)`` with pixel ``(row i, column j)`` centred at ``(j + 0.5, i +
0.5)``: drawing pixel centres are integers (:mod:`inkray.relief`), so at scale 1
drawing pixel ``(x, y)`` is output pixel ``(y, x)``, and its depth is ``q_z``. Normals stay in the relief's frame because a view
moves the camera, not the lighting.

The rasterizer is vectorized over (triangle, pixel-in-bounding-box) pairs in
chunks of bounded size, so memory stays flat for any mesh.
"""

from dataclasses import dataclass

import numpy as np

from inkray.errors import InputError
from inkray.relief.model import Relief

__all__ = ["Raster", "rasterize", "fit_view", "vertex_normals", "zbuffer"]

_CHUNK = 1 << 20  # (triangle, pixel) candidate pairs per vectorized batch
_EDGE_EPS = 1e-9  # pixel centres exactly on an edge count as inside


@dataclass
class Raster:
    """Per-pixel front-view attributes of a relief.

    Empty pixels have ``part == -1``, ``face == -1``, ``depth == -inf`` and
    zero ``normal``, ``uv``, ``bary`` and ``position``.

    Attributes
    ----------
    part : (h, w) int32 array
        Index into ``relief.parts`` of the visible part, -1 where empty.
    face : (h, w) int64 array
        Index into that part's ``faces`` of the visible triangle, -1 where empty.
    bary : (h, w, 3) float array
        Barycentric coordinates of the pixel centre in that triangle, in the
        order of its face's vertices.
    depth : (h, w) float array
        View-space ``z`` (toward the viewer, drawing pixels); ``-inf`` where
        empty. Without a view this is the relief's own ``z``.
    normal : (h, w, 3) float array
        Unit vertex-normal interpolation in the relief's frame (``x`` right,
        ``y`` down, ``z`` toward the viewer).
    position : (h, w, 3) float array
        The visible surface point in drawing coordinates (before the view).
    uv : (h, w, 2) float array
        Planar texture coordinates ``((x + 0.5) / W, 1 - (y + 0.5) / H)`` of that
        point (:meth:`inkray.relief.model.Relief.uv`).
    scale : float
        Output pixels per drawing pixel.
    offset : (float, float)
        Output pixel position of the drawing's top-left corner ``(-0.5, -0.5)``.
    """

    part: np.ndarray
    face: np.ndarray
    bary: np.ndarray
    depth: np.ndarray
    normal: np.ndarray
    position: np.ndarray
    uv: np.ndarray
    scale: float
    offset: tuple

    @property
    def mask(self):
        """(h, w) bool array: True where some part is visible."""
        return self.part >= 0


def fit_view(drawing_size, size):
    """Scale and offset that fit a drawing into an image, centred, aspect kept.

    Parameters
    ----------
    drawing_size : (int, int)
        ``(W, H)`` of the drawing in pixels.
    size : (int, int)
        ``(w, h)`` of the output image in pixels.

    Returns
    -------
    scale : float
        Output pixels per drawing pixel.
    offset : (float, float)
        Output pixel position of the drawing's top-left corner ``(-0.5, -0.5)``.

    Examples
    --------
    >>> fit_view((100, 50), (200, 200))
    (2.0, (0.0, 50.0))
    """
    (dw, dh), (w, h) = drawing_size, size
    scale = min(w / dw, h / dh)
    return float(scale), (float((w - dw * scale) / 2), float((h - dh * scale) / 2))


def rasterize(relief, *, size=None, scale=None, offset=None, view=None):
    """Rasterize a relief orthographically along ``-z`` with a z-buffer.

    Parameters
    ----------
    relief : inkray.relief.model.Relief
    size : (int, int), optional
        ``(w, h)`` of the output in pixels. Default: the drawing's size times
        ``scale`` (rounded), or the drawing's size when ``scale`` is not given.
    scale : float, optional
        Output pixels per drawing pixel. Default: fit the drawing into
        ``size`` (see :func:`fit_view`), or 1.
    offset : (float, float), optional
        Output pixel position of the drawing's top-left corner ``(-0.5,
        -0.5)`` (pixel centres are integers). Default: centred when
        ``size`` and ``scale`` are both derived, else ``(0, 0)``.
    view : (3, 4) array, optional
        Affine camera: a drawing point ``p`` is seen at ``view[:, :3] @ p +
        view[:, 3]`` (drawing pixels, ``z`` toward the viewer). Default:
        identity (the front view).

    Returns
    -------
    Raster

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.model import Part, Relief
    >>> v = np.array([[0, 0, 5], [4, 0, 5], [4, 4, 5], [0, 4, 5]], float) - [0.5, 0.5, 0]
    >>> f = np.array([[0, 3, 2], [0, 2, 1]])  # counter-clockwise as seen by the viewer
    >>> # the drawing's whole extent: pixel centres (integers) 0..3 lie inside
    >>> r = rasterize(Relief([Part("sq", v, f)], size=(4, 4)))
    >>> int(r.mask.sum()), float(r.depth[1, 1]), r.normal[1, 1].tolist()
    (16, 5.0, [0.0, 0.0, 1.0])
    """
    if not isinstance(relief, Relief):
        raise InputError("rasterize: expected an inkray.relief.model.Relief, "
                         f"got {type(relief).__name__}")
    dw, dh = (int(s) for s in relief.size)
    if dw <= 0 or dh <= 0:
        raise InputError(f"rasterize: relief size {relief.size} must be positive")
    if scale is not None and not (np.isfinite(scale) and scale > 0):
        raise InputError(f"rasterize: scale {scale} must be a positive number")
    if size is None:
        s = 1.0 if scale is None else float(scale)
        size = (max(1, round(dw * s)), max(1, round(dh * s)))
        scale, auto_offset = s, (0.0, 0.0)
    elif scale is None:
        scale, auto_offset = fit_view((dw, dh), size)
    else:
        auto_offset = (0.0, 0.0)
    w, h = (int(s) for s in size)
    if w <= 0 or h <= 0:
        raise InputError(f"rasterize: output size {size} must be positive")
    offset = auto_offset if offset is None else (float(offset[0]), float(offset[1]))
    view = np.eye(3, 4) if view is None else np.asarray(view, float)
    if view.shape != (3, 4) or not np.all(np.isfinite(view)):
        raise InputError(f"rasterize: view must be a finite (3, 4) matrix, got shape {view.shape}")

    verts, tris, tri_part, tri_local, normals = _soup(relief)
    seen = verts @ view[:, :3].T + view[:, 3]
    px = np.stack([(seen[:, 0] + 0.5) * scale + offset[0], (seen[:, 1] + 0.5) * scale + offset[1]],
                  axis=1)

    tri_id = _zbuffer(px, seen[:, 2], tris, w, h)

    hit = tri_id >= 0
    pix = np.flatnonzero(hit)
    t = tri_id[pix]
    cols, rows = pix % w + 0.5, pix // w + 0.5
    corners = tris[t]
    # Pixel centres on an edge or vertex get barycentrics a round-off below 0;
    # clamped, interpolated depths and positions stay within their triangle.
    b = np.clip(_barycentric(px[corners], cols, rows), 0.0, None)
    b /= b.sum(axis=1, keepdims=True)

    part = np.full(h * w, -1, np.int32)
    face = np.full(h * w, -1, np.int64)
    bary = np.zeros((h * w, 3))
    depth = np.full(h * w, -np.inf)
    normal = np.zeros((h * w, 3))
    position = np.zeros((h * w, 3))
    part[pix], face[pix], bary[pix] = tri_part[t], tri_local[t], b
    depth[pix] = np.einsum("nk,nk->n", b, seen[corners, 2])
    position[pix] = np.einsum("nk,nkc->nc", b, verts[corners])
    n = np.einsum("nk,nkc->nc", b, normals[corners])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    normal[pix] = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
    uv = np.zeros((h * w, 2))
    uv[pix] = relief.uv(position[pix])
    return Raster(part=part.reshape(h, w), face=face.reshape(h, w),
                  bary=bary.reshape(h, w, 3), depth=depth.reshape(h, w),
                  normal=normal.reshape(h, w, 3), position=position.reshape(h, w, 3),
                  uv=uv.reshape(h, w, 2), scale=float(scale), offset=offset)


def _soup(relief):
    """All parts as one vertex array and one triangle array, with vertex normals."""
    verts, tris, tri_part, tri_local, normals = [], [], [], [], []
    base = 0
    for i, p in enumerate(relief.parts):
        v = np.asarray(p.vertices, float)
        f = np.asarray(p.faces)
        if v.ndim != 2 or v.shape[1] != 3 or not np.all(np.isfinite(v)):
            raise InputError(f"rasterize: parts[{i}] ({p.name}): vertices must be finite (n, 3)")
        if f.size == 0:
            f = f.reshape(0, 3)
        if f.ndim != 2 or f.shape[1] != 3 or not np.issubdtype(f.dtype, np.integer):
            raise InputError(f"rasterize: parts[{i}] ({p.name}): faces must be an (m, 3) int array")
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            raise InputError(f"rasterize: parts[{i}] ({p.name}): face index out of range "
                             f"0..{len(v) - 1}")
        verts.append(v)
        tris.append(f.astype(np.int64) + base)
        tri_part.append(np.full(len(f), i, np.int32))
        tri_local.append(np.arange(len(f), dtype=np.int64))
        normals.append(vertex_normals(v, f))
        base += len(v)
    if not verts:
        return (np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros(0, np.int32),
                np.zeros(0, np.int64), np.zeros((0, 3)))
    return (np.concatenate(verts), np.concatenate(tris), np.concatenate(tri_part),
            np.concatenate(tri_local), np.concatenate(normals))


def vertex_normals(vertices, faces):
    """Area-weighted unit vertex normals of a relief part, in the relief's frame.

    Faces are counter-clockwise as seen by the viewer; with ``y`` growing
    downward they are clockwise in ``(x, y)``, so the raw cross product points
    away from the viewer and its negation is the normal. Vertices on no face
    get a zero normal.

    Parameters
    ----------
    vertices : (n, 3) float array
        ``[x, y, z]`` in drawing pixels.
    faces : (m, 3) int array

    Returns
    -------
    (n, 3) float array

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 2]], float)  # z = 2x, clockwise in (x, y)
    >>> np.round(vertex_normals(v, np.array([[0, 1, 2]]))[0], 3).tolist()
    [-0.894, 0.0, 0.447]
    """
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    n = np.zeros_like(v)
    if len(f) == 0:
        return n
    fn = -np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    for k in range(3):
        for c in range(3):
            n[:, c] += np.bincount(f[:, k], weights=fn[:, c], minlength=len(v))
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)


def _barycentric(corners, x, y):
    """Barycentric coordinates of points ``(x, y)`` in 2D triangles ``corners`` (n, 3, 2)."""
    (x0, y0), (x1, y1), (x2, y2) = (corners[:, k].T for k in range(3))
    det = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    b1 = ((y2 - y0) * (x - x0) - (x2 - x0) * (y - y0)) / det
    b2 = ((x1 - x0) * (y - y0) - (y1 - y0) * (x - x0)) / det
    return np.stack([1.0 - b1 - b2, b1, b2], axis=1)


def zbuffer(points, z, triangles, size):
    """Per output pixel, the triangle nearest the viewer (largest ``z``) covering its centre.

    The core of :func:`rasterize` for callers that keep their own attributes.

    Parameters
    ----------
    points : (n, 2) float array
        Vertices in output pixels: pixel ``(row i, column j)`` is centred at
        ``(j + 0.5, i + 0.5)``.
    z : (n,) float array
    triangles : (m, 3) int array
    size : (int, int)
        ``(w, h)``.

    Returns
    -------
    (h, w) int64 array
        Triangle index, -1 where none.

    Examples
    --------
    >>> pts = np.array([[0.0, 0], [4, 0], [0, 4], [4, 4]])
    >>> zbuffer(pts, np.array([0.0, 0, 0, 1]), np.array([[0, 1, 2], [1, 3, 2]]), (4, 4))[[0, 3], 0].tolist()
    [0, 1]
    """
    w, h = (int(v) for v in size)
    tris = np.asarray(triangles, np.int64).reshape(-1, 3)
    return _zbuffer(np.asarray(points, float), np.asarray(z, float), tris, w, h).reshape(h, w)


def _zbuffer(px, z, tris, w, h):
    """Index of the nearest (largest ``z``) triangle covering each pixel centre, -1 if none."""
    best = np.full(h * w, -np.inf)
    winner = np.full(h * w, -1, np.int64)
    if len(tris) == 0:
        return winner
    c = px[tris]  # (m, 3, 2)
    x0, y0 = c[:, 0, 0], c[:, 0, 1]
    ex1, ey1 = c[:, 1, 0] - x0, c[:, 1, 1] - y0
    ex2, ey2 = c[:, 2, 0] - x0, c[:, 2, 1] - y0
    det = ex1 * ey2 - ex2 * ey1
    # Pixel (i, j) is centred at (j + 0.5, i + 0.5): columns ceil(x - 0.5) .. floor(x - 0.5).
    lo = np.maximum(np.ceil(c.min(axis=1) - 0.5).astype(np.int64), 0)
    hi = np.minimum(np.floor(c.max(axis=1) - 0.5).astype(np.int64), [w - 1, h - 1])
    bw, bh = hi[:, 0] - lo[:, 0] + 1, hi[:, 1] - lo[:, 1] + 1
    # Triangles seen edge-on cover no pixel centre robustly; skip them.
    keep = np.flatnonzero((bw > 0) & (bh > 0) & (np.abs(det) > 1e-12))
    # Barycentrics b1, b2 and depth as affine functions of the pixel centre (x, y).
    d = det[keep]
    a1, c1 = ey2[keep] / d, -ex2[keep] / d
    a2, c2 = -ey1[keep] / d, ex1[keep] / d
    zt = z[tris[keep]]
    dz1, dz2 = zt[:, 1] - zt[:, 0], zt[:, 2] - zt[:, 0]
    coef = np.stack([a1, c1, a2, c2, x0[keep], y0[keep], zt[:, 0], dz1, dz2], axis=1)
    lo, bw, area = lo[keep], bw[keep], (bw * bh)[keep]
    ends = np.cumsum(area)
    start = 0
    while start < len(keep):
        done = ends[start - 1] if start else 0
        stop = max(start + 1, int(np.searchsorted(ends, done + _CHUNK, side="right")))
        sl = slice(start, stop)
        pix, zz, idx = _zbuffer_chunk(coef[sl], lo[sl], bw[sl], area[sl], w)
        np.maximum.at(best, pix, zz)
        # Ties (shared edges of one surface) agree on every attribute; any may win.
        won = zz >= best[pix]
        winner[pix[won]] = keep[start + idx[won]]
        start = stop
    return winner


def _zbuffer_chunk(coef, lo, bw, area, w):
    """Covered pixels, their depths and triangle indices (into ``coef``) of one batch."""
    t = np.repeat(np.arange(len(area)), area)
    k = np.arange(len(t)) - np.repeat(np.cumsum(area) - area, area)
    col = lo[t, 0] + k % bw[t]
    row = lo[t, 1] + k // bw[t]
    a1, c1, a2, c2, x0, y0, z0, dz1, dz2 = coef[t].T
    dx, dy = col + 0.5 - x0, row + 0.5 - y0
    b1 = a1 * dx + c1 * dy
    b2 = a2 * dx + c2 * dy
    inside = (b1 >= -_EDGE_EPS) & (b2 >= -_EDGE_EPS) & (b1 + b2 <= 1 + _EDGE_EPS)
    zz = (z0 + b1 * dz1 + b2 * dz2)[inside]
    return row[inside] * w + col[inside], zz, t[inside]
