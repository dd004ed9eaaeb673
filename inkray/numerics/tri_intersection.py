"""Self-intersections of a triangle mesh, tested exactly in double precision.

Candidate pairs come from a uniform grid over the faces' bounding boxes
(or only its cells that a given set of faces reaches, when the rest of the
mesh is known to cross nothing); each pair is tested with the separating axis theorem (two triangles are
disjoint exactly when their projections on one of 17 axes - the two
normals, the nine cross products of their edges and the six in-plane edge
normals, which separate coplanar triangles - do not overlap). Faces sharing
an edge are never counted (they meet along it); faces sharing one vertex
are tested shrunk a little toward their centroids, so touching at the
shared corner does not count but a fold over it does.
"""

import numpy as np

__all__ = ["self_intersecting_faces", "crossing_faces"]

_SHRINK = 1e-6  # relative shrink of faces that share a corner
_CHUNK = 200_000  # pairs tested at once (memory)


def self_intersecting_faces(vertices, faces, *, float32_scales=(), among=None):
    """Which faces cross or touch another face they share no edge with.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    float32_scales : sequence of float, default ()
        Also the faces that cross once the positions are multiplied by each of
        these and rounded to float32 (as files store them): faces touching
        within a rounding error may cross there. The candidate pairs are found
        once for all of them.
    among : (m,) bool array, optional
        Only pairs with at least one of these faces are tested: the others
        are reported only where they cross one of these (see
        :func:`crossing_faces`).

    Returns
    -------
    (m,) bool array

    Examples
    --------
    >>> import numpy as np
    >>> v = np.array([[0., 0, 0], [2, 0, 0], [0, 2, 0], [0.5, 0.5, -1], [0.5, 0.5, 1], [3, 3, 1]])
    >>> self_intersecting_faces(v, np.array([[0, 1, 2], [3, 4, 5]])).tolist()
    [True, True]
    >>> apart = v + np.repeat([[0.0, 0, 0], [5, 0, 0]], 3, axis=0)
    >>> self_intersecting_faces(apart, np.array([[0, 1, 2], [3, 4, 5]])).tolist()
    [False, False]
    """
    return crossing_faces(vertices, faces, float32_scales=float32_scales, among=among).any(axis=0)


def crossing_faces(vertices, faces, *, float32_scales=(), among=None):
    """Which faces cross or touch another, in double precision and once rounded, apart.

    :func:`self_intersecting_faces` with one row per precision: a caller that
    weighs crossings in double precision against those a file's float32
    positions add finds the candidate pairs once.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    float32_scales : sequence of float, default ()
        Scales at which the positions are also rounded to float32.
    among : (m,) bool array, optional
        Only pairs with at least one of these faces are tested (a face's
        row is then exact for these faces; another face is marked only where
        it crosses one of them). The cost grows with the faces near these,
        not with the mesh.

    Returns
    -------
    (1 + len(float32_scales), m) bool array
        Row 0 in double precision, then one row per scale.

    Examples
    --------
    >>> import numpy as np
    >>> v = 1000.0 + np.array([[0., 0, 0], [2, 0, 0], [0, 2, 0],  # a corner 1e-9 off the plane
    ...                        [0.5, 0.5, -1e-9], [0.5, 0.5, -1], [1, 0.5, -1]])
    >>> f = np.array([[0, 1, 2], [3, 4, 5]])
    >>> crossing_faces(v, f, float32_scales=(1.0,)).tolist()
    [[False, False], [True, True]]
    >>> crossing_faces(v, f, float32_scales=(1.0,), among=np.array([False, False])).tolist()
    [[False, False], [False, False]]
    """
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    out = np.zeros((1 + len(float32_scales), len(f)), bool)
    if len(f) < 2:
        return out
    # the positions are centred on all the vertices' box (rounding is monotonic, so the
    # rounded box is the box rounded), but only those of the faces are rounded
    low, high = v.min(axis=0), v.max(axis=0)
    used, f = np.unique(f, return_inverse=True)
    v, f = v[used], f.reshape(-1, 3)
    variants = [(v, 0.5 * (low + high))]
    for s in float32_scales:
        low_s, high_s = (_rounded(x * s) for x in (low, high))
        variants.append((_rounded(v * s), 0.5 * (low_s + high_s)))
    # the boxes widened by more than a rounding to float32 moves a corner (2^-24 of it)
    margin = 1e-6 * float(np.maximum(-low, high).max()) if float32_scales else 0.0
    t = v[f]
    lo, hi = t.min(axis=1), t.max(axis=1)
    a, b = _candidate_pairs(lo - margin, hi + margin,
                            None if among is None else np.asarray(among, bool))
    fa, fb = f[a], f[b]
    shared = sum((fa[:, i] == fb[:, j]).astype(np.int64) for i in range(3) for j in range(3))
    a, b, shared = a[shared < 2], b[shared < 2], shared[shared < 2]
    # boxes apart in double precision cannot meet there
    tight = np.ones(len(a), bool)
    for axis in range(3):
        tight &= (lo[a, axis] <= hi[b, axis]) & (lo[b, axis] <= hi[a, axis])
    # each face as it is, then shrunk (for the pairs sharing a corner): index + len(f)
    a, b = a + len(f) * (shared == 1), b + len(f) * (shared == 1)
    for row, (w, centre) in enumerate(variants):
        w = w - centre  # digits where the faces differ
        t = w[f]
        t = np.concatenate([t, _shrunk(t)])
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        i, j = (a[tight], b[tight]) if row == 0 else (a, b)
        for s in range(0, len(i), _CHUNK):
            hit = _meet(t, n, i[s:s + _CHUNK], j[s:s + _CHUNK])
            out[row, i[s:s + _CHUNK][hit] % len(f)] = True
            out[row, j[s:s + _CHUNK][hit] % len(f)] = True
    return out


