"""Quadtree fill: the harmonic fill solved on a reduced system of quadtree blocks.

The weighted Laplace fill of :mod:`inkray.numerics.harmonic_fill` (free
pixels minimize ``sum w_pq (d_p - d_q)^2`` given the known ones) is smooth
wherever no weak edge (ink) or known pixel lies near. As in Agarwala,
"Efficient gradient-domain compositing using quadtrees" (SIGGRAPH 2007),
the unknowns are kept at full resolution only near those, and the rest of
the grid is covered by square blocks (sizes 2 to ``max_block``, aligned,
larger farther away) whose pixels are bilinear in the block's four corner
nodes (the pixel ``(r0 + i, c0 + j)`` of a block of size ``s`` at ``(r0,
c0)`` weighs the corners at ``r0, r0 + s`` and ``c0, c0 + s`` by ``i/s`` and
``j/s``). With ``P`` that interpolation from the reduced unknowns to the free
pixels, the Galerkin system ``P^T A P u = P^T b`` (``A`` the Laplacian of the
free pixels, ``b`` their couplings to the known ones) gives the fill with
the least energy the blocks can express, which keeps the near-null modes of
areas closed by ink (their outlines stay at full resolution). A corner of a
small block that falls inside a larger block is an unknown of its own, so
the blocks need not match along their sides; the energy is always summed
over the real pixel edges. Fields that are bilinear over each block, such as
a linear ramp over uniform weights, are reproduced exactly.

The block's own edges enter through three weighted moments per direction
(closed form), the others (between blocks and at full resolution) through
the interpolation matrix; the system is factored by
:func:`inkray.numerics.spd.spd_factor`.
"""

import numpy as np
import scipy.sparse as sp
from scipy import ndimage

from inkray.errors import InputError
from inkray.numerics.spd import nested_dissection_of_edges, spd_factor

__all__ = ["quadtree_fill", "quadtree_blocks"]


def quadtree_fill(wx, wy, known, values, *, weak=0.1, band=1, max_block=64):
    """The harmonic fill of the unknown pixels, on quadtree blocks away from ink.

    Parameters
    ----------
    wx : (H, W-1) float array
        Positive weights between ``(y, x)`` and ``(y, x+1)``.
    wy : (H-1, W) float array
        Positive weights between ``(y, x)`` and ``(y+1, x)``.
    known : (H, W) bool array
        The pixels whose values are given (at least one).
    values : (H, W) float array
        Read on the known pixels only.
    weak : float, default 0.1
        Edges below this weight (ink) keep their pixels at full resolution.
    band : int, default 1
        Pixels within this chessboard distance of a known pixel or a weak
        edge stay at full resolution.
    max_block : int, default 64
        The largest block's side (a power of two, at least 2).

    Returns
    -------
    (H, W) float64 array
        ``values`` on the known pixels, the reduced system's fill elsewhere.

    Examples
    --------
    >>> import numpy as np
    >>> known = np.zeros((40, 50), bool); known[:, [0, -1]] = True
    >>> ramp = np.tile(np.linspace(0.0, 1.0, 50), (40, 1))
    >>> d = quadtree_fill(np.ones((40, 49)), np.ones((39, 50)), known, np.where(known, ramp, 0))
    >>> bool(np.abs(d - ramp).max() < 1e-9)          # bilinear blocks hold a ramp exactly
    True
    """
    wx, wy, known, values = _checked(wx, wy, known, values)
    h, w = known.shape
    out = np.where(known, values, 0.0)
    free = ~known
    if not free.any():
        return out
    blocks = quadtree_blocks(wx, wy, known, weak=weak, band=band, max_block=max_block)
    owner = _owner(blocks, (h, w))
    nodes, n_free = _nodes(blocks, owner, known)
    n = n_free + nodes.known_pixels.size
    pairs, mixed = _edge_energy(wx, wy, blocks, owner, nodes, known, n)
    entries = [_block_energy(wx, wy, blocks, nodes, (h, w)), *mixed]
    i, j, v = (np.concatenate([e[k] for e in entries]) for k in range(3))
    A, rhs, order = _ordered_system(pairs, (i, j, v), n_free, out.ravel()[nodes.known_pixels],
                                    nodes)
    u = np.empty(n_free)
    # SuperLU finds these systems well scaled (the same factor either way)
    u[order] = spd_factor(A, ordered=True, equilibrate=False).solve(rhs)
    return _interpolated(u, blocks, nodes, owner, out)


