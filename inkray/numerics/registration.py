"""As-rigid-as-possible registration of two line drawings.

Implements the registration of Sýkora, Dingliana and Collins, "As-rigid-as-
possible image registration for hand-drawn cartoon animations" (NPAR 2009):
a square lattice of control points is laid over the source drawing and
deformed, coarse to fine, so that the source's ink lands on the target's ink
while every small neighbourhood of the lattice moves as rigidly as possible.
Each iteration of a level

1. *matches blocks*: every control point whose block holds ink tries the
   integer shifts within ``radius`` of its current position and takes the one
   whose block of blurred target ink best agrees with its block of blurred
   source ink (sum of squared differences, refined to a sub-pixel shift by a
   parabola through the neighbouring costs);
2. *regularizes*: for every control point, the rigid motion (rotation and
   translation, weighted Procrustes) that best carries the rest positions of
   its 5x5 lattice neighbourhood to their matched positions; each point then
   moves to the weighted mean of where the rigid motions of the
   neighbourhoods it belongs to put it (shape matching, as in the paper).

Matches are weighted by how well their blocks agree (a Dice-like score in
[0, 1]); blocks that agree poorly, where a stroke appeared, vanished or
changed, are trimmed and follow their neighbours. Control points without ink
in their block take the harmonic interpolation of the others, and the dense
field is the bilinear interpolation of the lattice. The match confidence of a
pixel is the same agreement score of the registered drawings in a window
around it (or of the nearest window that holds ink).

Labelled segments of the source (a limb) can then be moved on their own
(:func:`rigid_segments`: chamfer matching, after Borgefors, "Hierarchical
chamfer matching: a parametric edge matching algorithm", PAMI 1988, over
rigid motions; :func:`rigid_poses`: several distinct such fits, including
the segment turned over the full circle about its attachment, for a caller
that can judge them otherwise; :func:`arap_segments`: the registration above
from there).
"""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy import ndimage

from inkray.errors import InputError
from inkray.numerics.grid import grid_laplacian
from inkray.numerics.spd import MinQuadWithFixed

__all__ = ["LocalField", "Registration", "RigidMotion", "arap_register", "arap_segments",
           "lattice_interpolate", "rigid_poses", "rigid_segments", "warp_points"]

#: Blocks that agree less than this (the score of their best shift) are trimmed:
#: they take no part in the rigid fits and follow their neighbours.
TRIM = 0.35
#: A segment's reported match distance is the mean over this share of its ink
#: pixels, the nearest: the rest may be lines another part now hides or reveals.
_KEEP = 0.75
#: Offsets of the lattice neighbourhood of a rigid fit (5x5 control points):
#: wide enough that a straight stroke's slide along itself is pinned by its ends.
_OFFSETS = (-2, -1, 0, 1, 2)


@dataclass
class Registration:
    """The result of :func:`arap_register`.

    Attributes
    ----------
    displacement : (H, W, 2) float array
        ``[dx, dy]``: the source pixel ``(x, y)`` lands at
        ``(x + dx, y + dy)`` in the target.
    confidence : (H, W) float array
        In [0, 1]: how well the registered drawings agree around each source
        pixel (1 = the ink matches exactly).
    nodes : (n, 2) float array
        Rest positions ``[x, y]`` of the finest lattice's control points.
    node_displacement : (n, 2) float array
        Their displacements.
    node_weight : (n,) float array
        Their final match scores (0 for points without ink in their block).
    """

    displacement: np.ndarray
    confidence: np.ndarray
    nodes: np.ndarray
    node_displacement: np.ndarray
    node_weight: np.ndarray


