"""Stitching and layering: offsets that put inflated parts at their depths.

Step 5 of Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for Adding Global
Illumination Effects to Hand-Drawn Characters" (TOG 2014). Every region ``i``
gets an offset field ``g_i`` on its mesh so that the heights
``z_i = h_i + g_i`` (``h_i`` the inflated heights) meet

- **inequalities**: where region ``A`` is in front of ``B`` (a relation of
  :mod:`inkray.order`, local to its place), ``z_A >= z_B + epsilon`` at
  corresponding points of their overlap: the vertices of either mesh that lie
  in the overlap of both completed regions inside that place, the points
  where an edge of one mesh crosses an edge of the other there (with the
  vertices, the corners of every cell of the two meshes' overlay, on which
  ``z_A - z_B`` is linear: the order holds over the whole overlap), plus the
  user's entry points;
- **C0 stitches**: ``z_a = z_b`` at the shared stations of a ``stitch`` entry;
- **smooth grafts**: along a ``graft`` entry, or an open join of
  :mod:`inkray.relief.joins` (outline without ink between two regions), the
  front region ``F`` (whose outline carries the seam, inflated with a
  Neumann condition there) meets the region ``K`` behind: ``z_F = z_K`` at
  every vertex of its seam (no crack; rows at the stations alone let ``F``
  bulge between them) and ``z_F >= z_K`` plus a margin growing to
  ``epsilon`` on every vertex of ``F`` within ``band`` pixels of them that
  lies over ``K``'s mesh (no z-fighting); after the solve ``F`` is blended
  over that band onto ``K``'s tangent plane across the seam, with a weight
  of zero value, slope and curvature at the seam, so ``F`` leaves ``K`` with
  its height and slope (no crease, no rim), as the single smooth surface of
  Dvořožňák et al. 2018, "Seamless reconstruction of part-based
  high-relief models from hand-drawn images", would;
- ``equal`` entries: ``z_A(a) = z_B(b)`` at the entry's two points,

with minimal energy ``sum_i g_i^T (-L_i + lambda_i M_i) g_i`` (cotangent
Laplacian ``L_i``, mass ``M_i``). The small screening term
``lambda_i = 1e-4 / area_i`` makes the system definite and, being far weaker
than bending, lets a part that only has to move *move rigidly*: constant
offsets cost almost nothing, and constraints that already hold leave ``g = 0``.

The QP has few active constraints and many unknowns. It is solved through its
multipliers (as :mod:`inkray.qp` does for depth maps): each region block is
factored once; the working set's dual matrix ``H = C Q^-1 C^T`` is built
column by column with solves on those factors; the small dual is solved
exactly by :func:`inkray.numerics.active_set.dual_active_set`. Inequality samples enter by
constraint generation: all violated ones at ``g = 0`` first, then, round by
round, the most violated candidates at the current solution, until none is
violated by more than ``tol``.
"""

import hashlib
from dataclasses import dataclass, field

import igl
import numpy as np
import scipy.sparse as sp
from scipy.ndimage import binary_dilation

from inkray.errors import InputError, StageError
from inkray.numerics.active_set import dual_active_set
from inkray.numerics.crossings import segment_crossings
from inkray.numerics.polyline import point_polyline_distance
from inkray.numerics.spd import spd_factor
from inkray.numerics.threads import one_blas_thread, thread_map

__all__ = ["Layers", "stitch", "DEFAULT_EPSILON_FRACTION"]

#: Default ``epsilon`` as a fraction of the drawing's longer side.
DEFAULT_EPSILON_FRACTION = 0.004
_SCREEN = 1e-4  # lambda_i * area_i: rigid shifts cost 1e-4 of a unit bend
_INSIDE = 0.75  # px: a point this close to a mesh counts as covered by it
_PLACE_STEP = 2  # px between the pixel centres of an overlap that get an order row
_SEGMENT_STEP = 0.5  # px between samples of an order entry's segment
_BAND_FRACTION = 0.5  # graft band width as a fraction of the seam's length
_RISE = 1.0  # and at least this times the grafted part's own height at the seam
_BATCH = 16  # right-hand sides per triangular solve of a block
_REACH = 2.0  # px before a graft seam over which the base's slope is taken (two fine triangles)


@dataclass
class Layers:
    """Inflated regions placed at their depths.

    Attributes
    ----------
    regions : list of InflatedRegion or None
        Per region index (None for a region without a mesh).
    offset : list of (n_i,) float arrays or None
        The offsets ``g_i``.
    epsilon : float
        The depth step used for inequalities (px).
    constraints : int
        Candidate constraints (equalities plus inequality samples).
    active : int
        Constraints with a nonzero multiplier at the solution.
    rounds : int
        Constraint-generation rounds.
    violation : float
        Largest violation of any candidate constraint at the QP's solution, before
        the graft bands are blended (px).
    bands : list of (int, int, (k, 2) array, float)
        Per graft: the grafted region, its base, the seam (station points)
        and the band's width (px). Within the band the grafted part rises
        from its base's surface, with its slope, to its own: an order between
        the two gives way to the seam there.
    warnings : list of str
        Order entries whose points lie in such a band.
    """

    regions: list
    offset: list
    epsilon: float
    constraints: int = 0
    active: int = 0
    rounds: int = 0
    violation: float = 0.0
    bands: list = field(default_factory=list)
    warnings: list = field(default_factory=list)

    def z(self, i):
        """Final heights ``h_i + g_i`` of region ``i`` (px)."""
        return self.regions[i].height + self.offset[i]


