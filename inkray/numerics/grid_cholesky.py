"""Sparse Cholesky factorization of 5-point operators on a pixel grid.

A multifrontal Cholesky (Duff and Reid, "The multifrontal solution of
indefinite sparse symmetric linear equations", ACM TOMS 9(3), 1983) in the
geometric nested-dissection order of George ("Nested dissection of a regular
finite element mesh", SIAM J. Numer. Anal. 10(2), 1973): a box of pixels is
split by its middle row or column (the separator) into two boxes, recursively,
down to leaf boxes of a few pixels; each box's separator is eliminated after
both halves, as one dense frontal matrix over the separator and the ring of
pixels around the box.

On a grid the fronts repeat: every box with the same size, depth and set of
sides inside the image has the same frontal structure, so the fronts of such
a group are assembled, factored and solved together with numpy's stacked
LAPACK/BLAS calls. The symbolic part (the tree, the groups and their index
maps) depends only on the grid size and is cached. :meth:`GridCholesky.update`
refactors only the fronts whose entries changed and their ancestors, and an
updatable factorization redoes its last forward substitution only where the
right-hand side or the factor changed;
:meth:`GridCholesky.gram` gives ``B^T A^-1 B`` by forward substitution over
the fronts that ``B``'s nonzero rows reach, and :meth:`GridCholesky.solve_pinned`
with it a solve under a few more Dirichlet pixels without refactoring (the
capacitance matrix method).

Used by the depth QP (:mod:`inkray.qp`), whose one image-size factorization
dominates its cost, and by the fast depth method's Laplace fill
(:mod:`inkray.depth`).
"""

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
import scipy.sparse as sp
from scipy.linalg import blas as _blas
from scipy.linalg import lapack as _lapack

from inkray.errors import InputError, StageError
from inkray.numerics.threads import one_blas_thread

__all__ = ["Forward", "GridCholesky"]

#: Boxes of at most this many pixels are leaves (eliminated as one dense front).
LEAF_PIXELS = 16
#: Fronts up to this size are factored as numpy stacks; larger ones front by
#: front with the triangular and symmetric BLAS kernels, which skip half the
#: flops (thresholds from 48 to 96 measured alike at 512x512).
_STACK_FRONT = 64


@dataclass
class _Group:
    """Boxes that share one frontal structure (same depth, size and inner sides)."""

    s: int                  # pixels eliminated at this front (the separator, or the leaf)
    r: int                  # ring pixels (updated, eliminated later)
    S: np.ndarray           # (nb, s) raster indices of the eliminated pixels
    R: np.ndarray           # (nb, r) raster indices of the ring pixels
    li: np.ndarray          # (k,) front rows of the operator's entries
    lj: np.ndarray          # (k,) front columns
    in_s: np.ndarray        # (k,) bool: the entry's row is an eliminated pixel
    vidx: np.ndarray        # (nb, k) indices of those entries in [diag, east, south]
    children: list          # [(group id, (nb,) batch positions, runs of front positions)]


@dataclass
class Forward:
    """A forward substitution ``Y = L^-1 B`` (:meth:`GridCholesky.forward`).

    Attributes
    ----------
    gram : (k, k) array
        ``B^T A^-1 B = Y^T Y``.
    """

    gram: np.ndarray
    _ys: list = field(repr=False)  # per group None or (fronts reached, their blocks of Y)