def arap_register(source, target, *, spacing=8, levels=None, radius=3, iterations=3,
                  sigma=1.0, trim=TRIM, stiffness=0.02, initial=None):
    """Register ``source`` onto ``target`` as rigidly as possible (Sýkora et al. 2009).

    Parameters
    ----------
    source, target : (H, W) float arrays
        Ink darkness in [0, 1] (1 = ink, 0 = paper), same shape.
    spacing : int, default 8
        Lattice spacing in pixels of each level (the finest lattice's spacing
        in the drawing's pixels).
    levels : int, optional
        Pyramid levels (each half the size of the one below); by default as
        many as keep the coarsest image at least 24 pixels on its short side,
        at most 5.
    radius : int, default 3
        Largest shift, in pixels of a level, one block-matching step tries (one
        less on the finest level, which refines what the coarser ones found).
    iterations : int, default 3
        Block-matching and regularization rounds per level (twice as many on
        the coarsest).
    sigma : float, default 1.0
        Blur of each level's ink, in that level's pixels, before matching.
    trim : float, default :data:`TRIM`
        Blocks whose best score is below it are left out of the rigid fits.
    stiffness : float, default 0.02
        Cost of a shift, per squared pixel, relative to a block's ink energy:
        featureless or ambiguous blocks (a straight line) keep still.
    initial : callable, optional
        Where to start: a function taking ``(k, 2)`` points ``[x, y]`` to
        their ``(k, 2)`` displacements (e.g. a rigid motion found by
        :func:`rigid_segments`); by default none.

    Returns
    -------
    Registration

    Raises
    ------
    InputError
        When the images differ in shape, are not 2-D or not finite, or a
        parameter is out of range.

    Examples
    --------
    >>> import numpy as np
    >>> ink = np.zeros((64, 64)); ink[20:44, 30] = 1; ink[20, 20:40] = 1
    >>> moved = np.roll(ink, (2, -3), axis=(0, 1))
    >>> reg = arap_register(ink, moved)
    >>> np.round(reg.displacement[30, 30]).tolist()
    [-3.0, 2.0]
    """
    source = _image(source, "source")
    target = _image(target, "target")
    if source.shape != target.shape:
        raise InputError(f"registration: source is {source.shape[1]}x{source.shape[0]} but "
                         f"target is {target.shape[1]}x{target.shape[0]}")
    for name, value, low in (("spacing", spacing, 2), ("radius", radius, 1), ("iterations", iterations, 1)):
        if int(value) != value or value < low:
            raise InputError(f"registration: {name} must be an integer >= {low}, got {value!r}")
    if not 0 <= trim < 1:
        raise InputError(f"registration: trim must lie in [0, 1), got {trim!r}")
    h, w = source.shape
    if levels is None:
        levels = 1
        while levels < 5 and min(h, w) / 2 ** levels >= 24:
            levels += 1
    if int(levels) != levels or levels < 1:
        raise InputError(f"registration: levels must be a positive integer, got {levels!r}")

    field = None  # node displacements (full-resolution pixels) of the previous level
    for level in range(levels - 1, -1, -1):
        f = 2 ** level
        src = _level_image(source, f, sigma)
        tgt = _level_image(target, f, sigma)
        lattice = _Lattice(src.shape, spacing)
        blocks = _Blocks(lattice, src.shape)
        if field is not None:
            u = field.sample(lattice.rest * f) / f
        elif initial is not None:
            u = np.asarray(initial((lattice.rest * f).reshape(-1, 2)), float).reshape(
                lattice.shape + (2,)) / f
        else:
            u = np.zeros(lattice.shape + (2,))
        rounds = iterations * 2 if field is None else iterations
        for _ in range(rounds):
            # The finest level only refines what the coarser ones found: a smaller search.
            reach = radius if level > 0 else max(1, radius - 1)
            proposal, score, active = _match_blocks(src, tgt, blocks, u, reach, stiffness)
            weight = np.where(active & (score >= trim), score ** 2, 0.0)
            u, placed = _regularize(lattice, u, proposal, weight)
            u = _fill(u, placed)
        field = _NodeField(lattice.rest * f, u * f, spacing * f)
        final_weight = np.where(active, score, 0.0)

    displacement = field.dense((h, w))
    confidence = _confidence(source, target, displacement, scale=2 * spacing)
    return Registration(displacement=displacement, confidence=confidence,
                        nodes=field.rest.reshape(-1, 2), node_displacement=field.u.reshape(-1, 2),
                        node_weight=final_weight.reshape(-1))


def warp_points(registration, points):
    """Where points of the source land in the target.

    Parameters
    ----------
    registration : Registration
    points : (k, 2) float array
        ``[x, y]`` in source pixels.

    Returns
    -------
    (k, 2) float array

    Examples
    --------
    >>> import numpy as np
    >>> ink = np.zeros((40, 40)); ink[10:30, 20] = 1
    >>> reg = arap_register(ink, ink)
    >>> np.round(warp_points(reg, np.array([[20.0, 15.0]])), 3).tolist()
    [[20.0, 15.0]]
    """
    p = np.asarray(points, float).reshape(-1, 2)
    d = registration.displacement
    coords = [p[:, 1], p[:, 0]]
    dx = ndimage.map_coordinates(d[..., 0], coords, order=1, mode="nearest")
    dy = ndimage.map_coordinates(d[..., 1], coords, order=1, mode="nearest")
    return p + np.stack([dx, dy], axis=1)


# -- the lattice ---------------------------------------------------------------

class _Lattice:
    """Control points every ``spacing`` pixels covering an image of ``shape``."""

    def __init__(self, shape, spacing):
        h, w = shape
        self.spacing = spacing
        self.shape = (int(np.ceil((h - 1) / spacing)) + 1, int(np.ceil((w - 1) / spacing)) + 1)
        ys, xs = np.mgrid[:self.shape[0], :self.shape[1]]
        self.rest = np.stack([xs * spacing, ys * spacing], axis=-1).astype(float)


class _NodeField:
    """Node displacements on a regular lattice, interpolated bilinearly."""

    def __init__(self, rest, u, spacing):
        self.rest, self.u, self.spacing = rest, u, spacing

    def sample(self, points):
        coords = [points[..., 1] / self.spacing, points[..., 0] / self.spacing]
        return np.stack([ndimage.map_coordinates(self.u[..., c], coords, order=1, mode="nearest")
                         for c in (0, 1)], axis=-1)

    def dense(self, shape):
        return lattice_interpolate(self.u, self.spacing, shape)


