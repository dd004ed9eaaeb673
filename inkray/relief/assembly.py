"""Assembly of the bas-relief: stitched layers -> one mesh per part.

Step 6 of Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for Adding Global
Illumination Effects to Hand-Drawn Characters" (TOG 2014): the stack of
inflated, stitched layers is the relief; seen from the front it reproduces the
drawing, and planar UVs map the drawing onto it.

The open relief has one front surface per part at ``z = h + g``. The closed
variant mirrors each part to the back about its offset field: the back is at
``z = g - h - t`` below the same outline, joined to the front by a wall of
height ``2 h + t`` along it. ``t`` is the depth step ``epsilon``: at the
silhouette (``h = 0``) the wall is a thin rim instead of a knife edge, which
keeps every part a proper 2-manifold (a knife edge pinches wherever a
triangle has all its corners on the silhouette) and gives ``flat`` parts a
slab of thickness ``epsilon``. Every closed part is watertight and
consistently oriented; ``union=True`` makes one solid of them for 3D
printing: the space between the highest front and the lowest back over the
union of the parts' outlines, built as a height field (no boolean, so no
near-coincident sheets and no slivers along intersection curves), which
joins a part floating in front of the part behind it to it. It is remeshed
(PyMeshLab's isotropic remeshing), its remaining slivers are flipped,
collapsed or split away, the vertices of faces folded through another
moved off them and the patches around faces still bad re-triangulated. Parts whose outlines do not overlap (drawn apart)
stay separate shells, named in :attr:`~inkray.relief.model.Relief.warnings`.
"""

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from inkray.errors import StageError
from inkray.relief.model import Part, Relief
from inkray.relief.patches import min_angles as _min_angles
from inkray.relief.patches import bad_faces, repair_patches

__all__ = ["assemble", "close_part", "union_parts", "remesh_solid", "shell_parts",
           "MIN_ANGLE"]

#: Smallest triangle angle (degrees) the union's remeshing aims for.
MIN_ANGLE = 10.0
_FIX_ROUNDS = 3  # further remeshing rounds while slivers are left (see remesh_solid)
_FINER = 3.0  # edges this much shorter when the first remeshing leaves slivers
_ITERATIONS = 4  # of the first remeshing (the further rounds go on where slivers are left)


def assemble(layers, *, size, texture=None, closed=False, union=False):
    """Turn stitched layers into a :class:`~inkray.relief.model.Relief`.

    Parameters
    ----------
    layers : inkray.relief.stitching.Layers
    size : (int, int)
        ``(width, height)`` of the drawing.
    texture : (H, W, 3) uint8 array, optional
        The drawing's colours.
    closed : bool, default False
        Make every part a closed solid (mirrored back).
    union : bool, default False
        With ``closed``: one watertight solid, the union of all parts, named
        ``"union"``.

    Returns
    -------
    Relief
        Parts in region order, named after the regions; heights shifted so
        the lowest front (or back, when closed) vertex is at ``z = 0``.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.inflation import inflate_region
    >>> from inkray.relief.stitching import stitch
    >>> yy, xx = np.mgrid[:60, :60]
    >>> layers = stitch([inflate_region((xx - 30) ** 2 + (yy - 30) ** 2 <= 20 ** 2, name="disk")], [], None)
    >>> relief = assemble(layers, size=(60, 60), closed=True)
    >>> relief.parts[0].name, relief.parts[0].closed
    ('disk', True)
    """
    parts = []
    for i, region in enumerate(layers.regions):
        if region is None:
            continue
        mesh = region.mesh
        z = layers.z(i)
        v = np.column_stack([mesh.vertices, z])
        part = Part(name=mesh.name, vertices=v, faces=np.asarray(mesh.faces, np.int64))
        if closed:
            part = close_part(part, layers.offset[i] - region.height - layers.epsilon)
        parts.append(part)
    if not parts:
        raise StageError("assemble: no region has a mesh")
    low = min(float(p.vertices[:, 2].min()) for p in parts)
    for p in parts:
        p.vertices[:, 2] -= low
    warnings = []
    if union:
        if not closed:
            raise StageError("assemble: union needs closed parts")
        solid = union_parts(parts)
        groups = shell_parts(solid, parts)
        if len(groups) > 1:
            apart = "; ".join(", ".join(g) for g in groups[1:])
            warnings.append(f"union: {len(groups)} separate shells: {apart} do not overlap "
                            f"{', '.join(groups[0])} in the drawing")
        parts = [solid]
    return Relief(parts=parts, size=tuple(size), texture=texture, warnings=warnings)


