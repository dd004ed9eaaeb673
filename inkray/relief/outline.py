"""Region outlines: a completed region mask -> oriented 2D polygons with provenance.

Step 4 of Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for Adding Global
Illumination Effects to Hand-Drawn Characters" (TOG 2014) inflates every
completed region as a 2D triangle mesh whose outline carries the boundary
condition: zero height on the silhouette (Dirichlet), zero normal derivative
on stretches marked ``flat``/``graft`` and on outline without ink such as the
image frame (Neumann). This module extracts that outline.

The outline is the sub-pixel 0.5 iso-contour (marching squares) of the mask
smoothed by a Gaussian of 1.5 px (which removes the mask's pixel stair-steps
and one-pixel bumps; where two regions meet their fields sum to one, so both
get the same contour), then smoothed along its arc length while staying
within half a pixel of that contour (a taut curve: corners and thin features
keep their place), simplified to a tolerance and resampled so no edge is
longer than a spacing derived from the mesh resolution. Holes are kept.
Every outline vertex records where it comes from (:data:`KIND_NAMES`), which
``boundaries`` entry marks it, and which region lies on its other side.

Coordinates are drawing pixels ``[x, y]`` (pixel centres at integers, ``y``
down). Loops are oriented like the faces of :mod:`inkray.relief`: outer loops
have negative shoelace area in ``(x, y)`` (clockwise in the image plane,
counter-clockwise as the viewer sees it), holes positive.

Correspondences along a marked stretch (stitching needs them): a ``boundaries``
entry's path of length ``P`` gets ``k = ceil(P / station_spacing)`` stretches,
i.e. ``k + 1`` *stations*. On every region outline the entry snaps to, the
snapped arc is cut at fractions ``j / k`` of its arc length, in the direction
of the path, and only these stations are outline vertices there. Station ``j``
of entry ``i`` on region A corresponds to station ``j`` of entry ``i`` on
region B; where both regions share the outline the two points coincide.
"""

import math
from bisect import bisect_left
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.ndimage import (binary_dilation, distance_transform_edt, gaussian_filter,
                           gaussian_filter1d, label, map_coordinates, minimum_filter1d)
from scipy.spatial import cKDTree
from skimage.measure import find_contours

from inkray.errors import InputError
from inkray.numerics.polyline import arc_length, resample_polyline

__all__ = [
    "MeshOptions", "RegionOutline", "region_outline", "check_boundaries", "boundary_problems",
    "edge_length", "check_triangle_count", "MAX_TRIANGLES",
    "INTERIOR", "INKED", "INVENTED", "FRAME", "STITCH", "GRAFT", "FLAT",
    "KIND_NAMES", "DIRICHLET_KINDS", "DEFAULT_MAX_AREA", "DEFAULT_SNAP",
]

INTERIOR, INKED, INVENTED, FRAME, STITCH, GRAFT, FLAT = range(7)
#: Names of the provenance codes, indexed by code.
KIND_NAMES = ("interior", "inked", "invented", "frame", "stitch", "graft", "flat")
#: Outline kinds that get f = 0 when inflating (silhouettes and C0 seams).
DIRICHLET_KINDS = (INKED, INVENTED, STITCH)
_MARK_KIND = {"stitch": STITCH, "graft": GRAFT, "flat": FLAT}

#: Default maximum triangle area in px^2 (the resolution knob).
DEFAULT_MAX_AREA = 50.0
_SMOOTH_STEP = 0.5  # px between resampled contour points
_MARGIN = 5  # px of context kept around a mask's bounding box (probes reach 3.5 px)
_MIN_SPACING = 1.5  # px: the shortest edge the local-width rule asks for
_CORNER_SPAN = 4.0  # px each side over which a corner's turning is measured
_NORMAL_SPAN = 3.0  # px each side over which an outline normal is measured
_CORNER_ANGLE = 75.0  # degrees of turning that make a corner (a circle of r > ~6 px has none)
_FIELD_SIGMA = 1.5  # px: the mask is smoothed this much before its 0.5 contour is taken
_FINE_SIGMA = 0.5  # px: the smoothing of thin features
_THIN_AREA = 6  # px^2: smaller pieces that the smoothing removes are bumps, not features
_BAND = 0.6  # px a smoothed outline may stray from the pixel contour
_RELAX = 150  # relaxation sweeps of the smoothed outline inside that band

#: Default distance (px) within which a ``boundaries`` path snaps to an outline.
DEFAULT_SNAP = 6.0
#: Most triangles a drawing may ask for: its area over ``max_area`` (a region covering
#: the whole drawing gets about that many; finer meshes take minutes and gigabytes).
MAX_TRIANGLES = 1_000_000


