"""Measurements of how clean a relief looks: seams, silhouettes, outline ink, order, solids.

Shared by ``benchmarks/bench_relief.py`` (the table) and
``tests/test_relief_quality.py`` (the bounds). Every figure is measured on
what a viewer sees, not on the solver's own variables:

- **normal jump** at ink-free seams: the relief is rasterized from the front
  with interpolated vertex normals (as a viewer shades it); where two
  4-neighbouring pixels show different parts, no ink is drawn within
  ``margin`` px and the two parts' surfaces meet (at the point between the
  two pixel centres their heights differ by less than half the depth step
  ``epsilon``), the angle between their normals. A seamless join is ~0 deg;
  reported is the 90th percentile. Where the heights differ by more, one
  part is in front of the other through a gap in the ink: an occlusion step,
  not a seam (``epsilon=None`` counts those pixels too, as this figure
  first did).
- **normal jump at open joins**: where a part's outline stroke stops short
  inside the part behind it (a leg drawn with one open stroke that ends in
  the body, a leg open at the top between two stroke tips), the two parts
  join along an ink-free stretch of their common outline. Such joins are
  found in the front view's part image (:mod:`inkray.relief.joins`: ink-free
  cuts between two parts at least 1.5 stroke widths and 20 px long; a
  shorter one is a gap in a drawn line, where one part is in front of the
  other). There the surfaces must join, so every ink-free pixel pair across
  the join counts, a step between the two surfaces included (a cliff's wall
  seen from the front is a strip of steep facets).
- **order held**: along the segment between an ``order`` entry's two points,
  and over its place's overlap, the front part's surface is above the back
  part's by the depth step (wherever both meshes are there, outside the band
  of a graft between the two parts where the relation gives way, warned).
- **silhouette turning ratio**: total absolute turning of every part's
  outline divided by that of the same outline smoothed over 3 px; pixel
  stair-steps turn by 90 degrees at every step, a smooth outline ~1.0-1.2.
- **outline ink on mesh**: the fraction of the contour ink between a part and
  the background (ink pixels whose two sides are a part and the paper within
  one stroke width) covered by the front view of the relief.
- **solids**: smallest triangle angle, largest aspect ratio and the number of
  connected shells of a closed (union) relief.
- **top distance** of a union solid: the largest distance (px) from a
  visible vertex of the closed parts' fronts (one no other part's front
  covers) to the solid's surface: how far the printed top strays from the
  relief a viewer sees.
"""

import math

import igl
import numpy as np
from scipy.ndimage import binary_dilation, distance_transform_edt, gaussian_filter1d
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from inkray.formats.mesh_report import mesh_quality
from inkray.relief.joins import open_joins as find_joins
from inkray.relief.model import Part
from inkray.numerics.polyline import point_polyline_distance
from inkray.view.rasterization import rasterize

INK = 0.5  # grey level below which a drawing pixel is ink
SMOOTH_PX = 3.0  # smoothing of the reference outline (px, Gaussian sigma along the arc)


def ink_mask(gray):
    """Ink pixels of a normalized grey drawing (paper 1)."""
    return np.asarray(gray) < INK


MEET = 0.5  # two parts meet where their heights differ by less than this times epsilon


def normal_jumps(relief, gray, *, epsilon=None, margin=2, raster=None):
    """Angles (deg) between the normals of neighbouring pixels of two parts that meet, ink-free.

    ``epsilon`` is the relief's depth step: pairs whose two surfaces differ
    by ``MEET * epsilon`` or more at the point between the pixel centres (an
    occlusion step) are left out; ``None`` keeps them.

    Returns an array with one angle per ink-free 4-neighbour pixel pair
    across a part change (empty when there is none).
    """
    r = raster if raster is not None else rasterize(relief)
    out = []
    for axis, a, b, sel in _pairs(r, gray, margin):
        if epsilon is not None:
            pa, pb = r.part[a], r.part[b]
            ys, xs = np.nonzero(sel)
            mid = np.column_stack([xs, ys]) + 0.5 * np.eye(2)[::-1][axis]
            step = np.abs(_height_of(relief, pa[sel], mid) - _height_of(relief, pb[sel], mid))
            sel[ys[step >= MEET * epsilon], xs[step >= MEET * epsilon]] = False
        out.append(_angles(r, a, b, sel))
    return np.concatenate(out)


