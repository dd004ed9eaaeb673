"""Bad faces of a triangle mesh cut out with a patch around them and re-triangulated.

The last repair of the union solid (:func:`inkray.relief.assembly.remesh_solid`):
where slivers or faces folded through another remain after the remeshing and
its local fixes, the faces within one ring of them (then two, three) are cut
out, projected onto the plane of their mean normal, triangulated anew there
(Triangle, quality and area bounded, the patch's boundary kept as it is) and
lifted back onto the old patch. Thin strips of slivers in one plane (the
walls of a column under a pixel across) are cut into ladders instead
(:func:`ladders`): their long edges split evenly, rungs across. A patch is
replaced only when its new faces
are all well shaped, cross nothing, and fewer faces around it are bad than
before. Boundary vertices keep their positions and the boundary its edges, so
a closed, manifold mesh stays so.
"""

import numpy as np
from scipy.sparse import coo_matrix, diags
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import spsolve

from inkray.numerics.tri_intersection import self_intersecting_faces

__all__ = ["repair_patches", "ladders", "bad_faces", "min_angles"]

_RINGS = (1, 2, 3)  # patch sizes tried, in rings of faces around the bad ones
_STORED_SCALES = (1.0, 0.001)  # pixels, and the mesh files' default units per pixel
_RUNG = 4.0  # a ladder's rungs at most this many times its width apart (14 degrees)


def repair_patches(vertices, faces, *, target, min_angle, bad=None):
    """A mesh with the patches around its bad faces re-triangulated where that helps.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
        Consistently oriented triangles.
    target : float
        Edge length of the new triangles (their area is bounded by an
        equilateral triangle's of this edge).
    min_angle : float
        Faces with a smaller angle (degrees) are bad, as are faces crossing
        another (:func:`bad_faces`).
    bad : (m,) bool array, optional
        The bad faces, when the caller knows them.

    Returns
    -------
    vertices : (n', 3) float array
    faces : (m', 3) int64 array
        Unused vertices dropped; the input back unchanged when no face is bad.

    Examples
    --------
    >>> v = np.array([[0., 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0], [2, 0.05, 0]])
    >>> f = np.array([[0, 4, 3], [4, 1, 2], [4, 2, 3]])  # a sliver at the bottom edge
    >>> w, g = repair_patches(v, f, target=1.0, min_angle=10.0)
    >>> bool(min_angles(w, g).min() >= 10.0), bool(np.abs(w[:, 2]).max() == 0.0)
    (True, True)
    """
    v = np.array(vertices, float)
    f = np.array(faces, np.int64)
    if bad is None:
        bad = bad_faces(v, f, min_angle=min_angle)
    bad = np.asarray(bad, bool).copy()
    if not bad.any():
        return v, f
    alive = np.ones(len(f), bool)
    for rings in _RINGS:
        # again while a pass replaces something: a patch next to one replaced in the
        # same pass waits for the next
        while (bad & alive).any():
            count = len(f)
            v, f, alive, bad = _pass(v, f, alive, bad, rings=rings, target=target,
                                     min_angle=min_angle)
            if len(f) == count:
                break
    used, f = np.unique(f[alive], return_inverse=True)
    return v[used], f.reshape(-1, 3).astype(np.int64)


def _pass(v, f, alive, bad, *, rings, target, min_angle):
    """One pass over the patches ``rings`` faces around the bad ones."""
    live = np.flatnonzero(alive)
    incidence = coo_matrix((np.ones(3 * len(live)), (f[live].ravel(), np.repeat(live, 3))),
                           shape=(len(v), len(f))).tocsr()
    chosen = bad & alive
    for _ in range(rings):
        corners = np.zeros(len(v), bool)
        corners[f[chosen].ravel()] = True
        chosen = np.asarray(incidence[corners].sum(axis=0)).ravel() > 0
    patches = _edge_components(f, np.flatnonzero(chosen))
    t = v[f]
    lo, hi = t.min(axis=1), t.max(axis=1)
    lo[~alive], hi[~alive] = np.inf, -np.inf
    new_v, new_f = [], []
    touched = np.zeros(len(v), bool)
    count = len(v)
    for patch in patches:
        out = _retriangulate(v, f[patch], target=target, min_angle=min_angle)
        if out is None:
            continue
        points, tris = out
        tris = np.where(tris >= len(v), tris - len(v) + count, tris)
        if touched[f[patch]].any() or _adds_existing_edge(incidence, patch, tris, len(v)):
            continue
        w = np.concatenate([v, *new_v, points])
        box_lo, box_hi = w[tris].min(axis=(0, 1)), w[tris].max(axis=(0, 1))
        near = np.flatnonzero((lo <= box_hi).all(axis=1) & (hi >= box_lo).all(axis=1))
        near = np.setdiff1d(near, patch)
        added = np.concatenate(new_f) if new_f else np.zeros((0, 3), np.int64)
        before = int(bad_faces(v, np.concatenate([f[near], f[patch]]), min_angle=min_angle).sum())
        after = bad_faces(w, np.concatenate([f[near], added, tris]), min_angle=min_angle)
        if after[-len(tris):].any() or after.sum() >= before:
            continue
        touched[f[patch].ravel()] = True
        alive[patch] = False
        bad[patch] = False
        lo[patch], hi[patch] = np.inf, -np.inf
        new_v.append(points)
        new_f.append(tris)
        count += len(points)
    if not new_f:
        return v, f, alive, bad
    added = np.concatenate(new_f)
    v = np.concatenate([v, *new_v])
    f = np.concatenate([f, added])
    alive = np.concatenate([alive, np.ones(len(added), bool)])
    bad = np.concatenate([bad, np.zeros(len(added), bool)])
    return v, f, alive, bad


