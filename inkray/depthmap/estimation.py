"""Depth maps from sparse depth (in)equalities.

Implements Sýkora et al., "Adding Depth to Cartoons Using Sparse Depth
(In)equalities", Computer Graphics Forum 29(2), 2010 (METHOD.md section 1):

- ``method="exact"``: the quadratic program over every pixel, solved exactly
  through its constraint multipliers (:mod:`inkray.qp`).
- ``method="fast"``: the paper's interactive approximation. (1) LazyBrush
  (Sýkora, Dingliana, Collins, CGF 2009) segments the drawing from seeds at
  the constraint endpoints (and the region and background scribbles when
  given); (2) the endpoints of one segment share a level as long as that
  contradicts no entry, otherwise the segment is cut into parts, one per
  group of its endpoints that can (order is local: two rings that cross
  twice, an entry with both points in one region); equalities merge nodes,
  inequalities are directed edges, Kahn's topological sort gives each node a
  level (longest chain of inequalities below it); with regions and no entry
  on the background, the background is a node below every region touching
  it (in the exact method, an order from each region piece to each
  background piece it touches, spread along their contact); (3) every endpoint pixel,
  and every pixel of an endpoint's segment (or part) that touches another
  segment across ink, is fixed at its node's level times epsilon; (4) the
  Laplace equation fills in the rest, so steps stay at ink lines and the
  depth is smooth across cuts through paper
  and over unconstrained areas (above :data:`REDUCED_ABOVE` pixels to solve,
  on a reduced system: full resolution near ink and fixed pixels, bilinear
  quadtree blocks elsewhere, after Agarwala, "Efficient gradient-domain
  compositing using quadtrees", SIGGRAPH 2007). :class:`DepthSession` keeps
  the segmentation and the factorization of step (4) and reuses them when a constraint is
  added or removed or the scribbles change.

Depth grows toward the viewer; both methods return a zero-mean depth map in
units of the annotation's epsilon (default 1). Annotation points are rounded
to the nearest pixel.
"""

import threading
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from inkray.errors import InputError
from inkray.numerics.harmonic_fill import DraftFill, HarmonicFill
from inkray.numerics.order_graph import OrderGraph
from inkray.depthmap.quadratic_program import check_constraints, solve_depth_qp
from inkray.numerics.grid import WEIGHT_FLOOR, edge_weights, grid_laplacian

__all__ = ["DepthResult", "DepthSession", "depth", "depth_constraints", "fill_weights", "METHODS"]

METHODS = ("exact", "fast")
#: Grey level below which a pixel counts as ink when deciding whether a
#: segment boundary is a step (on ink) or a cut through paper.
INK_LEVEL = 0.5
#: LazyBrush seed strength for the fast method: above the cost of cutting
#: around one pixel (4 paper edges), so an endpoint keeps its own label.
_SEED_STRENGTH = 5.0
#: A draft (:meth:`DepthSession.solve`) solves the fill at half resolution
#: only above this many pixels; below, a full solve is fast enough.
DRAFT_ABOVE = 300_000
#: A full fill with no kept factorization to reuse, over a box of more than this
#: many pixels, is solved on the reduced system of quadtree blocks
#: (:func:`~inkray.numerics.quadtree_fill.quadtree_fill`, within 0.02 of a
#: level of the exact fill on the bundled drawings at 1 Mpx, about a third of
#: the time); :meth:`DepthSession.prepare` then factors the exact one.
REDUCED_ABOVE = 300_000
#: The background's label in a segmentation of scribbles.
BACKGROUND = -1
#: Pieces (4-connected areas of one label) smaller than this many pixels get no
#: implicit order in the exact method: slivers along outlines, not parts.
_MIN_PIECE = 30


# (the drawing as given, its fill weights) of the last drawing fill_weights saw
_kept_weights = None
_kept_lock = threading.Lock()


def fill_weights(gray):
    """The edge weights of the fast method's Laplace fill for the drawing ``gray``
    (:func:`~inkray.numerics.grid.edge_weights`), kept for the last drawing asked.

    They depend on the drawing alone: an editor computes them while its depth
    map waits for the segmentation, and the :class:`DepthSession` of that
    drawing (the same array, unchanged) takes them from here.

    Parameters
    ----------
    gray : (H, W) float array in [0, 1]

    Returns
    -------
    wx : (H, W-1) float64 array
    wy : (H-1, W) float64 array

    Examples
    --------
    >>> import numpy as np
    >>> gray = np.ones((4, 5)); gray[:, 2] = 0.0
    >>> wx, wy = fill_weights(gray)
    >>> wx.shape, fill_weights(gray)[0] is wx
    ((4, 4), True)
    """
    global _kept_weights
    with _kept_lock:
        kept = _kept_weights
    if kept is not None and kept[0] is gray:
        return kept[1]
    weights = edge_weights(np.asarray(gray, np.float64))[:2]
    with _kept_lock:
        _kept_weights = gray, weights
    return weights


