"""Quality triangle meshes of region outlines (Shewchuk's Triangle).

Each completed region of Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for
Adding Global Illumination Effects to Hand-Drawn Characters" (TOG 2014) is
inflated as a 2D triangle mesh. This module meshes a
:class:`~inkray.relief.outline.RegionOutline` with a constrained conforming Delaunay
triangulation: minimum angle 20 degrees (except next to sharper input corners),
maximum area from the resolution knob ``max_area`` (px^2), and finer
triangles near the seams of ``graft`` entries (and of the open joins of
:mod:`inkray.relief.joins`, which are grafts too), so that a grafted part can
leave its base with the base's slope and its interpolated normals stay
smooth across the seam (the triangles grow with the distance to the seam).

All outline vertices are kept, so stations of ``boundaries`` entries stay
vertices (the correspondences stitching uses). Triangle may split an outline
edge to meet the quality bounds; the new vertex takes the provenance of the
nearer end of that edge (of its unmarked end when the edge leaves a marked
stretch) and is no station.

Triangle is only given a valid planar straight-line graph: an outline loop
that encloses no area (fewer than three distinct vertices, as a region of a
pixel or a one-pixel line can give) is left out with a warning, a region
left with nothing to mesh is an :class:`~inkray.errors.InputError` naming it
and its pixel, and the Steiner points Triangle may add are capped at a
multiple of what the area bounds ask for, so that no input makes it run
without end.

Faces follow :mod:`inkray.relief`: clockwise in the ``(x, y)`` image plane,
i.e. counter-clockwise as the viewer sees the drawing.
"""

import math
from dataclasses import dataclass, field

import numpy as np
import triangle

from inkray.errors import InputError, StageError
from inkray.numerics.polyline import point_polyline_distance
from inkray.relief.outline import (DEFAULT_MAX_AREA, INTERIOR, MeshOptions, check_triangle_count,
                                   region_outline)

__all__ = ["RegionMesh", "triangulate_outline", "mesh_region"]

_SEAM_EDGE = 1.0  # px: longest triangle edge on a graft seam
_SEAM_GROWTH = 0.25  # and its growth per px away from the seam
_MIN_LOOP_AREA = 1e-2  # px^2: a loop enclosing less is a degenerate polygon for Triangle
_STEINER_FACTOR = 8  # added vertices allowed per triangle the area bound asks for
_STEINER_SLACK = 1000  # and beyond that (small angles, short input edges)