def check_triangle_count(max_area, size, *, pixels=None):
    """Refuse a ``max_area`` that would mesh a drawing of ``size`` too finely.

    Parameters
    ----------
    max_area : float
        Triangle area in px^2.
    size : (int, int)
        ``(width, height)`` of the drawing.
    pixels : int, optional
        The area meshed (one region's pixels); default the whole drawing.

    Raises
    ------
    InputError
        When ``width * height / max_area`` exceeds :data:`MAX_TRIANGLES`
        (the message names ``max_area`` and its smallest allowed value).

    Examples
    --------
    >>> check_triangle_count(50.0, (1000, 1000))
    >>> check_triangle_count(0.001, (1000, 1000))
    Traceback (most recent call last):
    ...
    inkray.errors.InputError: max_area: 0.001 px^2 asks for up to 1e+09 triangles on a 1000x1000 drawing (at most 1e+06: expected at least 1)
    """
    w, h = (int(v) for v in size)
    area = w * h if pixels is None else int(pixels)
    count = area / float(max_area)
    if count > MAX_TRIANGLES:
        least = area / MAX_TRIANGLES
        where = f"a {w}x{h} drawing" if pixels is None else f"a region of {area} px"
        raise InputError(f"max_area: {float(max_area):g} px^2 asks for up to {count:.3g} triangles "
                         f"on {where} (at most {MAX_TRIANGLES:.3g}: expected at least "
                         f"{least:.3g})", option="max_area")


def edge_length(max_area):
    """Edge length of the equilateral triangle of area ``max_area``.

    Outline vertices are spaced at most this far apart so that the boundary is
    as fine as the triangles next to it.

    Parameters
    ----------
    max_area : float
        Triangle area in px^2.

    Returns
    -------
    float
        ``sqrt(4 * max_area / sqrt(3))`` in px.

    Examples
    --------
    >>> round(edge_length(50.0), 2)
    10.75
    """
    return math.sqrt(4.0 * float(max_area) / math.sqrt(3.0))


@dataclass(frozen=True)
class MeshOptions:
    """How a completed region becomes a mesh: one record from the outline to the inflation.

    Attributes
    ----------
    max_area : float, default 50
        Largest triangle area (px^2), the resolution knob; outline vertices
        are at most :func:`edge_length` of it apart.
    min_triangles : int, default 200
        Small regions get smaller triangles, at most ``area / min_triangles``.
    min_angle : float, default 20
        Smallest triangle angle (degrees), in (0, 34].
    across : int, default 8
        Where a region is narrow, outline edges are at most its local width
        divided by this (not below 1.5 px); 0 turns it off.
    smoothing : float, default 2
        Gaussian smoothing of the contour along its arc length (px, sigma)
        before it is relaxed within half a pixel of the contour; 0 keeps
        the contour as it is.
    tolerance : float, default 0.3
        Simplification tolerance (px, Douglas-Peucker).
    snap : float, default 6
        A ``boundaries`` path snaps to an outline when its median distance
        to it is at most this (px).
    spacing, station_spacing : float, optional
        Longest outline edge and the distance between stations of a
        ``boundaries`` entry (px); default :func:`edge_length` of ``max_area``.
    speckle : float, default 9
        Loops enclosing less than this area (px^2) are dropped.

    Examples
    --------
    >>> MeshOptions(max_area=20).max_area
    20.0
    >>> MeshOptions(max_area=-1)
    Traceback (most recent call last):
    ...
    inkray.errors.InputError: max_area: expected a positive area in px^2, got -1
    """

    max_area: float = DEFAULT_MAX_AREA
    min_triangles: int = 200
    min_angle: float = 20.0
    across: int = 8
    smoothing: float = 2.0
    tolerance: float = 0.3
    snap: float = DEFAULT_SNAP
    spacing: float = None
    station_spacing: float = None
    speckle: float = 9.0

    def __post_init__(self):
        if not (isinstance(self.max_area, (int, float)) and math.isfinite(self.max_area)
                and self.max_area > 0):
            raise InputError(f"max_area: expected a positive area in px^2, got {self.max_area!r}")
        object.__setattr__(self, "max_area", float(self.max_area))
        if not (isinstance(self.min_triangles, (int, np.integer)) and self.min_triangles >= 1):
            raise InputError(f"min_triangles: expected a positive integer, got {self.min_triangles!r}")
        if not 0 < self.min_angle <= 34:
            raise InputError(f"min_angle: expected 0 < min_angle <= 34 degrees, "
                             f"got {self.min_angle!r}")
        for key in ("spacing", "station_spacing"):
            value = getattr(self, key)
            if value is not None and not value > 0:
                raise InputError(f"{key}: expected a positive length in px, got {value!r}")
        if not (self.smoothing >= 0 and self.tolerance > 0 and self.snap > 0 and self.across >= 0
                and self.speckle >= 0):
            raise InputError("mesh options: tolerance and snap must be positive, smoothing, "
                             "across and speckle non-negative")

    def for_region(self, mask):
        """The options one region is meshed with: smaller triangles for a small region
        (at most its area over :attr:`min_triangles`), stations spaced by the
        drawing's triangle size.

        Examples
        --------
        >>> o = MeshOptions(max_area=50.0).for_region(np.ones((10, 10), bool))
        >>> o.max_area, round(o.station_spacing, 2)
        (0.5, 10.75)
        """
        area = min(self.max_area, float(np.count_nonzero(mask)) / self.min_triangles) or self.max_area
        spacing = self.station_spacing if self.station_spacing is not None else edge_length(self.max_area)
        return replace(self, max_area=area, station_spacing=spacing)