@dataclass
class DepthResult:
    """A depth map and how it was obtained.

    Attributes
    ----------
    depth : (H, W) float64 array
        Depth toward the viewer, zero mean, in units of epsilon's scale.
    method : str
        ``"exact"`` or ``"fast"``.
    epsilon : float
        The depth step of an ``order`` entry.
    info : dict
        ``exact``: ``kkt`` (measured KKT residuals), ``objective``,
        ``multipliers``, ``sigma``, ``timings``. ``fast``: ``levels``
        (``{label: level}`` for the segments, or parts of segments, holding
        endpoints), ``labels`` (the segmentation with those parts), ``timings``
        (seconds: ``segment``, ``laplace``) and, from a chain's kept session,
        ``draft`` (whether the fill was the half-resolution one, see
        :meth:`DepthSession.solve`).
    """

    depth: np.ndarray
    method: str
    epsilon: float
    info: dict = field(default_factory=dict)


def depth_constraints(annotations):
    """The ``order`` and ``equal`` entries as pixel-index constraints.

    Parameters
    ----------
    annotations : Annotations

    Returns
    -------
    p, q : (m,) int64 arrays
        Raster indices ``y * W + x`` of the rounded points: ``front``/``a``
        and ``back``/``b``.
    inequality : (m,) bool array
        True for ``order`` entries (``d[p] - d[q] >= epsilon``).
    labels : list of str
        ``"order[i]"`` / ``"equal[i]"``, the entries' key paths.

    Examples
    --------
    >>> from inkray.input.annotations import parse_annotations
    >>> ann = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [10, 10],
    ...     "order": [{"front": [1, 2], "back": [5.4, 5.6]}]})
    >>> p, q, ineq, labels = depth_constraints(ann)
    >>> p.tolist(), q.tolist(), labels
    ([21], [65], ['order[0]'])
    """
    w, h = annotations.size

    def pix(pt):
        x = min(max(int(np.floor(pt[0] + 0.5)), 0), w - 1)
        y = min(max(int(np.floor(pt[1] + 0.5)), 0), h - 1)
        return y * w + x

    p, q, ineq, labels = [], [], [], []
    for o in annotations.order:
        p.append(pix(o.front))
        q.append(pix(o.back))
        ineq.append(True)
        labels.append(f"order[{o.index}]")
    for e in annotations.equal:
        p.append(pix(e.a))
        q.append(pix(e.b))
        ineq.append(False)
        labels.append(f"equal[{e.index}]")
    return (np.array(p, np.int64), np.array(q, np.int64), np.array(ineq, bool), labels)


def depth(annotations, drawing, *, method="exact", epsilon=1.0, sigma=None,
          weight_floor=WEIGHT_FLOOR, segmentation=None, progress=None):
    """Depth map of a drawing from its annotation's ``order`` and ``equal`` entries.

    Parameters
    ----------
    annotations : Annotations
        Needs no regions; region and background scribbles, when present, seed
        the fast method's segmentation.
    drawing : Drawing or (H, W) float array
        Grey image in [0, 1], paper 1.
    method : {"exact", "fast"}, default "exact"
        The exact QP or the interactive approximation (see module docstring).
    epsilon : float, default 1.0
        Depth step of an ``order`` entry (> 0).
    sigma : float, optional
        Contrast scale of the edge weights (exact method); default the mean
        squared contrast of the image's edges, see :func:`inkray.numerics.grid.edge_weights`.
    weight_floor : float, default :data:`inkray.numerics.grid.WEIGHT_FLOOR`
        Smallest edge weight (exact method).
    segmentation : (H, W) int array, optional
        With regions: :func:`inkray.segmentation.segment`'s labels of this
        annotation, when the caller has them (computed otherwise). Both
        methods read the background and the regions from it, the fast
        method also its segments.
    progress : inkray.progress.Progress, optional

    Returns
    -------
    DepthResult

    Raises
    ------
    InputError
        Unknown method, bad epsilon, or contradictory constraints: with
        either method only when no depth map can satisfy them (the exact
        problem is infeasible); the message lists the entries, e.g.
        ``order[3] -> order[7] -> order[3]: ...``.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.input.annotations import parse_annotations
    >>> ann = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [9, 1],
    ...     "order": [{"front": [0, 0], "back": [8, 0]}]})
    >>> r = depth(ann, np.ones((1, 9)))
    >>> round(float(r.depth[0, 0] - r.depth[0, 8]), 6)
    1.0
    """
    if method not in METHODS:
        raise InputError(f"method: unknown method {method!r} "
                         f"(expected one of {', '.join(METHODS)})")
    if not (isinstance(epsilon, (int, float)) and np.isfinite(epsilon) and epsilon > 0):
        raise InputError(f"epsilon: expected a positive number, got {epsilon!r}")
    gray = np.asarray(getattr(drawing, "gray", drawing), np.float64)
    w, h = annotations.size
    if gray.shape != (h, w):
        raise InputError(f"drawing: the image is {gray.shape[1]}x{gray.shape[0]} but the "
                         f"annotation is for {w}x{h}")
    p, q, ineq, labels = depth_constraints(annotations)
    same = np.flatnonzero(ineq & (p == q))
    if len(same):
        y, x = divmod(int(p[same[0]]), w)
        raise InputError(f"{labels[same[0]]}: front and back round to the same pixel ({x}, {y})")
    check_constraints(p, q, ineq, labels)
    # With regions, the segments are the relief's (inkray.segmentation.segment).
    seg = None
    if annotations.regions:
        seg = segmentation if segmentation is not None else _segments(annotations, drawing,
                                                                        progress)
    if method == "exact":
        if seg is not None:
            p, q, ineq, labels = _with_background_behind(seg, p, q, ineq, labels)
        return _exact(gray, p, q, ineq, labels, epsilon, sigma, weight_floor, progress)
    session = DepthSession(gray, epsilon=epsilon,
                           seeds=None if seg is not None else _scribble_seeds(annotations),
                           labels=seg, incremental=False, progress=progress)
    for i in range(len(p)):
        session.add(p[i], q[i], inequality=bool(ineq[i]), label=labels[i])
    if progress is not None:
        with progress.stage("depth (fast)"):
            d = session.solve()
    else:
        d = session.solve()
    return DepthResult(depth=d, method="fast", epsilon=float(epsilon),
                       info={"levels": session.region_levels, "labels": session.parts,
                             "timings": dict(session.timings)})


