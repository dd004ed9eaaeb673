"""Harmonic fill: the weighted Laplace equation on a pixel grid with Dirichlet pixels.

Given an image's 4-neighbour edge weights ``w_pq`` (:func:`inkray.numerics.grid.edge_weights`,
Grady, "Random walks for image segmentation", PAMI 2006) and values on a set
of fixed pixels, the fill is the ``d`` that equals those values on the fixed
pixels and minimizes ``sum w_pq (d_p - d_q)^2`` elsewhere: on every free
pixel ``sum_q w_pq (d_p - d_q) = 0``. It is the smoothing step of Sýkora et
al., "Adding Depth to Cartoons Using Sparse Depth (In)equalities" (CGF 2010).

:class:`HarmonicFill` solves it as one system over the whole grid (a fixed
pixel's row and column are the identity, its couplings move to the
right-hand side) and keeps the grid Cholesky factorization
(:mod:`inkray.numerics.grid_cholesky`) to update it in place when the fixed
set moves. A cold solve over a large box can answer instead from the reduced
system of :func:`inkray.numerics.quadtree_fill.quadtree_fill` (quadtree
blocks away from ink) and leave the exact factorization to :meth:`HarmonicFill.prepare`.
:class:`DraftFill` solves the same problem on a grid half as fine
and interpolates back, for previews at about a third of the cost.
"""

import threading

import numpy as np
from scipy import ndimage

from inkray.errors import InputError
from inkray.numerics.grid import grid_degree
from inkray.numerics.grid_cholesky import GridCholesky
from inkray.numerics.quadtree_fill import quadtree_fill

__all__ = ["DraftFill", "HarmonicFill", "settle"]

#: At most this many pixels fixed since the fill was factored are pinned by
#: point sources instead of refactoring (an arrow fixes its two endpoints; a
#: new level's segment its outline). At 1 Mpx pinning 120 pixels costs about
#: a refactoring of a typical edit, 5 pixels a fifth of it.
PINNED = 128