@dataclass
class RegionOutline:
    """The oriented outline loops of one region, flattened.

    Attributes
    ----------
    name : str
        The region's name.
    points : (n, 2) float array
        Outline vertices ``[x, y]`` in drawing pixels, loop after loop.
    loop : (n,) int array
        Which loop each vertex belongs to; a loop's vertices are consecutive
        and the loop closes from its last vertex to its first.
    hole : (l,) bool array
        Per loop: True for a hole.
    kind : (n,) int8 array
        Provenance code per vertex (:data:`KIND_NAMES`).
    boundary_index : (n,) int array
        The ``boundaries`` entry marking the vertex, or -1.
    station : (n,) int array
        The vertex's station number along that entry, or -1.
    neighbour : (n,) int array
        Label of the region on the other side of the outline, or -1
        (background, image frame, or no label image given).
    hole_points : (h, 2) float array
        One point inside each hole (for the triangulator).
    matched : tuple of int
        Indices of the ``boundaries`` entries snapped to this outline.
    size : (int, int)
        ``(width, height)`` of the mask.
    snap_distance : dict
        ``boundaries`` index -> median distance (px) of its path to the nearest
        loop, for every entry tried (matched or not).
    """

    name: str
    points: np.ndarray
    loop: np.ndarray
    hole: np.ndarray
    kind: np.ndarray
    boundary_index: np.ndarray
    station: np.ndarray
    neighbour: np.ndarray
    hole_points: np.ndarray
    matched: tuple = ()
    size: tuple = (0, 0)
    snap_distance: dict = field(default_factory=dict)

    def segments(self):
        """Outline edges as vertex index pairs, each loop closed.

        Returns
        -------
        (n, 2) int array
            Edge ``i`` runs from vertex ``i`` to the next vertex of its loop.
        """
        idx = np.arange(len(self.points))
        nxt = idx + 1
        for lp in range(len(self.hole)):
            members = np.flatnonzero(self.loop == lp)
            nxt[members[-1]] = members[0]
        return np.stack([idx, nxt], axis=1)


def region_outline(mask, *, visible=None, labels=None, region=None, name=None, boundaries=(),
                   options=None):
    """Outline of a completed region mask with per-vertex provenance.

    Parameters
    ----------
    mask : (H, W) bool array
        The completed region (visible part plus what is invented under
        occluders).
    visible : (H, W) bool array, optional
        The region's visible pixels. Outline next to mask pixels that are not
        visible is ``invented``. Defaults to ``labels == region`` when labels
        are given, else to the whole mask (every non-frame outline ``inked``).
    labels : (H, W) int array, optional
        Label image (-1 background, region indices) used for ``neighbour``.
    region : int, optional
        This region's label in ``labels``.
    name : str, optional
        Name used in messages and on the result; defaults to ``region<i>``
        (``region`` without ``region``).
    boundaries : sequence of Boundary
        Annotation entries (``.type``, ``.path`` ``(k, 2)`` ``[x, y]``,
        ``.index``); those within ``snap`` px of an outline mark it, the others
        are ignored here (see :func:`check_boundaries`).
    options : MeshOptions, optional
        ``max_area``, ``spacing``, ``station_spacing``, ``across``,
        ``smoothing``, ``tolerance``, ``snap`` and ``speckle`` are used here.

    Returns
    -------
    RegionOutline

    Raises
    ------
    InputError
        Bad arrays, an empty mask, or two entries marking overlapping stretches.

    Examples
    --------
    >>> yy, xx = np.mgrid[:60, :80]
    >>> out = region_outline((xx - 40) ** 2 + (yy - 30) ** 2 <= 20 ** 2, name="ball")
    >>> bool(np.all(out.kind == INKED)), len(out.hole)
    (True, 1)
    """
    mask, visible, labels = _check_arrays(mask, visible, labels, region)
    name = name if name is not None else f"region{region if region is not None else ''}"
    o = options if options is not None else MeshOptions()
    # before any work; a small region's own options ask for finer triangles
    # (MeshOptions.for_region), so the count is the region's, not the drawing's
    check_triangle_count(o.max_area, mask.shape[::-1], pixels=np.count_nonzero(mask))
    spacing = float(o.spacing) if o.spacing is not None else edge_length(o.max_area)
    station_spacing = (float(o.station_spacing) if o.station_spacing is not None
                       else edge_length(o.max_area))
    across, smoothing, tolerance, snap = o.across, o.smoothing, o.tolerance, o.snap
    if not mask.any():
        raise InputError(f"region {name}: the mask is empty")
    h, w = mask.shape
    # Work on the mask's bounding box (plus a margin for the probes) but keep drawing
    # coordinates: a box edge on the image border is still the frame.
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    y0, y1 = max(rows[0] - _MARGIN, 0), min(rows[-1] + _MARGIN + 1, h)
    x0, x1 = max(cols[0] - _MARGIN, 0), min(cols[-1] + _MARGIN + 1, w)
    box = mask[y0:y1, x0:x1]
    loops, holes = _contours(box, o.speckle, _FIELD_SIGMA)
    loops = [p + (x0, y0) for p in loops]
    dense = [_smooth(p, w, h, smoothing) for p in loops]
    paths = [(b, resample_polyline(np.asarray(b.path, float), 0.5)) for b in boundaries]

    marks = [[] for _ in dense]
    matched, distances = [], {}
    for b, q in paths:
        best = None
        for li, d in enumerate(dense):
            dist, t = _project(q, d)
            med = float(np.median(dist))
            if best is None or med < best[0]:
                best = (med, li, dist, t)
        distances[b.index] = best[0]
        med, li, dist, t = best
        near = dist <= snap
        if med > snap or near.sum() < 2:
            continue
        length = arc_length(dense[li], closed=True)[-1]
        tn = t[near]
        steps = (np.diff(tn) + length / 2) % length - length / 2
        total = float(steps.sum())
        total = math.copysign(min(abs(total), length * (1 - 1e-6)), total)
        k = max(1, math.ceil(arc_length(np.asarray(b.path, float), closed=False)[-1] / station_spacing))
        start = float(tn[0])
        lo, hi = (start, start + total) if total > 0 else (start + total, start)
        for other in marks[li]:
            if _arcs_overlap(lo, hi, other["lo"], other["hi"], length):
                raise InputError(f"boundaries[{b.index}]: marks the same outline stretch of region "
                                 f"{name} as boundaries[{other['index']}]")
        marks[li].append(dict(index=b.index, kind=_MARK_KIND[b.type], lo=lo, hi=hi, path=q,
                              stations=start + total * np.arange(k + 1) / k))
        matched.append(b.index)

    inside = distance_transform_edt(box) if across > 0 else None
    pts, loop_id, kind, bidx, station, neigh = [], [], [], [], [], []
    for li, d in enumerate(dense):
        base_kind, base_neigh = _provenance(d, mask, visible, labels, region, w, h)
        local = (_local_spacing(d - (x0, y0), inside, spacing, across) if inside is not None
                 else np.full(len(d), spacing))
        res = _loop_vertices(d, base_kind, base_neigh, marks[li], local, tolerance)
        pts.append(res[0])
        kind.append(res[1])
        bidx.append(res[2])
        station.append(res[3])
        neigh.append(res[4])
        loop_id.append(np.full(len(res[0]), li))
    points = np.concatenate(pts)
    hole = np.array(holes, bool)
    out = RegionOutline(
        name=name, points=points, loop=np.concatenate(loop_id), hole=hole,
        kind=np.concatenate(kind).astype(np.int8), boundary_index=np.concatenate(bidx),
        station=np.concatenate(station), neighbour=np.concatenate(neigh),
        hole_points=np.zeros((0, 2)), matched=tuple(sorted(matched)), size=(w, h),
        snap_distance=distances)
    out.hole_points = _hole_points(out)
    return out