def _pairs(r, gray, margin):
    """``(axis, a, b, sel)`` per axis: the slices of a pixel and its next neighbour along
    it, and where the two are of different parts and ink-free (``margin`` px)."""
    ink = binary_dilation(ink_mask(gray), iterations=margin) if margin else ink_mask(gray)
    for axis in (0, 1):
        a = [slice(None), slice(None)]
        b = [slice(None), slice(None)]
        a[axis], b[axis] = slice(None, -1), slice(1, None)
        a, b = tuple(a), tuple(b)
        pa, pb = r.part[a], r.part[b]
        yield axis, a, b, (pa >= 0) & (pb >= 0) & (pa != pb) & ~ink[a] & ~ink[b]


def _angles(r, a, b, sel):
    """Angles (deg) between the normals of the ``sel`` pixel pairs ``a``, ``b``."""
    cos = np.clip((r.normal[a][sel] * r.normal[b][sel]).sum(axis=1), -1.0, 1.0)
    return np.degrees(np.arccos(cos))


def open_joins(part, gray, *, reach=1.0):
    """Pixels of a part-label image within ``reach`` px of its open joins.

    The joins are :func:`inkray.relief.joins.open_joins` of ``part`` (-1
    nothing, else the part; every join, the ones a ``graft`` entry marks
    included): ink-free cuts between two parts, at least 1.5 stroke widths
    and 20 px long.
    """
    part = np.asarray(part)
    out = np.zeros(part.shape, bool)
    h, w = part.shape
    for join in find_joins(part, gray):
        lo = np.maximum(np.floor(join.path.min(axis=0) - reach).astype(int), 0)
        hi = np.minimum(np.ceil(join.path.max(axis=0) + reach).astype(int) + 1, (w, h))
        ys, xs = np.mgrid[lo[1]:hi[1], lo[0]:hi[0]]
        pts = np.column_stack([xs.ravel(), ys.ravel()]).astype(float)
        near = point_polyline_distance(pts, join.path) <= reach
        out[ys.ravel()[near], xs.ravel()[near]] = True
    return out


def open_join_jumps(relief, gray, *, margin=2, raster=None):
    """Angles (deg) between the normals of neighbouring pixels across an open join.

    Every ink-free (``margin`` px) 4-neighbour pixel pair of two parts on an
    open join (:func:`open_joins` of the front view), whatever the step
    between their surfaces. Empty when the drawing has no open join.
    """
    r = raster if raster is not None else rasterize(relief)
    join = open_joins(r.part, gray)
    return np.concatenate([_angles(r, a, b, sel & join[a] & join[b])
                           for _, a, b, sel in _pairs(r, gray, margin)])


def _height_of(relief, part, points):
    """Height of part ``part[k]`` of the relief at ``points[k]``."""
    z = np.zeros(len(points))
    for i in np.unique(part):
        z[part == i] = height_on(relief.parts[i], points[part == i])[0]
    return z


def height_on(part, points):
    """Height of an open part's front surface at 2D points, and their distance to its mesh."""
    v = np.asarray(part.vertices, float)
    f = np.asarray(part.faces, np.int64)
    p = np.asarray(points, float).reshape(-1, 2)
    if len(p) == 0:
        return np.zeros(0), np.zeros(0)
    v2 = np.column_stack([v[:, :2], np.zeros(len(v))])
    d2, face, closest = igl.point_mesh_squared_distance(np.column_stack([p, np.zeros(len(p))]), v2, f)
    tri = f[np.asarray(face, np.int64)]
    a, b, c = (v[tri[:, k], :2] for k in range(3))
    q = np.asarray(closest)[:, :2]
    den = (b - a)[:, 0] * (c - a)[:, 1] - (c - a)[:, 0] * (b - a)[:, 1]
    den = np.where(np.abs(den) > 1e-300, den, 1.0)
    wb = ((q - a)[:, 0] * (c - a)[:, 1] - (c - a)[:, 0] * (q - a)[:, 1]) / den
    wc = ((b - a)[:, 0] * (q - a)[:, 1] - (q - a)[:, 0] * (b - a)[:, 1]) / den
    w = np.column_stack([1 - wb - wc, wb, wc])
    return (v[tri, 2] * w).sum(axis=1), np.sqrt(np.maximum(d2, 0.0))


