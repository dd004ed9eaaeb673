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
union of the parts' outlines, which joins a part floating in front of the
part behind it to it, built with the booleans of the Manifold library
(manifold3d, exact in their topology) once outlines of different parts that
run within :data:`SNAP` of each other are made to coincide exactly; only the faces
around the slivers its cuts leave (and the parts' own) are remeshed
(PyMeshLab's isotropic remeshing of those faces alone), then flipped,
collapsed or split, the patches around faces still bad re-triangulated.
Parts whose outlines do not overlap (drawn apart) stay separate shells,
named in :attr:`~inkray.relief.model.Relief.warnings`.
"""

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from inkray.errors import StageError
from inkray.numerics.arap import signed_areas
from inkray.relief.inflation import WALL_INSET
from inkray.relief.model import Part, Relief
from inkray.relief.patches import min_angles as _min_angles
from inkray.numerics.tri_intersection import crossing_faces, self_intersecting_faces
from inkray.relief.patches import _STORED_SCALES, ladders, repair_patches

__all__ = ["assemble", "close_part", "union_parts", "remesh_solid", "shell_parts",
           "MIN_ANGLE", "SKIRT", "SNAP"]

#: Smallest triangle angle (degrees) the union's remeshing aims for.
MIN_ANGLE = 10.0
_RINGS = 2  # rings of faces remeshed around each sliver (see remesh_solid)
_ROUNDS = 3  # of remeshing, two more rings each, while faces are left bad
_ITERATIONS = 4  # of that remeshing
_FEW = 32  # bad faces left by the rounds that are worked on one by one (see remesh_solid)
#: How far (pixels) each part's front and back reach beyond its outline in the union:
#: two parts' outlines less than twice this apart leave no slot between their fronts.
SKIRT = 0.3
#: How near (pixels) outlines of different parts are made to coincide before the booleans
#: (or, where the parts' slabs do not meet in height, kept half this apart).
SNAP = 1.5
# an outline vertex's copy at the top of the rim's wall lies at most four insets from it
# (farther in at a corner, see rim_wall)
_WALL_REACH = 4.04 * WALL_INSET


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
        warnings += _left_bad(solid)
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
    back_z = np.asarray(back_z, float)
    if (v[:, 2] - back_z <= 0).any():
        raise StageError(f"part {part.name}: the back does not lie below the front")
    vertices, faces = _prism(v, f, back_z)
    return Part(name=part.name, vertices=vertices, faces=faces, closed=True)


def _prism(vertices, faces, z):
    """An open sheet closed by its copy at heights ``z`` (faces reversed) and a wall
    along its outline: the sheet's vertices, then their copies."""
    n = len(vertices)
    a, b = _boundary_edges(faces).T  # edge a -> b as the sheet's faces run it
    # the wall runs the shared edges the other way: b -> a on the sheet, a' -> b' on the copy
    walls = np.concatenate([np.stack([b, a, a + n], 1), np.stack([b, a + n, b + n], 1)])
    copy = np.column_stack([vertices[:, :2], np.broadcast_to(z, (n,))])
    return (np.concatenate([vertices, copy]),
            np.concatenate([faces, faces[:, ::-1] + n, walls]))


def union_parts(parts, *, name="union", remesh=True, skirt=SKIRT, snap=SNAP):
    """One watertight solid over the union of closed parts' outlines.

    Every closed part is a slab over the image plane: over its outline it
    fills ``[back(x, y), front(x, y)]``. The solid fills ``[B, T]`` over the
    union of the outlines, with ``T`` the highest front and ``B`` the lowest
    back of the parts there: the union of the parts where their slabs
    overlap, and the gap filled where a part floats in front of the part
    behind it, so parts whose outlines overlap make one shell. It is built
    with manifold3d's booleans (exact in their topology, coplanar and
    coincident faces decided by symbolic perturbation): the union of every part with
    its back lowered below all parts (the space under ``T``), intersected
    with the union of every part with its front raised above all parts (the
    space over ``B``). Where outlines of different parts nearly meet, the
    cuts would leave a slot or a column of the solid's height under a
    pixel wide, whose slivers no remeshing shapes: every part's front and
    back reach :data:`SKIRT` beyond its outline (the outline's vertices
    moved outward at their own height), then outlines within :data:`SNAP`
    of an earlier part's outline are made to coincide with it exactly
    (vertices moved onto it, its vertices put into them), which the
    booleans decide by symbolic perturbation; where the two parts' slabs do
    not meet in height there (a part floating in front of another) the
    later outline is moved half :data:`SNAP` clear of the other instead, as
    the two would touch along a line, along its whole length (the other's
    vertices that a long edge passes put into it, pushed clear): an overlap
    left between the moved ends would be a column under a pixel wide from
    the lower part's back to the upper part's front. The rims' wall strips
    (:func:`~inkray.relief.inflation.rim_wall`, needles the textured views
    need and a print does not) are merged away first, each outline vertex
    into its copy at the wall's top, at the outline's ``(x, y)``; where that
    solid keeps bad faces after the remeshing, the solid with the strips is
    built too and the one with fewer bad faces kept. With snapping, holes of a part's
    outline smaller than one of the remeshing's triangles (a pipe through
    the solid) are filled. Pieces with under a hundredth of the
    smallest part's volume (splinters, or a part's tip cut off at a neck
    narrower than a pixel) are dropped. Its faces are the parts' own, cut
    where they meet, so it has about as many faces as the parts and follows
    their fronts (within the skirt and the snapping at the rims); only the
    faces around the slivers the cuts leave (and the parts' own) are
    remeshed.

    Parameters
    ----------
    parts : list of Part
        Closed parts, slabs over the image plane (front faces clockwise in
        ``(x, y)``, back faces counter-clockwise, no vertex on both).
    name : str, default "union"
    remesh : bool, default True
        Remesh the faces around those with an angle below :data:`MIN_ANGLE`
        (:func:`remesh_solid`) toward edges as long as the parts' median
        edge (the relief's own resolution).
    skirt : float, default :data:`SKIRT`
        How far (pixels) every part's front and back reach beyond its outline
        at the outline's height: where outlines of different parts run less
        than twice this apart, the booleans would leave a slot or column
        under a pixel wide (slivers no remeshing shapes).
    snap : float, default :data:`SNAP`
        How near (pixels) outlines of different parts are made to coincide
        (or kept apart, where their slabs do not meet in height); 0 also
        keeps small holes. With ``skirt`` and ``snap`` 0 the solid is the
        envelope exactly.

    Returns
    -------
    Part

    Raises
    ------
    StageError
        When a part is not a closed slab.

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
    # a hole smaller than one of the remeshing's triangles is a pipe it cannot shape
    fill = np.sqrt(3.0) / 4.0 * target ** 2 if snap else 0.0
    verts, faces = _envelope_solid(parts, skirt, snap, fill=fill, unwall=True)
    if remesh:
        verts, faces, left = _remeshed_solid(verts, faces, target=target)
        if left:
            # the faces left bad are where outlines nearly meet, and with the rims'
            # walls those places differ: the solid with them, where it is better
            other = _remeshed_solid(*_envelope_solid(parts, skirt, snap, fill=fill),
                                    target=target)
            if other[2] < left:
                verts, faces, _ = other
    return Part(name=name, vertices=verts, faces=faces, closed=True)


def _envelope_solid(parts, skirt, snap=0.0, fill=0.0, unwall=False):
    """The solid ``[B, T]`` over the union of the parts' outlines, each widened by
    ``skirt``, outlines within ``snap`` of each other made to coincide, holes of a
    part's outline under ``fill`` (square pixels) filled, the rims' wall strips merged
    away with ``unwall`` (see union_parts)."""
    z = np.concatenate([np.asarray(p.vertices, float)[:, 2] for p in parts])
    margin = max(1.0, float(np.ptp(z)))
    xy = np.concatenate([np.asarray(p.vertices, float)[:, :2] for p in parts])
    box = xy.min(axis=0), xy.max(axis=0)  # no skirt reaches beyond the parts (the drawing)
    fronts, backs, pairs = [], [], []
    for p in parts:
        v, front, back = _sheets(p)
        if not (len(front) and len(back)):
            raise StageError(f"union: part {p.name} is not a closed slab (a front over a back)")
        fronts.append(_skirted(*_compact(v, front), skirt, box))
        backs.append(_skirted(*_compact(v, back), skirt, box))
        pairs.append(_paired(v, front, back))
    paired = all(x is not None for x in pairs)
    if paired:
        # a front's and its back's outlines kept at the very same (x, y): walls a
        # rounding error apart would be cut into slivers
        reach = _WALL_REACH if unwall else 0.0
        sheets = [_skirted(*_filled(*_unwalled(*x, reach), fill), skirt, box) for x in pairs]
    for join in (True, False):
        if paired:
            snapped = _snapped(sheets, snap, join_covered=join) if snap else sheets
            below = [(s[:, :3], f) for s, f in snapped]
            above = [(s[:, [0, 1, 3]], f[:, ::-1]) for s, f in snapped]
        else:
            below, above = fronts, backs
            if snap:
                below, above = _snapped(fronts, snap), _snapped(backs, snap)
        verts, faces = _booleans(parts, below, above, z.min() - margin, z.max() + margin)
        if not (snap and paired and join and _twins(verts)):
            break
        # two vertices at one position: walls made to coincide under a third part still
        # touch at a point; those places are left as they are
    return verts, faces


def _booleans(parts, fronts, backs, floor, ceiling):
    """The union of the spaces under the ``fronts`` (down to ``floor``) intersected with
    the union of those over the ``backs`` (up to ``ceiling``), less pieces too small to
    be a part. Returns vertices, faces."""
    import manifold3d as m3d

    below = [_manifold(*_prism(*s, floor), p.name) for s, p in zip(fronts, parts)]
    above = [_manifold(*_prism(*s, ceiling), p.name) for s, p in zip(backs, parts)]
    solid = (m3d.Manifold.batch_boolean(below, m3d.OpType.Add)
             ^ m3d.Manifold.batch_boolean(above, m3d.OpType.Add))
    pieces = solid.decompose()
    if len(pieces) > 1:
        # a piece with under a hundredth of the smallest part's volume is no part of
        # the drawing: a splinter the cuts leave where outlines nearly meet, or a tip
        # of a part's triangulation cut off at a neck narrower than a pixel
        least = min(abs(_volume(p.vertices, p.faces)) for p in parts)
        solid = m3d.Manifold.compose([p for p in pieces if p.volume() >= 0.01 * least])
    mesh = solid.to_mesh64()
    verts = np.array(mesh.vert_properties, float)[:, :3]
    return verts, np.array(mesh.tri_verts, np.int64)[:, ::-1]


def _snapped(sheets, reach, *, join_covered=True):
    """Open sheets whose outlines are made to coincide exactly where they run within
    ``reach`` of each other.

    Each sheet in turn: its outline vertices within ``reach`` of an earlier sheet's
    outline move onto it (onto that outline's vertex where the nearest point is within
    half ``reach`` of one), where a neighbour along the outline moves too (two
    outlines meeting at one point would pinch the union), and the earlier outlines'
    vertices within ``reach`` of an edge that moved are put into it; then every
    outline vertex lying on another sheet's outline edge is put into that edge.
    Near-coincident stretches become identical polylines, which the booleans decide
    exactly (symbolic perturbation) rather than leaving a slot or column narrower than
    ``reach`` between them. Sheets with a fourth column (the back's height under the
    front, see ``_paired``) whose heights do not meet the other's there are moved
    half ``reach`` clear of it instead, unless a third sheet covers the place: then
    they coincide too (``join_covered``) or stay; the edges moved clear take the
    other outline's vertices they pass, pushed clear too (``_cleared``), so that a
    long edge beside a curve does not cut across it between its ends. A move or an
    insertion that would fold or flatten a triangle of its sheet (in ``(x, y)``) is
    left out, and so are moves that bring two outline vertices within a twentieth of
    ``reach`` of each other (into a corner of the other outline's offset). Returns the
    list of ``(vertices, faces)``.
    """
    done, outlines = [], []
    rims = [_outline_segments(v, f) for v, f in sheets]
    for v, f in sheets:
        if done:
            a, b = _boundary_edges(f).T
            on = np.unique(a)
            s0, s1, out = (np.concatenate(x) for x in zip(*outlines))
            owner = np.repeat(np.arange(len(outlines)), [len(x[0]) for x in outlines])
            c, dist, seg, t = _closest_on(v[on, :2], s0[:, :2], s1[:, :2], reach)
            found = np.isfinite(dist)
            k = np.maximum(seg, 0)
            # onto a vertex of the other outline when one is near (no edge of a few
            # hundredths of a pixel beside it)
            length = np.linalg.norm(s1[k, :2] - s0[k, :2], axis=1)
            start, end = t * length < 0.5 * reach, (1.0 - t) * length < 0.5 * reach
            q = c.copy()
            q[start], q[end & ~start] = s0[k[start], :2], s1[k[end & ~start], :2]
            apart = np.zeros(len(on), bool)
            if v.shape[1] > 3:
                # slabs whose heights do not meet there (a part floating in front of
                # another) would touch along a line: this outline is kept half
                # ``reach`` clear of the other instead (nothing fills the slot between)
                z = s0[k, 2:] + t[:, None] * (s1[k, 2:] - s0[k, 2:])
                apart = found & ((v[on, 3] > z[:, 0]) | (z[:, 1] > v[on, 2]))
                # where a third part covers the place its slab spans the slot: they are
                # made to coincide (with ``join_covered``) or left as they are
                covered = np.zeros(len(on), bool)
                for m, x in enumerate(rims):
                    third = apart & ~covered & (owner[k] != m)
                    if m != len(done) and third.any():
                        covered[third] = _inside(c[third], x[0][:, :2], x[1][:, :2])
                if not join_covered:
                    found &= ~covered
                apart &= ~covered
                clear = np.einsum("ij,ij->i", v[on, :2] - c, out[k])
                q[apart] = c[apart] + 0.5 * reach * out[k[apart]]
                found &= ~apart | (clear < 0.5 * reach)
            w = np.array(v, float)
            w[on, :2] = np.where(found[:, None], q, w[on, :2])
            snapped = np.zeros(len(v), bool)
            snapped[on[found & ~apart]] = True
            for _ in range(len(on)):  # (undoing a move may fold a triangle, or leave one alone)
                u = _runs(v, _uncrowded(v, _unfolded(v, w, f), on, 0.05 * reach), a, b, snapped)
                if np.array_equal(u, w):
                    break
                w = u
            moved = (w != v).any(axis=1)
            cleared = np.zeros(len(v), bool)
            cleared[on[found & apart]] = True
            v, f = _inserted(w, f, s0[:, :2], reach, clear=0.5 * reach, near=snapped & moved)
            if (cleared & moved).any():
                # an edge whose ends were moved clear can still cut across the other
                # outline between them (a long edge beside a curve): the other's vertices
                # it leaves inside, pushed half ``reach`` out, put into it
                v, f = _cleared(v, f, np.r_[cleared & moved, np.zeros(len(v) - len(w), bool)],
                                (s0, s1, out, owner), reach, rims, len(done))
        done.append((v, f))
        outlines.append(_outline_segments(v, f))
    out = []
    for k, (v, f) in enumerate(done):
        others = [x[0][:, :2] for j, x in enumerate(outlines) if j != k]
        if others:
            # (every outline vertex is the start of one of its edges)
            on = 1e-7 * max(1.0, float(np.abs(v[:, :2]).max()))
            v, f = _inserted(v, f, np.concatenate(others), on, clear=on)
        out.append((v, f))
    return out


def _uncrowded(before, after, on, near):
    """``after`` with the moves of outline vertices ``on`` undone where two of them end
    nearer than ``near`` to each other and than half as far as they were (moved
    together into a corner of the other outline's offset, they would pinch the union)."""
    w = np.array(after, float)
    moved = on[(w[on] != before[on]).any(axis=1)]
    if len(moved) < 2:
        return w
    pairs = on[cKDTree(w[on, :2]).query_pairs(near, output_type="ndarray")].reshape(-1, 2)
    # (two vertices of the part's own triangulation that near each other stay so)
    gap = [np.linalg.norm(x[pairs[:, 0], :2] - x[pairs[:, 1], :2], axis=1) for x in (w, before)]
    pairs = pairs[gap[0] < 0.5 * gap[1]]
    if not len(pairs):
        return w
    crowd = np.unique(pairs)
    crowd = crowd[(w[crowd] != before[crowd]).any(axis=1)]
    w[crowd] = before[crowd]
    return w


def _cleared(vertices, faces, away, others, reach, rims, this):
    """A sheet whose outline edges with an ``away`` end (moved clear of other outlines)
    take the other outlines' vertices that lie inside the sheet beyond such an edge
    (within ``reach`` of it), each pushed half ``reach`` out of its own outline
    (along the mean of the outward normals of its two edges); only where the two
    sheets' slabs do not meet in height and no third sheet's outline (``rims``, this
    one's at index ``this``) covers the place (see ``_snapped``). ``others``: the
    outline edges' starts and ends, outward normals and owners (indices into ``rims``)."""
    s0, s1, out, owner = others
    v = np.asarray(vertices, float)
    edges = _boundary_edges(faces)
    edges = edges[away[edges].any(axis=1)]
    e0, e1 = v[edges[:, 0]], v[edges[:, 1]]
    c, dist, seg, t = _closest_on(s0[:, :2], e0[:, :2], e1[:, :2], reach)
    found = np.isfinite(dist)
    k = np.maximum(seg, 0)
    z = e0[k, 2:] + t[:, None] * (e1[k, 2:] - e0[k, 2:])
    apart = (z[:, 1] > s0[:, 2]) | (s0[:, 3] > z[:, 0])
    mine = _outward(v, faces, edges[:, 0], edges[:, 1])[k]
    inside = np.einsum("ij,ij->i", s0[:, :2] - c, mine) < 0.0
    take = found & apart & inside
    for m, x in enumerate(rims):
        third = take & (owner != m)
        if m != this and third.any():
            take[third] = ~_inside(s0[third, :2], x[0][:, :2], x[1][:, :2])
    if not take.any():
        return v, faces
    # the edge of the same outline that ends at each vertex: the mean of the two normals
    ids = _position_ids(np.column_stack([np.r_[s0[:, :2], s1[:, :2]], np.r_[owner, owner]]))
    ending = np.full(int(ids.max()) + 1, -1)
    ending[ids[len(s0):]] = np.arange(len(s0))
    before = ending[ids[:len(s0)]]
    normal = out + np.where(before[:, None] >= 0, out[np.maximum(before, 0)], out)
    length = np.linalg.norm(normal, axis=1)
    # (at a corner sharper than a right angle "out of the outline" has no one direction)
    take &= length > np.sqrt(2.0)
    normal /= np.maximum(length, 1e-12)[:, None]
    if not take.any():
        return v, faces
    # one point for vertices of two outlines at one place (made to coincide before)
    points, normal = s0[take, :2], normal[take]
    twin = cKDTree(points).query_pairs(0.1 * reach, output_type="ndarray")
    single = np.ones(len(points), bool)
    single[twin.max(axis=1)] = False
    points, normal = points[single], normal[single]
    for _ in range(len(points)):
        w, g, over = _pushed_in(v, faces, edges, points, normal, reach)
        if not over.any():
            return w, g
        # a point pushed across a narrow spike into the sheet beyond: left out
        points, normal = points[~over], normal[~over]
    return v, faces


def _pushed_in(vertices, faces, edges, points, normal, reach):
    """``points`` moved along ``normal`` by half ``reach`` put into the outline
    ``edges``, or by a quarter or a tenth where the fan would fold a triangle (the
    edge's third corner near), each into one edge only. Returns the vertices, the
    faces and which points landed inside a triangle of the sheet they are no corner
    of (the sheet then overlaps itself)."""
    v, f = vertices, faces
    at = np.full(len(points), -1)
    for push in (0.5, 0.25, 0.1):
        todo = np.flatnonzero(at < 0)
        pushed = points[todo] + push * reach * normal[todo]
        n = len(v)
        v, f = _inserted(v, f, pushed, reach, clear=0.5 * reach, only=edges)
        edges = edges[_among(edges, _boundary_edges(f))]
        if len(v) > n:
            same = (pushed[:, None, :] == v[None, n:, :2]).all(axis=2)
            found = same.any(axis=1)
            at[todo[found]] = n + same[found].argmax(axis=1)
        if not len(edges) or (at >= 0).all():
            break
    over = np.zeros(len(at), bool)
    for k in np.flatnonzero(at >= 0).tolist():
        p = v[at[k], :2]
        t = v[f[(f != at[k]).all(axis=1)]][:, :, :2]
        d = [(t[:, (j + 1) % 3, 0] - t[:, j, 0]) * (p[1] - t[:, j, 1])
             - (t[:, (j + 1) % 3, 1] - t[:, j, 1]) * (p[0] - t[:, j, 0]) for j in range(3)]
        over[k] = (((d[0] > 0) & (d[1] > 0) & (d[2] > 0))
                   | ((d[0] < 0) & (d[1] < 0) & (d[2] < 0))).any()
    return v, f, over


def _among(edges, others):
    """Which ``edges`` (vertex pairs, either way round) are among ``others``."""
    keys = _edge_keys(np.concatenate([np.reshape(edges, (-1, 2)), np.reshape(others, (-1, 2))]))
    return np.isin(keys[:len(edges)], keys[len(edges):])


def _outline_segments(vertices, faces):
    """A sheet's outline edges: their start and end vertices (rows of ``vertices``) and
    their outward unit normals in ``(x, y)``."""
    a, b = _boundary_edges(faces).T
    return vertices[a], vertices[b], _outward(vertices, faces, a, b)


def _inside(points, s0, s1):
    """Which ``points`` lie inside the closed outline made of the segments ``s0 -> s1``
    (the even-odd rule)."""
    if not len(points):
        return np.zeros(0, bool)
    px, py = points[:, :1], points[:, 1:]
    x0, y0, x1, y1 = s0[:, 0], s0[:, 1], s1[:, 0], s1[:, 1]
    straddle = (y0 > py) != (y1 > py)
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = x0 + (py - y0) * (x1 - x0) / (y1 - y0)
    return ((straddle & (px < cross)).sum(axis=1) % 2).astype(bool)


def _outward(vertices, faces, a, b):
    """Outward unit normals (in ``(x, y)``) of a sheet's outline edges ``a -> b``."""
    t = vertices[faces][:, :, :2]
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    turn = np.sign((e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum())  # the faces' winding
    d = vertices[b, :2] - vertices[a, :2]
    return turn * np.column_stack([d[:, 1], -d[:, 0]]) / np.linalg.norm(d, axis=1)[:, None]


def _closest_on(points, s0, s1, reach):
    """For each point, the closest point on the segments ``s0 -> s1`` within ``reach``:
    that point, its distance (inf where none is that near), the segment and the
    parameter along it (-1 and nan where none)."""
    from scipy.spatial import cKDTree

    n = len(points)
    q, dist = np.array(points, float), np.full(n, np.inf)
    seg, t = np.full(n, -1), np.full(n, np.nan)
    if not len(s0) or not n:
        return q, dist, seg, t
    half = 0.5 * float(np.linalg.norm(s1 - s0, axis=1).max())
    near = cKDTree(0.5 * (s0 + s1)).query_ball_point(points, reach + half)
    i = np.repeat(np.arange(n), [len(x) for x in near])
    if not len(i):
        return q, dist, seg, t
    j = np.concatenate([np.asarray(x, np.int64) for x in near])
    d = s1[j] - s0[j]
    squared = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    u = np.clip(np.einsum("ij,ij->i", points[i] - s0[j], d) / squared, 0.0, 1.0)
    c = s0[j] + u[:, None] * d
    r = np.linalg.norm(points[i] - c, axis=1)
    order = np.lexsort((r, i))
    first = order[np.r_[True, i[order][1:] != i[order][:-1]]]
    keep = first[r[first] <= reach]
    q[i[keep]], dist[i[keep]], seg[i[keep]], t[i[keep]] = c[keep], r[keep], j[keep], u[keep]
    return q, dist, seg, t


def _runs(before, after, a, b, snapped):
    """``after`` with the move of every ``snapped`` outline vertex undone where neither
    neighbour along the outline ``a -> b`` moved (two outlines meeting at one point
    would pinch the union there)."""
    w = np.array(after, float)
    moved = (w != before).any(axis=1)
    following, preceding = np.arange(len(w)), np.arange(len(w))
    following[a], preceding[b] = b, a
    alone = snapped & moved & ~moved[following] & ~moved[preceding]
    w[alone] = before[alone]
    return w


def _unfolded(before, after, faces, keep=0.05):
    """``after`` with the moves of the corners of every triangle they fold or flatten
    (its area in ``(x, y)`` below ``keep`` of what it was, or of the other sign) undone."""
    a0 = signed_areas(before, faces)
    w = np.array(after, float)
    for _ in range(len(w)):
        bad = signed_areas(w, faces) / np.where(a0 == 0.0, 1.0, a0) < keep
        if not bad.any():
            break
        corners = np.unique(faces[bad])
        w[corners] = before[corners]
    return w


def _inserted(vertices, faces, points, reach, *, clear, near=None, only=None):
    """A sheet with ``points`` (k, 2) within ``reach`` of an outline edge and farther
    than ``clear`` from its ends put into that edge, at heights interpolated along
    it, the edge's triangle split into a fan; an edge whose fan would fold or
    flatten a triangle keeps its points out. With ``near`` (a flag per vertex), only
    edges with a flagged end take points; with ``only`` ((k, 2) vertex pairs), only
    those edges."""
    v = np.asarray(vertices, float)
    edges = _boundary_edges(faces)
    if near is not None:
        edges = edges[near[edges].any(axis=1)]
    if only is not None:
        edges = edges[_among(edges, only)]
    if not len(edges):
        return v, faces
    s0, s1 = v[edges[:, 0], :2], v[edges[:, 1], :2]
    points = np.unique(points, axis=0)
    _, dist, seg, t = _closest_on(points, s0, s1, reach)
    length = np.linalg.norm(s1 - s0, axis=1)[np.maximum(seg, 0)]
    take = np.isfinite(dist) & (t * length > clear) & ((1.0 - t) * length > clear)
    if not take.any():
        return v, faces
    # the triangle along each outline edge and its third corner
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    third = np.concatenate([faces[:, 2], faces[:, 0], faces[:, 1]])
    face = np.tile(np.arange(len(faces)), 3)
    key = {(int(x), int(y)): k for k, (x, y) in enumerate(e.tolist())}
    new_v, new_f, drop = [], [], set()
    count = len(v)
    a0 = signed_areas(v, faces)
    idx = np.flatnonzero(take)
    for s in np.unique(seg[idx]).tolist():
        mine = idx[seg[idx] == s]
        mine = mine[np.argsort(t[mine])]
        a, b = edges[s]
        k = key[(int(a), int(b))]
        if face[k] in drop:
            continue  # (a triangle with two outline edges is split along one)
        c = int(third[k])
        pz = v[a, 2:] + t[mine][:, None] * (v[b, 2:] - v[a, 2:])
        pts = np.column_stack([points[mine], pz])
        chain = [int(a)] + list(range(count, count + len(mine))) + [int(b)]
        fan = np.array([[chain[m], chain[m + 1], c] for m in range(len(chain) - 1)])
        w = np.concatenate([v, *new_v, pts]) if new_v else np.concatenate([v, pts])
        ratio = signed_areas(w, fan) / a0[face[k]]
        if (ratio <= 0.0).any() or (np.abs(ratio) < 1e-9).any():
            continue
        new_v.append(pts)
        new_f.append(fan)
        drop.add(int(face[k]))
        count += len(mine)
    if not new_f:
        return v, faces
    keep = np.ones(len(faces), bool)
    keep[sorted(drop)] = False
    return np.concatenate([v, *new_v]), np.concatenate([faces[keep], *new_f])


def _unwalled(vertices, faces, reach):
    """A sheet without the strip of faces along its outline that the rim's wall adds
    (:func:`~inkray.relief.inflation.rim_wall`): every outline vertex with an inner
    neighbour within ``reach`` (its copy, the wall's top) is merged into that copy,
    which takes the outline vertex's ``(x, y)`` and keeps its own heights; the strip's
    faces vanish. Moves that would fold or flatten a triangle are left out (the copy
    stays inside). Returns vertices, faces (the input where there is no such strip, or
    where removing it would not leave one sheet)."""
    v = np.asarray(vertices, float)
    a, b = _boundary_edges(faces).T
    rim = np.zeros(len(v), bool)
    rim[a] = True
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    e = np.concatenate([e, e[:, ::-1]])
    e = e[rim[e[:, 0]] & ~rim[e[:, 1]]]
    d = np.linalg.norm(v[e[:, 0], :2] - v[e[:, 1], :2], axis=1)
    e, d = e[d < reach], d[d < reach]
    if not len(e):
        return v, faces
    order = np.lexsort((d, e[:, 0]))
    e = e[order][np.r_[True, np.diff(e[order][:, 0]) != 0]]  # the nearest copy of each
    e = e[np.bincount(e[:, 1], minlength=len(v))[e[:, 1]] == 1]  # a copy of one vertex only
    to = np.arange(len(v))
    to[e[:, 0]] = e[:, 1]
    f = to[faces]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])]
    w = v.copy()
    w[e[:, 1], :2] = v[e[:, 0], :2]
    w = _unfolded(v, w, f)
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    if (np.unique(_edge_keys(edges), return_counts=True)[1].max() > 2
            or (np.bincount(_boundary_edges(f)[:, 0]) > 1).any()):
        return v, faces  # (an edge with three faces, or a vertex where loops touch)
    return _compact(w, f)


def _filled(vertices, faces, area):
    """A sheet with the holes of its outline smaller than ``area`` triangulated (no new
    vertex): a pipe through the solid that narrow is no feature the remeshing at the
    relief's resolution can shape."""
    import triangle

    if not area:
        return vertices, faces
    a, b = _boundary_edges(faces).T
    following = dict(zip(a.tolist(), b.tolist()))
    turn = np.sign(signed_areas(vertices, faces).sum())
    seen, added = set(), []
    for start in a.tolist():
        if start in seen:
            continue
        loop = [start]
        while following[loop[-1]] != start and len(loop) <= len(a):
            loop.append(following[loop[-1]])
        seen.update(loop)
        p = vertices[loop, :2]
        signed = 0.5 * float((p[:, 0] * np.roll(p[:, 1], -1)
                              - np.roll(p[:, 0], -1) * p[:, 1]).sum())
        if signed * turn >= 0.0 or abs(signed) >= area or len(loop) < 3:
            continue  # the outer outline (it runs as the faces do), or a large hole
        k = np.arange(len(loop))
        try:
            out = triangle.triangulate(
                {"vertices": p, "segments": np.column_stack([k, np.roll(k, -1)])}, "pQ")
        except RuntimeError:
            continue
        if len(out["vertices"]) != len(loop):
            continue
        tris = np.asarray(loop)[np.asarray(out["triangles"], np.int64)]
        flip = np.sign(signed_areas(vertices, tris)) != turn
        tris[flip] = tris[flip][:, ::-1]
        added.append(tris)
    if not added:
        return vertices, faces
    return vertices, np.concatenate([faces, *added])


def _volume(vertices, faces):
    """The signed volume a closed triangle mesh encloses."""
    t = np.asarray(vertices, float)[np.asarray(faces)]
    return float(np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum()) / 6.0


def _paired(vertices, front, back):
    """A closed slab's front and back sheets as one: its vertices' ``x, y``, front and
    back heights, and the front faces; None unless the back is the front's
    triangulation reversed, vertex for vertex at the same ``(x, y)``."""
    fv, ff = _compact(vertices, front)
    bv, bf = _compact(vertices, back)
    if len(fv) != len(bv) or len(ff) != len(bf):
        return None
    ids = _position_ids(np.concatenate([fv[:, :2], bv[:, :2]]))
    mine, theirs = ids[:len(fv)], ids[len(fv):]
    at = np.full(int(ids.max()) + 1, -1)
    at[mine] = np.arange(len(fv))
    to = at[theirs]
    if len(np.unique(mine)) < len(fv) or (to < 0).any():
        return None
    if not np.array_equal(_rotated(to[bf][:, ::-1]), _rotated(ff)):
        return None
    back_z = np.empty(len(fv))
    back_z[to] = bv[:, 2]
    return np.column_stack([fv, back_z]), ff


def _rotated(faces):
    """Faces each started at its smallest corner (orientation kept), sorted."""
    first = np.argmin(faces, axis=1)
    f = faces[np.arange(len(faces))[:, None], (first[:, None] + np.arange(3)) % 3]
    return f[np.lexsort(f.T[::-1])]


def _skirted(vertices, faces, width, box):
    """A sheet whose outline vertices are moved outward (in ``(x, y)``, at their own
    height) so that every outline edge lies ``width`` beyond where it was (up to twice
    that at a sharp corner, where the move is cut short), kept within ``box`` (the
    lowest and highest ``(x, y)``), except the corners of a triangle the moves would
    fold or flatten. Returns vertices, faces."""
    v = np.array(vertices, float)
    a, b = _boundary_edges(faces).T
    if not width or not len(a):
        return v, faces
    out = _outward(v, faces, a, b)
    miter = np.zeros((len(v), 2))
    np.add.at(miter, a, out)
    np.add.at(miter, b, out)
    into = np.zeros((len(v), 2))
    into[b] = out  # the normal of the edge reaching each outline vertex
    on = np.unique(np.r_[a, b])
    m = miter[on] / np.maximum(np.linalg.norm(miter[on], axis=1), 1e-12)[:, None]
    cos = np.einsum("ij,ij->i", m, into[on])
    w = v.copy()
    w[on, :2] = np.clip(v[on, :2] + m * (width / np.maximum(cos, 0.5))[:, None], *box)
    # a corner's move (up to twice the width at a spike) can pass a vertex beside it
    # and fold a triangle: a sheet crossing itself pinches the booleans' solid, so
    # the corners of a triangle it would fold or flatten stay where they were
    return _unfolded(v, w, faces), faces


def _compact(vertices, faces):
    """The vertices ``faces`` use, and the faces renumbered to them."""
    used, faces = np.unique(faces, return_inverse=True)
    return vertices[used], faces.reshape(-1, 3)


def _manifold(vertices, faces, name):
    """A manifold3d solid from a closed part's mesh (faces reversed: the image's y runs down)."""
    import manifold3d as m3d

    solid = m3d.Manifold(m3d.Mesh64(vert_properties=np.ascontiguousarray(vertices, np.float64),
                                    tri_verts=np.ascontiguousarray(np.asarray(faces)[:, ::-1],
                                                                   np.uint64)))
    if solid.status() != m3d.Error.NoError:
        raise StageError(f"union: part {name} is not a closed manifold ({solid.status().name})")
    return solid


def _sheets(part):
    """A closed part's vertices, front faces (clockwise in (x, y)) and back faces."""
    v = np.asarray(part.vertices, float)
    f = np.asarray(part.faces, np.int64)
    t = v[f][:, :, :2]
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    area = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]  # twice the signed area; walls have none
    return v, f[area < 0], f[area > 0]


def remesh_solid(vertices, faces, *, target, min_angle=MIN_ANGLE, rings=_RINGS,
                 iterations=_ITERATIONS):
    """The faces of a closed solid around its slivers remeshed (PyMeshLab), then repaired.

    Only where a face has an angle below ``min_angle``: those faces and
    ``rings`` rings of faces around them are remeshed (isotropic explicit
    remeshing, selected faces only) toward edges of length ``target``;
    creases sharper than 89 degrees (the steps between parts) are kept as
    features. PyMeshLab is given those faces and one ring around them (left
    as they are) only, as its every iteration visits the whole mesh it gets;
    the result is stitched back at that ring's outer vertices. The remeshing leaves a few slivers along those creases; each
    is then flipped (a cap whose long edge lies in a flat stretch),
    collapsed (a needle's short edge, to whichever of its midpoint and ends
    shapes the triangles around it best) or split (a cap's long edge at the
    foot of its far corner, making two needles), only where this turns no
    face by more than 30 degrees and raises the smallest angle around it (an
    edge shorter than a quarter of the median edge may be collapsed however
    far its faces turn, short of folding one over). The patches around
    faces still bad (an angle below ``min_angle``, or crossing another,
    also once rounded to float32 as files store them) are re-triangulated
    (:func:`~inkray.relief.patches.repair_patches`). Faces crossing another
    are looked for only near the faces that changed: the input is taken to
    cross itself nowhere (as manifold3d's booleans leave it). While faces
    are left bad this runs again (up to 3 rounds) on them, with two more
    rings and twice the iterations each round; the round leaving the fewest
    bad faces is kept, and where it leaves some, every vertex of a face that
    crosses another is moved to the centroid of its neighbours (or halfway)
    where that leaves fewer crossings and no angle below ``min_angle``
    (``_untangle``), and the patches are repaired once more. Where at most
    32 faces are still bad (a column or groove under a pixel across, where
    outlines nearly meet), its walls are cut into ladders
    (:func:`~inkray.relief.patches.ladders`), and each face still bad has any
    of its edges flipped, a corner moved toward its neighbours, or its
    shortest edge collapsed, within a 60 degree turn and only where no more
    faces nearby cross another; the patches are repaired once more. A step
    whose result is not watertight and edge-manifold (or puts two vertices
    at one position) is skipped.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
        A watertight, consistently oriented triangle mesh.
    target : float
        Edge length to aim for (same units as the vertices).
    min_angle : float, default 10
    rings : int, default 2
        Rings of faces remeshed around each sliver in the first round.
    iterations : int, default 4
        Of the first round's remeshing.

    Returns
    -------
    vertices : (n', 3) float array
    faces : (m', 3) int64 array
        The input itself where no face has an angle below ``min_angle``.

    Examples
    --------
    >>> v = np.array([[0., 0, 0], [9, 0, 0], [0, 9, 0], [0, 0, 0.5]])  # a thin tetrahedron
    >>> f = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    >>> w, g = remesh_solid(v, f, target=1.0)
    >>> bool(_min_angles(w, g).min() >= 10.0), _closed_manifold(g)
    (True, True)
    """
    v, f, _ = _remeshed_solid(vertices, faces, target=target, min_angle=min_angle, rings=rings,
                              iterations=iterations)
    return v, f


def _remeshed_solid(vertices, faces, *, target, min_angle=MIN_ANGLE, rings=_RINGS,
                    iterations=_ITERATIONS):
    """:func:`remesh_solid`, and how many faces it leaves bad."""
    v, f = np.asarray(vertices, float), np.asarray(faces, np.int64)
    bad = _min_angles(v, f) < min_angle
    best = (int(bad.sum()), v, f, bad)
    for k in range(_ROUNDS):
        if not bad.any():
            break
        # each round on a wider patch, longer
        w, g = _remesh_around(v, f, bad, target=target, min_angle=min_angle,
                              rings=rings + 2 * k, iterations=iterations * 2 ** k)
        if w is v:
            continue  # nothing kept closed and manifold: the next round, wider
        v, f, bad = _repair(w, g, target=target, min_angle=min_angle,
                            changed=_suspects(v, f, bad, w, g))
        if bad.sum() < best[0]:
            best = (int(bad.sum()), v, f, bad)
    count, v, f, bad = best
    if count:
        # vertices of faces folded through others moved one at a time: slow, so only
        # around the few faces the rounds leave
        w, g, left = _repair(v, f, target=target, min_angle=min_angle, changed=bad,
                             untangle=True)
        if left.sum() < count:
            v, f, bad, count = w, g, left, int(left.sum())
    if 0 < count <= _FEW:
        # a column or a groove under a pixel across, where outlines nearly meet: its walls
        # cut into ladders, the faces at its ends flipped or moved harder
        w, g = ladders(v, f, bad=bad, min_angle=min_angle)
        w, g = _SliverFix(w, g).polish(min_angle)
        if _closed_manifold(g) and _twins(w) <= _twins(v):
            w, g, left = _repair(w, g, target=target, min_angle=min_angle,
                                 changed=_suspects(v, f, bad, w, g))
            if left.sum() < count:
                v, f, count = w, g, int(left.sum())
    return v, f, count


def _remesh_around(v, f, bad, *, target, min_angle, rings, iterations):
    """The ``bad`` faces and ``rings`` rings around them remeshed, then their slivers
    fixed (each step kept where its result is closed and manifold)."""
    chosen = _dilated(f, bad, rings)
    # the remeshing's every iteration visits the whole mesh it is given: give it the
    # chosen faces and a ring left as they are (which keeps the cut's border in place)
    ids = _position_ids(v)
    twin = np.bincount(ids)[ids] > 1
    if twin.any():
        # two vertices at one position (a pinch) are merged by the remeshing, which
        # tears the surface there: the cut keeps a ring clear of the faces around them
        chosen &= ~_dilated(f, twin[f].any(axis=1), 2)
    cut = _dilated(f, chosen, 1)
    used, sub = np.unique(f[cut], return_inverse=True)
    sv, sf = _remeshed(v[used], sub.reshape(-1, 3), chosen[cut], target=target,
                       iterations=iterations)
    nv, nf = _stitched(v, f, cut, sv, sf)
    if nf is None:
        # (the cut's border moved, or two of its vertices at one position): the whole mesh
        nv, nf = _remeshed(v, f, chosen, target=target, iterations=iterations)
    if not _closed_manifold(nf):
        nv, nf = v, f
    fv, ff = _SliverFix(nv, nf).run(min_angle)
    if not _closed_manifold(ff) or _twins(fv) > _twins(v):
        return nv, nf
    return fv, ff


def _stitched(vertices, faces, cut, sub_vertices, sub_faces):
    """The ``cut`` faces replaced by a mesh of them whose border vertices are where they
    were (matched by position, within a rounding error: the remeshing may move one by
    an ulp). Returns vertices and faces, or faces None where the border does not match
    one to one or the result is not closed."""
    v, f = vertices, faces
    inside, outside = np.zeros(len(v), bool), np.zeros(len(v), bool)
    inside[f[cut]], outside[f[~cut]] = True, True
    border = np.flatnonzero(inside & outside)
    if len(sub_vertices) < 2:
        return v, None
    tol = 1e-9 * max(1.0, float(np.abs(v).max()))
    d, at = cKDTree(sub_vertices).query(v[border], k=2)
    if (d[:, 0] > tol).any() or (d[:, 1] <= tol).any() or len(np.unique(at[:, 0])) < len(border):
        return v, None  # a border vertex moved, or two sub vertices (or border ones) at it
    to = np.full(len(sub_vertices), -1)
    to[at[:, 0]] = border
    new = to < 0
    to[new] = len(v) + np.arange(int(new.sum()))
    nf = np.concatenate([f[~cut], to[sub_faces]])
    if not _closed_manifold(nf):
        return v, None
    used, nf = np.unique(nf, return_inverse=True)
    return np.concatenate([v, sub_vertices[new]])[used], nf.reshape(-1, 3).astype(np.int64)


def _twins(vertices):
    """How many vertices share their position with another (counting all but one)."""
    return len(vertices) - int(_position_ids(vertices).max(initial=-1)) - 1


def _dilated(faces, chosen, rings):
    """``chosen`` faces and ``rings`` rings of faces around them (sharing a vertex)."""
    chosen = np.asarray(chosen, bool).copy()
    for _ in range(rings):
        near = np.zeros(int(faces.max()) + 1, bool)
        near[faces[chosen]] = True
        chosen = near[faces].any(axis=1)
    return chosen


def _remeshed(vertices, faces, chosen, *, target, iterations):
    """The ``chosen`` faces remeshed isotropically (PyMeshLab), creases over 89 degrees
    kept. Returns vertices, faces (compacted)."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=vertices, face_matrix=faces.astype(np.int32),
                               f_scalar_array=chosen.astype(float)))
    ms.compute_selection_by_condition_per_face(condselect="fq > 0.5")
    ms.meshing_isotropic_explicit_remeshing(iterations=iterations, selectedonly=True,
                                            targetlen=pymeshlab.PureValue(float(target)),
                                            featuredeg=89.0, checksurfdist=False)
    m = ms.current_mesh()
    m.compact()
    return np.asarray(m.vertex_matrix(), float), np.asarray(m.face_matrix(), np.int64)


def _old_faces(old_vertices, old_faces, vertices, faces):
    """Each face's index among the old ones (compared by their corners' positions), or -1
    where it is new."""
    if len(old_faces) == 0:
        return np.full(len(faces), -1)
    ids = _position_ids(np.concatenate([old_vertices, vertices]))
    old = np.sort(ids[:len(old_vertices)][old_faces], axis=1)
    new = np.sort(ids[len(old_vertices):][faces], axis=1)
    span = int(ids.max()) + 1
    old, new = (x @ np.array([span * span, span, 1]) for x in (old, new))
    order = np.argsort(old, kind="stable")
    at = np.minimum(np.searchsorted(old[order], new), len(old) - 1)
    return np.where(old[order][at] == new, order[at], -1)


def _position_ids(points):
    """One integer per distinct position of ``points`` (n, d)."""
    p = np.ascontiguousarray(points, float) + 0.0  # (-0.0 is 0.0)
    # one sort of a hash of the positions' bits, not one per coordinate
    h = np.zeros(len(p), np.uint64)
    for column in p.view(np.uint64).T:
        h = (h ^ column) * np.uint64(0x9E3779B97F4A7C15)
        h ^= h >> np.uint64(29)
    order = np.argsort(h, kind="stable")
    first = np.r_[True, h[order][1:] != h[order][:-1]]
    q = p[order]
    if (q[1:][~first[1:]] != q[:-1][~first[1:]]).any():
        # two positions with one hash: sorted by their coordinates instead
        order = np.lexsort(p.T[::-1])
        q = p[order]
        first = np.r_[True, (np.diff(q, axis=0) != 0).any(axis=1)]
    ids = np.empty(len(p), np.int64)
    ids[order] = np.cumsum(first) - 1
    return ids


def _left_bad(solid):
    """A warning when the solid keeps slivers or faces crossing others (where three
    parts' outlines meet within a pixel the booleans leave a column the remeshing
    cannot shape): a printer's slicer may have to repair it."""

    v, f = np.asarray(solid.vertices, float), np.asarray(solid.faces, np.int64)
    thin = _min_angles(v, f) < MIN_ANGLE
    if not thin.any():
        return []
    near = _near_faces(v, f, thin)
    crossing = int(self_intersecting_faces(v, f[near]).sum())
    return [f"union: {int(thin.sum())} faces with an angle under {MIN_ANGLE:g} degrees and "
            f"{crossing} crossing another are left where parts' outlines meet within a pixel; "
            f"a slicer may have to repair the solid"]