def lattice_interpolate(values, spacing, shape):
    """Bilinear interpolation of values on a lattice to every pixel.

    Parameters
    ----------
    values : (ny, nx) or (ny, nx, c) float array
        Values at the lattice points ``(x, y) = (j spacing, i spacing)``.
    spacing : int
    shape : (h, w)
        The image; pixels beyond the last lattice point take its values.

    Returns
    -------
    (h, w) or (h, w, c) float array

    Examples
    --------
    >>> import numpy as np
    >>> lattice_interpolate(np.array([[0.0, 4.0]]), 4, (1, 6)).tolist()
    [[0.0, 1.0, 2.0, 3.0, 4.0, 4.0]]
    """
    values = np.asarray(values, float)
    # Bilinear on a regular lattice is separable: two sparse matrix products.
    ay = _hat_matrix(shape[0], values.shape[0], spacing)
    ax = _hat_matrix(shape[1], values.shape[1], spacing)
    if values.ndim == 2:
        return (ax @ (ay @ values).T).T
    return np.stack([(ax @ (ay @ values[..., c]).T).T for c in range(values.shape[2])], axis=-1)


def _hat_matrix(n, nodes, spacing):
    """(n, nodes) linear-interpolation weights of pixels 0..n-1 from nodes every ``spacing``."""
    t = np.minimum(np.arange(n) / spacing, nodes - 1)
    i = np.minimum(np.floor(t).astype(int), max(nodes - 2, 0))
    f = t - i
    rows = np.arange(n)
    if nodes == 1:
        return sp.csr_matrix((np.ones(n), (rows, i)), shape=(n, nodes))
    return sp.csr_matrix((np.r_[1 - f, f], (np.r_[rows, rows], np.r_[i, i + 1])), shape=(n, nodes))


# -- the steps -----------------------------------------------------------------