def order_margins(relief, relations, epsilon, *, completion=None, bands=(), step=0.5,
                  max_place=4000):
    """Per ``order`` entry: ``z_front - z_back - epsilon`` along its segment (and its place).

    Returns a dict ``label -> {"segment": array, "place": array}`` of margins
    at the samples where both parts' meshes are (a margin >= 0 holds). Samples
    inside a graft band between the entry's two regions (``bands`` of
    :class:`~inkray.relief.stitching.Layers`, where the relation gives way to
    the seam with a warning) are left out.
    """
    parts = {p.name: p for p in relief.parts}
    names = None if completion is None else completion.names
    out = {}
    for rel in relations:
        if rel.kind != "order" or rel.points is None:
            continue
        front, back = _part_names(rel, names, relief)
        if front not in parts or back not in parts:
            continue
        p, q = (np.asarray(x, float) for x in rel.points)
        n = max(2, int(math.ceil(np.linalg.norm(q - p) / step)) + 1)
        seg = p + np.linspace(0.0, 1.0, n)[:, None] * (q - p)
        res = {"segment": _margins(parts[front], parts[back], _outside(seg, rel, bands), epsilon)}
        if completion is not None and rel.place is not None:
            res["place"] = _margins(parts[front], parts[back], _outside(
                _place_points(completion, rel, max_place), rel, bands), epsilon)
        out.setdefault(rel.label, {"segment": np.zeros(0), "place": np.zeros(0)})
        for k, v in res.items():
            out[rel.label][k] = np.concatenate([out[rel.label][k], v])
    return out


def _outside(pts, rel, bands):
    """The points outside the graft bands between the relation's two regions."""
    keep = np.ones(len(pts), bool)
    for f, b, seam, width in bands:
        if {f, b} == {rel.front, rel.back}:
            keep &= point_polyline_distance(pts, seam) >= width
    return pts[keep]


def _part_names(rel, names, relief):
    if names is not None:
        return names[rel.front], names[rel.back]
    return relief.parts[rel.front].name, relief.parts[rel.back].name


def _margins(front, back, pts, epsilon):
    zf, df = height_on(front, pts)
    zb, db = height_on(back, pts)
    both = (df <= 1e-6) & (db <= 1e-6)  # inside both meshes
    return (zf - zb - epsilon)[both]


def _place_points(completion, rel, max_points):
    place = completion.places[rel.place]
    y0, y1, x0, x1 = place.box
    win = (slice(y0, y1), slice(x0, x1))
    lab, own = completion.labels[win], completion.owner[win]
    both = place.mask & ((lab == rel.front) | (own == rel.front)) & ((lab == rel.back) | (own == rel.back))
    ys, xs = np.nonzero(both)
    pts = np.column_stack([xs + x0, ys + y0]).astype(float)
    if len(pts) > max_points:
        pts = pts[np.linspace(0, len(pts) - 1, max_points).astype(int)]
    return pts


def boundary_loops(part):
    """Closed boundary loops of an open part as (k, 2) arrays of [x, y]."""
    f = np.asarray(part.faces, np.int64)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    b = e[counts[inv.ravel()] == 1]
    nxt = dict(zip(b[:, 0].tolist(), b[:, 1].tolist()))
    loops, seen = [], set()
    v = np.asarray(part.vertices, float)[:, :2]
    for s in b[:, 0].tolist():
        if s in seen:
            continue
        loop, cur = [], s
        while cur not in seen and cur in nxt:
            seen.add(cur)
            loop.append(cur)
            cur = nxt[cur]
        if len(loop) >= 3:
            loops.append(v[loop])
    return loops


def turning(loop):
    """Total absolute turning (radians) of a closed polyline."""
    e = np.roll(loop, -1, axis=0) - loop
    e = e[np.linalg.norm(e, axis=1) > 1e-9]
    if len(e) < 3:
        return 0.0
    a, b = e, np.roll(e, -1, axis=0)
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return float(np.abs(np.arctan2(cross, (a * b).sum(axis=1))).sum())


def smoothed(loop, sigma=SMOOTH_PX, step=0.5):
    """The loop resampled every ``step`` px and smoothed along its arc length."""
    closed = np.vstack([loop, loop[:1]])
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))]
    n = max(8, int(math.ceil(s[-1] / step)))
    t = np.linspace(0.0, s[-1], n, endpoint=False)
    q = np.stack([np.interp(t, s, closed[:, i]) for i in (0, 1)], axis=1)
    return gaussian_filter1d(q, sigma / (s[-1] / n), axis=0, mode="wrap")


def turning_ratio(relief, *, min_length=20.0):
    """Total turning of every part outline over that of the outlines smoothed over 3 px."""
    raw = smooth = 0.0
    for part in relief.parts:
        for loop in boundary_loops(part):
            length = float(np.linalg.norm(np.roll(loop, -1, axis=0) - loop, axis=1).sum())
            if length < min_length:
                continue
            raw += turning(loop)
            smooth += turning(smoothed(loop))
    return raw / smooth if smooth > 0 else float("nan")


def outline_ink(gray, labels):
    """Ink pixels of the contour between the parts and the background (bool image)."""
    ink = ink_mask(gray)
    paper = (labels < 0) & ~ink
    inside = (labels >= 0) & ~ink
    if not paper.any() or not inside.any() or not ink.any():
        return np.zeros_like(ink)
    width = 4.0 * float(np.median(distance_transform_edt(ink)[ink]))  # a stroke's width
    reach = distance_transform_edt(~paper) + distance_transform_edt(~inside)
    return ink & (reach <= 1.5 * width + 2.0)