@dataclass
class RegionMesh:
    """A region's 2D triangle mesh with per-vertex outline provenance.

    Attributes
    ----------
    name : str
        The region's name.
    vertices : (n, 2) float array
        ``[x, y]`` in drawing pixels.
    faces : (m, 3) int array
        Clockwise in ``(x, y)`` (toward the viewer, see :mod:`inkray.relief`).
    kind : (n,) int8 array
        Provenance code (:data:`inkray.relief.outline.KIND_NAMES`); ``INTERIOR`` (0)
        off the outline.
    boundary_index : (n,) int array
        The ``boundaries`` entry marking the vertex, or -1.
    station : (n,) int array
        Station number along that entry (shared with every other region the
        entry snapped to), or -1.
    neighbour : (n,) int array
        Label of the region across the outline, or -1.
    matched : tuple of int
        ``boundaries`` entries snapped to this region's outline.
    snap_distance : dict
        ``boundaries`` index -> median distance (px) to this outline.
    warnings : list of str
        Outline loops left out as too small to mesh, a Steiner point cap
        reached.
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    kind: np.ndarray
    boundary_index: np.ndarray
    station: np.ndarray
    neighbour: np.ndarray
    matched: tuple = ()
    snap_distance: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)

    @property
    def outline(self):
        """(n,) bool: True on outline vertices."""
        return self.kind != INTERIOR

    def station_vertices(self, index):
        """Vertex of each station of ``boundaries[index]`` on this mesh.

        Parameters
        ----------
        index : int
            The entry's index in ``boundaries``.

        Returns
        -------
        (k + 1,) int array
            Vertex index of station ``j`` at position ``j``; empty when the
            entry did not snap to this region.
        """
        sel = np.flatnonzero((self.boundary_index == index) & (self.station >= 0))
        return sel[np.argsort(self.station[sel])]


def triangulate_outline(outline, *, max_area=DEFAULT_MAX_AREA, min_angle=20.0, seams=()):
    """Quality-mesh the inside of a region outline.

    Parameters
    ----------
    outline : RegionOutline
    max_area : float, default 50
        Largest triangle area (px^2).
    min_angle : float, default 20
        Smallest angle (degrees) Triangle enforces (at most about 33).
    seams : sequence of (k, 2) arrays, default ()
        Polylines near which the triangles are finer: edges of about 1 px on
        them, growing by a quarter of the distance to them, up to the size
        ``max_area`` asks for.

    Returns
    -------
    RegionMesh

    Raises
    ------
    InputError
        Non-positive ``max_area``, ``min_angle`` outside (0, 34], or an
        outline with no loop that encloses an area.
    StageError
        Triangle produced no triangles.

    Examples
    --------
    >>> from inkray.relief.outline import region_outline
    >>> yy, xx = np.mgrid[:60, :80]
    >>> out = region_outline((xx - 40) ** 2 + (yy - 30) ** 2 <= 20 ** 2)
    >>> mesh = triangulate_outline(out, max_area=30.0)
    >>> bool(mesh.faces.shape[0] > 40)
    True
    >>> fine = triangulate_outline(out, max_area=30.0, seams=[np.array([[40.0, 10], [40, 50]])])
    >>> near = np.abs(fine.vertices[:, 0] - 40) < 2
    >>> int(near.sum()) > 4 * int((np.abs(mesh.vertices[:, 0] - 40) < 2).sum())
    True
    """
    if not max_area > 0:
        raise InputError(f"max_area: expected a positive area in px^2, got {max_area!r}")
    if not 0 < min_angle <= 34:
        raise InputError(f"min_angle: expected 0 < min_angle <= 34 degrees, got {min_angle!r}")
    n = len(outline.points)
    seg = outline.segments()
    kept, holes, warnings = _meshable(outline)
    use, graph = _planar_graph(outline.points, seg, kept)
    pslg = {"vertices": outline.points,
            "vertex_markers": (np.arange(n) + 2)[:, None],
            "segments": graph,
            "segment_markers": (use + 2)[:, None]}
    if len(holes):
        pslg["holes"] = holes
    area = sum(abs(_area(outline.points[outline.loop == lp])) for lp in np.unique(outline.loop[kept]))
    cap = _steiner_cap(area / max_area, n)
    res = triangle.triangulate(pslg, f"pq{min_angle:g}a{max_area:.17g}S{cap}Q")
    if len(res["vertices"]) - n >= cap:
        warnings.append(_capped(outline.name, cap))
    if len(seams) and len(res.get("triangles", ())):
        res = _refine(res, seams, max_area, min_angle, outline.name, warnings)
    faces = np.asarray(res.get("triangles", np.zeros((0, 3))), np.int64)
    if len(faces) == 0:
        raise StageError(f"region {outline.name}: the triangulation is empty")
    verts = np.asarray(res["vertices"], float)
    if not np.array_equal(verts[:n], outline.points):
        raise StageError(f"region {outline.name}: Triangle reordered the outline vertices")
    markers = np.asarray(res["vertex_markers"]).ravel()
    m = len(verts)
    kind = np.zeros(m, np.int8)
    bidx = np.full(m, -1)
    station = np.full(m, -1)
    neigh = np.full(m, -1)
    kind[:n], bidx[:n], station[:n], neigh[:n] = (outline.kind, outline.boundary_index,
                                                  outline.station, outline.neighbour)
    # Vertices of a left-out loop inside the region are plain interior points.
    kind[:n][~kept], bidx[:n][~kept], station[:n][~kept], neigh[:n][~kept] = INTERIOR, -1, -1, -1
    new = np.arange(n, m)
    on_seg = new[markers[n:] >= 2]
    if len(on_seg):
        a, b = seg[markers[on_seg] - 2].T
        near_a = (np.linalg.norm(verts[on_seg] - verts[a], axis=1)
                  <= np.linalg.norm(verts[on_seg] - verts[b], axis=1))
        src = np.where(near_a, a, b)
        # An edge leaving a marked stretch is not part of it: take the unmarked end.
        leaves = bidx[a] != bidx[b]
        src = np.where(leaves & (bidx[a] == -1), a, np.where(leaves & (bidx[b] == -1), b, src))
        kind[on_seg], bidx[on_seg], neigh[on_seg] = kind[src], bidx[src], neigh[src]
    # Triangle emits counter-clockwise faces in (x, y); inkray.relief wants clockwise.
    faces = faces[:, [0, 2, 1]]
    used = np.zeros(m, bool)
    used[faces.ravel()] = True
    if not used.all():
        # Isolated vertices (outline pieces of dropped slivers) would break the solvers.
        remap = np.cumsum(used) - 1
        faces = remap[faces]
        verts, kind, bidx, station, neigh = (x[used] for x in (verts, kind, bidx, station, neigh))
    return RegionMesh(name=outline.name, vertices=verts, faces=faces, kind=kind,
                      boundary_index=bidx, station=station, neighbour=neigh,
                      matched=outline.matched, snap_distance=dict(outline.snap_distance),
                      warnings=warnings)


def _meshable(outline):
    """Segments of the loops that enclose an area (bool per segment), their hole
    points, and a warning per loop left out."""
    kept = np.ones(len(outline.points), bool)
    dropped, warnings = [], []
    for lp in range(len(outline.hole)):
        members = np.flatnonzero(outline.loop == lp)
        p = outline.points[members]
        distinct = len(np.unique(np.round(p, 9), axis=0))
        if distinct >= 3 and abs(_area(p)) >= _MIN_LOOP_AREA:
            continue
        kept[members] = False
        dropped.append(p)
        x, y = np.rint(p.mean(axis=0)).astype(int)
        warnings.append(f"region {outline.name}: an outline {'hole' if outline.hole[lp] else 'piece'} "
                        f"at pixel ({x}, {y}) encloses no area; left out of the mesh")
    if not kept.any():
        x, y = np.rint(outline.points.mean(axis=0)).astype(int)
        raise InputError(f"region {outline.name}: too small or thin to mesh at pixel ({x}, {y}) "
                         f"(its outline encloses no area)")
    holes = np.asarray(outline.hole_points, float).reshape(-1, 2)
    for p in dropped:
        # A left-out hole's point would lie inside the region and eat its triangles.
        far = point_polyline_distance(holes, np.vstack([p, p[:1]])) > 0.1
        holes = holes[far]
    return kept, holes, warnings


def _planar_graph(points, seg, kept):
    """The kept segments (their indices, and their vertex pairs) with every
    position's first vertex for its copies, less the segments that shrink to a
    point or repeat another: Triangle fails on a segment whose ends coincide and
    crashes on some whose end is a copy of an earlier vertex."""
    _, first, inverse = np.unique(points, axis=0, return_index=True, return_inverse=True)
    pairs = first[inverse.ravel()][seg]
    use = np.flatnonzero(kept & (pairs[:, 0] != pairs[:, 1]))
    _, once = np.unique(np.sort(pairs[use], axis=1), axis=0, return_index=True)
    use = use[np.sort(once)]
    return use, pairs[use]


def _area(p):
    """Signed shoelace area of a closed polygon."""
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _steiner_cap(triangles, vertices):
    """Most Steiner points Triangle may add for a mesh of about ``triangles`` triangles."""
    return int(min(_STEINER_FACTOR * math.ceil(triangles) + 2 * vertices + _STEINER_SLACK,
                   np.iinfo(np.int32).max))


def _capped(name, cap):
    return (f"region {name}: the mesh reached its limit of {cap} added vertices; "
            f"some of its triangles may be sharper than asked")


def _refine(res, seams, max_area, min_angle, name, warnings):
    """``res`` refined by Triangle to the area bound of each triangle's distance to ``seams``."""
    verts = np.asarray(res["vertices"])
    corner = verts[np.asarray(res["triangles"])]
    centre = corner.mean(axis=1)
    dist = np.min([point_polyline_distance(centre, np.asarray(s, float)) for s in seams], axis=0)
    edge = _SEAM_EDGE + _SEAM_GROWTH * dist
    bound = np.minimum(max_area, np.sqrt(3.0) / 4.0 * edge ** 2)
    if not (bound < max_area).any():
        return res
    a, b = corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0]
    area = 0.5 * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    cap = _steiner_cap(float(np.sum(area / bound)), len(verts))
    out = triangle.triangulate({**res, "triangle_max_area": bound}, f"rpq{min_angle:g}aS{cap}Q")
    if len(out["vertices"]) - len(verts) >= cap:
        warnings.append(_capped(name, cap))
    return out