def close_part(part, back_z):
    """Close an open front surface with a back surface and a wall along its outline.

    Parameters
    ----------
    part : Part
        Open front surface: an outline-bounded triangle mesh, faces toward the
        viewer.
    back_z : (n,) float array
        Height of the back below each front vertex; strictly below the front
        on the outline (the wall has positive height everywhere, so no face
        is degenerate and every edge has exactly two faces).

    Returns
    -------
    Part
        Front vertices, then their back copies; front faces, reversed back
        faces, and two wall triangles per outline edge.

    Raises
    ------
    StageError
        When ``back_z`` is not below the front.
    """
    v = np.asarray(part.vertices, float)
    f = np.asarray(part.faces, np.int64)
    n = len(v)
    back_z = np.asarray(back_z, float)
    if (v[:, 2] - back_z <= 0).any():
        raise StageError(f"part {part.name}: the back does not lie below the front")
    a, b = _boundary_edges(f).T  # front edge a -> b as the front faces run it
    # the wall runs the shared edges the other way: b -> a on the front, a' -> b' on the back
    walls = np.concatenate([np.stack([b, a, a + n], 1), np.stack([b, a + n, b + n], 1)])
    faces = np.concatenate([f, f[:, ::-1] + n, walls])
    back = np.column_stack([v[:, :2], back_z])
    return Part(name=part.name, vertices=np.concatenate([v, back]), faces=faces, closed=True)


def union_parts(parts, *, name="union", remesh=True):
    """One watertight solid over the union of closed parts' outlines, remeshed.

    Every closed part is a slab over the image plane: over its outline it
    fills ``[back(x, y), front(x, y)]``. The solid fills ``[B, T]`` over the
    union of the outlines, with ``T`` the highest front and ``B`` the lowest
    back of the parts there: the union of the parts where their slabs
    overlap, and the gap filled where a part floats in front of the part
    behind it, so parts whose outlines overlap make one shell. It is built
    as a height field, without a boolean: the union's footprint is
    triangulated in 2D (Triangle) with every part's outline as a
    constraint, ``T`` and ``B`` are sampled at its vertices, and a wall
    joins them along the footprint's outline. Watertight, consistently
    oriented and free of near-coincident sheets by construction. A step
    where one part's outline crosses another part becomes a steep strip
    about ``3 gap`` wide, ``gap`` being a sixth of the parts' median edge
    (rows of points beside every outline bound it); slits, spikes and ledges
    narrower than about ``gap`` are closed, cut or filled, and a lone vertex
    rising (dropping) more than ``2 gap`` beyond all its neighbours is
    brought back to them (see ``_envelope_solid``).

    Parameters
    ----------
    parts : list of Part
        Closed parts, slabs over the image plane (front faces clockwise in
        ``(x, y)``, back faces counter-clockwise).
    name : str, default "union"
    remesh : bool, default True
        Remesh the solid (:func:`remesh_solid`) with edges as long as the
        parts' median edge (the relief's own resolution: finer multiplies
        the faces and the time); where that leaves a face bad (an angle
        below :data:`MIN_ANGLE` or crossing another), again from the start
        with edges a third as long and 8 iterations.

    Returns
    -------
    Part

    Examples
    --------
    >>> import manifold3d as m3d
    >>> def box(x, z):
    ...     m = m3d.Manifold.cube([4.0, 4.0, 1.0]).translate([x, 0.0, z]).to_mesh()
    ...     v = np.asarray(m.vert_properties, float) * [1, -1, 1]  # y down
    ...     return Part("box", v, np.asarray(m.tri_verts, np.int64), closed=True)
    >>> solid = union_parts([box(0.0, 0.0), box(2.0, 3.0)], remesh=False)  # floats above
    >>> len(shell_parts(solid, [box(0.0, 0.0)])), _closed_manifold(solid.faces)
    (1, True)
    """
    edges = np.concatenate([np.linalg.norm(p.vertices[p.faces] - p.vertices[np.roll(p.faces, 1, 1)],
                                           axis=2).ravel() for p in parts])
    target = float(np.median(edges))
    verts, faces = _envelope_solid(parts, gap=target / _FINER / 2.0)  # a sixth of it
    if remesh:
        v, f = remesh_solid(verts, faces, target=target)
        if bad_faces(v, f, min_angle=MIN_ANGLE).any():
            # where a sliver is left at the relief's resolution, edges a third as long
            # and 8 iterations leave none on every bundled drawing (minutes on the largest)
            v, f = remesh_solid(verts, faces, target=target / _FINER, iterations=8)
        verts, faces = v, f
    return Part(name=name, vertices=verts, faces=faces, closed=True)