def _near_faces(vertices, faces, chosen):
    """The ``chosen`` faces and every face whose bounding sphere meets one of theirs (every
    face, when most are chosen)."""
    t = np.asarray(vertices, float)[faces]
    centre = t.mean(axis=1)
    radius = np.linalg.norm(t - centre[:, None], axis=2).max(axis=1)
    near = np.asarray(chosen, bool).copy()
    if near.mean() > 0.5:
        return np.ones(len(near), bool)
    if near.any():
        tree = cKDTree(centre[near])
        reach = radius + radius[near].max()
        near |= tree.query_ball_point(centre, reach, return_length=True) > 0
    return near


def _repair(vertices, faces, *, target, min_angle, changed, untangle=False):
    """The patches around bad faces re-triangulated (after vertices moved off the faces
    they fold through, with ``untangle``). Faces crossing another are looked for in
    pairs with a ``changed`` face only (the others cross none). Returns the vertices, the
    faces and which are left bad."""
    if untangle:
        # the moves change the faces around the vertices moved too
        changed = _near_faces(vertices, faces, changed)
        v, crossing = _untangle(vertices, faces, min_angle=min_angle, near=changed)
    else:
        v, crossing = vertices, None
    bad = _bad_near(v, faces, changed, min_angle=min_angle, crossing=crossing)
    if not bad.any():
        return v, faces, bad
    rv, rf = repair_patches(v, faces, target=target, min_angle=min_angle, bad=bad)
    if not _closed_manifold(rf):
        return v, faces, bad
    return rv, rf, _bad_near(rv, rf, _suspects(v, faces, bad, rv, rf), min_angle=min_angle)