def _image(a, name):
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or min(a.shape) < 2:
        raise InputError(f"registration: {name} must be a 2-D image, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise InputError(f"registration: {name} holds NaN or infinite values")
    return a


def _level_image(ink, factor, sigma):
    """``ink`` averaged over ``factor`` x ``factor`` blocks and blurred by ``sigma``."""
    if factor > 1:
        h, w = ink.shape
        hh, ww = -(-h // factor) * factor, -(-w // factor) * factor
        padded = np.zeros((hh, ww))
        padded[:h, :w] = ink
        ink = padded.reshape(hh // factor, factor, ww // factor, factor).mean(axis=(1, 3))
    return ndimage.gaussian_filter(ink, sigma, mode="constant")


class _Blocks:
    """Sums over the (2 spacing)-square block centred on each control point.

    A pixel lies in the 2x2 blocks around its lattice cell; sums over a sparse
    set of pixels are bincounts over cells, then 2x2 sums of cells.
    """

    def __init__(self, lattice, shape):
        s = lattice.spacing
        self.lattice, self.shape = lattice, shape
        ny, nx = lattice.shape
        self.cells = (ny + 1, nx + 1)
        h, w = shape
        ys, xs = np.mgrid[:h, :w]
        # Cell c covers pixels [c s - s, c s): node j's block is cells j and j + 1.
        self.cell = ((ys + s) // s) * (nx + 1) + (xs + s) // s

    def sums(self, weights, cells=None):
        """Block sums of ``weights``, given at every pixel or at the pixels of a mask
        whose cells ``self.cell[mask]`` are ``cells`` (found once for repeated sums)."""
        cell = self.cell if cells is None else cells
        c = np.bincount(cell.reshape(-1), weights=np.ravel(weights),
                        minlength=self.cells[0] * self.cells[1]).reshape(self.cells)
        return c[:-1, :-1] + c[1:, :-1] + c[:-1, 1:] + c[1:, 1:]

    def shifted_sums(self, table, dy, dx, pad):
        """Block sums, each block (within the image) moved by ``(dy, dx)``, from
        the integral ``table`` of an image padded by ``pad >= |dy|, |dx|``."""
        s = self.lattice.spacing
        rest = self.lattice.rest.astype(int)
        h, w = self.shape
        y0 = np.clip(rest[..., 1] - s, 0, h) + dy + pad
        y1 = np.clip(rest[..., 1] + s, 0, h) + dy + pad
        x0 = np.clip(rest[..., 0] - s, 0, w) + dx + pad
        x1 = np.clip(rest[..., 0] + s, 0, w) + dx + pad
        return table[y1, x1] - table[y0, x1] - table[y1, x0] + table[y0, x0]


def _integral(a):
    t = np.zeros((a.shape[0] + 1, a.shape[1] + 1))
    np.cumsum(np.cumsum(a, axis=0), axis=1, out=t[1:, 1:])
    return t


def _match_blocks(src, tgt, blocks, u, radius, stiffness):
    """Best shift of every block, its score and whether the block holds ink.

    Integer shifts within ``radius`` are tried exhaustively; a block whose
    best shift is none takes one Lucas-Kanade step instead (sub-pixel, and
    only across a straight line where that line leaves the shift open).
    """
    lattice = blocks.lattice
    h, w = src.shape
    ink = src > 1e-3 * max(src.max(), 1e-12)
    py, px = np.nonzero(ink)
    sv, own = src[py, px], blocks.cell[ink]
    src2 = blocks.sums(sv * sv, cells=own)
    active = src2 > 1e-3 * max(src2.max(), 1e-12)
    # The target is looked at only in the blocks with ink and a cell around
    # them (a cell is wider than any shift tried).
    cells = np.zeros(blocks.cells, bool)
    for oy in (0, 1):
        for ox in (0, 1):
            cells[oy:oy + active.shape[0], ox:ox + active.shape[1]] |= active
    need = ndimage.binary_dilation(cells, iterations=1)[blocks.cell // blocks.cells[1],
                                                        blocks.cell % blocks.cells[1]]
    ys, xs = np.nonzero(need)
    du = _NodeField(lattice.rest, u, lattice.spacing).dense((h, w))
    warped = np.zeros((h, w))
    # Edge values beyond the border: a line the frame cuts does not end there.
    warped[ys, xs] = ndimage.map_coordinates(tgt, [ys + du[ys, xs, 1], xs + du[ys, xs, 0]],
                                             order=1, mode="nearest")
    r = radius
    big = np.pad(warped, r, mode="edge")
    table = _integral(big * big)
    shifts = [(dy, dx) for dy in range(-r, r + 1) for dx in range(-r, r + 1)]
    cost = np.empty((len(shifts),) + lattice.shape)
    energy = np.empty_like(cost)
    # The ink pixels' flat positions in ``big``, found once for every shift.
    at, flat = (py + r) * big.shape[1] + px + r, big.ravel()
    for k, (dy, dx) in enumerate(shifts):
        cross = blocks.sums(sv * flat[at + dy * big.shape[1] + dx], cells=own)
        energy[k] = src2 + blocks.shifted_sums(table, dy, dx, r)
        cost[k] = energy[k] - 2 * cross + stiffness * (dx * dx + dy * dy) * src2
    best = cost.argmin(axis=0)
    by, bx = np.take(np.array(shifts, float), best, axis=0).transpose(2, 0, 1)
    c0 = np.take_along_axis(cost, best[None], 0)[0]
    e0 = np.take_along_axis(energy, best[None], 0)[0]
    score = np.clip(1 - c0 / np.maximum(e0, 1e-12), 0.0, 1.0)
    step = np.stack([bx, by], axis=-1)
    still = best == shifts.index((0, 0))
    if still.any():
        step[still] = _lucas_kanade(src, warped, blocks)[still]
    return u + step, np.where(active, score, 0.0), active


def _lucas_kanade(src, warped, blocks):
    """One damped Gauss-Newton step per block of ``warped`` towards ``src``."""
    gy, gx = np.gradient(warped)
    res = warped - src
    m = (np.abs(res) > 1e-6) | (np.abs(gx) + np.abs(gy) > 1e-6)
    gx, gy, res, cells = gx[m], gy[m], res[m], blocks.cell[m]
    a, b, c = (blocks.sums(gx * gx, cells=cells), blocks.sums(gx * gy, cells=cells),
               blocks.sums(gy * gy, cells=cells))
    ex, ey = blocks.sums(gx * res, cells=cells), blocks.sums(gy * res, cells=cells)
    damp = 0.01 * (a + c) + 1e-9
    a, c = a + damp, c + damp
    det = a * c - b * b
    dx = -(c * ex - b * ey) / det
    dy = -(a * ey - b * ex) / det
    return np.clip(np.stack([dx, dy], axis=-1), -1.0, 1.0)


def _window_sum(a):
    """Sum over the lattice neighbourhood of each control point (zero outside)."""
    out = np.zeros_like(a)
    ny, nx = a.shape[:2]
    for dy in _OFFSETS:
        for dx in _OFFSETS:
            out[max(0, -dy):ny - max(0, dy), max(0, -dx):nx - max(0, dx)] += \
                a[max(0, dy):ny - max(0, -dy), max(0, dx):nx - max(0, -dx)]
    return out


def _regularize(lattice, u, proposal, weight):
    """Shape matching: each node to the weighted mean of its neighbourhoods' rigid fits."""
    p = lattice.rest
    q = p + proposal
    wsum = _window_sum(weight)
    safe = np.maximum(wsum, 1e-12)
    pbar = _window_sum(weight[..., None] * p) / safe[..., None]
    qbar = _window_sum(weight[..., None] * q) / safe[..., None]
    # Weighted cross terms of the centred positions, from the raw sums.
    sxx = _window_sum(weight * (p[..., 0] * q[..., 0] + p[..., 1] * q[..., 1])) \
        - wsum * (pbar[..., 0] * qbar[..., 0] + pbar[..., 1] * qbar[..., 1])
    sxy = _window_sum(weight * (p[..., 0] * q[..., 1] - p[..., 1] * q[..., 0])) \
        - wsum * (pbar[..., 0] * qbar[..., 1] - pbar[..., 1] * qbar[..., 0])
    # A neighbourhood with one weighted node (or none) has no rotation: a small
    # pull towards none keeps its angle from being rounding noise.
    theta = np.arctan2(sxy, sxx + 0.05 * wsum * lattice.spacing ** 2)
    c, s = np.cos(theta), np.sin(theta)
    # Node i in the neighbourhood of k lands at R_k (p_i - pbar_k) + qbar_k;
    # accumulate the weighted mean over the k around i.
    ny, nx = lattice.shape
    acc = np.zeros(lattice.shape + (2,))
    tot = np.zeros(lattice.shape)
    for dy in _OFFSETS:
        for dx in _OFFSETS:
            ki = (slice(max(0, dy), ny - max(0, -dy)), slice(max(0, dx), nx - max(0, -dx)))
            ii = (slice(max(0, -dy), ny - max(0, dy)), slice(max(0, -dx), nx - max(0, dx)))
            d = p[ii] - pbar[ki]
            x = np.stack([c[ki] * d[..., 0] - s[ki] * d[..., 1],
                          s[ki] * d[..., 0] + c[ki] * d[..., 1]], axis=-1) + qbar[ki]
            acc[ii] += wsum[ki][..., None] * x
            tot[ii] += wsum[ki]
    moved = tot > 1e-12
    out = u.copy()
    out[moved] = acc[moved] / tot[moved][..., None] - p[moved]
    return out, moved


def _fill(u, known):
    """Harmonic interpolation of the displacements of the nodes not ``known``."""
    if known.all():
        return u
    if not known.any():
        return np.zeros_like(u) + u.reshape(-1, 2).mean(axis=0)
    ny, nx = known.shape
    L = grid_laplacian(np.ones((ny, nx - 1)), np.ones((ny - 1, nx)))
    flat = known.reshape(-1)
    # One factorization for both components.
    return MinQuadWithFixed(L, flat).solve(Y=u.reshape(-1, 2)[flat]).reshape(u.shape)


def _confidence(source, target, displacement, *, scale):
    """Agreement of the registered drawings around each source pixel, in [0, 1]."""
    h, w = source.shape
    ys, xs = np.mgrid[:h, :w].astype(float)
    warped = ndimage.map_coordinates(target, [ys + displacement[..., 1], xs + displacement[..., 0]],
                                     order=1, mode="constant")
    # Lines a pixel or two apart (a redrawn stroke) still agree; a missing or
    # extra stroke does not.
    blur = scale / 8
    a = ndimage.gaussian_filter(source, blur)
    b = ndimage.gaussian_filter(warped, blur)
    # The windows are wide and smooth: their sums are taken on a grid `step`
    # times coarser and interpolated back.
    step = max(1, int(scale // 8))
    sigma = scale / 2 / step
    num = ndimage.gaussian_filter(_level_image(2 * a * b, step, 0), sigma)
    den = ndimage.gaussian_filter(_level_image(a * a + b * b, step, 0), sigma)
    # Where the window holds almost no ink the ratio says nothing: take the nearest
    # window that does.
    defined = den > 0.02 * max(den.max(), 1e-12)
    conf = np.where(defined, num / np.maximum(den, 1e-12), 0.0)
    if defined.any() and not defined.all():
        _, (iy, ix) = ndimage.distance_transform_edt(~defined, return_indices=True)
        conf = conf[iy, ix]
    if step > 1:
        ys, xs = np.mgrid[:h, :w]
        conf = ndimage.map_coordinates(conf, [(ys + 0.5) / step - 0.5, (xs + 0.5) / step - 0.5],
                                       order=1, mode="nearest")
    return np.clip(conf, 0.0, 1.0)


# -- segments moved rigidly ----------------------------------------------------

@dataclass
class RigidMotion:
    """A rotation by ``angle`` (radians) about ``pivot`` followed by a ``translation``.

    Attributes
    ----------
    angle : float
    pivot, translation : (2,) float arrays
        ``[x, y]``.
    cost : float
        Mean distance (pixels, clipped) from the segment's moved ink to the
        target's ink under this motion, over the nearest three quarters of
        its ink pixels (the rest may be lines another part hides or reveals).
    base_cost : float
        The same under the registration the search started from.
    """

    angle: float
    pivot: np.ndarray
    translation: np.ndarray
    cost: float
    base_cost: float

    def apply(self, points):
        """Where ``points`` ``(k, 2)`` ``[x, y]`` land."""
        p = np.asarray(points, float).reshape(-1, 2) - self.pivot
        c, s = np.cos(self.angle), np.sin(self.angle)
        return np.stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1]], axis=1) \
            + self.pivot + self.translation

    def invert(self, points):
        """The points that :meth:`apply` takes to ``points``."""
        p = np.asarray(points, float).reshape(-1, 2) - self.pivot - self.translation
        c, s = np.cos(self.angle), np.sin(self.angle)
        return np.stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1]], axis=1) + self.pivot