def _envelope_solid(parts, *, gap):
    """The height field ``[B, T]`` over the union of the parts' outlines (see union_parts).

    Notches and gaps of the union's outline narrower than ``gap`` are filled,
    spikes narrower than it cut off (a wall in a narrow slit cannot be
    remeshed into well-shaped triangles).
    """
    import triangle

    sheets = [_sheets(p) for p in parts]
    points = np.concatenate([v[:, :2] for v, _, _ in sheets])
    starts = np.cumsum([0] + [len(v) for v, _, _ in sheets])
    segments = np.concatenate([np.sort(_boundary_edges(front), axis=1) + s
                               for (_, front, _), s in zip(sheets, starts)])
    # rows of points beside every outline, beyond the parts' reach (below): a step where
    # a part's outline crosses another part becomes a strip this narrow, not a ramp
    # across a large triangle of the part behind
    a, b = points[segments[:, 0]], points[segments[:, 1]]
    normal = (b - a)[:, ::-1] * [1.0, -1.0]
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    beside = [0.5 * (a + b) + k * gap * normal for k in (-5.0, -3.0, 3.0, 5.0)]
    points = np.concatenate([points] + beside)
    # one vertex per position: Triangle warns about (and skips) duplicates
    points, inverse = np.unique(points, axis=0, return_inverse=True)
    segments = np.unique(np.sort(inverse.ravel()[segments], axis=1), axis=0)
    segments = segments[segments[:, 0] != segments[:, 1]]
    tri = triangle.triangulate({"vertices": points, "segments": segments}, "pnQ")
    xy, tris = np.asarray(tri["vertices"], float), np.asarray(tri["triangles"], np.int64)
    neighbours = np.asarray(tri["neighbors"], np.int64)
    tol = 1e-9 * float(np.ptp(xy, axis=0).max())
    centroids = xy[tris].mean(axis=1)
    inside = np.zeros(len(tris), bool)
    top = np.full(len(xy), -np.inf)
    bottom = np.full(len(xy), np.inf)
    for v, front, back in sheets:
        # the triangles of the convex hull inside this part (its outline is a constraint,
        # so a triangle is inside or outside as a whole)
        inside |= _sample(v, front, centroids, tol)[0]
        # a part reaching a fraction of a pixel beyond the part behind it would leave a
        # ledge that narrow on the solid's side: every part counts a little beyond its
        # outline (its front out to 2 gap, its back, unseen from the front, out to 4 gap)
        hit, z = _sample(v, front, xy, 2.0 * gap)
        top[hit] = np.maximum(top[hit], z)
        hit, z = _sample(v, back, xy, 4.0 * gap)
        bottom[hit] = np.minimum(bottom[hit], z)
    sampled = np.isfinite(top) & np.isfinite(bottom)
    tris = tris[_trim_footprint(xy, tris, neighbours, inside, gap, sampled[tris].all(axis=1))]
    used, tris = np.unique(tris, return_inverse=True)
    tris = tris.reshape(-1, 3)
    xy, top, bottom = xy[used], top[used], bottom[used]
    if not (np.isfinite(top).all() and np.isfinite(bottom).all()):
        raise StageError("union: a vertex of the outlines' triangulation lies in no part")
    top, bottom = _despike(tris, top, bottom, 2.0 * gap)
    n = len(xy)
    # Triangle's faces run counter-clockwise in (x, y): the back's orientation
    a, b = _boundary_edges(tris).T
    walls = np.concatenate([np.stack([a, b, b + n], 1), np.stack([a, b + n, a + n], 1)])
    verts = np.concatenate([np.column_stack([xy, top]), np.column_stack([xy, bottom])])
    return verts, np.concatenate([tris[:, ::-1], tris + n, walls])