def _suspects(old_vertices, old_faces, old_bad, vertices, faces):
    """The faces that may cross another after a change of a mesh whose faces crossed
    none but its ``old_bad`` ones: those that are new or were bad."""
    old = _old_faces(old_vertices, old_faces, vertices, faces)
    return (old < 0) | old_bad[old]


def _bad_near(vertices, faces, changed, *, min_angle, crossing=None):
    """Faces with an angle below ``min_angle``, and faces crossing another where one of
    the two is ``changed`` (also once rounded to float32, as files store them; those in
    ``crossing`` too)."""
    bad = _min_angles(vertices, faces) < min_angle
    near = _near_faces(vertices, faces, changed)
    hit = crossing_faces(vertices, faces[near], float32_scales=_STORED_SCALES,
                         among=changed[near]).any(axis=0)
    if crossing is not None:
        hit |= crossing[near]
    bad[near] |= hit
    return bad


def _untangle(vertices, faces, *, min_angle, near, rounds=3):
    """Vertices of a mesh moved, one at a time, off the faces they fold through.

    Each vertex of a ``near`` face that crosses another ``near`` face is
    tried at the centroid of its neighbours and halfway there; a move is
    kept when it leaves fewer crossing faces around it and no angle of its
    faces below ``min_angle`` (or below the smallest one there before). Only
    positions change, so the mesh stays as closed and manifold as it was.
    Returns the vertices and which faces still cross another.
    """

    v = np.array(vertices, float)
    f = np.asarray(faces, np.int64)
    n = len(v)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    ring = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n)).tocsr()
    ring = ((ring + ring.T) > 0).tocsr()
    flat = f.ravel()
    order = np.argsort(flat, kind="stable")
    start = np.searchsorted(flat[order], np.arange(n + 1))

    def crossing():
        bad = np.zeros(len(f), bool)
        bad[near] = self_intersecting_faces(v, f[near])
        return bad

    bad = crossing()
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
            near_x = f[np.flatnonzero((flo <= hi).all(axis=1) & (fhi >= lo).all(axis=1))]
            before = int(self_intersecting_faces(v, near_x).sum())
            worst = min(min_angle, float(_min_angles(v, f[around]).min()))
            for p in (centroid, 0.5 * (here + centroid)):
                v[x] = p
                if (self_intersecting_faces(v, near_x).sum() < before
                        and _min_angles(v, f[around]).min() >= worst):
                    moved = True
                    t = v[f[around]]
                    flo[around], fhi[around] = t.min(axis=1), t.max(axis=1)
                    break
                v[x] = here
        if not moved:
            break
        bad = crossing()
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
        self._angles = {}  # each face's smallest angle, dropped when the face changes
        e = self.v[self.f] - self.v[np.roll(self.f, 1, axis=1)]
        self._short = 0.25 * float(np.median(np.linalg.norm(e, axis=2)))

    def run(self, min_angle):
        """Vertices and faces with the slivers fixed where it can be done."""
        for _ in range(self._ROUNDS):
            live = np.flatnonzero(self.alive)
            angles = _min_angles(self.v, self.f[live])
            order = np.argsort(angles, kind="stable")[: int((angles < min_angle).sum())]
            bad = live[order]
            self._angles.update(zip(bad.tolist(), angles[order].tolist()))
            changed = False
            for t in bad.tolist():
                if self.alive[t] and self._angle(t) < min_angle:
                    changed |= self._flip(t) or self._collapse(t) or self._split(t)
            if not changed:
                break
        used, faces = np.unique(self.f[self.alive], return_inverse=True)
        return self.v[used], faces.reshape(-1, 3).astype(np.int64)

    def polish(self, min_angle):
        """Vertices and faces with the faces still bad changed harder: any of a bad face's
        edges flipped (its neighbour's normal and the new faces' within 60 degrees of its
        own), else one of its corners moved to the centroid of its neighbours or halfway
        there (its faces turned by at most 60 degrees), where that raises the smallest
        angle around. For the few faces the rounds leave (the foot and the top of a
        column, where faces meet at a crease the remeshing keeps)."""
        self._min = min_angle
        for _ in range(self._ROUNDS):
            live = np.flatnonzero(self.alive)
            changed = False
            for t in live[_min_angles(self.v, self.f[live]) < min_angle].tolist():
                if self.alive[t] and self._angle(t) < min_angle:
                    changed |= self._uncrossed(
                        t, lambda: self._flip(t, turn=self._WIDE, any_edge=True))
                    changed |= self._uncrossed(t, lambda: self._relax(t))
                    changed |= self._uncrossed(t, lambda: self._collapse(t) or self._split(t))
            if not changed:
                break
        used, faces = np.unique(self.f[self.alive], return_inverse=True)
        return self.v[used], faces.reshape(-1, 3).astype(np.int64)

    _WIDE = 0.5  # cos 60 degrees: the turn polish allows

    def _uncrossed(self, t, change):
        """``change()`` (a flip or a move around face ``t``), undone where it leaves more
        faces near it crossing another (in double precision or once stored as float32)
        than before: a column's walls under a pixel apart are easily pushed through."""
        if not self.alive[t] or self._angle(t) >= self._min:
            return False
        live = np.flatnonzero(self.alive)
        corners = self.f[t]
        reach = 2.0 * max(np.ptp(self.v[corners], axis=0).max(), self._short)
        lo, hi = self.v[corners].min(axis=0) - reach, self.v[corners].max(axis=0) + reach
        box = self.v[self.f[live]]
        near = live[((box.min(axis=1) <= hi) & (box.max(axis=1) >= lo)).all(axis=1)]
        # what a change around t may touch: the faces around its corners' neighbours
        ring = self._ring(set().union(*(self._faces(int(x)) for x in corners)))
        faces = sorted(set().union(*(self._faces(x) for x in ring)))
        ring = sorted(self._ring(faces))
        sizes = len(self.v), len(self.f)
        v, f, alive = self.v[ring].copy(), self.f[faces].copy(), self.alive[faces].copy()
        around = {x: set(self._faces(x)) for x in ring}
        # every face the change moves or adds lies within the box of those faces' corners
        # (a flip, a collapse or a split keeps to them, a move goes to their centroid):
        # only faces reaching into it may cross or stop crossing, so only theirs are counted
        pad = 1e-5 * float(np.abs(self.v).max())  # (and what a rounding to float32 moves)
        lo, hi = self.v[ring].min(axis=0) - pad, self.v[ring].max(axis=0) + pad

        def crossing():
            k = np.r_[near, np.arange(sizes[1], len(self.f))]  # (and the faces a split adds)
            used, g = np.unique(self.f[k[self.alive[k]]], return_inverse=True)
            w, g = self.v[used], g.reshape(-1, 3)
            t = w[g]
            touched = ((t.min(axis=1) <= hi) & (t.max(axis=1) >= lo)).all(axis=1)
            rows = crossing_faces(w, g, float32_scales=_STORED_SCALES, among=touched)[:, touched]
            return int(rows[0].sum()), int(rows.any(axis=0).sum())

        before = crossing()
        if not change():
            return False
        after = crossing()
        if after[0] <= before[0] and after[1] <= before[1]:
            return True
        self.v, self.f, self.alive = self.v[:sizes[0]], self.f[:sizes[1]], self.alive[:sizes[1]]
        self.v[ring], self.f[faces], self.alive[faces] = v, f, alive
        for x in list(self._around):
            if x >= sizes[0]:
                del self._around[x]
        self._around.update(around)
        self._changed(list(faces) + [g for g in self._angles if g >= sizes[1]])
        return False

    def _relax(self, t):
        tri = self.f[t].tolist()
        for x in tri:
            around = sorted(self._faces(x))
            ring = self._ring(around) - {x}
            here = self.v[x].copy()
            before = _normal(self.v[self.f[around]])
            worst = min(self._angle(g) for g in around)
            centroid = self.v[sorted(ring)].mean(axis=0)
            for p in (centroid, 0.5 * (here + centroid)):
                self.v[x] = p
                turned = np.einsum("ij,ij->i", _normal(self.v[self.f[around]]), before)
                if (turned >= self._WIDE).all() and _min_angles(self.v, self.f[around]).min() > worst:
                    self._changed(around)
                    return True
                self.v[x] = here
        return False

    def _faces(self, x):
        """The live faces around vertex ``x`` (a set, updated in place)."""
        if x not in self._around:
            if x + 1 < len(self._start):
                self._around[x] = set((self._order[self._start[x]:self._start[x + 1]] // 3).tolist())
            else:
                self._around[x] = set()
        return self._around[x]

    def _angle(self, t):
        if t not in self._angles:
            self._angles[t] = float(_min_angles(self.v, self.f[[t]])[0])
        return self._angles[t]

    def _changed(self, faces):
        """Faces whose corners moved or changed: their angles are measured again."""
        for g in faces:
            self._angles.pop(g, None)

    def _edge(self, t, longest):
        """Corners ``a, b, c`` of face ``t`` with ``a -> b`` its longest (shortest) edge."""
        tri = self.f[t]
        p = self.v[tri]
        lengths = np.linalg.norm(p - np.roll(p, -1, axis=0), axis=1)
        i = int(np.argmax(lengths) if longest else np.argmin(lengths))
        return int(tri[i]), int(tri[(i + 1) % 3]), int(tri[(i + 2) % 3])

    def _edges(self, t):
        """Corners ``a, b, c`` of face ``t`` for each of its edges ``a -> b``, longest first."""
        tri = self.f[t].tolist()
        p = self.v[tri]
        lengths = np.linalg.norm(p - np.roll(p, -1, axis=0), axis=1)
        return [(tri[i], tri[(i + 1) % 3], tri[(i + 2) % 3]) for i in np.argsort(-lengths).tolist()]

    def _across(self, t, a, b):
        """The other face on edge ``a b`` of ``t`` and its corner off the edge."""
        other = self._faces(a) & self._faces(b) - {t}
        if len(other) != 1:
            return None, None
        u = other.pop()
        return u, int(next(x for x in self.f[u] if x != a and x != b))

    def _flip(self, t, turn=_TURN, any_edge=False):
        n = _normal(self.v[self.f[t]])
        for a, b, c in self._edges(t) if any_edge else [self._edge(t, longest=True)]:
            u, d = self._across(t, a, b)
            if u is None or d == c or self._faces(c) & self._faces(d):
                continue
            new = np.array([[a, d, c], [d, b, c]])
            if (_normal(self.v[self.f[u]]) @ n >= turn and (_normal(self.v[new]) @ n >= turn).all()
                    and _min_angles(self.v, new).min() > min(self._angle(t), self._angle(u))):
                break
        else:
            return False
        self.f[t], self.f[u] = new
        self._changed((t, u))
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
        # the moved faces with the edge's ends at its midpoint, at a, at b: all at once
        points = np.stack([0.5 * (self.v[a] + self.v[b]), self.v[a], self.v[b]])
        tris = np.repeat(self.v[self.f[moved]][None], 3, axis=0)
        ends = np.isin(self.f[moved], (a, b))
        tris[:, ends] = points[:, None]
        folded = (np.einsum("kij,ij->ki", _normal(tris), _normal(self.v[self.f[moved]])) < turn)
        worst = _min_angles(tris.reshape(-1, 3), np.arange(9 * len(moved)).reshape(-1, 3))
        worst = worst.reshape(3, -1).min(axis=1)
        for k in range(3):
            if not folded[k].any() and worst[k] > best:
                best, where = worst[k], points[k].copy()
        if where is None:
            return False
        self._changed(fa | fb)
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

    @staticmethod
    def _appended(array, rows):
        """``array`` with ``rows`` appended: a view of a buffer twice as long as needed
        when it is full (splits add rows one at a time; copying them all each time is
        slow), which a shorter view of it (an undone change) keeps using."""
        n, rows = len(array), np.asarray(rows, array.dtype)
        buffer = array.base
        if buffer is None or len(buffer) < n + len(rows) or buffer.ctypes.data != array.ctypes.data:
            buffer = np.empty((2 * (n + len(rows)),) + array.shape[1:], array.dtype)
            buffer[:n] = array
        buffer[n:n + len(rows)] = rows
        return buffer[:n + len(rows)]

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
        self.v = self._appended(self.v, [foot])
        k = len(self.f)
        self.f = self._appended(self.f, [[m, b, c], [b, m, d]])
        self.alive = self._appended(self.alive, [True, True])
        self.f[t], self.f[u] = [a, m, c], [m, a, d]
        self._changed((t, u))
        self._faces(b).difference_update((t, u))
        self._faces(b).update((k, k + 1))
        self._faces(c).add(k)
        self._faces(d).add(k + 1)
        self._around[m] = {t, u, k, k + 1}
        return True


def _normal(tris):
    """Unit normals of triangles given by their corners (..., 3, 3)."""
    u, w = tris[..., 1, :] - tris[..., 0, :], tris[..., 2, :] - tris[..., 0, :]
    n = np.empty(u.shape)
    n[..., 0] = u[..., 1] * w[..., 2] - u[..., 2] * w[..., 1]
    n[..., 1] = u[..., 2] * w[..., 0] - u[..., 0] * w[..., 2]
    n[..., 2] = u[..., 0] * w[..., 1] - u[..., 1] * w[..., 0]
    return n / np.maximum(np.sqrt((n * n).sum(axis=-1, keepdims=True)), 1e-300)


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
    if len(faces) == 0:
        return False
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    _, inv, counts = np.unique(_edge_keys(e), return_inverse=True, return_counts=True)
    if (counts != 2).any():
        return False
    forward = np.bincount(inv, weights=(e[:, 0] < e[:, 1]).astype(float))
    return bool(np.all(forward == 1))


def _boundary_edges(faces):
    """Directed boundary edges (as the faces run them)."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    _, inv, counts = np.unique(_edge_keys(e), return_inverse=True, return_counts=True)
    return e[counts[inv] == 1]


def _edge_keys(edges):
    """One integer per undirected edge (sorting pairs of rows is several times slower)."""
    e = np.sort(np.asarray(edges, np.int64), axis=1)
    return e[:, 0] * (int(e.max(initial=0)) + 1) + e[:, 1]