class _Rows:
    """Constraint rows ``sum_k w_k g[idx_k] (>= | =) rhs`` with a label per row.

    ``graft`` marks the rows that make a grafted region follow its base
    (solved in the second pass, with the bases fixed). The rows are kept in
    the blocks they were added in and joined once, when read.
    """

    def __init__(self):
        self._blocks = []  # (idx (k, m), w (k, m), rhs (k,), ineq, label, graft, xy (k, 2))

    def extend(self, idx, w, rhs, ineq, label, graft, xy):
        """Add ``len(rhs)`` rows at once: ``idx``, ``w`` (k, m), ``rhs`` (k,), ``xy`` (k, 2)."""
        self._blocks.append((np.asarray(idx, np.int64), np.asarray(w, float),
                             np.asarray(rhs, float).reshape(-1), bool(ineq), label, bool(graft),
                             np.asarray(xy, float).reshape(-1, 2)))

    def merge(self, other):
        """Add the rows of ``other`` (a ``_Rows``) after these."""
        self._blocks.extend(other._blocks)

    def _each(self, k):
        return [b[k] for b in self._blocks]

    def _per_row(self, k, dtype):
        return np.repeat(np.array(self._each(k), dtype), [len(b[2]) for b in self._blocks])

    @property
    def rhs(self):
        return np.concatenate([np.zeros(0)] + self._each(2))

    @property
    def ineq(self):
        return self._per_row(3, bool)

    @property
    def graft(self):
        return self._per_row(5, bool)

    @property
    def label(self):
        return [b[4] for b in self._blocks for _ in range(len(b[2]))]

    @property
    def xy(self):
        """Where each row speaks (its first point), to spread the working set."""
        return np.concatenate([np.zeros((0, 2))] + self._each(6))

    def matrix(self, n):
        m = sum(len(b[2]) for b in self._blocks)
        if m == 0:
            return sp.csr_matrix((0, n))
        widths = np.concatenate([np.full(len(b[2]), b[0].shape[1]) for b in self._blocks])
        rows = np.repeat(np.arange(m), widths)
        return sp.csr_matrix((np.concatenate([b[1].ravel() for b in self._blocks]),
                              (rows, np.concatenate([b[0].ravel() for b in self._blocks]))),
                             shape=(m, n))


class _Region:
    """One region's block: its unknowns from ``start`` on, and its mesh's ``_Mesh``."""

    def __init__(self, mesh, start):
        self.start = start
        self.v, self.f, self.h = mesh.v, mesh.f, mesh.h
        self.solve, self.locate = mesh.solve, mesh.locate


def _mesh_of(inflated, memo, used):
    """The ``_Mesh`` of an inflated region, the one in ``memo`` when its content is
    the same (an edit of the editor re-stitches the meshes it did not change)."""
    mesh, solver = inflated.mesh, inflated.solver
    arrays = [mesh.vertices, mesh.faces, inflated.height]
    if solver is not None:
        arrays += [solver.laplacian.data, solver.laplacian.indices, solver.mass.data]
    digest = hashlib.blake2b(digest_size=16)
    for a in arrays:
        digest.update(np.ascontiguousarray(a).tobytes())
    key = digest.digest()
    found = memo.get(key) if memo is not None else None
    if found is None:
        found = _Mesh(inflated)
    used[key] = found
    return found


class _Mesh:
    """One region's mesh: factor of ``-L + lambda M``, point location, heights."""

    def __init__(self, inflated):
        mesh = inflated.mesh
        self.v = np.asarray(mesh.vertices, float)
        self.f = np.asarray(mesh.faces, np.int64)
        self.h = np.asarray(inflated.height, float)
        solver = inflated.solver
        if solver is not None:
            lap, mass = solver.laplacian, solver.mass
        else:
            lap = igl.cotmatrix(self.v, self.f)
            mass = igl.massmatrix(self.v, self.f, igl.MASSMATRIX_TYPE_VORONOI)
        area = float(mass.diagonal().sum())
        self.q = (-lap + (_SCREEN / area) * mass).tocsc()
        self._lu = None
        self._v3 = np.column_stack([self.v, np.zeros(len(self.v))])
        self._tree = None  # AABB tree of the mesh, built at the first locate

    def solve(self, rhs):
        with one_blas_thread():
            return self._solve(rhs)

    def _solve(self, rhs):
        if self._lu is None:
            self._lu = spd_factor(self.q)
        return self._lu.solve(rhs)

    def locate(self, points):
        """Barycentric location of ``points`` (k, 2) in the mesh.

        Returns (vertex indices (k, 3), weights (k, 3), distance (k,)).
        """
        p = np.asarray(points, float).reshape(-1, 2)
        if len(p) == 0:
            return np.zeros((0, 3), np.int64), np.zeros((0, 3)), np.zeros(0)
        p3 = np.column_stack([p, np.zeros(len(p))])
        if self._tree is None:  # built whole before it is shared: locate runs in threads
            tree = igl.AABB()
            tree.init(self._v3, self.f)
            self._tree = tree
        d2, face, closest = self._tree.squared_distance(self._v3, self.f, p3)
        tri = self.f[np.asarray(face, np.int64)]
        a, b, c = (self.v[tri[:, k]] for k in range(3))
        q = np.asarray(closest)[:, :2]
        v0, v1, v2 = b - a, c - a, q - a
        den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
        den = np.where(np.abs(den) > 1e-300, den, 1.0)
        wb = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
        wc = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
        w = np.clip(np.column_stack([1.0 - wb - wc, wb, wc]), 0.0, 1.0)
        w /= w.sum(axis=1, keepdims=True)
        return tri, w, np.sqrt(np.maximum(d2, 0.0))