def _edge_components(f, chosen):
    """``chosen`` face indices split into edge-connected pieces."""
    e = np.sort(np.concatenate([f[chosen][:, [0, 1]], f[chosen][:, [1, 2]],
                                f[chosen][:, [2, 0]]]), axis=1)
    _, edge = np.unique(e, axis=0, return_inverse=True)
    rows = np.tile(np.arange(len(chosen)), 3)
    graph = coo_matrix((np.ones(len(rows)), (rows, edge.ravel())),
                       shape=(len(chosen), int(edge.max()) + 1)).tocsr()
    count, label = connected_components(graph @ graph.T, directed=False)
    order = np.argsort(label, kind="stable")
    return np.split(chosen[order], np.cumsum(np.bincount(label, minlength=count))[:-1])


def _adds_existing_edge(incidence, patch, tris, n):
    """Whether a new face joins two old vertices joined outside the patch but not
    along its boundary (that edge would get more than two faces)."""
    e = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    inside = set(patch.tolist())
    for a, b in np.unique(e[(e < n).all(axis=1)], axis=0).tolist():
        around = set(incidence[a].indices.tolist()) & set(incidence[b].indices.tolist())
        if around - inside and not around & inside:
            return True
    return False


def _retriangulate(v, pf, *, target, min_angle):
    """New points and faces (old vertex indices, new points from ``len(v)``) filling
    the boundary of the disk ``pf``, or None where it is not a disk that projects
    onto the plane of its mean normal without folding its boundary."""
    import triangle

    loop = _loop(pf)
    if loop is None:
        return None
    t = v[pf]
    frame = _frame(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]).sum(axis=0))
    if frame is None:
        return None
    origin = v[loop].mean(axis=0)
    poly = (v[loop] - origin) @ frame
    if not _simple(poly):
        return None
    k = np.arange(len(loop))
    area = np.sqrt(3.0) / 4.0 * target ** 2
    # Y: no point on the boundary, which the faces around the patch share
    try:
        tri = triangle.triangulate({"vertices": poly,
                                    "segments": np.column_stack([k, np.roll(k, -1)])},
                                   f"pYQq{max(min_angle, 20.0):g}a{area:.9g}")
    except RuntimeError:  # Triangle gives up on a nearly degenerate patch: the patch stays
        return None
    xy, tris = np.asarray(tri["vertices"], float), np.asarray(tri["triangles"], np.int64)
    if len(xy) < len(loop) or not np.array_equal(xy[:len(loop)], poly):
        return None
    points = _lift(xy, tris, len(loop), v[loop], (t - origin) @ frame, t)
    index = np.concatenate([loop, len(v) + np.arange(len(xy) - len(loop))])
    return points, index[tris]


def _frame(normal):
    """Two unit axes (3, 2) of the plane of ``normal``, right-handed with it; None for
    a zero normal."""
    length = np.linalg.norm(normal)
    if length == 0.0:
        return None
    normal = normal / length
    u = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(normal, u)], axis=1)