class GridCholesky:
    """Cholesky factorization of a symmetric positive definite 5-point grid operator.

    The operator ``A`` acts on the pixels of an ``H x W`` grid in raster order
    (``y * W + x``); its only off-diagonal entries couple 4-neighbours.

    Parameters
    ----------
    diagonal : (H, W) array
        ``A[p, p]``.
    east : (H, W-1) array
        ``A[(y, x), (y, x+1)]``.
    south : (H-1, W) array
        ``A[(y, x), (y+1, x)]``.
    leaf : int, default :data:`LEAF_PIXELS`
        Boxes of at most this many pixels are not split further.
    updatable : bool, default False
        Keep the update matrices, which :meth:`update` reuses (they take
        about three times the memory of the factor), and the last single
        right-hand side's forward substitution: the next :meth:`solve` or
        :meth:`solve_pinned` redoes it only on the fronts whose right-hand
        side, factor or incoming updates changed (the result equals a fresh
        substitution to round-off).
    progress : object with ``update(done, total)``, optional
        Told the progress while factoring (in percent of the estimated
        flops), e.g. an :class:`inkray.progress.Progress`.

    Raises
    ------
    StageError
        When ``A`` is not positive definite.

    Examples
    --------
    >>> import numpy as np
    >>> diag = np.full((3, 4), 4.0)
    >>> f = GridCholesky(diag, -np.ones((3, 3)), -np.ones((2, 4)))
    >>> from inkray.numerics.grid import grid_operator
    >>> A = grid_operator(diag, -np.ones((3, 3)), -np.ones((2, 4)))
    >>> b = np.arange(12.0)
    >>> bool(np.allclose(A @ f.solve(b), b))
    True
    """

    def __init__(self, diagonal, east, south, *, leaf=LEAF_PIXELS, updatable=False,
                 progress=None):
        if not int(leaf) >= 1:
            raise InputError(f"leaf: expected a positive pixel count, got {leaf}")
        values, self.shape = _operator_values(diagonal, east, south)
        h, w = self.shape
        self.n = h * w
        self.updatable = bool(updatable)
        self._plan = _plan(h, w, int(leaf))
        self.fronts = sum(g.S.shape[0] for g in self._plan)  # nodes of the elimination tree
        self._values_now = values
        self._memo = None   # (rhs, ys, pushed, sub) of the last kept forward substitution
        self._stale = None  # per group, the fronts refactored since that substitution
        with one_blas_thread():
            self._factors, self._updates = _factorize(self._plan, values,
                                                      keep_updates=self.updatable,
                                                      progress=progress)

    def update(self, diagonal, east, south, *, rows=None):
        """Refactor for new operator values, redoing only the fronts they change.

        A front is redone when an entry it assembles changed or a front below
        it was redone: a change inside a window costs the boxes that meet the
        window and their ancestors, not the whole grid.

        Parameters
        ----------
        diagonal, east, south : arrays
            As for the constructor, same grid size.
        rows : (H, W) bool array, optional
            The pixels whose rows may have changed (the caller's promise):
            only their entries are read and compared, which at 1 Mpx saves
            building and comparing the whole operator when a few hundred
            rows change. Default: every entry is compared.

        Returns
        -------
        int
            Number of fronts refactored.

        Raises
        ------
        InputError
            When the factorization was not made with ``updatable=True``.

        Examples
        --------
        >>> import numpy as np
        >>> diag = np.full((40, 40), 4.5)
        >>> f = GridCholesky(diag, -np.ones((40, 39)), -np.ones((39, 40)), updatable=True)
        >>> diag[2, 3] = 5.0                       # one pixel's row changes
        >>> f.update(diag, -np.ones((40, 39)), -np.ones((39, 40))) < 20
        True
        >>> diag[2, 3] = 4.5
        >>> rows = np.zeros((40, 40), bool); rows[2, 3] = True
        >>> f.update(diag, -np.ones((40, 39)), -np.ones((39, 40)), rows=rows) < 20
        True
        """
        if not self.updatable:
            raise InputError("update: this factorization keeps no update matrices "
                             "(make it with updatable=True)")
        if rows is None:
            values, shape = _operator_values(diagonal, east, south)
            if shape != self.shape:
                raise InputError(f"diagonal: shape {shape} differs from the factored "
                                 f"{self.shape}")
            changed = values != self._values_now
            self._values_now = values
        else:
            changed = self._changed_rows(diagonal, east, south, rows)
        with one_blas_thread():
            self._factors, self._updates, redo = _factorize(
                self._plan, self._values_now, keep_updates=True,
                previous=(self._factors, self._updates), changed=changed)
        if self._memo is not None:
            self._stale = redo if self._stale is None else [
                a | b for a, b in zip(self._stale, redo)]
        return sum(int(m.sum()) for m in redo)

    def _changed_rows(self, diagonal, east, south, rows):
        """Write the entries of ``rows`` into the kept values; which entries changed."""
        h, w = self.shape
        rows = np.asarray(rows, bool)
        if rows.shape != self.shape or np.shape(diagonal) != self.shape:
            raise InputError(f"rows: shape {rows.shape} differs from the factored {self.shape}")
        y, x = np.nonzero(rows)
        # A row holds its diagonal and the edges to its four neighbours; the
        # west and north edges are stored with that neighbour.
        ey, ex = np.concatenate([y, y]), np.concatenate([x, x - 1])
        keep = (ex >= 0) & (ex < w - 1)
        ey, ex = ey[keep], ex[keep]
        sy, sx = np.concatenate([y, y - 1]), np.concatenate([x, x])
        keep = (sy >= 0) & (sy < h - 1)
        sy, sx = sy[keep], sx[keep]
        n = h * w
        at = np.concatenate([y * w + x, n + ey * w + ex, 2 * n + sy * w + sx])
        new = np.concatenate([np.asarray(diagonal, np.float64)[y, x],
                              np.asarray(east, np.float64)[ey, ex],
                              np.asarray(south, np.float64)[sy, sx]])
        changed = np.zeros(3 * n, bool)
        changed[at] = new != self._values_now[at]
        self._values_now[at] = new
        return changed

    def solve(self, rhs):
        """Solve ``A x = rhs``.

        Parameters
        ----------
        rhs : (N,) or (N, k) array
            ``N = H * W``, raster order.

        Returns
        -------
        array shaped like ``rhs``
        """
        b = self._rhs(rhs)
        if b.shape[1] == 1 and not self.updatable:
            nz = np.flatnonzero(b[:, 0])
            if len(nz) < self.n // 8:
                # Few sources (a Dirichlet fill's outlines): the forward substitution
                # visits only the fronts above them (at 1 Mpx a third of the time).
                fw = self.forward(sp.csr_matrix((b[nz, 0], (nz, np.zeros(len(nz), np.int64))),
                                                shape=(self.n, 1)))
                return self.backward(fw, [1.0]).reshape(np.shape(rhs))
        with one_blas_thread():
            x = self._backward(self._forward(b), b.shape[1])
        return x.reshape(np.shape(rhs))

    def solve_pinned(self, rhs, pixels, values):
        """Solve ``A x = rhs + P c`` with the sources ``c`` that pin ``x[pixels] = values``.

        ``P`` holds the unit columns of ``pixels``: every row but the pinned
        ones keeps its equation, so this is the solution of the operator with
        those pixels' rows replaced by the identity (a Dirichlet condition),
        without refactoring. It costs one solve plus a forward substitution
        from the pinned pixels (the capacitance matrix ``P^T A^-1 P`` is
        their :meth:`gram`).

        Parameters
        ----------
        rhs : (N,) array
        pixels : (k,) int array
            Distinct raster indices.
        values : (k,) array

        Returns
        -------
        (N,) float64 array: ``x[pixels] == values`` and ``(A x)[i] == rhs[i]`` elsewhere.

        Examples
        --------
        >>> import numpy as np
        >>> from inkray.numerics.grid import grid_operator
        >>> op = (np.full((2, 5), 3.0), -np.ones((2, 4)), -np.ones((1, 5)))
        >>> x = GridCholesky(*op).solve_pinned(np.ones(10), [2, 7], [2.0, -1.0])
        >>> x[[2, 7]].tolist(), bool(np.allclose(np.delete(grid_operator(*op) @ x, [2, 7]), 1.0))
        ([2.0, -1.0], True)
        """
        pixels = np.asarray(pixels, np.int64).reshape(-1)
        values = np.asarray(values, np.float64).reshape(-1)
        if len(values) != len(pixels) or len(np.unique(pixels)) != len(pixels):
            raise InputError(f"pixels: expected {len(values)} distinct pixels, one per value")
        b = self._rhs(rhs)
        if b.shape[1] != 1:
            raise InputError(f"rhs: expected one right-hand side, got shape {np.shape(rhs)}")
        if not len(pixels):
            return self.solve(rhs)
        k = len(pixels)
        f = self.forward(sp.csr_matrix((np.ones(k), (pixels, np.arange(k))), shape=(self.n, k)))
        with one_blas_thread():
            ys = [y.copy() for y in self._forward(b)]  # the kept ones stay as they are
            # x[pixels] before pinning is (L^-1 P)^T (L^-1 rhs): only the fronts P reaches.
            free = np.zeros(k)
            for y, part in zip(ys, f._ys):
                if part is not None:
                    sel, yk = part
                    free += np.einsum("bsk,bs->k", yk, y[sel, :, 0])
            c = np.linalg.solve(f.gram, values - free)
            for y, part in zip(ys, f._ys):
                if part is not None:
                    sel, yk = part
                    y[sel, :, 0] += yk @ c
            x = self._backward(ys, 1)[:, 0]
        x[pixels] = values  # exact, not to round-off
        return x

    def forward(self, rhs):
        """Forward substitution ``Y = L^-1 rhs`` for point sources, with ``A = L L^T``.

        When ``rhs`` has few nonzero rows, ``Y`` is nonzero only on the fronts
        from their boxes up to the root; only those are visited, on a
        right-hand side compacted to the pixels of those fronts.

        Parameters
        ----------
        rhs : (N, k) array or sparse matrix

        Returns
        -------
        Forward
            ``gram = rhs^T A^-1 rhs = Y^T Y``, and ``Y`` for :meth:`backward`.

        Examples
        --------
        >>> import numpy as np
        >>> f = GridCholesky(np.full((3, 4), 4.0), -np.ones((3, 3)), -np.ones((2, 4)))
        >>> B = np.zeros((12, 1)); B[0, 0], B[11, 0] = 1.0, -1.0
        >>> bool(np.isclose(f.forward(B).gram[0, 0], (B[:, 0] @ f.solve(B[:, 0]))))
        True
        """
        B = sp.csr_matrix(rhs, dtype=np.float64)
        if B.shape[0] != self.n:
            raise InputError(f"rhs: expected {self.n} rows, got shape {B.shape}")
        k = B.shape[1]
        # Symbolic pass: the fronts reached from the nonzero rows.
        touched = np.zeros(self.n, bool)
        touched[np.flatnonzero(np.diff(B.indptr))] = True
        sels = []
        for g in self._plan:
            sel = np.flatnonzero(touched[g.S].any(axis=1))
            sels.append(sel)
            touched[g.S[sel]] = True
            if g.r:
                touched[g.R[sel]] = True
        rows = np.flatnonzero(touched)
        lut = np.full(self.n, -1, np.int64)
        lut[rows] = np.arange(len(rows))
        b = B[rows].toarray()
        gram = np.zeros((k, k))
        ys = []
        with one_blas_thread():
            for g, (Li, W), sel in zip(self._plan, self._factors, sels):
                if not len(sel):
                    ys.append(None)
                    continue
                y = Li[sel] @ b[lut[g.S[sel]]]
                flat = y.reshape(-1, k)
                gram += flat.T @ flat
                if g.r:
                    np.subtract.at(b, lut[g.R[sel]].ravel(),
                                   (W[sel].transpose(0, 2, 1) @ y).reshape(-1, k))
                ys.append((sel, y))
        return Forward(gram=0.5 * (gram + gram.T), _ys=ys)

    def gram(self, rhs):
        """``rhs^T A^-1 rhs`` by forward substitution alone (:meth:`forward`).

        Parameters
        ----------
        rhs : (N, k) array or sparse matrix

        Returns
        -------
        (k, k) float64 array
        """
        return self.forward(rhs).gram

    def backward(self, forward, coef):
        """``A^-1 rhs coef`` from a :meth:`forward` substitution, by back substitution alone.

        Parameters
        ----------
        forward : Forward
            Of ``rhs``, from this factorization.
        coef : (k,) array

        Returns
        -------
        (N,) float64 array

        Examples
        --------
        >>> import numpy as np
        >>> f = GridCholesky(np.full((3, 4), 4.0), -np.ones((3, 3)), -np.ones((2, 4)))
        >>> B = np.zeros((12, 2)); B[0, 0], B[5, 1] = 1.0, 1.0
        >>> x = f.backward(f.forward(B), np.array([2.0, -1.0]))
        >>> bool(np.allclose(x, f.solve(B @ [2.0, -1.0])))
        True
        """
        coef = np.asarray(coef, np.float64).reshape(-1)
        k = forward.gram.shape[0]
        if len(coef) != k or len(forward._ys) != len(self._plan):
            raise InputError(f"coef: expected {k} coefficients for this factorization")
        ys = []
        for g, part in zip(self._plan, forward._ys):
            y = np.zeros((g.S.shape[0], g.s, 1))
            if part is not None:
                sel, yk = part
                y[sel, :, 0] = yk @ coef
            ys.append(y)
        with one_blas_thread():
            return self._backward(ys, 1)[:, 0]

    def _forward(self, b):
        """Forward substitution of ``b`` (N, k): kept and redone where it changed for
        one right-hand side of an updatable factorization, else afresh."""
        if not self.updatable or b.shape[1] != 1:
            return self._forward_dense(b)
        if self._memo is None:
            self._memo = (np.full(self.n, np.nan),
                          [np.zeros((g.S.shape[0], g.s, 1)) for g in self._plan],
                          [np.zeros((g.S.shape[0], g.r, 1)) for g in self._plan],
                          np.zeros(self.n))
            self._stale = None
        last, ys, pushed, sub = self._memo
        rhs = b[:, 0]
        # A front is redone when its right-hand side, its factor or what the
        # fronts below push onto it changed; ``sub`` holds the sum of those pushes.
        touched = rhs != last  # all of it the first time (NaN)
        for i, (g, (Li, W)) in enumerate(zip(self._plan, self._factors)):
            dirty = touched[g.S].any(axis=1)
            if self._stale is not None:
                dirty |= self._stale[i]
            whole = bool(dirty.all())
            sel = slice(None) if whole else np.flatnonzero(dirty)
            if not whole and not len(sel):
                continue
            S = g.S[sel]
            y = (Li if whole else Li[sel]) @ (rhs[S] - sub[S])[..., None]
            ys[i][sel] = y
            if g.r:
                push = W[sel].transpose(0, 2, 1) @ y
                delta = (push - pushed[i][sel]).reshape(-1)
                pushed[i][sel] = push
                np.add.at(sub, g.R[sel].ravel(), delta)
                touched[g.R[sel]] = True
        last[:] = rhs
        self._stale = None
        return ys

    def _forward_dense(self, b):
        """Forward substitution ``y = L^-1 b`` per group (``b`` is overwritten)."""
        k = b.shape[1]
        ys = []
        for g, (Li, W) in zip(self._plan, self._factors):
            y = Li @ b[g.S]
            if g.r:
                np.subtract.at(b, g.R.ravel(), (W.transpose(0, 2, 1) @ y).reshape(-1, k))
            ys.append(y)
        return ys

    def _backward(self, ys, k):
        """Back substitution ``x = L^-T y`` from the per-group blocks of ``y``."""
        x = np.zeros((self.n, k))
        for g, (Li, W), y in zip(self._plan[::-1], self._factors[::-1], ys[::-1]):
            if g.r:
                y = y - W @ x[g.R]
            x[g.S] = Li.transpose(0, 2, 1) @ y
        return x

    def _rhs(self, rhs):
        b = np.array(rhs, np.float64)
        if b.ndim not in (1, 2) or b.shape[0] != self.n:
            raise InputError(f"rhs: expected {self.n} rows, got shape {b.shape}")
        return b.reshape(self.n, -1)