class HarmonicFill:
    """The harmonic fill of an image's grid, factored once and updated in place.

    Only what the fixed values do not settle is solved. The free pixels fall
    into 4-connected components, each its own block of the system; a
    component whose fixed neighbours all hold one value is that value (the
    harmonic function with constant boundary values), so it is set and left
    out. The other components are solved together on the box that bounds
    them (the other pixels of the box as identity rows), by a grid Cholesky
    factorization that is kept: a later solve whose components still fit in
    the box updates it in place, refactoring the fronts of the pixels whose
    rows changed and their ancestors, and a change that only adds a few
    fixed pixels (at most :data:`PINNED`) refactors nothing: the factored
    system pins them by point sources (:meth:`GridCholesky.solve_pinned`),
    one solve. Components that outgrow the box make a new factorization
    over the union of both boxes. The first factorization keeps no update
    matrices (a cold solve takes about half the time); :meth:`prepare`, run
    while nothing else waits (an editor between edits), factors the same
    system again keeping them, so that the next change is an update. A
    change that pinning cannot follow before that factors afresh, keeping
    them from then on.

    With ``reduced_above``, a solve that has no kept factorization to reuse
    (none yet, or ``incremental`` off) and whose box holds more pixels than
    that answers from the reduced system of
    :func:`~inkray.numerics.quadtree_fill.quadtree_fill` instead (within about
    0.02 of the fixed values' spacing on 1 Mpx drawings, in a third of the
    time) and factors nothing; :meth:`prepare` then factors the exact system
    of those fixed values, and the solves after it are exact again.

    Parameters
    ----------
    wx : (H, W-1) float array
        Positive weights between ``(y, x)`` and ``(y, x+1)``.
    wy : (H-1, W) float array
        Positive weights between ``(y, x)`` and ``(y+1, x)``.
    incremental : bool, default True
        Keep the factorization between solves, and from the second one on
        what an update reuses (its update matrices, about three times the
        factor: 0.4 GB for a 512x512 box, 2 GB at 1024x1024); without it
        every :meth:`solve` factors afresh.
    progress : inkray.progress.Progress, optional
        Its ``update(done, total)`` while the fill is factored afresh.
    reduced_above : int, optional
        Boxes above this many pixels are solved cold on the reduced system
        (default: never).

    Attributes
    ----------
    refactored_fronts : int
        Fronts of the factorization the last :meth:`solve` factored.
    reduced : bool
        Whether the last :meth:`solve` answered from the reduced system.
    box : tuple of int or None
        ``(r0, r1, c0, c1)``, the rows and columns the kept factorization
        covers (None before the first solve that needed one).

    Examples
    --------
    >>> import numpy as np
    >>> fill = HarmonicFill(np.ones((5, 8)), np.ones((4, 9)))
    >>> fixed = np.zeros((5, 9), bool); fixed[:, 0] = fixed[:, -1] = True
    >>> d = fill.solve(fixed, np.where(fixed, np.arange(9.0), 0.0))
    >>> np.allclose(d, np.arange(9.0))          # a linear ramp between the two columns
    True
    >>> fixed[:, 4] = True                      # a fixed column at 4: each side is constant
    >>> d = fill.solve(fixed, np.where(fixed, 4.0, 0.0))
    >>> bool((d == 4.0).all()), fill.refactored_fronts
    (True, 0)
    """

    def __init__(self, wx, wy, *, incremental=True, progress=None, reduced_above=None):
        wx, wy = np.asarray(wx, np.float64), np.asarray(wy, np.float64)
        self.shape = _grid_shape(wx, wy)
        self._weights = wx, wy, grid_degree(wx, wy)
        self._incremental = bool(incremental)
        self._progress = progress
        self._reduced_above = reduced_above
        self._unfactored = None  # (fixed, values) of the last reduced solve, for prepare()
        self.reduced = False
        self._chol = None       # the factorization over self.box, updated in place
        self.box = None
        self._factored = None   # the box's pixels it holds as identity rows
        self._operator = None   # the factored operator (diag, east, south), kept in step
        self._preparing = None  # a background prepare(): (thread, outcome, stop, base)
        self._settled = None    # (fixed, values on them, settle's out, free) of the last ones
        self.refactored_fronts = 0

    def solve(self, fixed, values):
        """The fill for Dirichlet ``values`` on the ``fixed`` pixels.

        Parameters
        ----------
        fixed : (H, W) bool array
        values : (H, W) float array
            Read on the fixed pixels only.

        Returns
        -------
        (H, W) float64 array
            ``values`` on the fixed pixels, harmonic elsewhere.
        """
        fixed = _checked(self.shape, fixed, values)
        out, free = self._settle(fixed, values)
        out = out.copy()
        self.refactored_fronts = 0
        self.reduced = False
        if not free.any():
            return out
        self._adopt(wait=False)
        box = _bounds(free)
        if self._reduces(box):
            # A prepare() of the exact system under way goes on when this box fits in
            # its own (its factorization serves the solves after it).
            if self._preparing is not None and not _inside(box, self.box):
                self._stop_preparing()
            self._unfactored = fixed.copy(), np.where(fixed, values, 0.0)
            self.reduced = True
            return quadtree_fill(*self._weights[:2], ~free, out)
        self._unfactored = None
        kept = self._chol is not None and self._incremental
        if kept and not _inside(box, self.box):
            kept = False
            box = _union(box, self.box)
        elif kept:
            box = self.box
        r0, r1, c0, c1 = box
        crop = np.s_[r0:r1, c0:c1]
        known = ~free[crop]
        if kept:
            added = known & ~self._factored
            if not (self._factored & ~known).any() and np.count_nonzero(added) <= PINNED:
                pins = np.flatnonzero(added)
                # The pinned pixels act through the operator, not the right-hand side.
                sources = fixed.copy()
                sources[crop] &= ~added
                x = self._chol.solve_pinned(self._rhs(sources, out, free[crop], box), pins,
                                            out[crop].flat[pins])
                out[crop] = np.where(free[crop], x.reshape(known.shape), out[crop])
                return out
        if kept and not self._chol.updatable:
            # A prepare() under way has the update matrices this change needs: the
            # rest of it costs less than the factorization it saves.
            self._adopt(wait=True)
        elif not kept:
            self._stop_preparing()
        if kept and self._chol.updatable:
            rows = known ^ self._factored
            self._rewrite(known, rows, box)
            self.refactored_fronts = self._chol.update(*self._operator, rows=rows)
        else:
            # The first factorization keeps no update matrices (half the time and a
            # third of the memory; pinning needs none); prepare() or the first change
            # that pinning cannot follow makes one that keeps them.
            self._operator = self._system(known, box)
            self._chol = GridCholesky(*self._operator,
                                      updatable=self._incremental and self._chol is not None,
                                      progress=self._progress)
            self.refactored_fronts = self._chol.fronts
            self.box = box
        self._factored = known
        x = self._chol.solve(self._rhs(fixed, out, free[crop], box)).reshape(known.shape)
        out[crop] = np.where(known, out[crop], x)
        return out

    def prepare(self, *, background=False, progress=None):
        """Factor the kept system again, keeping its update matrices.

        A cold solve's factorization keeps no update matrices (about half the
        time). This factors the same system again keeping them, so that the
        next change pinning cannot follow is an update of the fronts it
        touches instead of a whole factorization (unless its free pixels
        leave the box). The answers stay the same. It costs about twice the
        cold solve and three times its memory, so it belongs where nothing
        waits for it. An exception from ``progress`` stops it and leaves the
        fill as it was.

        Parameters
        ----------
        background : bool, default False
            Factor in a thread of its own and return at once. The next
            :meth:`solve` that pinning can follow does not wait (it solves
            with the kept factorization, or the new one when it is done);
            one that needs an update waits for it, then updates; one whose
            free pixels leave the box stops it and factors afresh.
        progress : object with ``update(done, total)``, optional
            Told the progress while factoring; it may raise to stop.

        Returns
        -------
        bool
            Whether it factored or started to (False when there was nothing to
            do: no kept system, one already updatable or being prepared, or the
            fill not incremental).

        Examples
        --------
        >>> import numpy as np
        >>> fill = HarmonicFill(np.ones((16, 15)), np.ones((15, 16)))
        >>> fixed = np.zeros((16, 16), bool); fixed[:, [0, 8, 15]] = True
        >>> ramp = np.where(fixed, np.arange(16.0), 0.0)
        >>> d = fill.solve(fixed, ramp)
        >>> fill.prepare(), fill.prepare()
        (True, False)
        >>> fixed[12:, 8] = False                # pixels freed: no pinning, an update
        >>> d = fill.solve(fixed, ramp)
        >>> 0 < fill.refactored_fronts < fill.fronts
        True
        """
        if not self._incremental or self._preparing is not None:
            return False
        if self._chol is None and self._unfactored is not None:
            fixed, values = self._unfactored
            self._unfactored = None
            _, free = settle(fixed, values)
            r0, r1, c0, c1 = self.box = _bounds(free)
            self._factored = ~free[r0:r1, c0:c1]
            self._operator = self._system(self._factored, self.box)
        elif self._chol is None or self._chol.updatable:
            return False
        operator = self._operator
        if not background:
            self._chol = GridCholesky(*operator, updatable=True, progress=progress)
            return True
        outcome = {}
        stop = threading.Event()

        def run():
            try:
                outcome["chol"] = GridCholesky(*operator, updatable=True,
                                               progress=_Stoppable(stop, progress))
            except Exception as e:  # noqa: BLE001 - the solve that needs it factors instead
                outcome["error"] = e

        thread = threading.Thread(target=run, name="HarmonicFill.prepare", daemon=True)
        self._preparing = (thread, outcome, stop, self._chol)
        thread.start()
        return True

    @property
    def fronts(self):
        """Fronts of the kept factorization (0 before the first solve that needed one)."""
        return 0 if self._chol is None else self._chol.fronts

    def _adopt(self, *, wait):
        """Take the background :meth:`prepare`'s factorization once it is done
        (waiting for it with ``wait``); a failed one is dropped."""
        if self._preparing is None:
            return
        thread, outcome, _, base = self._preparing
        if not wait and thread.is_alive():
            return
        thread.join()
        self._preparing = None
        if "chol" in outcome and base is self._chol:
            self._chol = outcome["chol"]
        elif self._chol is None:
            self.box = None  # a first factorization that failed leaves no box

    def _stop_preparing(self):
        """Stop a background :meth:`prepare` whose system is being replaced."""
        if self._preparing is not None:
            self._preparing[2].set()
            self._preparing = None
            if self._chol is None:
                self.box = None

    def reduces(self, fixed, values):
        """Whether the next :meth:`solve` of these fixed values answers from the reduced
        system (see ``reduced_above``).

        Examples
        --------
        >>> import numpy as np
        >>> fill = HarmonicFill(np.ones((5, 8)), np.ones((4, 9)), reduced_above=20)
        >>> fixed = np.zeros((5, 9), bool); fixed[:, 0] = fixed[:, -1] = True
        >>> fill.reduces(fixed, np.where(fixed, np.arange(9.0), 0.0))
        True
        >>> d = fill.solve(fixed, np.where(fixed, np.arange(9.0), 0.0)); fill.prepare()
        True
        >>> fill.reduces(fixed, np.where(fixed, np.arange(9.0), 0.0))
        False
        """
        _, free = self._settle(_checked(self.shape, fixed, values), values)
        return bool(free.any()) and self._reduces(_bounds(free))

    def _settle(self, fixed, values):
        """:func:`settle` of these fixed values, kept for the next call: a caller asks
        :meth:`pending` and :meth:`reduces` before it solves the same fixed values, and
        comparing them costs a tenth of settling them again at 1 Mpx."""
        values = np.asarray(values, np.float64)
        kept = self._settled
        if kept is not None and np.array_equal(kept[0], fixed) and \
                np.array_equal(kept[1], values[fixed]):
            return kept[2], kept[3]
        out, free = settle(fixed, values)
        out.flags.writeable = free.flags.writeable = False
        self._settled = fixed.copy(), values[fixed], out, free
        return out, free

    def _reduces(self, box):
        self._adopt(wait=False)
        return self._reduced_above is not None and (self._chol is None or not self._incremental) \
            and (box[1] - box[0]) * (box[3] - box[2]) > self._reduced_above

    def pending(self, fixed, values):
        """The pixels of the box the next :meth:`solve` works on for these fixed values
        (0 when they settle every pixel): the box of the pixels they leave, joined
        with the kept factorization's.

        Examples
        --------
        >>> import numpy as np
        >>> fill = HarmonicFill(np.ones((5, 8)), np.ones((4, 9)))
        >>> fixed = np.zeros((5, 9), bool); fixed[:, 0] = fixed[:, -1] = True
        >>> fill.pending(fixed, np.where(fixed, np.arange(9.0), 0.0))
        35
        >>> fill.pending(fixed, np.ones((5, 9)))
        0
        """
        _, free = self._settle(_checked(self.shape, fixed, values), values)
        if not free.any():
            return 0
        box = _bounds(free)
        if self.box is not None and self._incremental:
            box = _union(box, self.box)
        r0, r1, c0, c1 = box
        return (r1 - r0) * (c1 - c0)

    def _system(self, known, box):
        """The box's operator ``diag, east, south``: free pixels keep their edges to
        free neighbours, known pixels are identity rows."""
        wx, wy, deg = self._weights
        r0, r1, c0, c1 = box
        free = ~known
        diag = np.where(known, 1.0, deg[r0:r1, c0:c1])
        east = np.where(free[:, :-1] & free[:, 1:], -wx[r0:r1, c0:c1 - 1], 0.0)
        south = np.where(free[:-1, :] & free[1:, :], -wy[r0:r1 - 1, c0:c1], 0.0)
        return diag, east, south

    def _rewrite(self, known, rows, box):
        """The kept operator's entries in ``rows`` (box pixels whose knownness changed)
        rewritten for ``known``: rewriting a few hundred rows costs far less than
        building the operator afresh at 1 Mpx."""
        wx, wy, deg = self._weights
        r0, r1, c0, c1 = box
        diag, east, south = self._operator
        h, w = known.shape
        y, x = np.nonzero(rows)
        diag[y, x] = np.where(known[y, x], 1.0, deg[y + r0, x + c0])
        for weights, edges, dy, dx in ((wx, east, 0, 1), (wy, south, 1, 0)):
            # The edges from the row's pixel and to it from its west/north neighbour.
            ey, ex = np.concatenate([y, y - dy]), np.concatenate([x, x - dx])
            ok = (ey >= 0) & (ex >= 0) & (ey < h - dy) & (ex < w - dx)
            ey, ex = ey[ok], ex[ok]
            free = ~known[ey, ex] & ~known[ey + dy, ex + dx]
            edges[ey, ex] = np.where(free, -weights[ey + r0, ex + c0], 0.0)

    def _rhs(self, fixed, vals, free, box):
        """The box's right-hand side (raster order): on a ``free`` pixel of the box its
        edges to ``fixed`` neighbours times their values, zero elsewhere (the known
        rows' values are set after the solve). Built from the fixed pixels alone:
        a free pixel's known neighbours are fixed, since two components never touch."""
        wx, wy, _ = self._weights
        h, w = self.shape
        r0, r1, c0, c1 = box
        bw = c1 - c0
        rhs = np.zeros((r1 - r0) * bw)
        y, x = np.nonzero(fixed[max(r0 - 1, 0):r1 + 1, max(c0 - 1, 0):c1 + 1])
        y, x = y + max(r0 - 1, 0), x + max(c0 - 1, 0)
        for ny, nx, ey, ex, weights in ((y, x + 1, y, x, wx), (y, x - 1, y, x - 1, wx),
                                        (y + 1, x, y, x, wy), (y - 1, x, y - 1, x, wy)):
            ok = (ny >= r0) & (nx >= c0) & (ny < r1) & (nx < c1)
            ok[ok] = free[ny[ok] - r0, nx[ok] - c0]
            np.add.at(rhs, (ny[ok] - r0) * bw + nx[ok] - c0,
                      weights[ey[ok], ex[ok]] * vals[y[ok], x[ok]])
        return rhs