def stitch(inflated, relations, completion, *, seams=(), epsilon=None, band=None,
           tol=1e-6, max_rounds=60, memo=None, progress=None):
    """Solve the offsets ``g_i`` of every region.

    Parameters
    ----------
    inflated : list of InflatedRegion or None
        Per region index, from :func:`inkray.relief.inflation.inflate_region`.
    relations : list of inkray.relief.ordering.Relation
        Depth relations; ``order`` relations with a place become inequalities,
        user ``equal`` relations equalities at the entry's points.
    completion : inkray.relief.completion.Completion
        The completion the meshes were made from (after
        :meth:`~inkray.relief.completion.Completion.ordered`); its places say where a
        relation applies.
    seams : sequence of inkray.input.annotations.Boundary, default ()
        The ``boundaries`` entries (``stitch``, ``graft``; ``flat`` needs no
        offset), found on the meshes by their index, and the open joins
        (:class:`~inkray.relief.joins.OpenJoin`, grafts between their own two
        regions, named by their ``label``).
    epsilon : float, optional
        Depth step of an inequality in px; default
        :data:`DEFAULT_EPSILON_FRACTION` of the drawing's longer side.
    band : float, optional
        Width in px of the graft band where the front region follows the one
        behind; default half the seam's length, at least two outline edges
        of the front mesh.
    tol : float, default 1e-6
        Allowed constraint violation (px).
    max_rounds : int, default 60
        Constraint-generation rounds before giving up.
    memo : dict, optional
        Kept across calls (the editor's chain keeps one): each mesh's
        factorization and point location by the mesh's content, so a
        re-stitch after an edit redoes them only for the meshes it changed,
        and the rows that held the solution, which start the next working
        set where the same entry speaks at the same point (the optimum is
        the same; it is found in fewer rounds, equal to a fresh solve to
        round-off). Left holding this call's meshes and rows only.
    progress : inkray.progress.Progress, optional

    Returns
    -------
    Layers

    Raises
    ------
    InputError
        When the constraints contradict each other (the message lists the
        annotation entries involved) or a boundary entry has no region on
        one side.
    StageError
        When constraint generation does not converge.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.inflation import inflate_region
    >>> yy, xx = np.mgrid[:80, :80]
    >>> disk = inflate_region((xx - 40) ** 2 + (yy - 40) ** 2 <= 30 ** 2)
    >>> layers = stitch([disk], [], None)
    >>> float(np.abs(layers.offset[0]).max())
    0.0
    """
    regions = list(inflated)
    kept = None if memo is None else memo.setdefault("meshes", {})
    blocks, start, used = [], 0, {}
    for r in regions:
        blocks.append(None if r is None else _Region(_mesh_of(r, kept, used), start))
        start += 0 if r is None else len(r.height)
    if memo is not None:  # keep what this stitch used: one relief's worth
        kept.clear()
        kept.update(used)
    n = start
    if epsilon is None:
        shape = completion.labels.shape if completion is not None else (0, 0)
        epsilon = DEFAULT_EPSILON_FRACTION * max(shape) if max(shape, default=0) else 1.0
    if not epsilon > 0:
        raise InputError(f"epsilon: expected a positive depth step in px, got {epsilon!r}")

    rows = _Rows()
    zones = []
    if seams:
        zones = _boundary_rows(rows, blocks, regions, relations, seams, band, epsilon)
    keepout = _keepout(zones)
    warnings = _band_warnings(relations, zones)
    if completion is not None:
        # One set of overlap rows per (front, back, place), however many entries say it.
        said = {}
        for rel in relations:
            if rel.kind == "order" and rel.place is not None:
                said.setdefault((rel.front, rel.back, rel.place), []).append(rel.label)
                if rel.points is not None:
                    _entry_rows(rows, blocks, rel, np.array(rel.points, float), epsilon, keepout)
            elif rel.kind == "equal" and rel.points is not None:
                _equal_rows(rows, blocks, rel)
        def overlap(item):
            (a, b, place), labels = item
            part = _Rows()
            _overlap_rows(part, blocks, a, b, completion.places[place], completion, epsilon,
                          keepout, " and ".join(labels))
            return part

        # Two places at a time, their rows added in the order of the places.
        for part in thread_map(overlap, said.items()):
            rows.merge(part)
        _beneath_rows(rows, blocks, completion, epsilon, keepout)

    C = rows.matrix(n)
    rhs, ineq, graft, labels, xy = rows.rhs, rows.ineq, rows.graft, rows.label, rows.xy
    owner = np.full(n, -1, np.int64)
    for i, b in enumerate(blocks):
        if b is not None:
            owner[b.start:b.start + len(b.h)] = i
    # Pass 1: everything but the graft rows. Pass 2: the bases of grafts stay
    # where pass 1 put them and everything else is solved again with the
    # graft rows, so a grafted part follows its base without denting it.
    bases = {z[1] for z in zones} - {z[0] for z in zones}
    # Rows that held the last solution (same entry, same point) start in the working set.
    def keys(sel):
        return zip([labels[i] for i in sel], map(tuple, xy[sel].tolist()), ineq[sel].tolist(),
                   graft[sel].tolist())

    before = memo.get("held", set()) if memo is not None else set()
    warm = np.zeros(len(rhs), bool)
    if before:
        warm[:] = [k in before for k in keys(np.arange(len(rhs)))]
    g, active, rounds, held = _solve(C, rhs, ineq, ~graft, labels, xy, blocks, owner,
                                     tol, max_rounds, progress, warm)
    if graft.any():
        fixed = np.isin(owner, sorted(bases))
        shifted = rhs - C[:, fixed] @ g[fixed]
        Cf = C.multiply(~fixed[None, :]).tocsr()
        touches = np.diff(Cf.indptr) > 0
        g2, active2, rounds2, held2 = _solve(Cf, shifted, ineq, touches, labels, xy,
                                             blocks, owner, tol, max_rounds, progress, warm)
        g = np.where(fixed, g, g2)
        active, rounds, held = active2, rounds + rounds2, np.concatenate([held, held2])
    if memo is not None:
        memo["held"] = set(keys(held))
    slack = C @ g - rhs
    violation = max(np.abs(slack[~ineq]).max(initial=0.0), (-slack[ineq]).max(initial=0.0))
    for front, base, seam, width, _, lift in zones:
        _blend(g, blocks, front, base, seam, width, lift)
    return Layers(regions=regions, epsilon=float(epsilon), constraints=len(rhs), active=active,
                  rounds=rounds, violation=float(violation), warnings=warnings,
                  bands=[z[:4] for z in zones],
                  offset=[None if b is None else g[b.start:b.start + len(b.h)] for b in blocks])