def mesh_region(mask, *, visible=None, labels=None, region=None, name=None, boundaries=(),
                options=None):
    """Outline and triangulate one completed region.

    Parameters
    ----------
    mask : (H, W) bool array
        The completed region.
    visible, labels, region, name, boundaries
        As in :func:`inkray.relief.outline.region_outline`.
    options : inkray.relief.outline.MeshOptions, optional
        Small regions get smaller triangles, at most ``area /
        options.min_triangles``, so that they are not faceted; stations keep
        the spacing of ``options.max_area`` (they must agree between regions).
        Triangles are finer near ``graft`` paths (see
        :func:`triangulate_outline`).

    Returns
    -------
    RegionMesh

    Examples
    --------
    >>> yy, xx = np.mgrid[:100, :200]
    >>> mesh = mesh_region((abs(xx - 100) < 80) & (abs(yy - 50) < 30),
    ...                    options=MeshOptions(max_area=40.0))
    >>> float(np.round(np.ptp(mesh.vertices[:, 0])))
    159.0
    """
    o = options if options is not None else MeshOptions()
    check_triangle_count(o.max_area, np.shape(mask)[::-1])  # the drawing's bound, before any work
    region_options = o.for_region(mask)
    out = region_outline(mask, visible=visible, labels=labels, region=region, name=name,
                         boundaries=boundaries, options=region_options)
    grafts = [np.asarray(b.path, float) for b in boundaries if b.type == "graft"]
    return triangulate_outline(out, max_area=region_options.max_area, min_angle=o.min_angle,
                               seams=grafts)