def _lift(xy, tris, fixed, boundary, old_xy, old):
    """3D positions of the new points ``xy[fixed:]``: on the old face that alone covers
    one (facing the plane's normal), else harmonic in the new triangulation."""
    new = xy[fixed:]
    pos = np.zeros((len(new), 3))
    known = np.zeros(len(new), bool)
    if len(new):
        a, b, c = old_xy[:, 0], old_xy[:, 1], old_xy[:, 2]
        det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        safe = np.where(det == 0.0, 1.0, det)
        r = new[:, None, :] - a[None]
        l1 = (r[..., 0] * (c[:, 1] - a[:, 1]) - r[..., 1] * (c[:, 0] - a[:, 0])) / safe
        l2 = ((b[:, 0] - a[:, 0]) * r[..., 1] - (b[:, 1] - a[:, 1]) * r[..., 0]) / safe
        bary = np.stack([1.0 - l1 - l2, l1, l2], axis=-1)
        cover = (bary >= -1e-12).all(axis=-1) & (det != 0.0)
        first = cover.argmax(axis=1)
        known = (cover.sum(axis=1) == 1) & (det[first] > 0.0)
        rows = np.arange(len(new))
        pos = np.einsum("ij,ijk->ik", bary[rows, first], old[first])
    every = np.concatenate([boundary, pos])
    free = np.flatnonzero(~np.concatenate([np.ones(fixed, bool), known]))
    if len(free):
        # where the old patch folds (or misses a point), the new points settle between
        # their neighbours
        e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
        e = np.concatenate([e, e[:, ::-1]])
        adjacency = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(len(xy),) * 2).tocsr()
        adjacency.data[:] = 1.0
        laplacian = (diags(np.asarray(adjacency.sum(axis=1)).ravel()) - adjacency).tocsr()
        rest = np.setdiff1d(np.arange(len(xy)), free)
        rhs = -(laplacian[free][:, rest] @ every[rest])
        every[free] = np.asarray(spsolve(laplacian[free][:, free].tocsc(), rhs)).reshape(-1, 3)
    return every[fixed:]