# -- constraint rows ---------------------------------------------------------------------

def _terms_rows(rows, blocks, terms, rhs, ineq, label, graft=False):
    """Rows ``sum_t coef_t z_{region_t}(points_t[k]) (>= | =) rhs[k]``, one per k.

    ``rhs`` is a number or one per point.
    ``terms`` is a list of ``(region, points (k, 2), coef)`` or
    ``(region, vertex indices (k,), coef)`` when the points are vertices of
    that region (exact, no interpolation). Rows with a point farther than
    ``_INSIDE`` from its mesh are skipped. Returns the number of rows added.
    """
    located = []
    ok = None
    for region, where, coef in terms:
        blk = blocks[region]
        where = np.asarray(where)
        if where.ndim == 1:  # vertex indices
            tri = np.repeat(where.astype(np.int64)[:, None], 3, axis=1)
            w = np.tile([1.0, 0.0, 0.0], (len(where), 1))
            dist = np.zeros(len(where))
        else:
            tri, w, dist = blk.locate(where)
        located.append((blk, tri, w, coef))
        if len(located) == 1:
            xy = (blk.v[tri] * w[..., None]).sum(axis=1)
        ok = dist <= _INSIDE if ok is None else ok & (dist <= _INSIDE)
    rhs = np.broadcast_to(np.asarray(rhs, float), ok.shape)
    k = np.flatnonzero(ok)
    idx = np.concatenate([blk.start + tri[k] for blk, tri, _, _ in located], axis=1)
    wts = np.concatenate([coef * w[k] for _, _, w, coef in located], axis=1)
    # z = h + g: move the known heights to the right-hand side
    const = rhs[k] - sum(coef * np.einsum("kj,kj->k", blk.h[tri[k]], w[k])
                         for blk, tri, w, coef in located)
    rows.extend(idx, wts, const, ineq, label, graft, xy[k])
    return len(k)


def _overlap_rows(rows, blocks, a, b, place, completion, epsilon, keepout, label):
    """``z_a >= z_b + epsilon`` at every vertex of either mesh in the place's overlap
    (and along the regions' contact) and at every crossing of their edges there,
    wherever both meshes are there."""
    if blocks[a] is None or blocks[b] is None:
        return
    y0, y1, x0, x1 = place.box
    h, w = completion.labels.shape
    # The overlap of both completed regions inside the place, grown by 2 px so
    # that outline vertices (half a pixel off the pixel grid) are caught.
    win = (slice(max(0, y0 - 2), min(h, y1 + 2)), slice(max(0, x0 - 2), min(w, x1 + 2)))
    lab, own = completion.labels[win], completion.owner[win]
    both = (((lab == a) | (own == a)) & ((lab == b) | (own == b)))
    pm = np.zeros_like(both)
    inner = (slice(y0 - win[0].start, y1 - win[0].start), slice(x0 - win[1].start, x1 - win[1].start))
    pm[inner] = place.mask
    # Where neither region continues under the other, the order still holds
    # along their common outline (the contact), so the step is visible there.
    contact = np.zeros_like(both)
    contact[inner] = place.contact
    zone = binary_dilation(pm, iterations=2) & binary_dilation(both | contact, iterations=2)
    _zone_rows(rows, blocks, a, b, zone, pm & both, (win[0].start, win[1].start), epsilon,
               keepout, label)