def check_boundaries(outlines, boundaries, *, snap=DEFAULT_SNAP):
    """Fail on ``boundaries`` entries that no region outline took.

    Parameters
    ----------
    outlines : sequence of RegionOutline
        Every region's outline (or anything with ``.matched`` and
        ``.snap_distance``, e.g. a :class:`~inkray.relief.triangulation.RegionMesh`),
        made with the same ``boundaries``.
    boundaries : sequence of Boundary
    snap : float, default 6
        Only used in the message.

    Raises
    ------
    InputError
        ``boundaries[i]: no region outline within 6 px of the path ...``.

    Examples
    --------
    >>> check_boundaries([], [])
    """
    problems = boundary_problems(outlines, boundaries, snap=snap)
    if problems:
        raise InputError(problems[0])


def boundary_problems(outlines, boundaries, *, snap=DEFAULT_SNAP):
    """The messages of :func:`check_boundaries`, one per entry no outline took.

    The rule, one for every command and ``validate``: a path is taken when
    the median distance of its points to a completed region's outline is at
    most ``snap`` px (:data:`DEFAULT_SNAP`) and two of its points are that
    near; two paths marking overlapping stretches of one outline are refused
    by :func:`region_outline`.

    Examples
    --------
    >>> boundary_problems([], [])
    []
    """
    taken = set()
    for o in outlines:
        taken.update(o.matched)
    out = []
    for b in boundaries:
        if b.index in taken:
            continue
        near = [o.snap_distance[b.index] for o in outlines if b.index in o.snap_distance]
        where = f" (the nearest is {min(near):.1f} px away)" if near else ""
        start = np.asarray(b.path, float)[0]
        out.append(f"boundaries[{b.index}]: no region outline within {snap:g} px of the "
                   f"{b.type} path starting at ({start[0]:g}, {start[1]:g}){where}")
    return out


# -- contours ----------------------------------------------------------------