class DraftFill:
    """The harmonic fill solved on a grid half as fine, for previews.

    The coarse grid is every other pixel of every other row (the pixels
    ``(2i, 2j)``), joined along the rows and columns through the pixel
    between two of them: by the series conductance of the two fine edges
    when that pixel is free (so an ink line between them keeps its weak
    edges), and not at all when it is fixed; then each of the two holds
    its fine edge to that pixel's value instead, a Dirichlet link. A fixed
    line therefore cuts the coarse grid as it cuts the fine one, and each
    side sees its own value (averaging the values of a block, which holds
    both sides of a thin line, mixed them). The coarse solution is carried
    back by the fine weights (a pixel between two coarse ones takes their
    mean weighted by its two edges, a pixel between four its neighbours'),
    and the fixed pixels keep their values (Gauss-Seidel sweeps along the
    fixed pixels afterwards changed the result by less than 0.001 levels on
    average). The coarse system is factored once and updated in place like
    :class:`HarmonicFill`'s; a draft costs about a third of a full re-solve.

    Parameters
    ----------
    wx, wy, incremental, progress
        As for :class:`HarmonicFill`.

    Examples
    --------
    >>> import numpy as np
    >>> fill = DraftFill(np.ones((6, 9)), np.ones((5, 10)))
    >>> fixed = np.zeros((6, 10), bool); fixed[:, 0] = fixed[:, -1] = True
    >>> d = fill.solve(fixed, np.where(fixed, np.arange(10.0), 0.0))
    >>> np.allclose(d, np.arange(10.0))          # the linear ramp, as the full fill
    True
    """

    def __init__(self, wx, wy, *, incremental=True, progress=None):
        wx, wy = np.asarray(wx, np.float64), np.asarray(wy, np.float64)
        self.shape = _grid_shape(wx, wy)
        wx, wy = _odd_weights(wx, wy)
        self._wx, self._wy = wx, wy
        # Edges from each coarse pixel to the pixel after it (east, south) and from
        # that pixel on to the next coarse one; their series, doubled (one coarse
        # edge stands for two rows of fine ones).
        self._e1, self._e2 = wx[0::2, 0::2], wx[0::2, 1::2]
        self._s1, self._s2 = wy[0::2, 0::2], wy[1::2, 0::2]
        self._ce = 2 * self._e1 * self._e2 / (self._e1 + self._e2)
        self._cs = 2 * self._s1 * self._s2 / (self._s1 + self._s2)
        self._incremental = bool(incremental)
        self._progress = progress
        self._chol = None
        self._operator = None  # the factored coarse operator (diag, east, south)
        self.refactored_fronts = 0

    def solve(self, fixed, values):
        """The draft fill for Dirichlet ``values`` on the ``fixed`` pixels (see
        :meth:`HarmonicFill.solve`)."""
        fixed = _checked(self.shape, fixed, values)
        values = np.asarray(values, np.float64)
        # The fixed pixels among the coarse ones and those between them, with values.
        parts = [(f, np.where(f, v, 0.0)) for f, v in zip(_lattice(fixed), _lattice(values))]
        c, (east, south) = self._coarse(*parts)
        return self._prolong(c, east, south, fixed, values)

    def _coarse(self, nodes, east, south):
        """The coarse solution, and the pixels between coarse ones (fixed, value) east
        and south, for the system of the coarse pixels, updated and solved."""
        (fn, vn), (fe, ve), (fs, vs) = nodes, east, south
        free = ~fn
        ce = np.where(fe, 0.0, self._ce)          # coarse edges, cut by fixed pixels
        cs = np.where(fs, 0.0, self._cs)
        # Dirichlet links to fixed pixels between coarse ones (doubled like the edges).
        link = np.zeros(fn.shape)
        rhs = np.zeros(fn.shape)
        for w1, w2, f, v, axis in ((self._e1, self._e2, fe, ve, 1), (self._s1, self._s2, fs, vs, 0)):
            a1, a2 = 2 * np.where(f, w1, 0.0), 2 * np.where(f, w2, 0.0)
            lo = [slice(None)] * 2
            hi = [slice(None)] * 2
            lo[axis], hi[axis] = slice(None, -1), slice(1, None)
            lo, hi = tuple(lo), tuple(hi)
            link[lo] += a1
            rhs[lo] += a1 * v
            link[hi] += a2
            rhs[hi] += a2 * v
        # Every edge counts in the degree (a cut one as its two links, always > 0);
        # edges to fixed coarse pixels move to the right-hand side.
        deg = link
        deg[:, :-1] += ce
        deg[:, 1:] += ce
        deg[:-1] += cs
        deg[1:] += cs
        rhs[:, :-1] += ce * vn[:, 1:]
        rhs[:, 1:] += ce * vn[:, :-1]
        rhs[:-1] += cs * vn[1:]
        rhs[1:] += cs * vn[:-1]
        diag = np.where(free, deg, 1.0)
        rhs = np.where(free, rhs, vn)
        east_op = np.where(free[:, :-1] & free[:, 1:], -ce, 0.0)
        south_op = np.where(free[:-1] & free[1:], -cs, 0.0)
        if self._chol is None or not self._incremental:
            self._chol = GridCholesky(diag, east_op, south_op, updatable=self._incremental,
                                      progress=self._progress)
            self.refactored_fronts = self._chol.fronts
        else:
            # The rows that changed, found on the coarse arrays: cheaper than letting
            # the update compare every entry of the operator.
            old_diag, old_east, old_south = self._operator
            rows = diag != old_diag
            moved = east_op != old_east
            rows[:, :-1] |= moved
            rows[:, 1:] |= moved
            moved = south_op != old_south
            rows[:-1] |= moved
            rows[1:] |= moved
            self.refactored_fronts = self._chol.update(diag, east_op, south_op, rows=rows)
        self._operator = diag, east_op, south_op
        c = self._chol.solve(rhs.ravel()).reshape(fn.shape)
        return c, (np.where(fe, ve, (self._e1 * c[:, :-1] + self._e2 * c[:, 1:])
                            / (self._e1 + self._e2)),
                   np.where(fs, vs, (self._s1 * c[:-1] + self._s2 * c[1:])
                            / (self._s1 + self._s2)))

    def _prolong(self, c, east, south, fixed, values):
        """The coarse solution carried to every pixel by the fine weights: ``east`` and
        ``south`` are the pixels between two coarse ones, those between four take
        their neighbours' mean weighted by their edges."""
        wx, wy = self._wx, self._wy
        h, w = self.shape
        n, s = wy[0:-1:2, 1::2], wy[1::2, 1::2]
        we, e = wx[1::2, 0:-1:2], wx[1::2, 1::2]
        centre = (n * east[:-1] + s * east[1:] + we * south[:, :-1] + e * south[:, 1:]) / (
            n + s + we + e)
        d = np.empty((h, w))
        hc, wc, hf, wf = (h + 1) // 2, (w + 1) // 2, h // 2, w // 2
        d[0::2, 0::2] = c[:hc, :wc]
        d[0::2, 1::2] = east[:hc, :wf]
        d[1::2, 0::2] = south[:hf, :wc]
        d[1::2, 1::2] = centre[:hf, :wf]
        np.copyto(d, values, where=fixed)
        return d