def rigid_segments(source, target, labels, registration, *, max_angle=45.0, radius=32.0,
                   clip=6.0, attach=0.3, samples=160, tolerance=0.75):
    """Each labelled segment of ``source`` moved rigidly onto ``target``'s ink.

    A smooth registration cannot follow a limb that swings far while the rest
    barely moves. For every segment (pixels of one label ``>= 0``) this
    searches the rotations within ``max_angle`` degrees and the translations
    within ``radius`` pixels of the rigid motion that best fits the
    registration on the segment, for the one that brings the segment's ink
    (its pixels and the ink around them) closest to the target's ink
    (chamfer matching: the mean distance to the target's nearest ink pixel,
    clipped at ``clip``), coarse to fine. Where the segment meets other
    segments it must stay attached: the distance of those pixels from where
    the registration puts them costs ``attach`` per pixel.

    Parameters
    ----------
    source, target : (H, W) float arrays
        Ink darkness in [0, 1], same shape.
    labels : (H, W) int array
        Segments of ``source`` (``< 0``: none).
    registration : Registration
        Of ``source`` onto ``target`` (:func:`arap_register`).
    max_angle, radius, clip, attach : float
        See above.
    samples : int, default 160
        Ink pixels of a segment the cost is measured on (evenly picked).
    tolerance : float, default 0.75
        A segment whose ink the registration already leaves this close
        (pixels, mean) to the target's is not searched: its motion is the
        rigid fit of the registration.

    Returns
    -------
    dict
        Label -> :class:`RigidMotion`, for every label with ink.

    Examples
    --------
    >>> import numpy as np
    >>> src = np.zeros((80, 80)); src[20:60, 20] = src[20:60, 30] = 1
    >>> src[20, 20:31] = src[59, 20:31] = 1
    >>> labels = np.full((80, 80), -1); labels[21:59, 21:30] = 0
    >>> tgt = np.roll(src, 25, axis=1)
    >>> m = rigid_segments(src, tgt, labels, arap_register(src, src))[0]
    >>> np.round(m.apply([[25.0, 40.0]])).tolist(), round(m.cost, 2)
    ([[50.0, 40.0]], 0.0)
    """
    source = _image(source, "source")
    target = _image(target, "target")
    labels = np.asarray(labels)
    if source.shape != target.shape or labels.shape != source.shape:
        raise InputError("registration: source, target and labels must have one shape")
    fields = _fields(target, clip)
    out = {}
    for k, window in _segment_windows(labels, 5):
        seg = _PoseSearch(source, labels, k, window, registration, fields, clip, attach, samples)
        if seg.p is None:
            continue
        if seg.base <= tolerance:
            out[int(k)] = RigidMotion(angle=seg.theta0, pivot=seg.pivot, translation=seg.t0,
                                      cost=seg.base, base_cost=seg.base)
            continue
        # Coarse steps on distances clipped far (a smooth cost, so that a thin
        # line's narrow basin is not stepped over), then the few best angles
        # refined on the near distances.
        coarse = seg.search((0.0, seg.theta0, seg.t0), max_angle, 5.0, radius, 4.0, coarse=True)
        out[int(k)] = seg.refined(coarse)
    return out