def _check_arrays(mask, visible, labels, region):
    mask = np.asarray(mask)
    if mask.ndim != 2 or mask.dtype != bool:
        raise InputError(f"mask: expected a 2D bool array, got {mask.dtype} with shape {mask.shape}")
    if visible is not None:
        visible = np.asarray(visible)
        if visible.shape != mask.shape or visible.dtype != bool:
            raise InputError(f"visible: expected a bool array of shape {mask.shape}, got "
                             f"{visible.dtype} {visible.shape}")
    if labels is not None:
        labels = np.asarray(labels)
        if labels.shape != mask.shape or not np.issubdtype(labels.dtype, np.integer):
            raise InputError(f"labels: expected an integer array of shape {mask.shape}, got "
                             f"{labels.dtype} {labels.shape}")
        if region is None:
            raise InputError("region: needed with labels (this region's label)")
        if visible is None:
            visible = labels == region
    return mask, visible, labels


def _contours(mask, speckle, sigma=0.0):
    """Closed 0.5 contours of the mask smoothed by ``sigma`` px, as (k, 2) [x, y] arrays
    without the repeated end point."""
    # 'low' orientation: the mask is on the right in (row, col), so outer loops have
    # positive and holes negative shoelace area in (x, y); contours never cross.
    raw = find_contours(np.pad(_level_set(mask, sigma), 1), 0.5, positive_orientation="low")
    loops, areas = [], []
    for c in raw:
        p = c[:-1, ::-1] - 1.0
        keep = np.r_[True, np.any(np.abs(np.diff(p, axis=0)) > 1e-9, axis=1)]
        if keep.sum() >= 3:
            # Orientation like the faces: outer loops negative area, holes positive.
            loops.append(p[keep][::-1])
            areas.append(-_area(loops[-1]))
    areas = np.array(areas)
    big = np.abs(areas) >= speckle
    if not (big & (areas > 0)).any():
        big = areas > 0  # only specks: keep them rather than lose the region
    return [p for p, b in zip(loops, big) if b], [bool(a < 0) for a, b in zip(areas, big) if b]


def _level_set(mask, sigma):
    """The mask smoothed by ``sigma`` px, with its corners, thin features and frame kept.

    Smoothing removes stair-steps and bumps, but would also round real
    corners and remove features thinner than about ``2 sigma`` (a toe, a
    tail's tip). Near a corner of the pixel contour (:func:`_corners`) the
    mask keeps its pixel values; pixels of the mask that fall below 0.5 and
    form a piece of at least ``_THIN_AREA`` px^2 get the finely smoothed mask
    around them; a region that would vanish whole keeps its pixel mask. The
    outermost rows and columns keep their pixel values, so an outline along
    the image frame stays on it.
    """
    binary = mask.astype(float)
    if sigma <= 0:
        return binary
    level = gaussian_filter(binary, sigma, mode="nearest")
    lost = mask & (level < 0.5)
    if lost.any():
        pieces, _ = label(lost, structure=np.ones((3, 3), bool))
        big = (np.bincount(pieces.ravel()) >= _THIN_AREA)[pieces] & lost
        if big.any():
            near = binary_dilation(big, iterations=2)
            fine = gaussian_filter(binary, _FINE_SIGMA, mode="nearest")
            level = np.where(near, np.maximum(level, fine), level)
    corners = np.zeros(mask.shape, bool)
    for c in find_contours(np.pad(binary, 1), 0.5):
        q = resample_polyline(c - 1.0, _SMOOTH_STEP)[:-1]
        rc = np.rint(q[_corners(q, max(1, round(_CORNER_SPAN / _SMOOTH_STEP)))]).astype(int)
        corners[np.clip(rc[:, 0], 0, mask.shape[0] - 1), np.clip(rc[:, 1], 0, mask.shape[1] - 1)] = True
    if corners.any():
        keep = distance_transform_edt(~corners) <= 2.0 * sigma + 1.0
        level[keep] = binary[keep]
    for edge in (0, -1):
        level[edge, :], level[:, edge] = binary[edge, :], binary[:, edge]
    if not (level >= 0.5).any():
        return binary
    return level


def _corners(q, k):
    """Indices where the loop turns by more than _CORNER_ANGLE over +-k and +-2k samples.

    A real corner turns at both scales; a bump of a pixel or two (noise along
    a photographed stroke) turns sharply over short chords only.
    """
    turn, wide = _turn(q, k), _turn(q, 2 * k)
    peak = turn >= np.max([np.roll(turn, j) for j in range(-k, k + 1)], axis=0)
    # Ties on a plateau: keep the first index of each run.
    angle = math.radians(_CORNER_ANGLE)
    cand = np.flatnonzero(peak & (turn > angle) & (wide > angle))
    keep = [c for i, c in enumerate(cand) if i == 0 or c - cand[i - 1] > k]
    if len(keep) > 1 and keep[0] + len(q) - keep[-1] <= k:
        keep.pop()
    return np.array(keep, int)