class _Stoppable:
    """A factorization's progress that stops it once ``stop`` is set, and passes the
    rest on to ``progress`` (optional)."""

    def __init__(self, stop, progress):
        self._stop, self._progress = stop, progress

    def update(self, done, total):
        if self._stop.is_set():
            raise _Stopped()
        if self._progress is not None:
            self._progress.update(done, total)


class _Stopped(Exception):
    """A background factorization no longer wanted."""


def settle(fixed, values):
    """The fill where the fixed values settle it, and the free pixels they do not.

    ``values`` on the fixed pixels; on each 4-connected component of the free
    pixels whose fixed neighbours all hold one value, that value (the
    harmonic function with constant boundary values).

    Parameters
    ----------
    fixed : (H, W) bool array
    values : (H, W) float array
        Read on the fixed pixels only.

    Returns
    -------
    out : (H, W) float64 array
        The settled values, zero on the pixels left.
    free : (H, W) bool array
        The pixels left to solve.

    Examples
    --------
    >>> import numpy as np
    >>> fixed = np.zeros((3, 7), bool); fixed[:, [0, 3, 6]] = True
    >>> out, free = settle(fixed, np.where(fixed, [[1, 0, 0, 1, 0, 0, 2]] * 3, 0.0))
    >>> out[0].tolist(), free[0].tolist()     # the left room settles at 1, the right one not
    ([1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 2.0], [False, False, False, False, True, True, False])
    """
    free = ~fixed
    comp, n = ndimage.label(free)
    out = np.where(fixed, values, 0.0)
    lo = np.full(n + 1, np.inf)
    hi = np.full(n + 1, -np.inf)
    h, w = fixed.shape
    y, x = np.nonzero(fixed)
    v = out[y, x]
    for ny, nx in ((y, x + 1), (y, x - 1), (y + 1, x), (y - 1, x)):
        ok = (ny >= 0) & (nx >= 0) & (ny < h) & (nx < w)
        c = comp[ny[ok], nx[ok]]
        np.minimum.at(lo, c, v[ok])
        np.maximum.at(hi, c, v[ok])
    settled = lo == hi
    settled[0] = False
    if settled.any():
        at = settled[comp]
        out[at] = lo[comp[at]]
        free &= ~at
    return out, free


