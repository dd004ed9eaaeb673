"""Quality triangle meshes of region outlines (Shewchuk's Triangle).

Each completed region of Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for
Adding Global Illumination Effects to Hand-Drawn Characters" (TOG 2014) is
inflated as a 2D triangle mesh. This module meshes a
:class:`~inkray.relief.outline.RegionOutline` with a constrained conforming Delaunay
triangulation: minimum angle 20 degrees (except next to sharper input corners),
maximum area from the resolution knob ``max_area`` (px^2), and finer
triangles near the seams of ``graft`` entries, so that a grafted part can
leave its base with the base's slope and its interpolated normals stay
smooth across the seam (the triangles grow with the distance to the seam).

All outline vertices are kept, so stations of ``boundaries`` entries stay
vertices (the correspondences stitching uses). Triangle may split an outline
edge to meet the quality bounds; the new vertex takes the provenance of the
nearer end of that edge (of its unmarked end when the edge leaves a marked
stretch) and is no station.

Faces follow :mod:`inkray.relief`: clockwise in the ``(x, y)`` image plane,
i.e. counter-clockwise as the viewer sees the drawing.
"""

from dataclasses import dataclass, field, replace

import numpy as np
import triangle

from inkray.errors import InputError, StageError
from inkray.numerics.polyline import point_polyline_distance
from inkray.relief.outline import (DEFAULT_MAX_AREA, INTERIOR, MeshOptions, edge_length,
                                   region_outline)

__all__ = ["RegionMesh", "triangulate_outline", "mesh_region"]

_SEAM_EDGE = 1.0  # px: longest triangle edge on a graft seam
_SEAM_GROWTH = 0.25  # and its growth per px away from the seam


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
        Non-positive ``max_area`` or ``min_angle`` outside (0, 34].
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
    pslg = {"vertices": outline.points,
            "vertex_markers": (np.arange(n) + 2)[:, None],
            "segments": seg,
            "segment_markers": (np.arange(len(seg)) + 2)[:, None]}
    if len(outline.hole_points):
        pslg["holes"] = outline.hole_points
    res = triangle.triangulate(pslg, f"pq{min_angle:g}a{max_area:.17g}Q")
    if len(seams) and len(res.get("triangles", ())):
        res = _refine(res, seams, max_area, min_angle)
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
                      matched=outline.matched, snap_distance=dict(outline.snap_distance))


def _refine(res, seams, max_area, min_angle):
    """``res`` refined by Triangle to the area bound of each triangle's distance to ``seams``."""
    centre = np.asarray(res["vertices"])[np.asarray(res["triangles"])].mean(axis=1)
    dist = np.min([point_polyline_distance(centre, np.asarray(s, float)) for s in seams], axis=0)
    edge = _SEAM_EDGE + _SEAM_GROWTH * dist
    bound = np.minimum(max_area, np.sqrt(3.0) / 4.0 * edge ** 2)
    if not (bound < max_area).any():
        return res
    return triangle.triangulate({**res, "triangle_max_area": bound}, f"rpq{min_angle:g}aQ")


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
    area = min(o.max_area, float(np.count_nonzero(mask)) / o.min_triangles) or o.max_area
    station_spacing = o.station_spacing if o.station_spacing is not None else edge_length(o.max_area)
    out = region_outline(mask, visible=visible, labels=labels, region=region, name=name,
                         boundaries=boundaries,
                         options=replace(o, max_area=area, station_spacing=station_spacing))
    grafts = [np.asarray(b.path, float) for b in boundaries if b.type == "graft"]
    return triangulate_outline(out, max_area=area, min_angle=o.min_angle, seams=grafts)