def _smooth(p, w, h, sigma):
    """A smooth loop within ``band`` px of the pixel contour ``p``; the image frame kept.

    Pixel contours turn by 90 degrees at every stair step. The loop is
    resampled evenly, smoothed along its arc length by ``sigma`` px, and then
    relaxed (each point moves toward the midpoint of its neighbours) while no
    point may leave the disk of radius ``_BAND`` around its contour point: a
    taut, smooth curve inside the pixel contour's uncertainty. Corners
    (:func:`_corners`) and the image frame are pinned, each stretch between
    corners smoothed on its own; thin features stay, since no point moves
    farther than ``_BAND``.
    """
    if sigma == 0 or _on_frame(p, w, h).all():
        return p
    # Marching-squares points are unevenly spaced; smooth on a uniform resampling.
    s = arc_length(p, closed=True)
    n = max(8, math.ceil(s[-1] / _SMOOTH_STEP))
    step = s[-1] / n
    t = np.linspace(0.0, s[-1], n, endpoint=False)
    q = np.stack([np.interp(t, s, np.r_[p[:, i], p[0, i]]) for i in (0, 1)], axis=1)
    corners = _corners(q, max(1, round(_CORNER_SPAN / step)))
    if len(corners) == 0:
        sm = gaussian_filter1d(q, sigma / step, axis=0, mode="wrap")
    else:
        # Smooth each stretch between corners on its own, corners pinned, so that
        # sharp input corners stay sharp instead of being cut by the filter.
        sm = q.copy()
        for a, b in zip(corners, np.r_[corners[1:], corners[0] + n]):
            idx = np.arange(a, b + 1) % n
            piece = gaussian_filter1d(q[idx], sigma / step, axis=0, mode="nearest")
            sm[idx[1:-1]] = piece[1:-1]
    pinned = _on_frame(q, w, h)
    pinned[corners] = True
    sm = _clamp(sm, q, _BAND)
    around = np.empty_like(sm)  # the two neighbours' sum, without rolling two copies
    for _ in range(_RELAX):
        around[1:], around[0] = sm[:-1], sm[-1]
        around[:-1] += sm[1:]
        around[-1] += sm[0]
        sm = _clamp(0.5 * sm + 0.25 * around, q, _BAND, copy=False)
        sm[pinned] = q[pinned]
    # A loop not much longer than the filter (a pixel, a dot) collapses onto a line:
    # it keeps its pixel contour, so that it still encloses its area.
    if abs(_area(sm)) < 0.5 * abs(_area(p)):
        return p
    return sm


def _clamp(x, q, band, *, copy=True):
    """``x`` moved back into the disks of radius ``band`` around ``q`` (in place unless ``copy``)."""
    d = x - q
    length = np.hypot(d[:, 0], d[:, 1])
    far = np.flatnonzero(length > band)
    if copy:
        x = x.copy()
    x[far] = q[far] + d[far] * (band / length[far])[:, None]
    return x


def _turn(q, k):
    """Turning angle (rad) of a closed loop at each sample over chords of +-k samples."""
    a = q - np.roll(q, k, axis=0)
    b = np.roll(q, -k, axis=0) - q
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return np.abs(np.arctan2(cross, (a * b).sum(1)))


def _on_frame(p, w, h):
    eps = 1e-6
    return ((p[:, 0] <= -0.5 + eps) | (p[:, 0] >= w - 0.5 - eps)
            | (p[:, 1] <= -0.5 + eps) | (p[:, 1] >= h - 0.5 - eps))


def _provenance(d, mask, visible, labels, region, w, h):
    """Per dense vertex: frame / inked / invented, and the region beyond."""
    nrm = _normals(d)
    kind = np.full(len(d), INKED, np.int8)
    if visible is not None:
        inside = _pixel(d - 0.75 * nrm, w, h)
        deeper = _pixel(d - 1.5 * nrm, w, h)  # when rounding left the mask
        px = np.where(mask[inside[1], inside[0]], inside, deeper)
        kind[~visible[px[1], px[0]]] = INVENTED
    kind[_on_frame(d, w, h)] = FRAME
    neigh = np.full(len(d), -1)
    if labels is not None:
        todo = kind != FRAME
        for step in (0.75, 1.5, 2.5, 3.5):
            q = d + step * nrm
            outside = (q[:, 0] < -0.5) | (q[:, 0] >= w - 0.5) | (q[:, 1] < -0.5) | (q[:, 1] >= h - 0.5)
            todo &= ~outside
            px = _pixel(q, w, h)
            lab = labels[px[1], px[0]]
            hit = todo & (lab != region)
            neigh[hit] = lab[hit]
            todo &= ~hit
    return kind, neigh


def _normals(d, span=1):
    """Unit outward normals of an oriented loop (outer loops clockwise in (x, y))."""
    t = np.roll(d, -span, axis=0) - np.roll(d, span, axis=0)
    n = np.stack([-t[:, 1], t[:, 0]], axis=1)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def _pixel(q, w, h):
    return (np.clip(np.rint(q[:, 0]), 0, w - 1).astype(int),
            np.clip(np.rint(q[:, 1]), 0, h - 1).astype(int))


# -- marks and resampling ----------------------------------------------------