def _exact(gray, p, q, ineq, labels, epsilon, sigma, weight_floor, progress):
    h, w = gray.shape
    if h * w < 2:
        raise InputError("drawing: needs at least 2 pixels")

    def run():
        wx, wy, s = edge_weights(gray, sigma=sigma, floor=weight_floor)
        L = grid_laplacian(wx, wy)
        if len(p) == 0:
            return np.zeros(h * w), {"sigma": s, "kkt": {}, "objective": 0.0,
                                     "multipliers": np.zeros(0), "timings": {}}
        r = solve_depth_qp(L, p, q, ineq, epsilon=epsilon, shape=(h, w), labels=labels,
                           progress=progress)
        return r.depth, {"sigma": s, "kkt": r.kkt, "objective": r.objective,
                         "multipliers": r.multipliers, "timings": r.timings,
                         "iterations": r.iterations}

    if progress is not None:
        with progress.stage("depth (exact QP)"):
            d, info = run()
    else:
        d, info = run()
    return DepthResult(depth=d.reshape(h, w), method="exact", epsilon=float(epsilon), info=info)


def _scribble_seeds(annotations):
    """Region scribbles as labels 0..R-1 and background scribbles as -1, or None."""
    if not annotations.regions and not annotations.background and \
            annotations.background_pixels is None:
        return None
    from inkray.input.scribbles import seed_image

    return seed_image(annotations)


def _segments(annotations, drawing, progress):
    from inkray.segmentation import segment

    return segment(annotations, drawing, progress=progress).labels


def _on_background(labels):
    """The region labels 4-adjacent to the background, sorted."""
    out = set()
    for a, b in ((labels[:, :-1], labels[:, 1:]), (labels[:-1], labels[1:])):
        edge = (a == BACKGROUND) != (b == BACKGROUND)
        out.update(np.unique(np.where(a[edge] == BACKGROUND, b[edge], a[edge])).tolist())
    return sorted(out)