def rigid_poses(source, target, labels, label, registration, *, count=6, max_angle=45.0,
                radius=32.0, clip=6.0, attach=0.3, samples=160, hinge=8.0, apart=6.0):
    """Several distinct rigid motions of one segment that bring its ink near ``target``'s.

    Where chamfer matching is ambiguous (a small limb among another limb's
    lines), the best fit need not be the right one: these are the
    ``count`` best local fits of the searches of :func:`rigid_segments`
    (within ``max_angle`` and ``radius`` of the registration's fit) and of
    a hinge search: the segment turned over the full circle about points of
    its attachment to other segments, which move at most ``hinge`` pixels
    from where the registration puts them (a limb folded further than any
    smooth motion reaches), each refined, for the caller to judge by other
    evidence.

    Parameters
    ----------
    source, target, labels, registration
        As in :func:`rigid_segments`.
    label : int
        The segment.
    count : int, default 6
    max_angle, radius, clip, attach, samples
        As in :func:`rigid_segments`.
    hinge : float, default 8.0
        See above.
    apart : float, default 6.0
        Two motions are distinct when they put some of the segment's ink at
        least this far (pixels) apart.

    Returns
    -------
    list of RigidMotion
        Best first (by :attr:`RigidMotion.cost`); empty when the segment has
        no ink.

    Examples
    --------
    >>> import numpy as np
    >>> src = np.zeros((80, 80)); src[20:60, 20] = src[20:60, 30] = 1
    >>> src[20, 20:31] = src[59, 20:31] = 1
    >>> labels = np.full((80, 80), -1); labels[21:59, 21:30] = 0
    >>> tgt = np.roll(src, 25, axis=1)
    >>> poses = rigid_poses(src, tgt, labels, 0, arap_register(src, src))
    >>> np.round(poses[0].apply([[25.0, 40.0]])).tolist(), len(poses) > 1
    ([[50.0, 40.0]], True)
    """
    source = _image(source, "source")
    target = _image(target, "target")
    labels = np.asarray(labels)
    if source.shape != target.shape or labels.shape != source.shape:
        raise InputError("registration: source, target and labels must have one shape")
    windows = dict(_segment_windows(labels, 5))
    if label not in windows:
        return []
    seg = _PoseSearch(source, labels, label, windows[label], registration, _fields(target, clip),
                      clip, attach, samples)
    if seg.p is None:
        return []
    found = seg.search((0.0, seg.theta0, seg.t0), max_angle, 5.0, radius, 4.0, coarse=True, keep=4)
    if len(seg.a):
        found += seg.search((0.0, seg.theta0 + np.pi, seg.held), 180.0, 10.0, hinge,
                            min(4.0, hinge), coarse=True, hinged=True, keep=2)
    poses = []
    for c in sorted(found, key=lambda c: c[0]):
        m = seg.refined([c])
        q = m.apply(seg.p)
        if all(np.abs(q - o.apply(seg.p)).max() >= apart for o in poses):
            poses.append(m)
            if len(poses) == count:
                break
    return sorted(poses, key=lambda m: m.cost)