def _bounds(mask):
    """``(r0, r1, c0, c1)``: the rows and columns that hold ``mask``'s pixels."""
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def _inside(a, b):
    return b[0] <= a[0] and a[1] <= b[1] and b[2] <= a[2] and a[3] <= b[3]


def _union(a, b):
    return min(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), max(a[3], b[3])

def _grid_shape(wx, wy):
    """The grid's (H, W) from its edge weights, which must fit it and be positive."""
    if wx.ndim != 2 or wy.ndim != 2 or wx.shape[0] != wy.shape[0] + 1 or \
            wy.shape[1] != wx.shape[1] + 1:
        raise InputError(f"wx, wy: expected shapes (H, W-1) and (H-1, W), got "
                         f"{wx.shape} and {wy.shape}")
    if not (wx > 0).all() or not (wy > 0).all():
        raise InputError("wx, wy: expected positive edge weights")
    return (wy.shape[0] + 1, wx.shape[1] + 1)


def _checked(shape, fixed, values):
    """``fixed`` as a bool array, once it and ``values`` have the grid's shape."""
    fixed = np.asarray(fixed, bool)
    if fixed.shape != shape or np.shape(values) != shape:
        raise InputError(f"fixed, values: expected shape {shape}, got "
                         f"{fixed.shape} and {np.shape(values)}")
    return fixed