def _with_background_behind(lab, p, q, ineq, labels):
    """The constraints, with the background behind every region touching it when no
    entry has a point on the background: along the contact of each region piece
    (4-connected area of one label) with each background piece, one order per
    cell of a grid of :func:`_contact_spacing` pixels, from a pixel of the piece
    to its background neighbour, and those background pixels held equal. ``lab``
    is the segmentation of the scribbles."""
    if (lab.flat[np.concatenate([p, q])] == BACKGROUND).any():
        return p, q, ineq, labels
    h, w = lab.shape
    piece = np.zeros(lab.shape, np.int64)
    n = 0
    for v in range(BACKGROUND, int(lab.max()) + 1):
        comp, k = ndimage.label(lab == v)
        np.add(comp, n, out=piece, where=comp > 0)
        n += k
    size = np.bincount(piece.ravel(), minlength=n + 1)
    flat = np.arange(h * w).reshape(h, w)
    front, back = [], []
    for a, b in ((np.s_[:, :-1], np.s_[:, 1:]), (np.s_[:-1], np.s_[1:])):
        la, lb = lab[a], lab[b]
        on = ((la == BACKGROUND) != (lb == BACKGROUND)) & \
            (size[piece[a]] >= _MIN_PIECE) & (size[piece[b]] >= _MIN_PIECE)
        fa, fb = flat[a][on], flat[b][on]
        bg = lab.flat[fa] == BACKGROUND
        front.append(np.where(bg, fb, fa))
        back.append(np.where(bg, fa, fb))
    front, back = np.concatenate(front), np.concatenate(back)
    if not len(front):
        return p, q, ineq, labels
    s = _contact_spacing(lab.shape)
    y, x = np.divmod(front, w)
    cell = (y // s) * (w // s + 1) + x // s
    key = (piece.flat[front] * (n + 1) + piece.flat[back]) * ((h // s + 1) * (w // s + 1)) + cell
    _, first = np.unique(key, return_index=True)
    front, back = front[first], back[first]
    # The background is one level, as in the fast method: its pixels in the orders
    # are held equal (a chain), so no part can sink below the paper elsewhere.
    ground = np.unique(back)
    names = [f"background behind regions[{lab.flat[v]}]" for v in front]
    names += ["the background's one level"] * (len(ground) - 1)
    return (np.concatenate([p, front, ground[1:]]), np.concatenate([q, back, ground[:-1]]),
            np.concatenate([ineq, np.ones(len(front), bool), np.zeros(len(ground) - 1, bool)]),
            list(labels) + names)


def _contact_spacing(shape):
    """Pixels between the exact method's implicit orders along a contact: 5 % of the
    longer side, at least 16."""
    return max(16, int(0.05 * max(shape)))


class DepthSession:
    """Interactive depth from (in)equalities: the fast method with caches.

    Add and remove constraints, then :meth:`solve`. Nodes of the region graph
    are the segments of a LazyBrush labelling: of the region and background
    scribbles when given (replaced by :meth:`reseed`), otherwise of seeds at
    the constraint endpoints (a small disk of paper around each; a new
    endpoint re-segments only the segment it lands in, a removed one only
    its own). The Laplace fill is one system over the grid (fixed pixels as
    identity rows, :class:`~inkray.numerics.harmonic_fill.HarmonicFill`) whose
    nested-dissection factorization is kept and updated in place: a change
    that moves the fixed pixels only inside a window refactors the fronts of
    that window and their ancestors, and a change that only moves levels, or
    also fixes a few more pixels, costs one solve. A fill over a large box
    with no factorization to reuse (the first solve, or every solve without
    ``incremental``) is solved on a reduced system of quadtree blocks away
    from ink instead (:data:`REDUCED_ABOVE`), and :meth:`prepare` factors
    the exact system for the edits after it. A draft solve keeps its
    own half-resolution fill, updated alike.

    Parameters
    ----------
    gray : (H, W) float array in [0, 1]
        The drawing, paper 1.
    epsilon : float, default 1.0
        Depth step of an inequality.
    seeds : (H, W) int array, optional
        Region scribbles ``0..R-1`` and background ``-1`` (``-2`` elsewhere),
        as :func:`inkray.input.scribbles.seed_image` makes. When given, they alone
        define the regions, and unless an entry has a point on the background
        (label ``-1``) every region touching it lies in front of it: the
        background is one more node of the region graph, below each of them.
    labels : (H, W) int array, optional
        Instead of ``seeds``, their segmentation, when the caller has it
        (:func:`inkray.segmentation.segment`'s, the relief's: regions
        ``0..R-1``, background ``-1``).
    incremental : bool, default True
        Keep what a re-solve reuses: the fill's factorization and, after
        :meth:`prepare` or once a change needed more than pinning, its
        update matrices (up to about 0.4 GB for a 512x512 drawing, 2 GB at
        1024x1024; see :class:`~inkray.numerics.harmonic_fill.HarmonicFill`).
        Without it every :meth:`solve` factors the fill afresh.
    progress : inkray.progress.Progress, optional
        Its ``update(done, total)`` while the fill is factored afresh.

    Examples
    --------
    >>> import numpy as np
    >>> gray = np.ones((20, 20)); gray[:, 10] = 0.0           # one vertical ink line
    >>> s = DepthSession(gray)
    >>> k = s.add((3, 5), (15, 5))                            # left in front of right
    >>> d = s.solve()
    >>> bool(d[:, :10].min() > d[:, 11:].max())
    True
    >>> s.remove(k); float(np.abs(s.solve()).max())
    0.0
    """

    def __init__(self, gray, *, epsilon=1.0, seeds=None, labels=None, incremental=True,
                 progress=None):
        self._drawing = gray  # as given: its fill weights may be kept (fill_weights)
        self.gray = np.asarray(gray, np.float64)
        if self.gray.ndim != 2:
            raise InputError(f"gray: expected an (H, W) image, got shape {self.gray.shape}")
        if not epsilon > 0:
            raise InputError(f"epsilon: expected a positive depth step, got {epsilon}")
        self.epsilon = float(epsilon)
        h, w = self.shape = self.gray.shape
        self._scribbles, self._given = self._checked(seeds, labels)
        self._constraints = {}  # handle -> (p, q, inequality, label)
        self._next = 0
        self._endpoint_label = {}  # endpoint pixel -> its seed label (endpoint mode)
        self._dirty = set()     # endpoint pixels added or removed since the last segmentation
        self.labels = None      # (H, W) int32 segmentation, None before the first solve
        self._on_background = []  # the region labels touching the background, with scribbles
        self._fills = {}        # draft -> HarmonicFill or DraftFill, kept and updated
        self._answer = None     # (fixed, their values, fill) of the last full fill
        self._changes = 0       # constraints added or removed and reseeds so far
        self._solved = None     # (changes, depth map) of the last solve by the full fill
        self._drafted = False   # whether the last fill was the half-resolution one
        self._weights = None    # the image's edge weights (wx, wy), once
        self._incremental = bool(incremental)
        self._progress = progress
        self._ink = self.gray < INK_LEVEL
        self._radius = max(2, int(round(0.01 * max(h, w))))
        self.parts = None       # the segmentation with split segments, after solve()
        self._split_cache = {}  # (segment, endpoint groups) -> labels of its parts
        self.region_levels = {}  # label in ``parts`` -> level, after solve()
        self.timings = {}       # of the last solve: "segment", "laplace"
        self.refactored_fronts = 0  # fronts of the fill factored by the last solve()
        self._warming = None    # the thread factoring the draft fill in prepare(), if any

    def prepare(self, *, background=False, progress=None):
        """Ready the kept fill for the next change, in time nobody waits on.

        A cold :meth:`solve` factors the fill without what an update reuses
        (about half the time); this factors it again keeping that, so that
        the next change that pinning cannot follow (a new scribble, a new
        part's level) refactors only the fronts it touches. The answers do
        not change. See :meth:`inkray.numerics.harmonic_fill.HarmonicFill.prepare`.
        After a cold solve on the reduced system it factors the exact fill,
        and above :data:`DRAFT_ABOVE` pixels also the draft's half-resolution
        one (a cold open skips the draft), so that the next edit's draft is
        an update; a draft asked for before that is done is the full fill.

        Parameters
        ----------
        background : bool, default False
            Factor in a thread and return at once: the next :meth:`solve`
            waits for it only when it needs the update matrices.
        progress : object with ``update(done, total)``, optional
            May raise to stop (the session stays as it was).

        Returns
        -------
        bool
            Whether there was anything to do.

        Examples
        --------
        >>> import numpy as np
        >>> gray = np.ones((20, 20)); gray[4:, 10] = 0.0          # a line with a gap
        >>> s = DepthSession(gray)
        >>> k = s.add((3, 15), (15, 15)); d = s.solve()
        >>> s.prepare(), s.prepare()
        (True, False)
        """
        fill = self._fills.get(False)
        started = fill is not None and fill.prepare(background=background, progress=progress)
        answer = self._answer
        if answer is None or not self._incremental or True in self._fills or \
                self._warming is not None or self.gray.size <= DRAFT_ABOVE:
            return started
        fixed, vals = answer[0], np.zeros(self.shape)
        vals[fixed] = answer[1]
        draft = DraftFill(*self._weights, incremental=True)

        def warm():
            try:
                draft.solve(fixed, vals)
                self._fills[True] = draft
            finally:
                self._warming = None

        if background:
            self._warming = threading.Thread(target=warm, name="DepthSession.prepare",
                                             daemon=True)
            self._warming.start()
        else:
            warm()
        return True

    def reseed(self, seeds=None, *, labels=None):
        """Replace the region and background scribbles (``seeds`` or their ``labels``,
        as for the constructor).

        The next :meth:`solve` segments afresh (or takes the given labels); the
        fill's factorization is
        kept and updated, so it refactors only the fronts where the fixed
        pixels moved (where the segments changed), not the whole grid.
        """
        self._scribbles, self._given = self._checked(seeds, labels)
        self._changes += 1
        self.labels = None
        self._split_cache = {}
        self._dirty = set()

    def _checked(self, seeds, labels):
        """The scribbles as an int32 image (None when there are none; the labels when
        given) and the given labels."""
        for name, a in (("seeds", seeds), ("labels", labels)):
            if a is not None and np.shape(a) != self.shape:
                raise InputError(f"{name}: shape {np.shape(a)} differs from the drawing's "
                                 f"{self.shape}")
        if labels is not None:
            labels = np.asarray(labels, np.int32)
            return labels, labels
        if seeds is None:
            return None, None
        seeds = np.asarray(seeds, np.int32)
        return (seeds if (seeds != -2).any() else None), None

    # -- constraints ------------------------------------------------------------

    def add(self, p, q, *, inequality=True, label=None):
        """Add ``d[p] - d[q] >= epsilon`` (or ``d[p] = d[q]``).

        Parameters
        ----------
        p, q : int or (x, y)
            Raster index ``y * W + x`` or a point ``(x, y)`` (rounded).
        inequality : bool, default True
        label : str, optional
            Name used in error messages (default ``order[k]``/``equal[k]``
            with ``k`` the handle).

        Returns
        -------
        int
            A handle for :meth:`remove`.
        """
        p, q = self._index(p), self._index(q)
        k = self._next
        if label is None:
            label = f"{'order' if inequality else 'equal'}[{k}]"
        if inequality and p == q:
            raise InputError(f"{label}: front and back are the same pixel")
        self._next += 1
        self._changes += 1
        self._constraints[k] = (p, q, bool(inequality), label)
        for v in (p, q):
            if v not in self._endpoint_label:
                self._endpoint_label[v] = None
                self._dirty.add(v)
        return k

    def remove(self, handle):
        """Remove the constraint ``handle`` returned by :meth:`add`."""
        if handle not in self._constraints:
            raise InputError(f"constraint {handle}: no such constraint in this session")
        p, q, _, _ = self._constraints.pop(handle)
        self._changes += 1
        used = {v for c in self._constraints.values() for v in c[:2]}
        for v in (p, q):
            if v not in used and v in self._endpoint_label:
                del self._endpoint_label[v]
                self._dirty.add(v)

    def _index(self, v):
        h, w = self.shape
        if np.ndim(v) == 0:
            v = int(v)
            if not 0 <= v < h * w:
                raise InputError(f"pixel index {v} lies outside the {w}x{h} drawing")
            return v
        fx, fy = (float(c) for c in v)
        # The drawing covers [-0.5, W - 0.5]: its edge rounds into the last pixel.
        if not (-0.5 <= fx <= w - 0.5 and -0.5 <= fy <= h - 0.5):
            raise InputError(f"point ({fx:g}, {fy:g}) lies outside the {w}x{h} drawing")
        x = min(max(int(np.floor(fx + 0.5)), 0), w - 1)
        y = min(max(int(np.floor(fy + 0.5)), 0), h - 1)
        return y * w + x

    def constraints(self):
        """The current constraints as ``p, q, inequality, labels`` (handle order)."""
        items = sorted(self._constraints.items())
        p = np.array([c[0] for _, c in items], np.int64)
        q = np.array([c[1] for _, c in items], np.int64)
        ineq = np.array([c[2] for _, c in items], bool)
        return p, q, ineq, [c[3] for _, c in items]

    # -- solve ------------------------------------------------------------------

    def solve(self, *, draft=False):
        """The depth map for the current constraints.

        Parameters
        ----------
        draft : bool, default False
            Above :data:`DRAFT_ABOVE` pixels, solve the Laplace fill of step
            (4) on a half-resolution grid (:class:`~inkray.numerics.harmonic_fill.DraftFill`,
            about a third of the time at 1 Mpx; the levels and the fixed
            pixels stay exact). Draft and full fills keep their own
            factorizations (the draft's about a quarter of the full one's
            memory). When the full fill works on a box of at most
            :data:`DRAFT_ABOVE` pixels (its fixed values settle the rest), the
            draft is the full fill; :attr:`drafted` says which one answered.

        Returns
        -------
        (H, W) float64 array
            Zero mean; all zeros without constraints.

        Raises
        ------
        InputError
            Contradictory constraints: a cycle of the entries themselves (the
            entries are listed). Entries that only disagree about whole
            regions cut those regions into parts instead.
        """
        if self._solved is not None and self._solved[0] == self._changes:
            # nothing changed since the full fill answered (a draft request that got
            # the full map on opening, then the full request)
            return self._solved[1].copy()
        h, w = self.shape
        p, q, ineq, labels = self.constraints()
        check_constraints(p, q, ineq, labels)  # point-level cycles, before any work
        self.timings = {}
        self._drafted = False
        if not len(p) and self._scribbles is None:
            return self._flat()
        t = time.perf_counter()
        self._segment()
        self.timings["segment"] = time.perf_counter() - t
        t = time.perf_counter()
        behind = []
        if self._scribbles is not None and \
                not (self.labels.flat[np.concatenate([p, q])] == BACKGROUND).any():
            behind = self._on_background  # no entry mentions the background
        if not len(p) and not len(behind):
            return self._flat()
        groups, level = _local_levels(p, q, ineq, self.labels, behind=behind)
        lab = self._split(groups)
        self.parts = lab
        self.region_levels = {int(lab.flat[g[0]]): level[g[0]]
                              for parts in groups.values() for g in parts}
        lo = int(lab.min())
        value = np.full(int(lab.max()) - lo + 1, np.nan)
        for k, v in self.region_levels.items():
            value[k - lo] = self.epsilon * v
        lvl = value[lab - lo]  # NaN on segments without endpoints: they are free
        fixed = np.zeros((h, w), bool)
        # Segment boundaries on ink are steps: both sides keep their level.
        for axis in (0, 1):
            a = [slice(None)] * 2
            b = [slice(None)] * 2
            a[axis], b[axis] = slice(None, -1), slice(1, None)
            a, b = tuple(a), tuple(b)
            step = (lab[a] != lab[b]) & (self._ink[a] | self._ink[b])
            fixed[a] |= step & ~np.isnan(lvl[a])
            fixed[b] |= step & ~np.isnan(lvl[b])
        fixed.flat[np.concatenate([p, q])] = True
        d = self._fill(fixed, lvl, draft)  # the fills read lvl on the fixed pixels only
        d -= d.mean()
        self.timings["laplace"] = time.perf_counter() - t
        if not self._drafted:
            self._solved = self._changes, d.copy()
        return d

    @property
    def drafted(self):
        """Whether the last :meth:`solve` was answered by the half-resolution fill
        (a draft), not the full one."""
        return self._drafted

    def _flat(self):
        """No entry and no default order: one depth everywhere."""
        self._dirty = set()
        self.region_levels = {}
        self.parts = self.labels
        return np.zeros(self.shape)

    def _segment(self):
        from inkray.segmentation import lazybrush

        if self.labels is not None and not self._dirty:
            return
        self._split_cache = {}
        if self._scribbles is not None:
            if self.labels is None:
                self.labels = self._given if self._given is not None else lazybrush(
                    self.gray, self._scribbles, frame_background=False)
                self._on_background = _on_background(self.labels)
            self._dirty = set()
            return
        if self.labels is None:
            self._fresh()
            return
        # Re-segment only where the changed endpoints lie: a removed endpoint's
        # whole segment (its label goes), for a new one the part of its host
        # segment within a window around it (the new label cannot reach
        # farther; a cut at the window edge runs through paper and the Laplace
        # fill keeps the depth smooth across it).
        h, w = self.shape
        nxt = max([k for k in self._endpoint_label.values() if k is not None] + [-1]) + 1
        area = np.zeros(self.shape, bool)
        r = max(32, int(0.1 * max(h, w)))
        for v in sorted(self._dirty):
            seg = self.labels == self.labels.flat[v]
            if self._endpoint_label.get(v, 0) is None:
                self._endpoint_label[v] = nxt
                nxt += 1
                y, x = divmod(v, w)
                window = np.zeros(self.shape, bool)
                window[max(y - r, 0):y + r + 1, max(x - r, 0):x + r + 1] = True
                seg &= window
            area |= seg
        self._dirty = set()
        # Apart areas (the two ends of a long order) are cut one crop each.
        parts, n = ndimage.label(area)
        for c in range(1, n + 1):
            self._resegment(parts == c)

    def _split(self, groups):
        """The segmentation with every segment whose endpoints need several levels
        cut into one part per group (LazyBrush seeded at the groups' endpoints)."""
        lab = self.labels
        split = {seg: parts for seg, parts in groups.items() if len(parts) > 1}
        if not split:
            return lab
        from inkray.segmentation import lazybrush

        h, w = self.shape
        lab = lab.copy()
        nxt = int(lab.max()) + 1
        for seg in sorted(split):
            parts = split[seg]
            key = (seg, tuple(tuple(g) for g in parts))
            if key not in self._split_cache:
                area = self.labels == seg
                rows = np.flatnonzero(area.any(axis=1))
                cols = np.flatnonzero(area.any(axis=0))
                r0, r1 = max(rows[0] - 2, 0), min(rows[-1] + 3, h)
                c0, c1 = max(cols[0] - 2, 0), min(cols[-1] + 3, w)
                inside = area[r0:r1, c0:c1]
                # Outside the segment counts as ink: cutting there is free, so
                # the cut between the parts runs inside the segment.
                gray = np.where(inside, self.gray[r0:r1, c0:c1], 0.0)
                seeds = np.full(inside.shape, -2, np.int32)
                for k, group in enumerate(parts):
                    for v in group:
                        yy, xx = self._disk(v)
                        yy, xx = yy - r0, xx - c0
                        keep = inside[yy, xx]
                        seeds[yy[keep], xx[keep]] = k
                # Coarse to fine from 0.1 Mpx: the free paths around the segment
                # (ink, cost 0) made the direct cut slow (the rings' at 1 Mpx: 0.55 s,
                # 0.07 s coarse to fine, the same depth map).
                cut = lazybrush(gray, seeds, frame_background=False, seed_strength=_SEED_STRENGTH,
                                coarse_to_fine=inside.size > 100_000)
                for k, group in enumerate(parts):
                    for v in group:  # an endpoint always lies in its own part
                        y, x = divmod(v, w)
                        cut[y - r0, x - c0] = k
                self._split_cache[key] = ((r0, r1, c0, c1), np.where(inside, cut, -1))
            (r0, r1, c0, c1), cut = self._split_cache[key]
            window = lab[r0:r1, c0:c1]
            # The first part keeps the segment's label, the others get new ones.
            ids = np.array([seg] + list(range(nxt, nxt + len(parts) - 1)), np.int32)
            nxt += len(parts) - 1
            lab[r0:r1, c0:c1] = np.where(cut >= 0, ids[np.maximum(cut, 0)], window)
        return lab

    def _disk(self, v):
        """Seed pixels of endpoint ``v``: the paper within a small disk that connects to it."""
        h, w = self.shape
        y, x = divmod(v, w)
        r = self._radius
        r0, r1, c0, c1 = max(y - r, 0), min(y + r + 1, h), max(x - r, 0), min(x + r + 1, w)
        yy, xx = np.mgrid[r0:r1, c0:c1]
        disk = ((yy - y) ** 2 + (xx - x) ** 2 <= r * r) & ~self._ink[r0:r1, c0:c1]
        disk[y - r0, x - c0] = True
        comp, _ = ndimage.label(disk)
        sel = comp == comp[y - r0, x - c0]
        return yy[sel], xx[sel]

    def _seed_endpoints(self, seeds, offset=(0, 0), inside=None):
        y0, x0 = offset
        for v, k in sorted(self._endpoint_label.items()):
            yy, xx = self._disk(v)
            yy, xx = yy - y0, xx - x0
            ok = (yy >= 0) & (yy < seeds.shape[0]) & (xx >= 0) & (xx < seeds.shape[1])
            yy, xx = yy[ok], xx[ok]
            if inside is not None:
                keep = inside[yy, xx]
                yy, xx = yy[keep], xx[keep]
            seeds[yy, xx] = k

    def _fresh(self):
        from inkray.segmentation import lazybrush

        for i, v in enumerate(sorted(self._endpoint_label)):
            self._endpoint_label[v] = i
        seeds = np.full(self.shape, -2, np.int32)
        self._seed_endpoints(seeds)
        self.labels = lazybrush(self.gray, seeds, frame_background=False,
                                seed_strength=_SEED_STRENGTH)
        self._pin()
        self._dirty = set()

    def _pin(self):
        for v, k in self._endpoint_label.items():
            self.labels.flat[v] = k  # an endpoint always keeps its own label

    def _resegment(self, area):
        from inkray.segmentation import lazybrush

        h, w = self.shape
        rows = np.flatnonzero(area.any(axis=1))
        cols = np.flatnonzero(area.any(axis=0))
        r0, r1 = max(rows[0] - 2, 0), min(rows[-1] + 3, h)
        c0, c1 = max(cols[0] - 2, 0), min(cols[-1] + 3, w)
        crop = (slice(r0, r1), slice(c0, c1))
        inside = area[crop]
        # Outside the area the labels stay; they take part as hard seeds.
        seeds = np.where(inside, -2, self.labels[crop]).astype(np.int32)
        self._seed_endpoints(seeds, (r0, c0), inside)
        new = lazybrush(self.gray[crop], seeds, frame_background=False,
                        seed_strength=_SEED_STRENGTH)
        self.labels[crop] = np.where(inside, new, self.labels[crop])
        self._pin()

    def _fill(self, fixed, vals, draft):
        """The harmonic fill for ``vals`` on ``fixed``, by the kept fill of the full grid
        or, for a draft above :data:`DRAFT_ABOVE` pixels, of the half-resolution one.

        A draft is the full fill when that works on a box of at most
        :data:`DRAFT_ABOVE` pixels (as fast, and exact), or when it has no kept
        factorization and answers from the reduced system (as fast as a draft,
        closer to the exact fill); the full solve that follows is then that answer."""
        self._drafted = False
        if self._answer is not None and not draft and np.array_equal(fixed, self._answer[0]) \
                and np.array_equal(vals[fixed], self._answer[1]):
            self.refactored_fronts = 0
            return self._answer[2].copy()
        self._answer = None
        if self._weights is None:
            self._weights = fill_weights(self._drawing)
        if False not in self._fills:
            self._fills[False] = HarmonicFill(*self._weights, incremental=self._incremental,
                                              progress=self._progress, reduced_above=REDUCED_ABOVE)
        full = self._fills[False]
        # The draft's own fill unless the full one is as fast (a small box, or the
        # reduced system), or the draft's is being factored by prepare().
        draft = draft and self.gray.size > DRAFT_ABOVE and self._warming is None and \
            full.pending(fixed, vals) > DRAFT_ABOVE and not full.reduces(fixed, vals)
        if draft not in self._fills:
            self._fills[draft] = DraftFill(*self._weights, incremental=self._incremental,
                                           progress=self._progress)
        fill = self._fills[draft]
        self._drafted = draft
        d = fill.solve(fixed, vals)
        self.refactored_fronts = fill.refactored_fronts
        if not draft:
            self._answer = fixed, vals[fixed], d.copy()
        return d


def _local_levels(p, q, ineq, labels, *, behind=()):
    """Levels of the endpoints, and how each segment's endpoints group.

    The endpoints of one segment share a level (the segment is one node of
    the region graph) as long as that contradicts no entry; otherwise they
    form as few groups as needed (greedily, in pixel order), each a part of
    the segment with its own level. Two rings that cross twice, or an entry
    with both points in one segment, so give a segment two parts. Only a
    cycle of the entries themselves (checked before) is a contradiction.
    Every part of the segments ``behind`` lies in front of the background
    (:data:`BACKGROUND`, which no endpoint may lie in); a segment or the
    background without endpoints is then one group of its first pixel.

    Returns
    -------
    groups : dict
        ``{segment label: [[endpoint pixel, ...], ...]}``, one list per part.
    level : dict
        ``{endpoint pixel: level}``.
    """
    edges = [(int(p[i]), int(q[i]), bool(ineq[i])) for i in range(len(p))]
    by_segment = {}
    for v in sorted({e[0] for e in edges} | {e[1] for e in edges}):
        by_segment.setdefault(int(labels.flat[v]), []).append(v)
    groups = {}
    adjacent = {}  # node -> [(next node, strict)]: orders front to back, equalities both ways
    for front, back, strict in edges:
        _link(adjacent, front, back, strict)
    for seg in sorted(by_segment):
        ends = by_segment[seg]
        together = [(ends[0], v, False) for v in ends[1:]]
        if _acyclic(edges + together):  # the usual case: one check per segment
            parts = [ends]
            for _, v, _ in together:
                _link(adjacent, ends[0], v, False)
        else:
            parts = []
            for v in ends:
                part = next((g for g in parts if not _ordered_between(adjacent, g[0], v)), None)
                if part is None:
                    parts.append([v])
                else:
                    part.append(v)
                    _link(adjacent, part[0], v, False)
        edges += [(part[0], v, False) for part in parts for v in part[1:]]
        groups[seg] = parts
    if len(behind):
        flat = labels.ravel()
        back = int(np.argmax(flat == BACKGROUND))
        groups[BACKGROUND] = [[back]]
        for seg in behind:
            parts = groups.setdefault(seg, [[int(np.argmax(flat == seg))]])
            edges += [(part[0], back, True) for part in parts]
    return groups, _graph(edges).levels()


def _link(adjacent, front, back, strict):
    adjacent.setdefault(front, []).append((back, strict))
    if not strict:
        adjacent.setdefault(back, []).append((front, False))


def _ordered_between(adjacent, u, v):
    """Whether a chain of relations with an order on it leads from ``u`` to ``v`` or
    back: then the two cannot share a level."""
    for start, goal in ((u, v), (v, u)):
        seen = {(start, False)}
        todo = [(start, False)]
        while todo:
            node, strict = todo.pop()
            for nxt, s in adjacent.get(node, ()):
                state = (nxt, strict or s)
                if state == (goal, True):
                    return True
                if state not in seen:
                    seen.add(state)
                    todo.append(state)
    return False


def _graph(edges):
    graph = OrderGraph()
    for front, back, strict in edges:
        graph.add(front, back, strict=strict)
    return graph


def _acyclic(edges):
    try:
        _graph(edges).levels()
    except ValueError:
        return False
    return True