def _zone_rows(rows, blocks, a, b, zone, pixels, corner, epsilon, keepout, label):
    """``z_a >= z_b + epsilon`` at the vertices of either mesh in ``zone``, the crossings of
    their edges there and every other pixel centre of ``pixels`` (both masks of a window
    whose top-left pixel is ``corner``, (row, column))."""
    top, left = corner

    def in_zone(p):
        px = np.rint(p).astype(np.int64)
        iy, ix = px[:, 1] - top, px[:, 0] - left
        inside = (iy >= 0) & (iy < zone.shape[0]) & (ix >= 0) & (ix < zone.shape[1])
        out = np.zeros(len(p), bool)
        out[inside] = zone[iy[inside], ix[inside]]
        return out & ~keepout(a, b, p)

    edges = []
    for src in (a, b):
        blk = blocks[src]
        sel = np.flatnonzero(in_zone(blk.v))
        pts = blk.v[sel]
        front_at = sel if src == a else pts
        _terms_rows(rows, blocks, [(a, front_at, 1.0), (b, pts, -1.0)], epsilon, True, label)
        edges.append(_edges_at(blk, sel))
    # z_a - z_b is linear on each cell of the overlay of the two meshes, so it
    # is least at a cell's corners: the vertices above and the points where an
    # edge of one mesh crosses an edge of the other (where the meshes'
    # interpolations part most, along an outline edge over a finer mesh).
    cross = segment_crossings(*edges)
    cross = cross[in_zone(cross)]
    _terms_rows(rows, blocks, [(a, cross, 1.0), (b, cross, -1.0)], epsilon, True, label)
    # Between the vertices the two meshes interpolate differently: the pixel centres of
    # the overlap (every other one) keep the order there too.
    ys, xs = np.nonzero(pixels)
    grid = (ys % _PLACE_STEP == 0) & (xs % _PLACE_STEP == 0)
    pts = np.column_stack([xs[grid] + left, ys[grid] + top]).astype(float)
    pts = pts[~keepout(a, b, pts)]
    _terms_rows(rows, blocks, [(a, pts, 1.0), (b, pts, -1.0)], epsilon, True, label)


def _beneath_rows(rows, blocks, completion, epsilon, keepout):
    """The second hidden layers (:attr:`Completion.beneath`) below both parts over them: the
    hidden part whose pixels they lie under and the part in front of both."""
    beneath = completion.beneath
    if beneath is None or not (beneath >= 0).any():
        return
    names, h, w = completion.names, *beneath.shape
    for b in np.unique(beneath[beneath >= 0]):
        mine = beneath == b
        ys, xs = np.nonzero(mine)
        win = (slice(max(ys.min() - 2, 0), min(ys.max() + 3, h)),
               slice(max(xs.min() - 2, 0), min(xs.max() + 3, w)))
        mine = mine[win]
        for over in (completion.owner[win], completion.labels[win]):
            for a in np.unique(over[mine]):
                if blocks[a] is None or blocks[b] is None:
                    continue
                at = mine & (over == a)
                _zone_rows(rows, blocks, int(a), int(b), binary_dilation(at, iterations=2), at,
                           (win[0].start, win[1].start), epsilon, keepout,
                           f"{names[b]} under {names[a]} (its second hidden layer)")