def _local_spacing(d, inside, spacing, across):
    """Longest outline edge at each dense point: spacing, or local width / across."""
    nrm = _normals(d, span=max(1, round(_NORMAL_SPAN / _SMOOTH_STEP)))  # raster bumps tilt short chords
    reach = spacing * across / 2.0  # half-widths beyond this do not shorten edges
    t = np.arange(0.5, reach + 0.5, 0.5)
    probe = d[:, None, :] - nrm[:, None, :] * t[None, :, None]
    depth = map_coordinates(inside, [probe[..., 1], probe[..., 0]], order=1, mode="nearest")
    # Walking inward, the distance to the outside grows like t up to the medial axis
    # (the inscribed radius r), then falls as 2r - t: the first t where it lags well
    # behind is about 1.1 r (the slack absorbs a normal tilted by up to ~35 degrees).
    beyond = depth < 0.8 * t[None, :] - 1.0
    radius = np.where(beyond.any(axis=1), t[np.argmax(beyond, axis=1)], reach)
    local = np.clip(2.0 * radius / across, _MIN_SPACING, spacing)
    # Grade along the outline too: no edge longer than a close neighbour allows.
    window = 2 * max(1, round(spacing / _SMOOTH_STEP)) + 1
    return minimum_filter1d(local, window, mode="wrap")


def _loop_vertices(d, base_kind, base_neigh, marks, local, tolerance):
    """Outline vertices of one loop: stations, provenance changes, simplified curve."""
    s = arc_length(d, closed=True)
    length = s[-1]
    s = s[:-1]
    # Candidates with priorities: stations 2, provenance changes 1, curve points 0.
    cand = []
    for m in marks:
        cand += [(float(t % length), 2) for t in m["stations"]]
    # Both ends of every provenance change are vertices, so an outline edge never
    # spans two kinds (a Dirichlet end would pin a whole Neumann edge).
    change = np.flatnonzero(base_kind != np.roll(base_kind, 1))
    ends = np.unique(np.r_[change, change - 1] % len(s)) if len(change) else change
    cand += [(float(s[i]), 1) for i in ends
             if not any(_in_arc(s[i], m["lo"], m["hi"], length) for m in marks)]
    cand = cand or [(0.0, 1)]
    fixed = sorted(t for t, _ in cand)
    for a, b in zip(fixed, fixed[1:] + [fixed[0] + length]):
        if any(_in_arc((a + b) / 2, m["lo"], m["hi"], length) for m in marks):
            continue
        cand += [(t, 0) for t in _simplified(d, s, length, a, b, local, tolerance)]
    params = _thin(cand, length, gap=min(0.3 * float(local.min()), 0.5))
    params = np.array(params)

    pts = np.stack([np.interp(params, np.r_[s, length], np.r_[d[:, i], d[0, i]]) for i in (0, 1)], axis=1)
    after = np.searchsorted(s, params) % len(s)
    before = (after - 1) % len(s)
    nearest = np.where(_cyclic(params - s[after], length) < _cyclic(params - s[before], length),
                       after, before)
    kind = base_kind[nearest].copy()
    neigh = base_neigh[nearest].copy()
    bidx = np.full(len(params), -1)
    station = np.full(len(params), -1)
    for m in marks:
        inside = np.array([_in_arc(t, m["lo"], m["hi"], length, eps=1e-6) for t in params], bool)
        kind[inside] = m["kind"]
        bidx[inside] = m["index"]
        st = np.asarray(m["stations"]) % length
        hits = []
        for j, t in enumerate(st):
            hit = np.argmin(_cyclic(params - t, length))
            station[hit] = j
            hits.append(hit)
        # The seam is where the entry's path runs, not the segmentation's pixel edge: the
        # stations move onto the path (when that keeps their order), so a stitch's two
        # regions share their stations and a graft's seam is as smooth as the stroke.
        on_path, where = _closest_on_path(pts[hits], m["path"])
        if np.all(np.diff(where) > 0) or np.all(np.diff(where) < 0):
            pts[hits] = on_path
    return pts, kind, bidx, station, neigh


def _closest_on_path(points, path):
    """Closest points on an open polyline and their arc parameters."""
    s = arc_length(path)
    _, near = cKDTree(path).query(points)
    best = np.full(len(points), np.inf)
    out, where = np.zeros_like(points), np.zeros(len(points))
    for k in (np.maximum(near - 1, 0), np.minimum(near, len(path) - 2)):
        a, b = path[k], path[k + 1]
        ab = b - a
        length = np.maximum((ab ** 2).sum(1), 1e-24)
        u = np.clip(((points - a) * ab).sum(1) / length, 0.0, 1.0)
        c = a + u[:, None] * ab
        dist = np.linalg.norm(c - points, axis=1)
        better = dist < best
        best[better], out[better] = dist[better], c[better]
        where[better] = (s[k] + u * np.sqrt(length))[better]
    return out, where