def outline_ink_on_mesh(relief, gray, labels, *, raster=None):
    """Fraction of the outline ink (:func:`outline_ink`) that the front view covers."""
    r = raster if raster is not None else rasterize(relief)
    line = outline_ink(gray, labels)
    total = int(line.sum())
    return float((r.part[line] >= 0).sum()) / total if total else float("nan")


def shells(vertices, faces):
    """Connected components of a triangle mesh (vertices at one position welded)."""
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    if len(f) == 0:
        return 0
    _, inv = np.unique(v, axis=0, return_inverse=True)
    wf = inv.ravel()[f]
    n = int(wf.max()) + 1
    rows = np.concatenate([wf[:, 0], wf[:, 1]])
    cols = np.concatenate([wf[:, 1], wf[:, 2]])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    used = np.unique(wf)
    count, label = connected_components(graph, directed=False)
    return int(len(np.unique(label[used])))


def solid_figures(relief):
    """Min angle (deg), max aspect ratio, shells, watertight and manifold of every part, combined."""
    qs = [mesh_quality(p.vertices, p.faces, self_intersections=False) for p in relief.parts]
    return {"min_angle": min(q["min_angle_deg"] for q in qs),
            "max_aspect": max(q["max_aspect_ratio"] for q in qs),
            "shells": sum(shells(p.vertices, p.faces) for p in relief.parts),
            "watertight": all(q["watertight"] for q in qs),
            "manifold": all(q["edge_manifold"] and q["vertex_manifold"] for q in qs)}


def relief_figures(result, gray):
    """The open relief's figures from a :class:`~inkray.chain.ReliefResult` (dict)."""
    relief = result.relief
    raster = rasterize(relief)
    jumps = normal_jumps(relief, gray, epsilon=result.layers.epsilon, raster=raster)
    steps = normal_jumps(relief, gray, raster=raster)
    joins = open_join_jumps(relief, gray, raster=raster)
    margins = order_margins(relief, result.relations, result.layers.epsilon,
                            completion=result.completion, bands=result.layers.bands)
    seg = np.concatenate([m["segment"] for m in margins.values()] or [np.zeros(0)])
    place = np.concatenate([m["place"] for m in margins.values()] or [np.zeros(0)])
    tol = -1e-3 * result.layers.epsilon
    return {
        "jump_p90": float(np.percentile(jumps, 90)) if len(jumps) else 0.0,
        "seam_pixels": int(len(jumps)),
        "jump_p90_all": float(np.percentile(steps, 90)) if len(steps) else 0.0,
        "open_p90": float(np.percentile(joins, 90)) if len(joins) else 0.0,
        "open_pixels": int(len(joins)),
        "order_held": float((seg >= tol).mean()) if len(seg) else 1.0,
        "place_held": float((place >= tol).mean()) if len(place) else 1.0,
        "entries_broken": sorted(k for k, m in margins.items()
                                 if (m["segment"] < tol).any()),
        "turning": turning_ratio(relief),
        "ink_on_mesh": outline_ink_on_mesh(relief, gray, result.segmentation.labels, raster=raster),
    }


def top_distance(solid, parts):
    """Largest distance (px) from the parts' visible front vertices to the solid's surface.

    ``parts`` are the closed parts the union ``solid`` was made of; a front
    vertex is visible when no other part's front lies above it.
    """
    fronts = []
    for p in parts:
        v, f = np.asarray(p.vertices, float), np.asarray(p.faces, np.int64)
        t = v[f][:, :, :2]
        e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        front = f[e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0]  # clockwise in (x, y)
        fronts.append((v, front))
    worst = 0.0
    sv, sf = np.asarray(solid.vertices, float), np.asarray(solid.faces, np.int64)
    for i, (v, front) in enumerate(fronts):
        pts = v[np.unique(front)]
        covered = np.zeros(len(pts), bool)
        for j, (w, g) in enumerate(fronts):
            if j != i:
                covered |= _above(pts, w, g)
        if (~covered).any():
            d2, _, _ = igl.point_mesh_squared_distance(pts[~covered], sv, sf)
            worst = max(worst, float(np.sqrt(d2.max())))
    return worst


def _above(points, vertices, faces):
    """Whether the front ``faces`` lie above ``points`` (within their outline in x, y)."""
    z, d = height_on(Part("front", vertices, faces), points[:, :2])
    return (d < 1e-6) & (z > points[:, 2] + 1e-9)