def _despike(tris, top, bottom, height):
    """``top`` and ``bottom`` with lone vertices more than ``height`` beyond all their
    neighbours brought back to the nearest of them.

    A vertex just within a part's sampling tolerance (see ``_envelope_solid``)
    takes that part's height while its neighbours do not: a needle of the
    solid a fraction of a pixel wide, which no remeshing makes well shaped.
    """
    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    e = np.concatenate([e, e[:, ::-1]])
    n = len(top)
    highest = np.full(n, -np.inf)
    np.maximum.at(highest, e[:, 0], top[e[:, 1]])
    lowest = np.full(n, np.inf)
    np.minimum.at(lowest, e[:, 0], bottom[e[:, 1]])
    return (np.where(top > highest + height, highest, top),
            np.where(bottom < lowest - height, lowest, bottom))


def _trim_footprint(xy, tris, neighbours, inside, gap, sampled):
    """``inside`` with thin triangles between two outside (inside) neighbours flipped,
    islands smaller than ``(4 gap)^2`` dropped and holes that small filled (where
    every corner is ``sampled``)."""
    t = xy[tris]
    e = np.linalg.norm(t - np.roll(t, 1, axis=1), axis=2)
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    thin = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) / e.max(axis=1) < gap  # altitude
    inside = inside.copy()
    for _ in range(len(tris)):
        near = np.where(neighbours >= 0, inside[neighbours], False).sum(axis=1)
        fill = thin & ~inside & (near >= 2)
        cut = thin & inside & (near <= 1)
        if not (fill.any() or cut.any()):
            break
        inside[fill] = True
        inside[cut] = False
    # islands smaller than a few gaps across (a tip cut off at a thin neck) would be
    # needles of the solid's full height; holes that small (a gap where several parts
    # meet around one outline vertex) would be pipes of it
    area = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) / 2.0
    limit = 16.0 * gap ** 2
    inside[_small_pieces(inside, neighbours, area, limit)] = False
    open_ = (neighbours < 0).any(axis=1) | ~sampled  # the outside around the footprint
    inside[_small_pieces(~inside, neighbours, np.where(open_, np.inf, area), limit)] = True
    return inside


def _small_pieces(chosen, neighbours, area, limit):
    """The ``chosen`` triangles in edge-connected pieces of ``chosen`` with area below ``limit``."""
    k = np.flatnonzero(chosen)
    index = np.full(len(chosen), -1)
    index[k] = np.arange(len(k))
    rows = np.repeat(np.arange(len(k)), 3)
    cols = index[neighbours[k]].ravel()
    keep = (cols >= 0) & (neighbours[k].ravel() >= 0)
    graph = coo_matrix((np.ones(keep.sum()), (rows[keep], cols[keep])), shape=(len(k), len(k)))
    _, label = connected_components(graph, directed=False)
    small = np.zeros(len(chosen), bool)
    small[k] = np.bincount(label, weights=area[k])[label] < limit
    return small


def _sheets(part):
    """A closed part's vertices, front faces (clockwise in (x, y)) and back faces."""
    v = np.asarray(part.vertices, float)
    f = np.asarray(part.faces, np.int64)
    t = v[f][:, :, :2]
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    area = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]  # twice the signed area; walls have none
    return v, f[area < 0], f[area > 0]