def _operator_values(diagonal, east, south):
    """The operator's entries as one vector ``[diagonal, east, south]`` (each H*W,
    zero where a pixel has no east or south neighbour), and the grid shape."""
    diagonal = np.asarray(diagonal, np.float64)
    if diagonal.ndim != 2 or diagonal.size == 0:
        raise InputError(f"diagonal: expected a non-empty (H, W) array, got shape "
                         f"{diagonal.shape}")
    h, w = diagonal.shape
    e = np.zeros((h, w))
    e[:, :-1] = np.asarray(east, np.float64).reshape(h, w - 1)
    s = np.zeros((h, w))
    s[:-1, :] = np.asarray(south, np.float64).reshape(h - 1, w)
    return np.concatenate([diagonal.ravel(), e.ravel(), s.ravel()]), (h, w)


def _factorize(plan, values, *, keep_updates=False, previous=None, changed=None,
               progress=None):
    """Dense partial Cholesky of every front, children before parents.

    Returns ``factors`` (per group ``(Li, W)``) and ``updates`` (per group the
    update matrices, kept only with ``keep_updates``); with ``previous`` and
    ``changed`` (which entries of ``values`` changed), only the fronts that
    assemble a changed entry or have a redone child are redone, and which
    fronts were redone (a mask per group) is returned third.
    """
    factors, updates = [], []
    # A group's updates may feed several parent groups: keep them until the last.
    uses = {}
    for g in ([] if keep_updates else plan):
        for gid, _, _ in g.children:
            uses[gid] = uses.get(gid, 0) + 1
    redo = []
    if progress is not None:
        cost = np.cumsum([g.S.shape[0] * (g.s ** 3 / 3 + g.s ** 2 * g.r + g.s * g.r ** 2)
                          for g in plan])
        done = np.floor(100 * cost / cost[-1]).astype(int)
        shown = -1
    for i, g in enumerate(plan):
        if progress is not None and i and done[i - 1] != shown:
            shown = int(done[i - 1])
            progress.update(shown, 100)
        nb = g.S.shape[0]
        if previous is None:
            sel = slice(None)
        else:
            dirty = changed[g.vidx].any(axis=1)
            for gid, pos, _ in g.children:
                dirty |= redo[gid][pos]
            redo.append(dirty)
            if not dirty.any():
                factors.append(previous[0][i])
                updates.append(previous[1][i])
                continue
            sel = slice(None) if dirty.all() else np.flatnonzero(dirty)
            nb = nb if isinstance(sel, slice) else len(sel)
        kids = [(updates[gid][pos] if isinstance(sel, slice) else
                 updates[gid][np.arange(len(updates[gid]))[pos][sel]], runs)
                for gid, pos, runs in g.children]
        out = None
        if previous is not None and isinstance(sel, slice) and _in_place(g.s, g.r):
            # Redone whole and factored in place: into the previous arrays, since
            # fresh ones cost a page fault per 4 KiB (the first update twice the next).
            Li0, W0 = previous[0][i]
            out = Li0, W0.transpose(0, 2, 1), previous[1][i]
        Fss, Frs, U = _assemble(g, values, sel, kids, nb, out)
        Li, W = _eliminate(Fss, Frs, U)
        if not isinstance(sel, slice):  # in place: the previous factorization is replaced
            Li0, W0 = previous[0][i]
            Li0[sel], W0[sel] = Li, W
            previous[1][i][sel] = U
            Li, W, U = Li0, W0, previous[1][i]
        factors.append((Li, W))
        updates.append(U)
        if not keep_updates:
            for gid, _, _ in g.children:
                uses[gid] -= 1
                if uses[gid] == 0:
                    updates[gid] = None
    if progress is not None:
        progress.update(100, 100)
    if previous is None:
        return factors, updates
    return factors, updates, redo