def _simplified(d, s, length, a, b, local, tolerance):
    """Arc parameters in (a, b) keeping the curve within tolerance, edges <= local spacing."""
    inner = (s - a) % length
    order = np.argsort(inner)
    inner = inner[order]
    sel = (inner > 1e-9) & (inner < (b - a) - 1e-9)
    ts = np.r_[0.0, inner[sel], b - a]
    pts = np.stack([np.interp((ts + a) % length, np.r_[s, length], np.r_[d[:, i], d[0, i]])
                    for i in (0, 1)], axis=1)
    ends = np.interp(np.r_[a, b] % length, np.r_[s, length], np.r_[local, local[0]])
    allowed = np.r_[ends[0], local[order][sel], ends[1]]
    keep = _douglas_peucker(pts, tolerance)
    out = []
    for i, j in zip(keep[:-1], keep[1:]):
        n = math.ceil((ts[j] - ts[i]) / allowed[i:j + 1].min())
        out += list(ts[i] + (ts[j] - ts[i]) * np.arange(1, n) / n)
        if j != keep[-1]:
            out.append(ts[j])
    return [float((t + a) % length) for t in out]


def _douglas_peucker(p, tol):
    keep = np.zeros(len(p), bool)
    keep[[0, -1]] = True
    stack = [(0, len(p) - 1)]
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        seg = p[j] - p[i]
        rel = p[i + 1:j] - p[i]
        norm = np.hypot(*seg)
        if norm < 1e-12:
            dist = np.hypot(rel[:, 0], rel[:, 1])
        else:
            dist = np.abs(seg[0] * rel[:, 1] - seg[1] * rel[:, 0]) / norm
        k = int(np.argmax(dist))
        if dist[k] > tol:
            m = i + 1 + k
            keep[m] = True
            stack += [(i, m), (m, j)]
    return np.flatnonzero(keep)


def _thin(cand, length, gap):
    """Accept candidates by priority, dropping those closer than gap to an accepted one."""
    accepted = []
    for t, pri in sorted(cand, key=lambda c: (-c[1], c[0])):
        i = bisect_left(accepted, t)
        near = [accepted[i % len(accepted)], accepted[i - 1]] if accepted else []
        too_close = any(_cyclic(t - u, length) < (1e-6 if pri else gap) for u in near)
        if not too_close:
            accepted.insert(i, t)
    return accepted


def _cyclic(dt, length):
    """Absolute distance between arc parameters on a loop of the given length."""
    return np.abs((np.asarray(dt) + length / 2) % length - length / 2)


def _in_arc(t, lo, hi, length, eps=0.0):
    return (t - lo + eps) % length <= (hi - lo) + 2 * eps


def _arcs_overlap(lo1, hi1, lo2, hi2, length):
    return (_in_arc((lo1 + hi1) / 2, lo2, hi2, length) or _in_arc((lo2 + hi2) / 2, lo1, hi1, length)
            or _in_arc(lo1, lo2, hi2, length, eps=-1e-6) or _in_arc(lo2, lo1, hi1, length, eps=-1e-6))


# -- geometry ----------------------------------------------------------------

def _project(q, loop):
    """Distance of each point to a closed polyline and the arc parameter of its projection."""
    n = len(loop)
    s = arc_length(loop, closed=True)
    _, near = cKDTree(loop).query(q)
    # The nearest segment touches the nearest vertex (up to the vertex spacing): try both.
    best_d = np.full(len(q), np.inf)
    best_t = np.zeros(len(q))
    for k in (near - 1) % n, near:
        a, b = loop[k], loop[(k + 1) % n]
        ab = b - a
        seglen2 = np.maximum((ab ** 2).sum(1), 1e-24)
        u = np.clip(((q - a) * ab).sum(1) / seglen2, 0.0, 1.0)
        d = np.linalg.norm(a + u[:, None] * ab - q, axis=1)
        better = d < best_d
        best_d[better] = d[better]
        best_t[better] = (s[k] + u * np.sqrt(seglen2))[better]
    return best_d, best_t


def _area(p):
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _inside(q, loop):
    """Even-odd test of points q against one closed polygon."""
    x, y = loop[:, 0], loop[:, 1]
    x2, y2 = np.roll(x, -1), np.roll(y, -1)
    qx, qy = q[:, :1], q[:, 1:]
    crosses = (y > qy) != (y2 > qy)
    with np.errstate(divide="ignore", invalid="ignore"):
        xcross = x + (qy - y) * (x2 - x) / (y2 - y)
    return (np.sum(crosses & (qx < xcross), axis=1) % 2) == 1


def _hole_points(out):
    """A point just inside each hole loop (outside the region), for Triangle."""
    loops = [out.points[out.loop == i] for i in range(len(out.hole))]
    boxes = np.array([np.r_[lp.min(axis=0), lp.max(axis=0)] for lp in loops])
    found = []
    for li in np.flatnonzero(out.hole):
        p = loops[li]
        e = np.roll(p, -1, axis=0) - p
        # The region's outward normal (-e_y, e_x) points into the hole.
        cand = p + 0.5 * e + np.stack([-e[:, 1], e[:, 0]], axis=1) * 1e-2
        parity = np.zeros(len(cand), int)
        lo, hi = cand.min(axis=0), cand.max(axis=0)
        near = np.flatnonzero(np.all(boxes[:, :2] <= hi, axis=1) & np.all(boxes[:, 2:] >= lo, axis=1))
        for j in near:
            parity += _inside(cand, loops[j])
        ok = np.flatnonzero(parity % 2 == 0)
        if len(ok):
            found.append(cand[ok[0]])
    return np.array(found).reshape(-1, 2)