def quadtree_blocks(wx, wy, known, *, weak=0.1, band=1, max_block=64):
    """The blocks of :func:`quadtree_fill`: ``(r0, c0, s)`` arrays, largest first.

    A pixel is a detail when it is known or has an edge below ``weak``; an
    aligned ``s x s`` tile of the grid is a block when every pixel in it is
    farther than ``band + s // 2`` (chessboard) from every detail and no
    larger block holds it. The pixels of no block stay at full resolution.

    Parameters
    ----------
    wx, wy, known, weak, band, max_block
        As for :func:`quadtree_fill`.

    Returns
    -------
    r0, c0, s : (B,) int64 arrays
        Top-left pixels and sides of the blocks.

    Examples
    --------
    >>> import numpy as np
    >>> known = np.zeros((64, 64), bool); known[:, 0] = True
    >>> r0, c0, s = quadtree_blocks(np.ones((64, 63)), np.ones((63, 64)), known, max_block=16)
    >>> int(s.max()), bool((c0 > 0).all())
    (16, True)
    """
    wx, wy, known, _ = _checked(wx, wy, known, np.zeros(np.shape(known)))
    if max_block < 2 or max_block & (max_block - 1):
        raise InputError(f"max_block: expected a power of two of at least 2, got {max_block}")
    if band < 0:
        raise InputError(f"band: expected a distance of at least 0, got {band}")
    h, w = known.shape
    detail = known.copy()
    for weights, axis in ((wx < weak, 1), (wy < weak, 0)):
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        detail[tuple(lo)] |= weights
        detail[tuple(hi)] |= weights
    if detail.all():
        empty = np.zeros(0, np.int64)
        return empty, empty, empty
    # Distance to the nearest detail, 0 on the details (and off the grid's tiles).
    dist = ndimage.distance_transform_cdt(~detail, metric="chessboard")
    # The nearest detail of every aligned tile of each size, by 2x2 minima of the
    # next smaller size's (a tile of size s is four of size s / 2).
    nearest = {1: dist}
    s = 2
    while s <= max_block:
        th, tw = h // s, w // s
        if not (th and tw):
            break
        m = nearest[s // 2][:2 * th, :2 * tw]
        nearest[s] = np.minimum(np.minimum(m[0::2, 0::2], m[0::2, 1::2]),
                                np.minimum(m[1::2, 0::2], m[1::2, 1::2]))
        s *= 2
    found = []
    taken = None  # the tiles of the size at hand inside a larger block (aligned: all or none)
    s = max_block
    while s >= 2:
        th, tw = h // s, w // s
        if s in nearest:
            free = nearest[s] > band + s // 2
            if taken is not None:
                free &= ~taken
            rows, cols = np.nonzero(free)
            if len(rows):
                found.append((rows * s, cols * s, np.full(len(rows), s)))
            inside = free if taken is None else free | taken
            taken = np.zeros((h // (s // 2), w // (s // 2)), bool)
            taken[:2 * th, :2 * tw] = inside.repeat(2, axis=0).repeat(2, axis=1)
        s //= 2
    if not found:
        empty = np.zeros(0, np.int64)
        return empty, empty, empty
    return tuple(np.concatenate([f[k] for f in found]).astype(np.int64) for k in range(3))


class _Nodes:
    """The reduced system's variables: ``index`` over the corner lattice ``(H+1, W+1)``
    (-1 where none), the unknowns first; the unknowns' lattice positions
    ``unknown_rows, unknown_cols``; ``known_pixels`` the raster indices of the
    known pixels, in the order of the variables after the unknowns."""

    def __init__(self, index, unknown_rows, unknown_cols, known_pixels):
        self.index = index
        self.unknown_rows, self.unknown_cols = unknown_rows, unknown_cols
        self.known_pixels = known_pixels


def _checked(wx, wy, known, values):
    wx, wy = np.asarray(wx, np.float64), np.asarray(wy, np.float64)
    known = np.asarray(known, bool)
    values = np.asarray(values, np.float64)
    if wx.ndim != 2 or wy.ndim != 2 or wx.shape[0] != wy.shape[0] + 1 or \
            wy.shape[1] != wx.shape[1] + 1:
        raise InputError(f"wx, wy: expected shapes (H, W-1) and (H-1, W), got "
                         f"{wx.shape} and {wy.shape}")
    shape = (wy.shape[0] + 1, wx.shape[1] + 1)
    if known.shape != shape or values.shape != shape:
        raise InputError(f"known, values: expected shape {shape}, got {known.shape} and "
                         f"{values.shape}")
    if not (wx > 0).all() or not (wy > 0).all():
        raise InputError("wx, wy: expected positive edge weights")
    if not known.any():
        raise InputError("known: expected at least one known pixel (the fill is otherwise "
                         "undetermined)")
    return wx, wy, known, values


def _owner(blocks, shape):
    """The block of each pixel, -1 for the pixels at full resolution."""
    owner = np.full(shape, -1, np.int64)
    r0, c0, s = blocks
    for size in np.unique(s):
        k = np.flatnonzero(s == size)
        i, j = np.mgrid[0:size, 0:size]
        owner[r0[k, None, None] + i, c0[k, None, None] + j] = k[:, None, None]
    return owner


def _corners(blocks):
    """Lattice positions (rows, cols) of each block's corners, (B, 4) each, in the
    order top-left, top-right, bottom-left, bottom-right."""
    r0, c0, s = blocks
    rows = np.stack([r0, r0, r0 + s, r0 + s], axis=1)
    cols = np.stack([c0, c0 + s, c0, c0 + s], axis=1)
    return rows, cols


def _nodes(blocks, owner, known):
    """The variables: every free pixel at full resolution, every block corner that is
    neither such a pixel nor a known one, then the known pixels next to a free pixel
    or at a corner. Returns the :class:`_Nodes` and the number of unknowns."""
    h, w = known.shape
    lattice = np.zeros((h + 1, w + 1), np.int8)  # 1 unknown, 2 known
    lattice[:h, :w][~known & (owner < 0)] = 1
    rows, cols = _corners(blocks)
    inside = (rows < h) & (cols < w)
    corner_known = np.zeros(rows.shape, bool)
    corner_known[inside] = known[rows[inside], cols[inside]]
    lattice[rows[~corner_known], cols[~corner_known]] = 1
    cross = ndimage.generate_binary_structure(2, 1)
    near = known & ndimage.binary_dilation(~known, structure=cross)
    lattice[:h, :w][near] = 2
    lattice[rows[corner_known], cols[corner_known]] = 2
    index = np.full((h + 1) * (w + 1), -1, np.int64)
    flat = lattice.ravel()
    unknown = np.flatnonzero(flat == 1)
    given = np.flatnonzero(flat == 2)
    index[unknown] = np.arange(len(unknown))
    index[given] = len(unknown) + np.arange(len(given))
    uy, ux = np.divmod(unknown, w + 1)
    gy, gx = np.divmod(given, w + 1)
    return _Nodes(index.reshape(h + 1, w + 1), uy, ux, gy * w + gx), len(unknown)


def _ordered_system(pairs, entries, n_free, known_values, nodes):
    """The unknowns' system ``(A, rhs, order)``: ``A`` (CSC) and ``rhs`` in the
    nested-dissection ``order`` of the unknowns, so that ``u[order] = A^-1 rhs``.

    ``pairs`` ``(a, b, w)`` are edges between two variables (at most one end
    known), each once: the Laplacian's off-diagonal ``-w`` and ``w`` on both
    diagonals; ``entries`` ``(i, j, v)`` are symmetric matrix entries. The
    variables are the unknowns first, then the known pixels of value
    ``known_values``. The entries are compressed once, in that order;
    duplicates add up.
    """
    a, b, w = pairs
    i, j, v = entries
    n = n_free + len(known_values)
    # the diagonal of the pairs, the unknowns' couplings to known values as the rhs
    diagonal = np.bincount(a, weights=w, minlength=n) + np.bincount(b, weights=w, minlength=n)
    rhs = np.zeros(n_free)
    for p, q, x in ((a, b, w), (b, a, w), (i, j, -v)):
        coupled = (p < n_free) & (q >= n_free)
        rhs += np.bincount(p[coupled], weights=x[coupled] * known_values[q[coupled] - n_free],
                           minlength=n_free)
    inner = (a < n_free) & (b < n_free)
    a, b, w = a[inner], b[inner], w[inner]
    inner = (i < n_free) & (j < n_free)
    i, j, v = i[inner], j[inner], v[inner]
    upper = i < j
    order = nested_dissection_of_edges(np.concatenate([a, i[upper]]),
                                       np.concatenate([b, j[upper]]),
                                       nodes.unknown_rows, nodes.unknown_cols)
    rank = np.empty(n_free, np.int32)
    rank[order] = np.arange(n_free, dtype=np.int32)
    ra, rb = rank[a], rank[b]
    A = sp.csc_matrix((np.concatenate([-w, -w, v, diagonal[:n_free]]),
                       (np.concatenate([ra, rb, rank[i], rank]),
                        np.concatenate([rb, ra, rank[j], rank]))), shape=(n_free, n_free))
    return A, rhs[order], order


def _slots(y, x, blocks, owner, nodes):
    """Each pixel's value as a combination of variables: (n, 4) variable indices and
    (n, 4) coefficients (a full-resolution or known pixel is its own variable)."""
    var = np.zeros((len(y), 4), np.int64)
    coef = np.zeros((len(y), 4))
    k = owner[y, x]
    single = k < 0
    var[single, 0] = nodes.index[y[single], x[single]]
    coef[single, 0] = 1.0
    inb = ~single
    kb = k[inb]
    r0, c0, s = (b[kb] for b in blocks)
    a = (y[inb] - r0) / s
    b = (x[inb] - c0) / s
    rows, cols = _corners((r0, c0, s))
    var[inb] = nodes.index[rows, cols]
    coef[inb] = np.stack([(1 - a) * (1 - b), (1 - a) * b, a * (1 - b), a * b], axis=1)
    return var, coef


def _edge_energy(wx, wy, blocks, owner, nodes, known, n):
    """The energy of the edges not inside one block and not between two known pixels:
    ``(a, b, w)`` the edges between two pixels that are their own variables, each
    once, and a list of ``(rows, cols, values)`` triplets (empty or one), those of
    ``G^T diag(w) G`` with ``G`` the other edges' differences in the ``n``
    variables."""
    h, w = known.shape
    single = np.where(owner < 0, nodes.index[:h, :w], -1)
    i, j, v = [], [], []
    mixed = []
    for weights, dy, dx in ((wx, 0, 1), (wy, 1, 0)):
        a = np.s_[:h - dy, :w - dx]
        b = np.s_[dy:, dx:]
        sa, sb = single[a], single[b]
        some = ~(known[a] & known[b])
        plain = (sa >= 0) & (sb >= 0) & some
        i.append(sa[plain])
        j.append(sb[plain])
        v.append(weights[plain])
        oa, ob = owner[a], owner[b]
        y, x = np.nonzero(((sa < 0) | (sb < 0)) & ((oa < 0) | (oa != ob)) & some)
        if len(y):
            mixed.append((y, x, dy, dx, weights[y, x]))
    plain = np.concatenate(i), np.concatenate(j), np.concatenate(v)
    if not mixed:
        return plain, []
    var, coef, wts = [], [], []
    for y, x, dy, dx, wt in mixed:
        vp, cp = _slots(y, x, blocks, owner, nodes)
        vq, cq = _slots(y + dy, x + dx, blocks, owner, nodes)
        var.append(np.concatenate([vp, vq], axis=1))
        coef.append(np.concatenate([cp, -cq], axis=1))
        wts.append(wt)
    var, coef, wts = np.concatenate(var), np.concatenate(coef), np.concatenate(wts)
    rows = np.repeat(np.arange(len(wts)), var.shape[1])
    nz = coef.ravel() != 0
    G = sp.csr_matrix((coef.ravel()[nz], (rows[nz], var.ravel()[nz])), shape=(len(wts), n))
    M = (G.T @ G.multiply(wts[:, None]).tocsr()).tocoo()
    return plain, [(M.row, M.col, M.data)]


def _block_energy(wx, wy, blocks, nodes, shape):
    """The energy of the edges inside the blocks as ``(rows, cols, values)``: per block
    a 4x4 matrix in its corners from three weighted moments of its rows' and its
    columns' weights."""
    h, w = shape
    r0, c0, s = blocks
    if not len(s):
        empty = np.zeros(0, np.int64)
        return empty, empty, np.zeros(0)
    # Row sums of a block's horizontal edges from cumulative sums along the rows.
    cx = np.zeros((h, w))
    np.cumsum(wx, axis=1, out=cx[:, 1:])
    cy = np.zeros((h, w))
    np.cumsum(wy, axis=0, out=cy[1:, :])
    blk = np.repeat(np.arange(len(s)), s)
    i = np.arange(len(blk)) - np.repeat(np.cumsum(s) - s, s)  # offset within the block
    t = i / s[blk]
    rowsum = cx[r0[blk] + i, c0[blk] + s[blk] - 1] - cx[r0[blk] + i, c0[blk]]
    colsum = cy[r0[blk] + s[blk] - 1, c0[blk] + i] - cy[r0[blk], c0[blk] + i]
    moments = [np.bincount(blk, weights=sums * f, minlength=len(s)) / s ** 2
               for sums in (rowsum, colsum) for f in ((1 - t) ** 2, t * (1 - t), t * t)]
    # Corners TL, TR, BL, BR. Across the rows: the differences TR - TL (weight 1 - a)
    # and BR - BL (weight a); across the columns BL - TL and BR - TR.
    gp = np.array([-1.0, 1.0, 0.0, 0.0])
    gq = np.array([0.0, 0.0, -1.0, 1.0])
    gr = np.array([-1.0, 0.0, 1.0, 0.0])
    gt = np.array([0.0, -1.0, 0.0, 1.0])
    local = np.zeros((len(s), 4, 4))
    for (m0, m1, m2), (u, v) in ((moments[:3], (gp, gq)), (moments[3:], (gr, gt))):
        uu, uv, vv = np.outer(u, u), np.outer(u, v) + np.outer(v, u), np.outer(v, v)
        local += m0[:, None, None] * uu + m1[:, None, None] * uv + m2[:, None, None] * vv
    rows, cols = _corners(blocks)
    var = nodes.index[rows, cols]
    return np.repeat(var, 4, axis=1).ravel(), np.tile(var, (1, 4)).ravel(), local.ravel()


def _interpolated(u, blocks, nodes, owner, out):
    """The fill: ``out`` on the known pixels, the unknowns at full resolution, the
    blocks' pixels bilinear in their corners."""
    h, w = out.shape
    x = np.concatenate([u, out.ravel()[nodes.known_pixels]])
    d = out.copy()
    single = (owner < 0) & (nodes.index[:h, :w] >= 0) & (nodes.index[:h, :w] < len(u))
    d[single] = u[nodes.index[:h, :w][single]]
    r0, c0, s = blocks
    rows, cols = _corners(blocks)
    corner = x[nodes.index[rows, cols]]
    for size in np.unique(s):
        k = np.flatnonzero(s == size)
        t = np.arange(size) / size
        a, b = t[None, :, None], t[None, None, :]
        tl, tr, bl, br = (corner[k, c][:, None, None] for c in range(4))
        i, j = np.mgrid[0:size, 0:size]
        d[r0[k, None, None] + i, c0[k, None, None] + j] = (
            (1 - a) * ((1 - b) * tl + b * tr) + a * ((1 - b) * bl + b * br))
    return d