def _lattice(a):
    """``a`` (H, W) grown to odd sizes by repeating its last row and column, then
    split into its pixels ``(2i, 2j)`` and the pixels between two of them along
    the rows (``(2i, 2j+1)``) and the columns (``(2i+1, 2j)``); without copying
    the full-size array."""
    h, w = a.shape
    last = a[-1:, 0::2]  # the repeated last row's pixels at even columns
    nodes = a[0::2, 0::2]
    if w % 2 == 0:
        nodes = np.concatenate([nodes, a[0::2, -1:]], axis=1)
        last = np.concatenate([last, a[-1:, -1:]], axis=1)
    if h % 2 == 0:
        nodes = np.concatenate([nodes, last], axis=0)
    east = a[0::2, 1::2]
    if h % 2 == 0:
        east = np.concatenate([east, a[-1:, 1::2]], axis=0)
    south = a[1::2, 0::2]
    if w % 2 == 0:
        south = np.concatenate([south, a[1::2, -1:]], axis=1)
    return nodes, east, south


def _odd_weights(wx, wy):
    """The weights of the grid grown to odd sizes by one repeated row or column,
    joined to its original by strong edges, so that the coarse pixels ``(2i, 2j)``
    reach the last row and column."""
    h, w = wy.shape[0] + 1, wx.shape[1] + 1
    if h % 2 == 0:
        wx = np.concatenate([wx, wx[-1:]], axis=0)
        wy = np.concatenate([wy, np.full((1, w), wx.max(initial=1.0))], axis=0)
    if w % 2 == 0:
        wy = np.concatenate([wy, wy[:, -1:]], axis=1)
        wx = np.concatenate([wx, np.full((wx.shape[0], 1), wx.max(initial=1.0))], axis=1)
    return wx, wy