def _edges_at(blk, sel):
    """The edges (k, 2, 2) of ``blk``'s triangles that have a vertex in ``sel``."""
    mark = np.zeros(len(blk.v), bool)
    mark[sel] = True
    f = blk.f[mark[blk.f].any(axis=1)]
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    # One integer per edge sorts as the (low, high) pairs do.
    key = np.unique(e[:, 0] * len(blk.v) + e[:, 1])
    return blk.v[np.column_stack([key // len(blk.v), key % len(blk.v)])]


def _entry_rows(rows, blocks, rel, points, epsilon, keepout):
    """The user's own two points and the segment between them: the front region
    above the back one wherever both are there."""
    a, b = rel.front, rel.back
    if blocks[a] is None or blocks[b] is None:
        return
    if len(points) == 2:
        n = int(np.ceil(np.linalg.norm(points[1] - points[0]) / _SEGMENT_STEP)) + 1
        points = points[0] + np.linspace(0.0, 1.0, max(n, 2))[:, None] * (points[1] - points[0])
    points = points[~keepout(a, b, points)]
    _terms_rows(rows, blocks, [(a, points, 1.0), (b, points, -1.0)], epsilon, True, rel.label)


def _equal_rows(rows, blocks, rel):
    a, b = rel.front, rel.back
    if blocks[a] is None or blocks[b] is None:
        return
    pa, pb = np.array(rel.points, float)
    added = _terms_rows(rows, blocks, [(a, pa[None], 1.0), (b, pb[None], -1.0)],
                        0.0, False, rel.label)
    if not added:
        raise InputError(f"{rel.label}: a point lies off its region's mesh")


def _boundary_rows(rows, blocks, regions, relations, seams, band, epsilon):
    """Rows of the ``stitch`` and ``graft`` entries; returns the graft zones.

    A zone ``(front, base, station points, band width, key, lift)`` says
    where inequalities between the two regions are left out and where
    :func:`_blend` joins them.
    """
    zones = []
    for entry in seams:
        if entry.type == "flat":
            continue
        # An open join (inkray.relief.joins) names itself and joins its own two regions.
        key = getattr(entry, "label", f"boundaries[{entry.index}]")
        holders = [i for i, r in enumerate(regions)
                   if r is not None and len(r.mesh.station_vertices(entry.index))
                   and i in getattr(entry, "regions", (i,))]
        if not holders:
            continue  # reported by the outline stage (no outline within reach)
        front = holders[0]
        st = regions[front].mesh.station_vertices(entry.index)
        other = _behind(regions, blocks, front, st, holders)
        if other is None:
            raise InputError(f"{key}: the {entry.type} has no region on the other side of "
                             f"{regions[front].mesh.name!r}")
        if entry.type == "stitch":
            pts = (regions[other].mesh.station_vertices(entry.index) if other in holders
                   else blocks[front].v[st])
            if len(pts) != len(st):
                pts = blocks[front].v[st]
            _terms_rows(rows, blocks, [(front, st, 1.0), (other, pts, -1.0)], 0.0, False, key)
            continue
        if other in holders and _in_front(relations, other, front, blocks):
            front, other = other, front  # the graft grows out of the region behind
            st = regions[front].mesh.station_vertices(entry.index)
        seam = _seam_vertices(regions[front].mesh, entry.index, blocks[front].v[st])
        if band is not None:
            width = band
        else:
            # The grafted part rises epsilon above its base over the band: a band as
            # wide as half the seam keeps that tilt (about 3 epsilon / length) unseen.
            # It also comes down from its own height (its inflation at the seam) to
            # the base's: a band at least that wide keeps the descent gentle.
            length = float(np.linalg.norm(np.diff(blocks[front].v[st], axis=0), axis=1).sum())
            width = max(2.0 * _mean_outline_edge(regions[front].mesh), _BAND_FRACTION * length,
                        _RISE * float(blocks[front].h[seam].max()))
        # The stations' polyline is the seam's (the other vertices lie on its edges),
        # with far fewer edges to measure distances to.
        line = blocks[front].v[st]
        lift = _graft_rows(rows, blocks, front, other, seam, line, width, epsilon, key)
        zones.append((front, other, line, width, key, lift))
    return zones


def _in_front(relations, a, b, blocks):
    """Is ``a`` the grafted (front) one of the pair: by an order relation, else the smaller."""
    for r in relations:
        if r.kind == "order" and {r.front, r.back} == {a, b}:
            return r.front == a
    return len(blocks[a].h) < len(blocks[b].h)


def _seam_vertices(mesh, index, stations):
    """Every outline vertex of a marked stretch (its stations and the points the
    triangulation put between them), in order along the stations' polyline."""
    sel = np.flatnonzero(mesh.boundary_index == index)
    if len(stations) < 2 or len(sel) <= len(stations):
        return mesh.station_vertices(index)
    a, b = stations[:-1], stations[1:]
    ab = b - a
    p = mesh.vertices[sel]
    t = np.clip(((p[:, None] - a[None]) * ab[None]).sum(-1)
                / np.maximum((ab * ab).sum(-1), 1e-12), 0.0, 1.0)
    near = a[None] + t[..., None] * ab[None]
    k = np.argmin(((p[:, None] - near) ** 2).sum(-1), axis=1)
    return sel[np.argsort(k + t[np.arange(len(sel)), k], kind="stable")]


def _graft_rows(rows, blocks, front, base, stations, line, width, epsilon, key):
    """The front region grows out of ``base``: no crack, no z-fighting.

    At the seam's vertices ``stations`` (all of them, in order along the
    seam, whose polyline is ``line``) ``z_front = z_base`` (C0, lifted by the base's bulge:
    :func:`_sagitta`). Where ``base`` continues under ``front`` (it was
    completed there), every other vertex of ``front`` within ``width`` of the
    seam, at distance ``d``, lies above ``base`` by the margin ``epsilon
    (d / width)^2``: zero at the seam, ``epsilon`` (the order step) at the end
    of the band. The base thus stays below the grafted part all the way, and
    :func:`_blend` then makes the grafted part leave the seam with the
    base's slope. Returns the largest lift of a seam vertex.
    """
    blk = blocks[front]
    seam = blk.v[stations]
    lift = _sagitta(blocks[base], seam)
    _terms_rows(rows, blocks, [(front, stations, 1.0), (base, seam, -1.0)], lift, False,
                key, graft=True)
    dist = np.full(len(blk.v), np.inf)
    box = _in_box(blk.v, line, width)
    dist[box] = point_polyline_distance(blk.v[box], line)
    sel = np.setdiff1d(np.flatnonzero(dist <= width), stations)
    _terms_rows(rows, blocks, [(front, sel, 1.0), (base, blk.v[sel], -1.0)],
                _margin(dist[sel], width, epsilon), True, key, graft=True)
    return float(lift.max(initial=0.0))


def _blend(g, blocks, front, base, seam, width, lift):
    """Make the grafted part ``front`` leave ``base`` with its height and slope.

    Over the band the grafted part's height becomes ``e + lift + w(d / width)
    (z_front - e - lift)`` with ``w(t) = 10 t^3 - 15 t^4 + 6 t^5``, ``d`` the
    distance to the seam and ``e`` the base continued across the seam by its
    tangent plane (its slope from the last :data:`_REACH` px before the
    seam): ``w(0) = w'(0) = w''(0) = 0``, so at the seam the grafted part has
    the base's height (lifted by the base's bulge between seam vertices) and
    slope, and bends away from it gently (a pixel beside the seam its normal
    is still the base's, where a cubic weight turned it by the rise over the
    band); ``w(1) = 1, w'(1) = w''(1) = 0``, so it joins its solved surface
    with no crease at the band's end. The tangent plane, not the base's own surface where it was
    completed under the grafted part: that surface falls to zero height at
    its invented outline, wherever the completion ended. Where the base is
    above its tangent plane (a concave base) its own surface is taken, so
    that with ``z_front >= z_base`` (the graft rows) the grafted part stays
    above the base all the way.
    """
    f, b = blocks[front], blocks[base]
    box = np.flatnonzero(_in_box(f.v, seam, width))
    foot = _foot(f.v[box], seam)
    d = np.linalg.norm(f.v[box] - foot, axis=1)
    near = d < width
    sel = box[near]
    p, s, d = f.v[sel], foot[near], d[near]
    away = (p - s) / np.maximum(d, 1e-12)[:, None]
    # the slope at the seam, by the second-order one-sided difference
    at, one, two = (_height(g, b, s - k * _REACH / 2.0 * away)[0] for k in (0, 1, 2))
    e = at + (3.0 * at - 4.0 * one + two) * d / _REACH
    under, dist = _height(g, b, p)
    e = np.where(dist <= _INSIDE, np.maximum(e, under), e)
    t = d / width
    w = t ** 3 * (10.0 - 15.0 * t + 6.0 * t * t)
    z = f.h[sel] + g[f.start + sel]
    g[f.start + sel] = e + lift + w * (z - e - lift) - f.h[sel]


def _height(g, blk, points):
    """Final height of ``blk`` at ``points`` (its nearest point's) and their distance to it."""
    tri, w, dist = blk.locate(points)
    return ((blk.h + g[blk.start:blk.start + len(blk.h)])[tri] * w).sum(axis=1), dist


def _in_box(points, line, width):
    """Mask of ``points`` in the bounding box of ``line`` grown by ``width``: the
    others are farther than ``width`` from it."""
    return np.all((points >= line.min(axis=0) - width) & (points <= line.max(axis=0) + width),
                  axis=1)


def _foot(points, line):
    """Nearest point of the polyline ``line`` to each of ``points``."""
    a, b = (line[:-1], line[1:]) if len(line) > 1 else (line, line)
    ab = b - a
    t = ((points[:, None] - a[None]) * ab[None]).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-12)
    near = a[None] + np.clip(t, 0.0, 1.0)[..., None] * ab[None]
    k = np.argmin(((points[:, None] - near) ** 2).sum(-1), axis=1)
    return near[np.arange(len(points)), k]


def _sagitta(base, seam):
    """Per seam vertex, how far the base bulges above the straight seam edges beside it.

    The grafted part's seam runs straight from vertex to vertex while the
    base's surface is curved along it; lifting each vertex by this much (a
    fraction of a pixel) keeps the base from showing through between them.
    """
    if len(seam) < 2:
        return np.zeros(len(seam))
    frac = np.array([0.25, 0.5, 0.75])
    pts = seam[:-1, None, :] + frac[None, :, None] * (seam[1:] - seam[:-1])[:, None, :]
    tri, w, _ = base.locate(np.concatenate([seam, pts.reshape(-1, 2)]))
    h = (base.h[tri] * w).sum(axis=1)
    ends, mid = h[:len(seam)], h[len(seam):].reshape(-1, 3)
    chord = (1 - frac) * ends[:-1, None] + frac * ends[1:, None]
    edge = np.maximum(mid - chord, 0.0).max(axis=1)
    return 1.25 * np.maximum(np.r_[edge, 0.0], np.r_[0.0, edge])


def _margin(d, width, epsilon):
    """Height of the grafted part above its base at distance ``d`` from the seam."""
    return epsilon * np.minimum(np.asarray(d, float) / width, 1.0) ** 2


def _behind(regions, blocks, front, stations, holders):
    """The region on the other side of a marked stretch of ``front``'s outline."""
    neigh = regions[front].mesh.neighbour[stations]
    neigh = neigh[(neigh >= 0) & (neigh != front)]
    if len(neigh):
        cand = int(np.bincount(neigh).argmax())
        if blocks[cand] is not None:
            return cand
    for other in holders:
        if other != front:
            return other
    return None


def _band_warnings(relations, zones):
    """One warning per order entry with a point in the band of a graft between its regions."""
    out = []
    for rel in relations:
        if rel.kind != "order" or rel.points is None:
            continue
        pts = np.array(rel.points, float).reshape(-1, 2)
        for front, base, line, width, key, _ in zones:
            if {front, base} == {rel.front, rel.back} and \
                    (point_polyline_distance(pts, line) < width).any():
                out.append(f"{rel.label}: gives way to the graft seam of {key} within "
                           f"{width:.0f} px of it (the grafted part rises from its base there)")
    return out


def _keepout(zones):
    """Predicate: is a point of the pair (i, j) inside the band of a graft between them?

    There the graft's margin (zero at the seam, ``epsilon`` at the band's
    end) takes the place of the order step: the relation gives way to the seam.
    """
    def near(i, j, pts):
        out = np.zeros(len(pts), bool)
        for front, base, line, width, _, _ in zones:
            if {front, base} == {i, j} and len(pts):
                box = _in_box(pts, line, width)
                out[box] |= point_polyline_distance(pts[box], line) < width
        return out
    return near


def _mean_outline_edge(mesh):
    e = np.concatenate([mesh.faces[:, [0, 1]], mesh.faces[:, [1, 2]], mesh.faces[:, [2, 0]]])
    both = mesh.outline[e].all(axis=1)
    e = e[both]
    if len(e) == 0:
        return 4.0
    return float(np.linalg.norm(mesh.vertices[e[:, 0]] - mesh.vertices[e[:, 1]], axis=1).mean())


# -- the QP ------------------------------------------------------------------------------

def _solve(C, rhs, ineq, use, labels, xy, blocks, owner, tol, max_rounds, progress, warm,
           per_group=4):
    """Constraint generation around the exact dual active set on the working set.

    Only rows where ``use`` is True take part. The working set starts with the
    equalities, the rows ``warm`` marks and, per annotation entry, the
    ``per_group`` inequalities most violated at ``g = 0``; each round adds the
    most violated candidates per entry, spread apart (neighbouring samples
    carry nearly the same information and would make the dual singular).
    Returns ``(g, active, rounds, held)``, ``held`` the rows with a nonzero
    multiplier.
    """
    n = C.shape[1]
    cand = np.flatnonzero(use)
    C, rhs, ineq, xy = C[cand], rhs[cand], ineq[cand], np.asarray(xy, float)[cand]
    ids = {}  # one number per entry (its rows' label)
    group = np.fromiter((ids.setdefault(lab, len(ids)) for lab in labels), np.int64,
                        len(labels))[cand]
    in_work = ~ineq | warm[cand]
    in_work |= _worst_per_group(np.where(ineq, rhs, 0.0), group, xy, tol, per_group)
    if not in_work.any():
        return np.zeros(n), 0, 0, np.zeros(0, np.int64)
    # Z = Q^-1 C[order]^T and H = C[order] Z grow by the new rows' blocks each round
    # (copying Z, n x rows, every round cost more than the solves on large drawings).
    Z = []
    H = np.zeros((0, 0))
    order = np.zeros(0, np.int64)  # row of C behind each column of Z
    lam = np.zeros(0)
    for rnd in range(1, max_rounds + 1):
        new = np.setdiff1d(np.flatnonzero(in_work), order)
        z = _qinv_rows(C[new], blocks, owner)
        across = C[order] @ z
        inner = C[new] @ z
        H = np.block([[H, across], [across.T, 0.5 * (inner + inner.T)]])
        Z.append(z)
        order = np.concatenate([order, new])
        start = np.concatenate([lam, np.zeros(len(new))])
        try:
            lam = dual_active_set(H, rhs[order], ineq[order], what="stitching QP", start=start)
        except StageError:
            names = [labels[cand[r]] for r in order]
            raise InputError(_conflict_message(H, rhs[order], ineq[order], names)) from None
        g, k = np.zeros(n), 0
        for z in Z:
            g += z @ lam[k:k + z.shape[1]]
            k += z.shape[1]
        viol = np.where(ineq, rhs - C @ g, 0.0)
        viol[in_work] = 0.0  # held by the dual; only new candidates matter
        if progress is not None:
            progress.update(rnd, max_rounds)
        if viol.max(initial=0.0) <= tol:
            return g, int((np.abs(lam) > 0).sum()), rnd, cand[order[np.abs(lam) > 0]]
        in_work |= _worst_per_group(viol, group, xy, tol, per_group)
    raise StageError(f"stitching: constraint generation did not converge in {max_rounds} rounds")


def _worst_per_group(viol, group, xy, tol, k):
    """Mask of up to ``k`` violated rows per group: the worst, then the worst
    farther than a quarter of the group's violated extent from those taken."""
    out = np.zeros(len(viol), bool)
    for g in np.unique(group[viol > tol]):
        bad = np.flatnonzero((group == g) & (viol > tol))
        bad = bad[np.argsort(-viol[bad], kind="stable")]
        p = xy[bad]
        radius = 0.25 * float(np.ptp(p, axis=0).max(initial=0.0))
        near = np.zeros(len(bad), bool)
        for _ in range(k):
            free = np.flatnonzero(~near)
            if len(free) == 0:
                break
            j = free[0]
            out[bad[j]] = True
            near |= np.hypot(*(p - p[j]).T) <= radius
    return out


def _qinv_rows(rows, blocks, owner):
    """``Q^-1 rows^T`` as a dense (n, k) array, one batched solve per region block, two
    blocks at a time (SuperLU lets go of the GIL; a block's first solve factors it)."""
    n = rows.shape[1]
    out = np.zeros((n, rows.shape[0]))
    if rows.shape[0] == 0:
        return out
    csc = rows.tocsc()

    def solve(i):
        b = blocks[i]
        sl = slice(b.start, b.start + len(b.h))
        part = csc[:, sl]
        # Only the rows with a term in this block: the others' columns are zero
        # (a row speaks of two regions, a round's rows of many).
        speak = np.unique(part.indices)
        # A few columns at a time: the triangular solves sweep the factor once per
        # batch, and a narrow batch's columns stay in cache (each column's answer is
        # the same whatever its batch).
        for k in range(0, len(speak), _BATCH):
            cols = speak[k:k + _BATCH]
            out[sl, cols] = b.solve(part[cols].T.toarray())

    # Each block writes its own rows: the same array whatever the scheduling.
    thread_map(solve, np.unique(owner[rows.indices]))
    return out


def _conflict_message(H, b, ineq, labels):
    """Name the entries of an irreducible infeasible subset (deletion filter)."""
    groups = list(dict.fromkeys(labels))
    keep = set(groups)
    for grp in groups:
        trial = keep - {grp}
        sel = np.array([lab in trial for lab in labels])
        if not sel.any():
            continue
        try:
            dual_active_set(H[np.ix_(sel, sel)], b[sel], ineq[sel], what="stitching QP")
        except StageError:
            keep = trial
    involved = [g for g in groups if g in keep]
    return ("stitching: the depth constraints contradict each other: "
            + " and ".join(involved))