def _assemble(g, values, sel, kids, nb, out=None):
    """The fronts ``sel`` of group ``g`` in three blocks: F_SS and F_RS (lower
    triangle of the eliminated rows) and the ring block, which accumulates the
    children's updates ``kids`` (``[(U_child, runs)]``) and becomes the fronts'
    update in place. Fronts and updates are symmetric: only their lower
    triangles are formed and read. ``out``: the three blocks' arrays to reuse."""
    s, r = g.s, g.r
    if out is None:
        Fss, Frs, U = np.zeros((nb, s, s)), np.zeros((nb, r, s)), np.zeros((nb, r, r))
    else:
        Fss, Frs, U = out
        for a in out:
            a.fill(0.0)
    vals = values[g.vidx[sel]]
    Fss[:, g.li[g.in_s], g.lj[g.in_s]] = vals[:, g.in_s]
    Frs[:, g.li[~g.in_s] - s, g.lj[~g.in_s]] = vals[:, ~g.in_s]
    # Extend-add, one block per pair of contiguous runs on or below the diagonal.
    for Uc, runs in kids:
        for a0, b0, na in runs:
            for c0, d0, nc in runs:
                if b0 < d0:
                    continue
                if a0 >= c0:
                    blk = Uc[:, a0:a0 + na, c0:c0 + nc]
                else:  # the source block lies above Uc's diagonal: read its mirror
                    blk = Uc[:, c0:c0 + nc, a0:a0 + na].transpose(0, 2, 1)
                if b0 < s:
                    Fss[:, b0:b0 + na, d0:d0 + nc] += blk
                elif d0 < s:
                    Frs[:, b0 - s:b0 - s + na, d0:d0 + nc] += blk
                else:
                    U[:, b0 - s:b0 - s + na, d0 - s:d0 - s + nc] += blk
    return Fss, Frs, U