def _fields(target, clip):
    """The target's ink distances clipped at ``clip`` and at three times it."""
    edt = ndimage.distance_transform_edt(target < 0.5)
    return np.minimum(edt, clip), np.minimum(edt, 3 * clip)


class _PoseSearch:
    """Chamfer search over rigid motions of one segment (see :func:`rigid_segments`)."""

    def __init__(self, source, labels, k, window, registration, fields, clip, attach, samples):
        self.dist, self.far = fields
        self.clip, self.attach = clip, attach
        mask = labels[window] == k
        ring = ndimage.binary_dilation(mask, iterations=2)
        py, px = np.nonzero((source[window] >= 0.5) & ring)
        self.p = None
        if len(px) < 3:
            return
        pick = np.linspace(0, len(px) - 1, min(samples, len(px))).astype(int)
        origin = np.array([window[1].start, window[0].start], float)
        p = np.stack([px[pick], py[pick]], axis=1) + origin
        g = warp_points(registration, p)
        others = ndimage.binary_dilation((labels[window] >= 0) & ~mask, iterations=3) & mask
        ay, ax = np.nonzero(others)
        a = np.stack([ax, ay], axis=1)[::max(1, len(ax) // 60)] + origin
        self.goal = warp_points(registration, a)
        # A limb turns about where it is attached: rotations about there need
        # the smallest translations.
        pivot = a.mean(axis=0) if len(a) else p.mean(axis=0)
        self.theta0 = _procrustes_angle(p - p.mean(axis=0), g - g.mean(axis=0))
        self.t0 = g.mean(axis=0) - _rotate(p.mean(axis=0) - pivot, self.theta0) - pivot
        self.held = warp_points(registration, pivot[None])[0] - pivot
        self.hinges = a[np.linspace(0, len(a) - 1, min(12, len(a))).astype(int)] if len(a) else a
        self.p, self.a, self.pivot = p, a, pivot
        self.base = float(_chamfer(self.dist, g[None], clip, _KEEP)[0])

    def search(self, centre, span_a, step_a, span_t, step_t, *, coarse=False, hinged=False,
               keep=1):
        """The ``keep`` best (cost, angle, shift) per angle tried around ``centre``; hinged,
        turned about each point of the attachment, which moves at most ``span_t`` from
        where the registration puts it."""
        field, cut = (self.far, 3 * self.clip) if coarse else (self.dist, self.clip)
        p, a, pivot = self.p, self.a, self.pivot
        r = np.arange(-span_t, span_t + 1e-9, step_t)
        near = np.stack(np.meshgrid(r, r), axis=-1).reshape(-1, 2)
        found = []
        for th in centre[1] + np.deg2rad(np.arange(-span_a, span_a + 1e-9, step_a)):
            if hinged:
                held = self.hinges - pivot - _rotate(self.hinges - pivot, th) + centre[2]
                shifts = (held[:, None] + near[None]).reshape(-1, 2)
            else:
                shifts = near + centre[2]
            cost = _chamfer(field, _rotate(p - pivot, th)[None] + pivot + shifts[:, None], cut)
            if len(a) and not hinged:
                qa = _rotate(a - pivot, th) + pivot
                gap = np.linalg.norm(qa[None] + shifts[:, None] - self.goal[None], axis=2)
                cost = cost + self.attach * np.minimum(gap, cut).mean(axis=1)
            for j in np.argsort(cost, kind="stable")[:keep]:
                found.append((float(cost[j]), float(th), shifts[j].copy()))
        return found

    def refined(self, coarse):
        """The best of the three best ``coarse`` candidates refined on the near distances."""
        best = (np.inf, self.theta0, self.t0)
        for c in sorted(coarse, key=lambda c: c[0])[:3]:
            best = min([best] + self.search(c, 4.0, 1.0, 4.0, 1.0), key=lambda c: c[0])
        return self.motion(best)

    def motion(self, found):
        m = RigidMotion(angle=found[1], pivot=self.pivot, translation=np.asarray(found[2], float),
                        cost=0.0, base_cost=self.base)
        m.cost = float(_chamfer(self.dist, m.apply(self.p)[None], self.clip, _KEEP)[0])
        return m


def _segment_windows(labels, pad):
    """``(label, window)`` for each label ``>= 0``: the slices of its bounding box plus ``pad``."""
    h, w = labels.shape
    found = ndimage.find_objects(np.where(labels >= 0, labels + 1, 0))
    for k, box in enumerate(found):
        if box is None:
            continue
        yield k, (slice(max(box[0].start - pad, 0), min(box[0].stop + pad, h)),
                  slice(max(box[1].start - pad, 0), min(box[1].stop + pad, w)))


def _rotate(d, theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * d[..., 0] - s * d[..., 1], s * d[..., 0] + c * d[..., 1]], axis=-1)


def _procrustes_angle(a, b):
    """The rotation angle best taking centred points ``a`` to centred points ``b``."""
    return float(np.arctan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]),
                            np.sum(a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1])))