def _loop(faces):
    """The boundary of a disk of faces as one vertex loop (as the faces run it), or None."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    if (counts > 2).any():
        return None
    boundary = e[counts[inverse.ravel()] == 1]
    following = dict(zip(boundary[:, 0].tolist(), boundary[:, 1].tolist()))
    if len(boundary) < 3 or len(following) < len(boundary):
        return None  # a vertex twice on the boundary: not a disk
    loop = [int(boundary[0, 0])]
    while following[loop[-1]] != loop[0] and len(loop) <= len(boundary):
        loop.append(following[loop[-1]])
    # one boundary loop and Euler characteristic 1
    if len(loop) != len(boundary) or len(np.unique(faces)) - len(counts) + len(faces) != 1:
        return None
    return np.array(loop, np.int64)


def _simple(poly):
    """Whether a closed polygon (k, 2) is simple and counter-clockwise."""
    x, y = poly[:, 0], poly[:, 1]
    if (x * np.roll(y, -1) - np.roll(x, -1) * y).sum() <= 0.0:
        return False
    a, b = poly, np.roll(poly, -1, axis=0)
    i, j = np.triu_indices(len(poly), 2)
    keep = ~((i == 0) & (j == len(poly) - 1))  # the last edge meets the first
    i, j = i[keep], j[keep]

    def side(p, q, r):
        return np.sign((q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1])
                       - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0]))

    s1, s2 = side(a[i], b[i], a[j]), side(a[i], b[i], b[j])
    meet = (s1 * s2 <= 0) & (side(a[j], b[j], a[i]) * side(a[j], b[j], b[i]) <= 0)
    # segments on one line meet only where their extents along it overlap
    line = (s1 == 0) & (s2 == 0)
    d = b[i] - a[i]
    lo_i, hi_i = np.zeros(len(i)), np.einsum("ij,ij->i", d, d)
    pa, pb = (np.einsum("ij,ij->i", x - a[i], d) for x in (a[j], b[j]))
    apart = (np.maximum(pa, pb) < lo_i) | (np.minimum(pa, pb) > hi_i)
    return not (meet & ~(line & apart)).any()


def bad_faces(vertices, faces, *, min_angle, crossing=None):
    """Faces with an angle below ``min_angle`` or crossing another, also once rounded.

    A face that only touches another within a rounding error in double
    precision may cross it in a file: PLY and GLB store float32 positions,
    in pixels or scaled (0.001 units per pixel by default). Such faces are
    bad too.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    min_angle : float
        Degrees.
    crossing : (m,) bool array, optional
        Which faces cross another in double precision, when the caller knows.

    Returns
    -------
    (m,) bool array

    Examples
    --------
    >>> v = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5], [6, 5, 5], [5, 5.01, 5]])
    >>> bad_faces(v, np.array([[0, 1, 2], [3, 4, 5]]), min_angle=10.0).tolist()
    [False, True]
    """
    v = np.asarray(vertices, float)
    bad = self_intersecting_faces(v, faces, float32_scales=_STORED_SCALES)
    if crossing is not None:
        bad |= crossing
    return bad | (min_angles(v, faces) < min_angle)


def min_angles(vertices, faces):
    """Smallest angle (degrees) of each triangle.

    Parameters
    ----------
    vertices : (n, 3) float array
        Corner positions.
    faces : (m, 3) int array
        Corner indices of the triangles.

    Returns
    -------
    (m,) float array
        Degrees, per triangle.

    Examples
    --------
    >>> min_angles(np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]])).round(6)
    array([45.])
    """
    t = np.asarray(vertices, float)[np.asarray(faces)]
    d = t[:, [1, 2, 0]] - t
    squared = np.einsum("ijk,ijk->ij", d, d)
    squared.sort(axis=1)
    # the smallest angle lies opposite the shortest edge (law of cosines)
    a, b, c = squared[:, 0], squared[:, 1], squared[:, 2]
    cos = (b + c - a) / np.maximum(2.0 * np.sqrt(b * c), 1e-300)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def ladders(vertices, faces, *, bad, min_angle, flat=15.0):
    """A closed mesh whose thin strips of bad faces are cut into ladders.

    Where the booleans leave a column or a groove under a pixel across, its
    walls are strips ``w`` wide and many times longer, cut into needles by
    any isotropic remeshing. Here each connected set of ``bad`` faces lying in
    one plane (normals within ``flat`` degrees of each other) is a strip: its
    boundary edges longer than :data:`_RUNG` times its width ``w`` across them
    (the faces' smallest height over the edge) are split evenly into pieces at
    most that long, and the strip is triangulated anew between its boundary
    points (constrained Delaunay in its plane, no point inside): rungs ``w``
    long at most :data:`_RUNG` ``w`` apart, every angle at least
    ``atan(1 / _RUNG)`` (14 degrees). A face across a split edge takes its
    points too (triangulated anew alone). A strip whose new faces are no
    better than its old, or that leaves a face it touches worse than
    ``min_angle`` and than it was, is left as it is.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
        A closed, consistently oriented triangle mesh.
    bad : (m,) bool array
        The faces to refine.
    min_angle : float
        Degrees.
    flat : float, default 15
        Largest angle (degrees) between the normals of neighbouring faces of
        one strip.

    Returns
    -------
    vertices : (n', 3) float array
        The input's, then the split points.
    faces : (m', 3) int64 array
        The input itself where no strip is refined.

    Examples
    --------
    >>> v = np.array([[0., 0, 0], [0.5, 0, 0], [0.5, 10, 0], [0, 10, 0]])
    >>> f = np.array([[0, 1, 2], [0, 2, 3]])  # a strip 0.5 wide, 10 long
    >>> w, g = ladders(v, f, bad=np.ones(2, bool), min_angle=10.0)
    >>> len(g), round(float(min_angles(w, g).min()), 1)
    (10, 14.0)
    """
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    bad = np.asarray(bad, bool)
    m = len(f)
    if not bad.any():
        return v, f
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])  # row k: face k % m
    lo, hi = e.min(axis=1), e.max(axis=1)
    _, edge = np.unique(lo * (int(f.max()) + 1) + hi, return_inverse=True)
    edge = edge.ravel()
    order = np.argsort(edge, kind="stable")
    first = np.r_[True, edge[order][1:] != edge[order][:-1]]
    starts = np.flatnonzero(first)
    face_of = np.tile(np.arange(m), 3)
    across = np.full(3 * m, -1)
    pair = np.split(order, starts[1:])
    for rows in pair:
        if len(rows) == 2:
            across[rows[0]], across[rows[1]] = face_of[rows[1]], face_of[rows[0]]
    t = v[f]
    normal = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    area2 = np.linalg.norm(normal, axis=1)
    unit = normal / np.maximum(area2, 1e-300)[:, None]
    length = np.linalg.norm(v[e[:, 1]] - v[e[:, 0]], axis=1)
    height = area2[face_of] / np.maximum(length, 1e-300)  # of each face over each of its edges
    # strips: thin faces (under twice min_angle) joined across edges to thin faces in
    # nearly their plane, with a bad face among them
    thin = bad | (min_angles(v, f) < 2.0 * min_angle)
    k = np.flatnonzero(thin[face_of] & (across >= 0))
    k = k[thin[across[k]] & (np.einsum("ij,ij->i", unit[face_of[k]], unit[across[k]])
                             >= np.cos(np.radians(flat)))]
    graph = coo_matrix((np.ones(len(k)), (face_of[k], across[k])), shape=(m, m))
    _, label = connected_components(graph, directed=False)
    label = np.where(thin & np.isin(label, label[bad]), label, -1)
    bad = label >= 0
    # each boundary edge of a strip split into pieces at most _RUNG times the strip's width
    width = np.full(int(edge.max()) + 1, np.inf)
    rim = bad[face_of] & ((across < 0) | (label[face_of] != label[np.maximum(across, 0)]))
    np.minimum.at(width, edge[rim], height[rim])
    pieces = np.ones(len(width), np.int64)
    split = np.isfinite(width)
    elen = np.zeros(len(width))
    elen[edge] = length
    pieces[split] = np.minimum(np.ceil(elen[split] / (_RUNG * width[split])), 64).astype(np.int64)
    strips = {int(x) for x in np.unique(label[bad])}
    while strips:
        cut = np.zeros(len(pieces), bool)
        rows = np.flatnonzero(np.isin(label[face_of], list(strips)) & (pieces[edge] > 1))
        cut[edge[rows]] = True
        polygons = _ladder_polygons(f, label, strips, cut, edge, face_of)
        points, base = _split_points(v, e, edge, cut, pieces)
        w = np.concatenate([v, points])
        rows = np.flatnonzero(cut[edge])
        which = dict(zip(map(tuple, e[rows].tolist()), edge[rows].tolist()))
        worse, done = set(), []
        for owner, members in polygons:
            loop = _loop(f[members])
            tris = None if loop is None else _fill(w, loop, which, pieces, base, len(v))
            old = float(min_angles(v, f[members]).min())
            new = -1.0 if tris is None else float(min_angles(w, tris).min())
            if owner >= 0 and new <= old or owner < 0 and new < min(old, min_angle):
                # (a strip no better, or a face across its split edges made worse)
                touched = {owner} if owner >= 0 else set(
                    label[across[np.flatnonzero(np.isin(face_of, members) & cut[edge])]].tolist())
                worse |= touched & strips
            done.append((members, tris))
        if not worse:
            break
        strips -= worse
    if not strips:
        return v, f
    keep = np.ones(m, bool)
    for members, _ in done:
        keep[members] = False
    used = np.concatenate([f[keep]] + [tris for _, tris in done])
    return w, used.astype(np.int64)



def _ladder_polygons(f, label, strips, cut, edge, face_of):
    """The polygons to triangulate anew: each strip's faces, and each other face with
    a split edge alone. Returns (strip label or -1, face indices) pairs."""
    out = [(s, np.flatnonzero(label == s)) for s in sorted(strips)]
    mine = np.isin(label, list(strips))
    rows = np.flatnonzero(cut[edge] & ~mine[face_of])
    out += [(-1, np.array([x])) for x in np.unique(face_of[rows]).tolist()]
    return out


def _split_points(v, e, edge, cut, pieces):
    """The points splitting each ``cut`` edge evenly (from its lower vertex index to its
    higher), and where each edge's points start among them."""
    base = np.full(len(pieces), -1)
    points = []
    count = 0
    ends = np.zeros((len(pieces), 2), np.int64)
    ends[edge] = np.sort(e, axis=1)
    for x in np.flatnonzero(cut).tolist():
        a, b = ends[x]
        s = np.arange(1, pieces[x])[:, None] / pieces[x]
        points.append(v[a] + s * (v[b] - v[a]))
        base[x] = count
        count += pieces[x] - 1
    return (np.concatenate(points) if points else np.zeros((0, 3))), base


def _fill(w, loop, which, pieces, base, n):
    """Triangles (indices into ``w``) filling a polygon: its boundary ``loop`` with the
    split points of its edges (``which``: the split edge of a vertex pair), constrained
    Delaunay in its mean plane; None where it does not project onto that plane as a
    simple polygon or would get a point inside."""
    import triangle

    ring = []
    for a, b in zip(loop.tolist(), np.roll(loop, -1).tolist()):
        ring.append(a)
        x = which.get((a, b), which.get((b, a)))
        if x is not None:
            ids = n + base[x] + np.arange(pieces[x] - 1)
            ring += (ids if a < b else ids[::-1]).tolist()
    ring = np.array(ring)
    p = w[ring]
    centred = p - p.mean(axis=0)
    frame = _frame(np.cross(centred, np.roll(centred, -1, axis=0)).sum(axis=0))
    if frame is None:
        return None
    poly = centred @ frame
    if not _simple(poly):
        return None
    k = np.arange(len(ring))
    try:
        out = triangle.triangulate(
            {"vertices": poly, "segments": np.column_stack([k, np.roll(k, -1)])}, "pYQ")
    except RuntimeError:
        return None
    if len(out["vertices"]) != len(ring) or "triangles" not in out:
        return None
    return ring[np.asarray(out["triangles"], np.int64)]