def _meet(t, n, i, j):
    """Whether triangles ``t[i]`` and ``t[j]`` (normals ``n``) meet."""
    ti, tj = t[i], t[j]
    near = _straddle(ti, tj, n[i]) & _straddle(tj, ti, n[j])
    hit = np.zeros(len(i), bool)
    hit[near] = _overlap(ti[near], tj[near])
    return hit


def _rounded(x):
    return x.astype(np.float32).astype(float)


def _shrunk(t):
    c = t.mean(axis=1, keepdims=True)
    return c + (1.0 - _SHRINK) * (t - c)


def _candidate_pairs(lo, hi, among=None):
    """Pairs ``a < b`` of boxes ``[lo, hi]`` that overlap (with at least one box ``among``)."""
    cell = max(float(np.median((hi - lo).max(axis=1))), 1e-12)
    ilo = np.floor(lo / cell).astype(np.int64)
    ihi = np.floor(hi / cell).astype(np.int64)
    span = ihi - ilo + 1
    count = span.prod(axis=1)
    face = np.repeat(np.arange(len(lo)), count)
    k = np.arange(len(face)) - np.repeat(np.cumsum(count) - count, count)  # index within a face
    sx, sy = span[face, 0], span[face, 1]
    cell_of = np.stack([ilo[face, 0] + k % sx, ilo[face, 1] + (k // sx) % sy,
                        ilo[face, 2] + k // (sx * sy)], axis=1)
    c = cell_of - cell_of.min(axis=0)
    size = c.max(axis=0) + 1
    key = (c[:, 0] * size[1] + c[:, 1]) * size[2] + c[:, 2]  # one integer per cell
    if among is not None:
        # only the cells a box among them reaches
        hot = np.isin(key, key[among[face]])
        key, face, cell_of = key[hot], face[hot], cell_of[hot]
    order = np.argsort(key * len(lo) + face)  # by cell, then by face
    key, face, cell_of = key[order], face[order], cell_of[order]
    end = np.searchsorted(key, key, side="right")
    later = end - np.arange(len(key)) - 1  # members of the same cell after this one
    first = np.repeat(np.arange(len(key)), later)
    second = first + 1 + np.arange(len(first)) - np.repeat(np.cumsum(later) - later, later)
    a, b = face[first], face[second]
    if among is not None:
        keep = among[a] | among[b]
        first, a, b = first[keep], a[keep], b[keep]
    keep = np.ones(len(a), bool)
    for axis in range(lo.shape[1]):  # (a column at a time: reductions over rows of 3 are slow)
        la, lb = lo[a, axis], lo[b, axis]
        keep &= (la <= hi[b, axis]) & (lb <= hi[a, axis])
        # a pair shares every cell its boxes' overlap spans: kept in the overlap's lowest one
        keep &= np.floor(np.maximum(la, lb) / cell).astype(np.int64) == cell_of[first, axis]
    return a[keep], b[keep]


def _straddle(p, q, n):
    """Whether triangles ``q`` touch the planes of triangles ``p`` (normals ``n``): a cheap
    rejection."""
    d = np.einsum("kij,kj->ki", q - p[:, :1], n)
    return (_least(d) <= 0) & (_most(d) >= 0)


def _least(x):
    """Smallest of each row's three entries (a reduction over so short an axis is slow)."""
    return np.minimum(np.minimum(x[:, 0], x[:, 1]), x[:, 2])


def _most(x):
    return np.maximum(np.maximum(x[:, 0], x[:, 1]), x[:, 2])


def _overlap(p, q):
    """Separating-axis test of triangle pairs ``p, q`` (k, 3, 3): True where they meet."""
    ep = np.roll(p, -1, axis=1) - p
    eq = np.roll(q, -1, axis=1) - q
    np_ = np.cross(ep[:, 0], ep[:, 1])
    nq = np.cross(eq[:, 0], eq[:, 1])
    axes = [np_, nq]
    axes += [np.cross(ep[:, i], eq[:, j]) for i in range(3) for j in range(3)]
    axes += [np.cross(np_, ep[:, i]) for i in range(3)] + [np.cross(nq, eq[:, i]) for i in range(3)]
    scale = np.maximum(np.abs(ep).max(axis=(1, 2)), np.abs(eq).max(axis=(1, 2)))
    meet = np.ones(len(p), bool)
    for axis in axes:
        norm = np.linalg.norm(axis, axis=1)
        usable = norm > 1e-12 * scale ** 2  # (parallel edges give no axis)
        u = axis / np.maximum(norm, 1e-300)[:, None]
        sp = np.einsum("kij,kj->ki", p, u)
        sq = np.einsum("kij,kj->ki", q, u)
        apart = (_most(sp) < _least(sq)) | (_most(sq) < _least(sp))
        meet &= ~(apart & usable)
    return meet