def _chamfer(dist, q, clip, keep=1.0):
    """Mean clipped distance at points ``q`` (..., n, 2), of the ``keep`` share of them
    nearest; ``clip`` outside the image."""
    h, w = dist.shape
    x = np.rint(q[..., 0]).astype(int)
    y = np.rint(q[..., 1]).astype(int)
    inside = (x >= 0) & (y >= 0) & (x < w) & (y < h)
    d = np.where(inside, dist[np.clip(y, 0, h - 1), np.clip(x, 0, w - 1)], clip)
    if keep < 1:
        k = max(1, int(round(keep * d.shape[-1])))
        d = np.partition(d, k - 1, axis=-1)[..., :k]
    return d.mean(axis=-1)


@dataclass
class LocalField:
    """A displacement field over a window of the image.

    Attributes
    ----------
    origin : (2,) int array
        ``[x, y]`` of the window's top-left pixel.
    displacement : (h, w, 2) float array
        As :attr:`Registration.displacement`, over the window (points outside
        it take the nearest window pixel's).
    cost : float
        As :attr:`RigidMotion.cost`.
    """

    origin: np.ndarray
    displacement: np.ndarray
    cost: float

    def apply(self, points):
        """Where ``points`` ``(k, 2)`` ``[x, y]`` land."""
        p = np.asarray(points, float).reshape(-1, 2)
        q = p - self.origin
        d = self.displacement
        return p + np.stack([ndimage.map_coordinates(d[..., c], [q[:, 1], q[:, 0]], order=1,
                                                     mode="nearest") for c in (0, 1)], axis=1)


def arap_segments(source, target, labels, motions, *, spacing=4, margin=None, clip=6.0):
    """Each segment's own as-rigid-as-possible registration, started from its rigid motion.

    A limb that bends (a knee) is not one rigid piece: from the motion found
    by :func:`rigid_segments`, the segment's ink alone (its pixels and the two
    pixels of ink around them) is registered onto the whole target by
    :func:`arap_register`, in a window around the segment.

    Parameters
    ----------
    source, target : (H, W) float arrays
        Ink darkness in [0, 1], same shape.
    labels : (H, W) int array
        Segments of ``source``.
    motions : dict
        Label -> :class:`RigidMotion`; only these segments are registered.
    spacing : int, default 4
        Lattice spacing of the segments' registrations.
    margin : int, optional
        Pixels of the window beyond the segment and where its motion takes it;
        by default four lattice spacings.
    clip : float, default 6.0
        As in :func:`rigid_segments`, for :attr:`LocalField.cost`.

    Returns
    -------
    dict
        Label -> :class:`LocalField`.

    Examples
    --------
    >>> import numpy as np
    >>> ys, xs = np.mgrid[:90, :90]
    >>> src = (np.abs(np.hypot(xs - 30, ys - 40) - 12) < 0.8).astype(float)
    >>> labels = np.where(np.hypot(xs - 30, ys - 40) < 11, 0, -1)
    >>> tgt = np.roll(src, (10, 20), axis=(0, 1))
    >>> motions = rigid_segments(src, tgt, labels, arap_register(src, src))
    >>> f = arap_segments(src, tgt, labels, motions)[0]
    >>> np.round(f.apply([[30.0, 40.0]])).tolist()
    [[50.0, 50.0]]
    """
    source = _image(source, "source")
    target = _image(target, "target")
    labels = np.asarray(labels)
    h, w = source.shape
    margin = 4 * spacing if margin is None else int(margin)
    out = {}
    for k, motion in motions.items():
        ky, kx = np.nonzero(labels == k)
        if not len(kx):
            continue
        box = np.array([[kx.min(), ky.min()], [kx.max(), ky.max()]], float)
        corners = np.array([[box[i, 0], box[j, 1]] for i in (0, 1) for j in (0, 1)])
        reach = np.vstack([corners, motion.apply(corners)])
        x0, y0 = np.clip(np.floor(reach.min(axis=0)).astype(int) - margin, 0, [w, h])
        x1, y1 = np.clip(np.ceil(reach.max(axis=0)).astype(int) + margin + 1, 0, [w, h])
        window = (slice(y0, y1), slice(x0, x1))
        ring = ndimage.binary_dilation(labels[window] == k, iterations=2)
        src = np.where(ring, source[window], 0.0)
        tgt = target[window]
        origin = np.array([x0, y0])

        def initial(points, motion=motion, origin=origin):
            p = points + origin
            return motion.apply(p) - p

        reg = arap_register(src, tgt, spacing=spacing, levels=2, initial=initial)
        local = LocalField(origin=origin, displacement=reg.displacement, cost=0.0)
        py, px = np.nonzero(ring & (src >= 0.5))
        if len(px):
            p = np.stack([px, py], axis=1).astype(float) + origin
            dist = np.minimum(ndimage.distance_transform_edt(tgt < 0.5), clip)
            local.cost = float(_chamfer(dist, (local.apply(p) - origin)[None], clip, _KEEP)[0])
        out[int(k)] = local
    return out