def _sample(vertices, faces, points, tol):
    """Which points lie on the faces in (x, y) (within ``tol``), and the faces' z there."""
    import igl

    hit = np.zeros(len(points), bool)
    z = np.zeros(len(points))
    lo, hi = vertices[:, :2].min(axis=0) - tol, vertices[:, :2].max(axis=0) + tol
    box = np.flatnonzero(((points >= lo) & (points <= hi)).all(axis=1))
    if len(box) == 0 or len(faces) == 0:
        return hit, z[hit]
    flat = np.column_stack([vertices[:, :2], np.zeros(len(vertices))])
    query = np.column_stack([points[box], np.zeros(len(box))])
    d2, face, near = igl.point_mesh_squared_distance(query, flat, faces)
    t = vertices[faces[face]]
    e1, e2, r = t[:, 1, :2] - t[:, 0, :2], t[:, 2, :2] - t[:, 0, :2], near[:, :2] - t[:, 0, :2]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    l1 = (r[:, 0] * e2[:, 1] - r[:, 1] * e2[:, 0]) / det
    l2 = (e1[:, 0] * r[:, 1] - e1[:, 1] * r[:, 0]) / det
    hit[box] = d2 <= tol * tol
    z[box] = t[:, 0, 2] + l1 * (t[:, 1, 2] - t[:, 0, 2]) + l2 * (t[:, 2, 2] - t[:, 0, 2])
    return hit, z[hit]


def remesh_solid(vertices, faces, *, target, min_angle=MIN_ANGLE, iterations=_ITERATIONS):
    """Isotropic remeshing of a closed solid (PyMeshLab), then its slivers removed.

    The whole surface is remeshed toward edges of length ``target``;
    creases sharper than 89 degrees (the steps between parts) are kept as
    features. The remeshing leaves a few slivers along those creases; each
    is then flipped (a cap whose long edge lies in a flat stretch),
    collapsed (a needle's short edge, to whichever of its midpoint and ends
    shapes the triangles around it best) or split (a cap's long edge at the
    foot of its far corner, making two needles), only where this turns no
    face by more than 30 degrees and raises the smallest angle around it (an
    edge shorter than a quarter of the median edge may be collapsed however
    far its faces turn, short of folding one over). Then every vertex of a
    face that crosses another is moved to the centroid of its neighbours (or
    halfway) where that leaves fewer crossings and no angle below
    ``min_angle`` (``_untangle``), and the patches around faces still bad
    (an angle below ``min_angle`` or crossing another) are re-triangulated
    (:func:`~inkray.relief.patches.repair_patches`). When faces are left bad,
    further remeshing rounds (up to three) run while the local fixes leave a
    sliver, and the round with the largest smallest angle (the last of
    equals) is repaired the same way and kept. The remeshed surface is
    returned only when it is still watertight and edge-manifold (a round
    that is not ends the rounds; when the first is not, the input comes back
    unchanged), and without the sliver fixes (the re-triangulation) when
    they would break that or put two vertices at one position.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
        A watertight, consistently oriented triangle mesh.
    target : float
        Edge length to aim for (same units as the vertices).
    min_angle : float, default 10
    iterations : int, default 4
        Of the first remeshing (the further rounds take 4).

    Returns
    -------
    vertices : (n', 3) float array
    faces : (m', 3) int64 array

    Examples
    --------
    >>> import manifold3d as m3d
    >>> cube = m3d.Manifold.cube([10.0, 10.0, 1.0]).to_mesh()
    >>> v, f = remesh_solid(np.asarray(cube.vert_properties, float), np.asarray(cube.tri_verts), target=1.0)
    >>> bool(_min_angles(v, f).min() >= 10.0), len(f) > 100
    (True, True)
    """
    import pymeshlab

    v, f = np.asarray(vertices, float), np.asarray(faces, np.int32)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=v, face_matrix=f))
    length = pymeshlab.PureValue(float(target))
    ms.meshing_isotropic_explicit_remeshing(iterations=iterations, targetlen=length,
                                            featuredeg=89.0, checksurfdist=False)
    best = None  # (smallest angle, vertices, faces) of the best round so far
    first = None  # the first round repaired, and its bad faces left
    for rounds in range(_FIX_ROUNDS + 1):
        m = ms.current_mesh()
        m.compact()
        nv, nf = np.asarray(m.vertex_matrix(), float), np.asarray(m.face_matrix(), np.int64)
        if not _closed_manifold(nf):
            if best is None:
                return v, f.astype(np.int64)
            break
        fv, ff = _SliverFix(nv, nf).run(min_angle)
        if not _closed_manifold(ff) or len(np.unique(fv, axis=0)) < len(fv):
            fv, ff = nv, nf
        if rounds == 0:
            # most solids are done here: the further rounds cost minutes on large ones
            first = _repair(fv, ff, target=target, min_angle=min_angle)
            if first[2] == 0:
                return first[0], first[1]
        smallest = _min_angles(fv, ff).min(initial=180.0)
        # a round may leave worse needles than the one before (the fox: 1.8, 0.6,
        # 0.01, 0.0 degrees): the best round is kept, not the last
        if best is None or smallest >= best[0]:  # ties: the later round
            best = (smallest, fv, ff, rounds)
        if rounds == _FIX_ROUNDS or smallest >= min_angle:
            break
        # the remeshing goes on from its own mesh, not the fixed one; (remeshing only the
        # slivers would be cheaper, but PyMeshLab's selected-only remeshing depends on
        # earlier calls: the output would too)
        ms.meshing_isotropic_explicit_remeshing(iterations=4, targetlen=length, featuredeg=89.0,
                                                checksurfdist=False)
    if best[3] == 0:
        return first[0], first[1]
    fv, ff, _ = _repair(best[1], best[2], target=target, min_angle=min_angle)
    return fv, ff