def _eliminate(Fss, Frs, U):
    """Partial Cholesky of assembled fronts: ``(Li, W)``, ``U`` updated in place."""
    if _in_place(Fss.shape[1], Frs.shape[1]):
        return _partial_cholesky_each(Fss, Frs, U)
    return _partial_cholesky_stacked(Fss, Frs, U)


def _in_place(s, r):
    """Whether fronts of ``s`` eliminated and ``r`` ring pixels are factored front
    by front in their own arrays (``Li`` and ``W`` are ``F_SS`` and ``F_RS^T``)."""
    return s + r > _STACK_FRONT


def _partial_cholesky_stacked(Fss, Frs, U):
    """``Li = chol(F_SS)^-1``, ``W = Li F_SR`` and ``U -= W^T W`` for a stack of small fronts.

    Reads the lower triangle of ``F_SS``; ``U`` is updated in its lower triangle.
    """
    try:
        Lc = np.linalg.cholesky(Fss)
    except np.linalg.LinAlgError:
        raise StageError("grid Cholesky: the operator is not positive definite") from None
    Li = np.linalg.inv(Lc)
    W = Li @ Frs.transpose(0, 2, 1)
    U -= W.transpose(0, 2, 1) @ W
    return Li, W


def _partial_cholesky_each(Fss, Frs, U):
    """The same for larger fronts, one LAPACK/BLAS call each, in place.

    Each call gets the Fortran-ordered transpose of a C-ordered block (no
    copy): ``F_SS^T``'s upper triangle becomes ``chol(F_SS)^-T``, so ``Fss``
    becomes ``Li``, and ``F_RS^T`` becomes ``W``.
    """
    for b in range(Fss.shape[0]):
        c, info = _lapack.dpotrf(Fss[b].T, lower=0, overwrite_a=1, clean=1)
        if info != 0:
            raise StageError("grid Cholesky: the operator is not positive definite")
        c, _ = _lapack.dtrtri(c, lower=0, overwrite_c=1)
        if Frs.shape[1]:
            Wb = Frs[b].T
            _blas.dtrmm(1.0, c, Wb, lower=0, trans_a=1, overwrite_b=1)
            # U^T is Fortran-ordered: syrk updates its upper triangle (U's lower).
            _blas.dsyrk(-1.0, Wb, beta=1.0, c=U[b].T, trans=1, lower=0, overwrite_c=1)
    return Fss, Frs.transpose(0, 2, 1)