def _repair(vertices, faces, *, target, min_angle):
    """Vertices moved off the faces they fold through, then the patches around faces
    still bad re-triangulated; with the number of faces bad after both."""
    v, crossing = _untangle(vertices, faces, min_angle=min_angle)
    bad = bad_faces(v, faces, min_angle=min_angle, crossing=crossing)
    if not bad.any():
        return v, faces, 0
    rv, rf = repair_patches(v, faces, target=target, min_angle=min_angle, bad=bad)
    if not _closed_manifold(rf):
        return v, faces, int(bad.sum())
    return rv, rf, int(bad_faces(rv, rf, min_angle=min_angle).sum())


def _untangle(vertices, faces, *, min_angle, rounds=3):
    """Vertices of a mesh moved, one at a time, off the faces they fold through.

    Each vertex of a face that crosses another is tried at the centroid of
    its neighbours and halfway there; a move is kept when it leaves fewer
    crossing faces around it and no angle of its faces below ``min_angle``
    (or below the smallest one there before). Only positions change, so the
    mesh stays as closed and manifold as it was. Returns the vertices and which
    faces still cross another.
    """
    from inkray.numerics.tri_intersection import self_intersecting_faces

    v = np.array(vertices, float)
    f = np.asarray(faces, np.int64)
    n = len(v)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    ring = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n)).tocsr()
    ring = ((ring + ring.T) > 0).tocsr()
    flat = f.ravel()
    order = np.argsort(flat, kind="stable")
    start = np.searchsorted(flat[order], np.arange(n + 1))

    bad = self_intersecting_faces(v, f)
    for _ in range(rounds):
        if not bad.any():
            break
        t = v[f]
        flo, fhi = t.min(axis=1), t.max(axis=1)  # the faces' boxes, kept up to date
        moved = False
        for x in np.unique(f[bad]).tolist():
            around = order[start[x]:start[x + 1]] // 3
            centroid = v[ring.indices[ring.indptr[x]:ring.indptr[x + 1]]].mean(axis=0)
            here = v[x].copy()
            lo = np.minimum(flo[around].min(axis=0), centroid)
            hi = np.maximum(fhi[around].max(axis=0), centroid)
            near = f[np.flatnonzero((flo <= hi).all(axis=1) & (fhi >= lo).all(axis=1))]
            before = int(self_intersecting_faces(v, near).sum())
            worst = min(min_angle, float(_min_angles(v, f[around]).min()))
            for p in (centroid, 0.5 * (here + centroid)):
                v[x] = p
                if (self_intersecting_faces(v, near).sum() < before
                        and _min_angles(v, f[around]).min() >= worst):
                    moved = True
                    t = v[f[around]]
                    flo[around], fhi[around] = t.min(axis=1), t.max(axis=1)
                    break
                v[x] = here
        if not moved:
            break
        bad = self_intersecting_faces(v, f)
    return v, bad