@lru_cache(maxsize=4)
def _plan(h, w, leaf):
    """The nested-dissection tree of an ``h x w`` grid, as groups in elimination order."""
    # The tree level by level: boxes (r0, r1, c0, c1) and, per box, the
    # indices of its two children (left/top, right/bottom) in the next level.
    levels, kids = [], []
    box = np.array([[0, h, 0, w]], np.int64)
    while len(box):
        levels.append(box)
        bh, bw = box[:, 1] - box[:, 0], box[:, 3] - box[:, 2]
        split = (bh * bw > leaf) & (np.maximum(bh, bw) >= 3)
        cols = split & (bw >= bh)
        rows = split & ~cols
        m_c = box[:, 2] + (bw - 1) // 2
        m_r = box[:, 0] + (bh - 1) // 2
        first, second = box.copy(), box.copy()
        first[cols, 3] = m_c[cols]
        second[cols, 2] = m_c[cols] + 1
        first[rows, 1] = m_r[rows]
        second[rows, 0] = m_r[rows] + 1
        nxt = np.flatnonzero(split)
        child = np.full((len(box), 2), -1, np.int64)
        child[nxt, 0] = 2 * np.arange(len(nxt))
        child[nxt, 1] = 2 * np.arange(len(nxt)) + 1
        kids.append(child)
        box = np.stack([first[nxt], second[nxt]], axis=1).reshape(-1, 4)
    # Groups: boxes of one level with the same size and the same sides inside the image.
    keys, where = [], {}   # key -> (level, member indices); per level: box -> (group, pos)
    gid_of, pos_of = [], []
    for d in range(len(levels) - 1, -1, -1):  # deepest first
        box = levels[d]
        bh, bw = box[:, 1] - box[:, 0], box[:, 3] - box[:, 2]
        sides = (box[:, 0] > 0) * 8 + (box[:, 1] < h) * 4 + (box[:, 2] > 0) * 2 + (box[:, 3] < w)
        code = (bh * (w + 1) + bw) * 16 + sides
        uniq, inv = np.unique(code, return_inverse=True)
        gid = np.empty(len(box), np.int64)
        pos = np.empty(len(box), np.int64)
        for u, c in enumerate(uniq.tolist()):
            ids = np.flatnonzero(inv == u)
            gid[ids] = len(keys)
            pos[ids] = np.arange(len(ids))
            (sh, sw), bits = divmod(c // 16, w + 1), c % 16
            keys.append((d, sh, sw, tuple(bool(bits >> k & 1) for k in (3, 2, 1, 0))))
            where[len(keys) - 1] = ids
        gid_of.insert(0, gid)
        pos_of.insert(0, pos)
    groups = []
    for g, key in enumerate(keys):
        d, bh, bw, sides = key
        ids = where[g]
        box = levels[d][ids]
        S_rel, R_rel = _front(bh, bw, sides, leaf)
        s, r = len(S_rel), len(R_rel)
        # Front positions on the box and its ring, offset by one (-1: in a child box).
        local = np.full((bh + 2, bw + 2), -1, np.int64)
        local[S_rel[:, 0] + 1, S_rel[:, 1] + 1] = np.arange(s)
        local[R_rel[:, 0] + 1, R_rel[:, 1] + 1] = s + np.arange(r)
        # The operator's entries in the eliminated rows, lower triangle: the
        # diagonal, then per neighbour direction (its value lives at the
        # west/north pixel of the pair, in the east/south arrays).
        a = np.arange(s)
        li, lj, kind, rel = [a], [a], [np.zeros(s, np.int64)], [S_rel]
        for dy, dx, kd in ((0, 1, 1), (0, -1, 1), (1, 0, 2), (-1, 0, 2)):
            b = local[S_rel[:, 0] + 1 + dy, S_rel[:, 1] + 1 + dx]
            keep = (b >= 0) & ((b >= s) | (b > a))  # not in a child, each S-S pair once
            li.append(b[keep])
            lj.append(a[keep])
            kind.append(np.full(keep.sum(), kd, np.int64))
            rel.append(S_rel[keep] + [min(dy, 0), min(dx, 0)])
        li, lj, kind, rel = (np.concatenate(v) for v in (li, lj, kind, rel))
        origins = box[:, 0] * w + box[:, 2]
        vidx = (kind * (h * w))[None, :] + origins[:, None] + (rel[:, 0] * w + rel[:, 1])[None, :]
        S = origins[:, None] + (S_rel[:, 0] * w + S_rel[:, 1])[None, :]
        R = origins[:, None] + (R_rel[:, 0] * w + R_rel[:, 1])[None, :]
        children = []
        child = kids[d][ids]
        if child[0, 0] >= 0:
            for slot in range(2):
                ck = child[:, slot]
                cg = gid_of[d + 1][ck]
                if (cg != cg[0]).any():
                    raise StageError("grid Cholesky: inconsistent nested-dissection groups")
                cbox = levels[d + 1][ck[0]]
                oy, ox = cbox[0] - box[0, 0], cbox[2] - box[0, 2]
                _, crel = _front(*keys[cg[0]][1:], leaf)
                m = local[crel[:, 0] + oy + 1, crel[:, 1] + ox + 1]
                children.append((int(cg[0]), _as_slice(pos_of[d + 1][ck]), _runs(m, s)))
        groups.append(_Group(s=s, r=r, S=S, R=R, li=li, lj=lj, in_s=li < s, vidx=vidx,
                             children=children))
    return groups


def _as_slice(pos):
    """Batch positions as a slice when they step evenly (a view instead of a copy)."""
    if len(pos) == 1:
        return slice(int(pos[0]), int(pos[0]) + 1)
    step = pos[1] - pos[0]
    if step > 0 and (np.diff(pos) == step).all():
        return slice(int(pos[0]), int(pos[-1]) + 1, int(step))
    return pos


def _runs(m, s):
    """``m`` (child ring -> parent front positions) as contiguous runs ``(src, dst, length)``,
    none crossing from the eliminated positions (``< s``) into the ring."""
    cut = np.flatnonzero((np.diff(m) != 1) | (m[1:] == s)) + 1
    starts = np.r_[0, cut]
    ends = np.r_[cut, len(m)]
    return [(int(a), int(m[a]), int(b - a)) for a, b in zip(starts, ends)]


@lru_cache(maxsize=4096)
def _front(bh, bw, sides, leaf):
    """Relative cells ``(row, col)`` of a box's eliminated pixels and of its ring
    (cached: a child's structure is read again by its parents; do not modify)."""
    top, bottom, left, right = sides
    if bh * bw <= leaf or max(bh, bw) < 3:
        S = np.argwhere(np.ones((bh, bw), bool))
    elif bw >= bh:
        S = np.stack([np.arange(bh), np.full(bh, (bw - 1) // 2)], axis=1)
    else:
        S = np.stack([np.full(bw, (bh - 1) // 2), np.arange(bw)], axis=1)
    across, down = np.arange(bw), np.arange(bh)
    R = [np.stack([np.full(bw, row), across], axis=1) for row, on in ((-1, top), (bh, bottom))
         if on]
    R += [np.stack([down, np.full(bh, col)], axis=1) for col, on in ((-1, left), (bw, right))
          if on]
    R = np.concatenate(R) if R else np.zeros((0, 2), np.int64)
    return S.astype(np.int64), R.astype(np.int64)