class _SliverFix:
    """Local flips, collapses and splits of a closed mesh's slivers (see remesh_solid)."""

    _ROUNDS = 8
    _TURN = np.cos(np.radians(30.0))  # largest turn of a face's normal an operation may cause

    def __init__(self, vertices, faces):
        self.v = np.array(vertices, float)
        self.f = np.array(faces, np.int64)
        self.alive = np.ones(len(self.f), bool)
        flat = self.f.ravel()
        self._order = np.argsort(flat, kind="stable")
        self._start = np.searchsorted(flat[self._order], np.arange(len(self.v) + 1))
        self._around = {}
        e = self.v[self.f] - self.v[np.roll(self.f, 1, axis=1)]
        self._short = 0.25 * float(np.median(np.linalg.norm(e, axis=2)))

    def run(self, min_angle):
        """Vertices and faces with the slivers fixed where it can be done."""
        for _ in range(self._ROUNDS):
            live = np.flatnonzero(self.alive)
            angles = _min_angles(self.v, self.f[live])
            bad = live[np.argsort(angles, kind="stable")[: int((angles < min_angle).sum())]]
            changed = False
            for t in bad.tolist():
                if self.alive[t] and self._angle(t) < min_angle:
                    changed |= self._flip(t) or self._collapse(t) or self._split(t)
            if not changed:
                break
        used, faces = np.unique(self.f[self.alive], return_inverse=True)
        return self.v[used], faces.reshape(-1, 3).astype(np.int64)

    def _faces(self, x):
        """The live faces around vertex ``x`` (a set, updated in place)."""
        if x not in self._around:
            if x + 1 < len(self._start):
                self._around[x] = set((self._order[self._start[x]:self._start[x + 1]] // 3).tolist())
            else:
                self._around[x] = set()
        return self._around[x]

    def _angle(self, t):
        return float(_min_angles(self.v, self.f[[t]])[0])

    def _edge(self, t, longest):
        """Corners ``a, b, c`` of face ``t`` with ``a -> b`` its longest (shortest) edge."""
        tri = self.f[t]
        p = self.v[tri]
        lengths = np.linalg.norm(p - np.roll(p, -1, axis=0), axis=1)
        i = int(np.argmax(lengths) if longest else np.argmin(lengths))
        return int(tri[i]), int(tri[(i + 1) % 3]), int(tri[(i + 2) % 3])

    def _across(self, t, a, b):
        """The other face on edge ``a b`` of ``t`` and its corner off the edge."""
        other = self._faces(a) & self._faces(b) - {t}
        if len(other) != 1:
            return None, None
        u = other.pop()
        return u, int(next(x for x in self.f[u] if x != a and x != b))

    def _flip(self, t):
        a, b, c = self._edge(t, longest=True)
        u, d = self._across(t, a, b)
        if u is None or d == c or self._faces(c) & self._faces(d):
            return False
        n = _normal(self.v[self.f[t]])
        new = np.array([[a, d, c], [d, b, c]])
        if (_normal(self.v[self.f[u]]) @ n < self._TURN
                or (_normal(self.v[new]) @ n < self._TURN).any()
                or _min_angles(self.v, new).min() <= min(self._angle(t), self._angle(u))):
            return False
        self.f[t], self.f[u] = new
        self._faces(b).discard(t)
        self._faces(a).discard(u)
        self._faces(d).add(t)
        self._faces(c).add(u)
        return True

    def _collapse(self, t):
        a, b, _ = self._edge(t, longest=False)
        fa, fb = self._faces(a), self._faces(b)
        shared = fa & fb
        if len(shared) != 2 or self._ring(fa) & self._ring(fb) != self._ring(shared):
            return False  # the link condition: the collapse would pinch the surface
        moved = sorted((fa | fb) - shared)
        before = min(self._angle(g) for g in moved + sorted(shared))
        best, where = before, None
        # an edge much shorter than the mesh's edges moves its faces little however far
        # they turn: only a face turned over (a fold) is refused
        short = np.linalg.norm(self.v[a] - self.v[b]) < self._short
        turn = 0.0 if short else self._TURN
        for p in (0.5 * (self.v[a] + self.v[b]), self.v[a], self.v[b]):
            tris = self.v[self.f[moved]]
            tris[np.isin(self.f[moved], (a, b))] = p
            if (np.einsum("ij,ij->i", _normal(tris), _normal(self.v[self.f[moved]])) < turn).any():
                continue
            worst = _min_angles(tris.reshape(-1, 3), np.arange(3 * len(moved)).reshape(-1, 3)).min()
            if worst > best:
                best, where = worst, p.copy()
        if where is None:
            return False
        self.v[b] = where
        for g in shared:
            self.alive[g] = False
            for x in self.f[g].tolist():
                self._faces(x).discard(g)
        for g in sorted(fa - shared):
            self.f[g][self.f[g] == a] = b
            fb.add(g)
        fa.clear()
        return True

    def _ring(self, faces):
        """The vertices of ``faces``."""
        return {int(y) for g in faces for y in self.f[g]}

    def _split(self, t):
        a, b, c = self._edge(t, longest=True)
        u, d = self._across(t, a, b)
        if u is None:
            return False
        ab = self.v[b] - self.v[a]
        s = float((self.v[c] - self.v[a]) @ ab / (ab @ ab))
        foot = self.v[a] + s * ab
        if not 0.05 < s < 0.95 or np.linalg.norm(self.v[c] - foot) < 1e-3 * np.sqrt(ab @ ab):
            return False  # (a corner on the edge would get a twin at its position)
        m = len(self.v)
        self.v = np.vstack([self.v, foot])
        k = len(self.f)
        self.f = np.vstack([self.f, [[m, b, c], [b, m, d]]])
        self.alive = np.append(self.alive, [True, True])
        self.f[t], self.f[u] = [a, m, c], [m, a, d]
        self._faces(b).difference_update((t, u))
        self._faces(b).update((k, k + 1))
        self._faces(c).add(k)
        self._faces(d).add(k + 1)
        self._around[m] = {t, u, k, k + 1}
        return True


def _normal(tris):
    """Unit normals of triangles given by their corners (..., 3, 3)."""
    n = np.cross(tris[..., 1, :] - tris[..., 0, :], tris[..., 2, :] - tris[..., 0, :])
    return n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-300)


def shell_parts(solid, parts):
    """The parts in each connected shell of a union, the largest shell first.

    Parameters
    ----------
    solid : Part
        The union.
    parts : list of Part
        The closed parts it was made of.

    Returns
    -------
    list of list of str
        Part names per shell (a part goes to the shell nearest to most of its
        vertices); one list when the union is one solid.

    Examples
    --------
    >>> import manifold3d as m3d
    >>> m = m3d.Manifold.cube([1.0, 1.0, 1.0]).to_mesh()
    >>> cube = Part("a", np.asarray(m.vert_properties, float), np.asarray(m.tri_verts, np.int64))
    >>> shell_parts(cube, [cube])
    [['a']]
    """
    f = np.asarray(solid.faces, np.int64)
    n = len(solid.vertices)
    graph = coo_matrix((np.ones(2 * len(f)), (np.r_[f[:, 0], f[:, 1]], np.r_[f[:, 1], f[:, 2]])),
                       shape=(n, n))
    _, label = connected_components(graph, directed=False)
    tree = cKDTree(np.asarray(solid.vertices, float))
    groups = {}
    for p in parts:
        _, near = tree.query(np.asarray(p.vertices, float))
        groups.setdefault(int(np.bincount(label[near]).argmax()), []).append(p.name)
    sizes = np.bincount(label)
    return [groups[k] for k in sorted(groups, key=lambda k: -sizes[k])]


def _closed_manifold(faces):
    """Every edge has exactly two faces, running it opposite ways."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    if len(faces) == 0 or (counts != 2).any():
        return False
    forward = np.bincount(inv.ravel(), weights=(e[:, 0] < e[:, 1]).astype(float))
    return bool(np.all(forward == 1))


def _boundary_edges(faces):
    """Directed boundary edges (as the faces run them)."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return e[counts[inv.ravel()] == 1]
