"""The depth quadratic program of Sýkora et al., "Adding Depth to Cartoons
Using Sparse Depth (In)equalities" (CGF 2010), solved exactly through its
constraint multipliers.

The problem, on the 4-neighbour pixel grid::

    minimize    1/2 d^T L d = 1/2 sum_{edges pq} w_pq (d_p - d_q)^2
    subject to  d_p - d_q  = 0        (equalities)
                d_p - d_q >= epsilon  (inequalities)

(the paper's double sum over ordered neighbour pairs is 4x this; the
minimizer is the same). ``L`` is the weighted graph Laplacian with
``w_pq = max(exp(-(I_p - I_q)^2 / sigma), floor)``.

The constraints are few (tens) and the unknowns many (pixels), so the problem
is reduced to its ``m`` multipliers: with the gauge fixed, every stationary
point is ``d = L^+ C^T lam``, and ``lam`` solves the small dual

    minimize    1/2 lam^T H lam - b^T lam,   H = C L^+ C^T (m x m, dense)
    subject to  lam_i >= 0 for the inequalities,

whose gradient ``H lam - b = C d - b`` is the constraint slack. One sparse
Cholesky factorization of the grounded Laplacian ``L_g = G G^T`` (multifrontal,
in the grid's nested-dissection order: :mod:`inkray.grid_cholesky`) gives
``H = (G^-1 C^T)^T (G^-1 C^T)`` by forward substitution from the ``2m``
endpoints, which touches only the fronts on their paths to the root; the dual
is solved exactly by an active-set method; one solve recovers ``d``; the KKT
conditions of the full problem are then measured on ``d`` itself.

Gauge: ``L`` has the constants in its null space (the floor keeps every weight
positive, so the pixel graph is connected and there is exactly one such
direction). The system is grounded at one pixel (its row and column dropped,
which is exact, unlike a regularization) and the result is shifted to zero
mean. The floor bounds the near-null spaces of areas almost cut off by ink:
their smallest eigenvalues stay above about ``floor * perimeter / area``, so
a direct factorization in double precision stays accurate far below 1e-6.
"""

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from threadpoolctl import threadpool_limits

from inkray.errors import InputError, StageError
from inkray.numerics.grid_cholesky import GridCholesky

__all__ = ["edge_weights", "grid_laplacian", "GroundedLaplacian",
           "QPResult", "solve_depth_qp", "dual_active_set", "constraint_cycle", "check_constraints",
           "WEIGHT_FLOOR", "SIGMA_FLOOR"]

#: Smallest edge weight: keeps the pixel graph connected and L well enough
#: conditioned for a 1e-6 KKT check, while a step across ink still costs
#: 1e5 times less than the same step across paper.
WEIGHT_FLOOR = 1e-5
#: Smallest sigma, so a blank or nearly blank image gives uniform weights
#: instead of turning paper noise into walls.
SIGMA_FLOOR = 1e-4


def edge_weights(gray, *, sigma=None, floor=WEIGHT_FLOOR):
    """4-neighbour edge weights ``w_pq = max(exp(-(I_p - I_q)^2 / sigma), floor)``.

    Parameters
    ----------
    gray : (H, W) float array in [0, 1]
        Paper 1, ink near 0.
    sigma : float, optional
        Contrast scale. Default: the mean contrast of the image's edges,
        ``mean((I_p - I_q)^2)`` over all 4-neighbour pairs (at least
        :data:`SIGMA_FLOOR`), so only edges much stronger than the typical
        one (ink outlines) become weak.
    floor : float, default :data:`WEIGHT_FLOOR`
        Smallest weight (> 0).

    Returns
    -------
    wx : (H, W-1) float64 array
        Weights between ``(y, x)`` and ``(y, x+1)``.
    wy : (H-1, W) float64 array
        Weights between ``(y, x)`` and ``(y+1, x)``.
    sigma : float
        The sigma used.

    Examples
    --------
    >>> import numpy as np
    >>> wx, wy, s = edge_weights(np.ones((3, 4)))
    >>> float(wx.min()), wx.shape, wy.shape
    (1.0, (3, 3), (2, 4))
    """
    g = np.asarray(gray, np.float64)
    if g.ndim != 2 or min(g.shape) < 1:
        raise InputError(f"gray: expected an (H, W) image, got shape {g.shape}")
    if not np.isfinite(g).all():
        y, x = np.argwhere(~np.isfinite(g))[0]
        raise InputError(f"gray: pixel ({x}, {y}) is not a finite number")
    if not floor > 0:
        raise InputError(f"floor: expected a positive weight floor, got {floor}")
    dx2 = np.diff(g, axis=1) ** 2
    dy2 = np.diff(g, axis=0) ** 2
    if sigma is None:
        n = dx2.size + dy2.size
        sigma = (dx2.sum() + dy2.sum()) / n if n else 0.0
        sigma = max(float(sigma), SIGMA_FLOOR)
    elif not sigma > 0:
        raise InputError(f"sigma: expected a positive contrast scale, got {sigma}")
    wx = np.maximum(np.exp(-dx2 / sigma), floor)
    wy = np.maximum(np.exp(-dy2 / sigma), floor)
    return wx, wy, float(sigma)


def grid_laplacian(wx, wy):
    """Weighted graph Laplacian ``L = D - W`` of the 4-neighbour grid.

    Parameters
    ----------
    wx : (H, W-1) array
        Horizontal edge weights.
    wy : (H-1, W) array
        Vertical edge weights.

    Returns
    -------
    (H*W, H*W) scipy.sparse.csr_matrix
        Pixels in raster order (``y * W + x``); ``d^T L d`` is the sum over
        edges of ``w_pq (d_p - d_q)^2``.

    Examples
    --------
    >>> import numpy as np
    >>> L = grid_laplacian(np.ones((1, 1)), np.zeros((0, 2)))
    >>> L.toarray().tolist()
    [[1.0, -1.0], [-1.0, 1.0]]
    """
    wx = np.asarray(wx, np.float64)
    wy = np.asarray(wy, np.float64)
    h, w = wx.shape[0], wx.shape[1] + 1
    n = h * w
    idx = np.arange(n).reshape(h, w)
    i = np.concatenate([idx[:, :-1].ravel(), idx[:-1, :].ravel()])
    j = np.concatenate([idx[:, 1:].ravel(), idx[1:, :].ravel()])
    v = np.concatenate([wx.ravel(), wy.ravel()])
    deg = np.bincount(i, v, minlength=n) + np.bincount(j, v, minlength=n)
    rows = np.concatenate([i, j, idx.ravel()])
    cols = np.concatenate([j, i, idx.ravel()])
    vals = np.concatenate([-v, -v, deg])
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, n))


class GroundedLaplacian:
    """A factorization of a connected graph Laplacian with one node grounded.

    Solves ``L d = r`` for right-hand sides with zero sum (the range of
    ``L``); the solution has ``d[ground] = 0``. Dropping the ground node's row
    and column removes the constant null space exactly.

    Parameters
    ----------
    laplacian : (N, N) sparse matrix
        Symmetric, connected, zero row sums.
    shape : (int, int), optional
        ``(H, W)`` when ``laplacian`` is a 4-neighbour grid Laplacian over the
        pixels in raster order: it is then factored by the grid's nested
        dissection (:class:`inkray.numerics.grid_cholesky.GridCholesky`, several times
        faster on images); otherwise by SuperLU with a minimum-degree order.
    progress : inkray.progress.Progress, optional
        Its ``update(done, total)`` during a grid factorization.

    Examples
    --------
    >>> import numpy as np
    >>> L = grid_laplacian(np.ones((2, 2)), np.ones((1, 3)))
    >>> f = GroundedLaplacian(L, shape=(2, 3))
    >>> r = np.array([1.0, 0, 0, 0, 0, -1.0])
    >>> bool(np.allclose(L @ f.solve(r), r))
    True
    """

    def __init__(self, laplacian, *, shape=None, progress=None):
        L = sp.csr_matrix(laplacian, dtype=np.float64)
        n = L.shape[0]
        if n < 2:
            raise InputError("laplacian: needs at least 2 nodes")
        self.laplacian = L
        self.n = n
        # Ground the last node: the bottom-right pixel on a grid.
        self.ground = n - 1
        if shape is not None:
            diag, east, south = _grid_parts(L, shape)
            # The ground's row and column become the identity: its diagonal is
            # 1 and its couplings to the west and north neighbours vanish.
            diag[-1, -1] = 1.0
            east[-1, -1:] = 0.0
            south[-1:, -1] = 0.0
            self._grid = GridCholesky(diag, east, south, progress=progress)
        else:
            self._grid = None
            A = L[:-1, :-1].tocsc()
            try:
                self._lu = sla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                    options=dict(SymmetricMode=True))
            except RuntimeError as e:  # singular: the graph is not connected
                raise StageError(f"the graph is not connected ({e})") from None

    def _solve_grounded(self, b):
        """``L_g^-1 b`` on full-length vectors; ``b``'s ground row is ignored, ``x``'s is 0."""
        if self._grid is not None:
            # The ground's row and column are the identity: b's ground entry
            # reaches x's ground entry only, which is set to 0.
            x = self._grid.solve(b)
            x[self.ground] = 0.0
            return x
        x = np.zeros_like(b)
        x[:-1] = self._lu.solve(b[:-1])
        return x

    def solve(self, rhs, *, refine=1):
        """Solve ``L d = rhs`` with ``d[ground] = 0``.

        Parameters
        ----------
        rhs : (N,) or (N, k) array
            Columns with zero sum (projected onto zero sum otherwise).
        refine : int, default 1
            Most steps of iterative refinement with the same factorization;
            none is taken once the residual is at rounding level
            (``1e-12`` of the right-hand side).

        Returns
        -------
        array shaped like ``rhs``
        """
        r = np.asarray(rhs, np.float64)
        r = r - r.mean(axis=0, keepdims=True)
        return self.refine(self._solve_grounded(r), r, steps=refine)

    def refine(self, d, rhs, *, steps=1):
        """Iterative refinement of a solution ``d`` of ``L d = rhs`` (``rhs`` with zero sum).

        At most ``steps`` steps, none once the residual is at rounding level
        (``1e-12`` of the right-hand side).

        Parameters
        ----------
        d, rhs : (N,) or (N, k) arrays

        Returns
        -------
        array shaped like ``d``
        """
        for _ in range(steps):
            res = rhs - self.laplacian @ d
            res[self.ground] = 0.0  # the ground's row was dropped
            if np.abs(res).max(initial=0.0) <= 1e-12 * np.abs(rhs).max(initial=0.0):
                break
            d = d + self._solve_grounded(res)
        return d

    def dual_matrix(self, p, q):
        """``H = C L_g^-1 C^T`` for constraint rows ``e_p - e_q`` (the ground's entries dropped).

        Parameters
        ----------
        p, q : (m,) int arrays

        Returns
        -------
        (m, m) float64 array

        Examples
        --------
        >>> import numpy as np
        >>> L = grid_laplacian(np.ones((1, 4)), np.zeros((0, 5)))   # a path of 5 nodes
        >>> GroundedLaplacian(L, shape=(1, 5)).dual_matrix([0], [4]).tolist()  # resistance 4
        [[4.0]]
        """
        return self.dual(p, q)[0]

    def dual(self, p, q):
        """The dual matrix ``H = C L_g^-1 C^T`` and the map ``lam -> L_g^-1 C^T lam``.

        On a grid ``H`` comes from a forward substitution over the fronts
        above the endpoints only, and the map is the back substitution that
        completes it (:meth:`inkray.numerics.grid_cholesky.GridCholesky.forward`);
        otherwise both come from solves with the columns of ``C^T``.

        Parameters
        ----------
        p, q : (m,) int arrays

        Returns
        -------
        H : (m, m) float64 array
        primal : callable
            ``primal(lam)`` is the ``(N,)`` depth ``L_g^-1 C^T lam`` (zero at the ground).

        Examples
        --------
        >>> import numpy as np
        >>> L = grid_laplacian(np.ones((1, 4)), np.zeros((0, 5)))   # a path of 5 nodes
        >>> H, primal = GroundedLaplacian(L, shape=(1, 5)).dual([0], [4])
        >>> np.round(primal(np.array([0.25])), 6).tolist()   # the ground is the last node
        [1.0, 0.75, 0.5, 0.25, 0.0]
        """
        m = len(p)
        rows = np.r_[p, q]
        cols = np.r_[np.arange(m), np.arange(m)]
        vals = np.r_[np.ones(m), -np.ones(m)]
        on = rows != self.ground
        Ct = sp.csr_matrix((vals[on], (rows[on], cols[on])), shape=(self.n, m))
        if self._grid is not None:
            # The ground's row is the identity and C^T is zero there, so the
            # back substitution gives 0 at the ground by itself.
            fw = self._grid.forward(Ct)
            return fw.gram, lambda lam: self._grid.backward(fw, lam)
        X = self._solve_grounded(Ct.toarray())
        H = Ct.T @ X
        return 0.5 * (H + H.T), lambda lam: X @ np.asarray(lam, np.float64)


def _grid_parts(L, shape):
    """Diagonal, east and south couplings of a 4-neighbour grid operator ``L``."""
    h, w = shape
    n = h * w
    if L.shape != (n, n):
        raise InputError(f"laplacian: {L.shape[0]} nodes, but the grid {w}x{h} has {n} pixels")
    diag = L.diagonal().reshape(h, w).copy()
    east = np.zeros((h, max(w - 1, 0)))
    south = np.zeros((max(h - 1, 0), w))
    if w > 1:
        east[:] = np.append(L.diagonal(1), 0.0).reshape(h, w)[:, :-1]
    if h > 1:
        south[:] = L.diagonal(w).reshape(h - 1, w)
    # Any other entry would show in the product with a random vector.
    v = np.random.default_rng(0).standard_normal((h, w))
    Av = diag * v
    Av[:, :-1] += east * v[:, 1:]
    Av[:, 1:] += east * v[:, :-1]
    Av[:-1, :] += south * v[1:, :]
    Av[1:, :] += south * v[:-1, :]
    tol = 1e-10 * np.abs(L.data).max(initial=0.0) * np.abs(v).max()
    if np.abs(L @ v.ravel() - Av.ravel()).max() > tol:
        raise InputError("laplacian: not a 4-neighbour operator on the given grid shape")
    return diag, east, south


@dataclass
class QPResult:
    """The solution of :func:`solve_depth_qp`.

    Attributes
    ----------
    depth : (N,) float64 array
        The minimizer, zero mean.
    multipliers : (m,) float64 array
        Lagrange multipliers (``>= 0`` for inequalities).
    active : (m,) bool array
        Constraints met with equality at the solution (all equalities).
    objective : float
        ``1/2 d^T L d``.
    kkt : dict
        Measured on ``depth``: ``stationarity`` (max ``|L d - C^T lam|``
        relative to ``max(1, |C^T lam|)``), ``primal`` (max constraint
        violation), ``dual`` (most negative inequality multiplier, as a
        positive number), ``complementarity`` (max ``|lam_i slack_i|``).
    iterations : int
        Active-set iterations.
    timings : dict
        Seconds per phase.
    """

    depth: np.ndarray
    multipliers: np.ndarray
    active: np.ndarray
    objective: float
    kkt: dict
    iterations: int
    timings: dict = field(default_factory=dict)


def check_constraints(p, q, inequality, labels, *, what="point"):
    """Reject contradictory constraints before solving.

    Parameters
    ----------
    p, q : (m,) int arrays
        Node (pixel) indices: constraint ``i`` is ``d[p_i] - d[q_i] >= eps``
        when ``inequality[i]``, else ``d[p_i] = d[q_i]``.
    inequality : (m,) bool array
    labels : list of str
        The annotation entry of each constraint, e.g. ``"order[3]"``.
    what : str, default "point"
        What the nodes are, for the message (``"region"`` for the region graph).

    Raises
    ------
    InputError
        Listing the entries of a contradictory cycle, see
        :func:`constraint_cycle`.

    Examples
    --------
    >>> check_constraints([0, 1], [1, 0], [True, True], ["order[0]", "order[1]"])
    Traceback (most recent call last):
    ...
    inkray.errors.InputError: order[0] -> order[1] -> order[0]: contradictory depth constraints: following them, a point must lie in front of itself
    """
    cycle = constraint_cycle(p, q, inequality)
    if cycle:
        names = [labels[i] for i in cycle]
        raise InputError(" -> ".join(names + names[:1]) + ": contradictory depth constraints: "
                         f"following them, a {what} must lie in front of itself")


def constraint_cycle(p, q, inequality):
    """Find a cycle of constraints that no depth map can satisfy.

    With ``epsilon > 0`` the system of (in)equalities is feasible exactly when
    no closed chain of constraints (equalities walked either way,
    inequalities from front to back) contains an inequality. This is the
    infeasibility test of the exact QP and the cycle test of the region graph.

    Parameters
    ----------
    p, q : (m,) int arrays
        Node indices (``p`` in front for inequalities).
    inequality : (m,) bool array

    Returns
    -------
    list of int
        Constraint indices around one such cycle (starting with the smallest
        inequality index on it), or an empty list when the constraints are
        consistent.

    Examples
    --------
    >>> constraint_cycle([0, 1, 2], [1, 2, 0], [True, False, True])
    [0, 1, 2]
    >>> constraint_cycle([0, 1], [1, 2], [True, True])
    []
    """
    p = [int(v) for v in np.asarray(p).ravel()]
    q = [int(v) for v in np.asarray(q).ravel()]
    ineq = [bool(v) for v in np.asarray(inequality).ravel()]
    m = len(p)
    # Equalities: adjacency for paths inside one equality class.
    eq_adj = {}
    for i in range(m):
        if not ineq[i]:
            eq_adj.setdefault(p[i], []).append((q[i], i))
            eq_adj.setdefault(q[i], []).append((p[i], i))
    comp = {}
    for start in sorted(set(p) | set(q)):
        if start in comp:
            continue
        comp[start] = start
        todo = [start]
        while todo:
            u = todo.pop()
            for v, _ in eq_adj.get(u, ()):
                if v not in comp:
                    comp[v] = start
                    todo.append(v)

    def eq_path(a, b):
        # Constraint indices of an equality path from node a to node b (BFS).
        if a == b:
            return []
        prev = {a: None}
        todo = [a]
        for u in todo:
            for v, i in sorted(eq_adj.get(u, ())):
                if v not in prev:
                    prev[v] = (u, i)
                    todo.append(v)
        path, v = [], b
        while prev[v] is not None:
            u, i = prev[v]
            path.append(i)
            v = u
        return path[::-1]

    # Directed graph of equality classes, one edge per inequality (front -> back).
    out = {}
    for i in range(m):
        if ineq[i]:
            out.setdefault(comp[p[i]], []).append(i)
    for first in range(m):
        if not ineq[first]:
            continue
        # Shortest chain of inequalities from back(first) back to front(first).
        target = comp[p[first]]
        prev = {comp[q[first]]: None}
        todo = [comp[q[first]]]
        found = target in prev
        for u in todo:
            if found:
                break
            for i in out.get(u, ()):
                v = comp[q[i]]
                if v not in prev:
                    prev[v] = (u, i)
                    todo.append(v)
                    if v == target:
                        found = True
                        break
        if not found:
            continue
        chain, v = [], target
        while prev[v] is not None:
            u, i = prev[v]
            chain.append(i)
            v = u
        chain = [first] + chain[::-1]
        cycle = []
        for k, i in enumerate(chain):
            j = chain[(k + 1) % len(chain)]
            cycle.append(i)
            cycle += eq_path(q[i], p[j])
        return cycle  # the smallest inequality on a cycle: a deterministic report
    return []


def solve_depth_qp(laplacian, p, q, inequality, *, epsilon=1.0, factor=None, shape=None,
                   tol=1e-6, labels=None, progress=None):
    """Solve the depth QP exactly.

    Parameters
    ----------
    laplacian : (N, N) sparse matrix
        Connected weighted graph Laplacian (see :func:`grid_laplacian`).
    p, q : (m,) int arrays
        Node indices of the constraints.
    inequality : (m,) bool array
        ``d[p] - d[q] >= epsilon`` where True, ``d[p] = d[q]`` where False.
    epsilon : float, default 1.0
        Minimal depth step of an inequality (> 0).
    factor : GroundedLaplacian, optional
        A factorization of ``laplacian`` to reuse.
    shape : (int, int), optional
        Grid shape, for the grid factorization when ``factor`` is None.
    tol : float, default 1e-6
        Every KKT measure of the result must be at most this.
    labels : list of str, optional
        Annotation entries of the constraints, for error messages.
    progress : inkray.progress.Progress, optional
        Its ``update(done, total)`` during the factorization.

    Returns
    -------
    QPResult

    Raises
    ------
    InputError
        Contradictory constraints (listing the entries on a cycle).
    StageError
        When the KKT conditions cannot be met to ``tol``.

    Examples
    --------
    >>> import numpy as np
    >>> L = grid_laplacian(np.ones((1, 4)), np.zeros((0, 5)))   # a path of 5 nodes
    >>> r = solve_depth_qp(L, [0], [4], [True], epsilon=1.0)
    >>> np.round(r.depth, 6).tolist()
    [0.5, 0.25, 0.0, -0.25, -0.5]
    """
    import time

    t0 = time.perf_counter()
    p = np.asarray(p, np.int64).ravel()
    q = np.asarray(q, np.int64).ravel()
    ineq = np.asarray(inequality, bool).ravel()
    m = len(p)
    if not (len(q) == m and len(ineq) == m):
        raise InputError("constraints: p, q and inequality must have the same length")
    if not epsilon > 0:
        raise InputError(f"epsilon: expected a positive depth step, got {epsilon}")
    n = laplacian.shape[0]
    if m and (min(p.min(), q.min()) < 0 or max(p.max(), q.max()) >= n):
        raise InputError("constraints: a node index lies outside the graph")
    if labels is None:
        labels = [f"{'order' if ineq[i] else 'equal'}[{i}]" for i in range(m)]
    check_constraints(p, q, ineq, labels)
    # Constraints between a node and itself: equalities are void (and make the
    # dual singular for nothing); inequalities were rejected above.
    keep = p != q
    b = np.where(ineq, float(epsilon), 0.0)
    timings = {}
    if factor is None:
        factor = GroundedLaplacian(laplacian, shape=shape, progress=progress)
    timings["factorize"] = time.perf_counter() - t0
    lam = np.zeros(m)
    iterations = 0
    if keep.any():
        t = time.perf_counter()
        kp, kq, kb, kin = p[keep], q[keep], b[keep], ineq[keep]
        H, primal = factor.dual(kp, kq)
        timings["dual_matrix"] = time.perf_counter() - t
        t = time.perf_counter()
        klam, iterations = _active_set(H, kb, kin)
        lam[keep] = klam
        timings["active_set"] = time.perf_counter() - t
    t = time.perf_counter()
    d = primal(lam[keep]) if keep.any() else np.zeros(n)
    d = factor.refine(d, _ct(p, q, lam, n))
    # Polish: the small system used H from unrefined solves; correct the
    # multipliers of the active constraints on the measured slack.
    for _ in range(3):
        slack = d[p] - d[q] - b
        free = keep & (~ineq | (lam > 0))
        if not free.any() or np.abs(slack[free]).max() <= 1e-10 * max(1.0, epsilon):
            break
        fi = np.flatnonzero(free)
        Hf = H[np.ix_(np.flatnonzero(free[keep]), np.flatnonzero(free[keep]))]
        dl = np.zeros(m)
        dl[fi] = _pinv_solve(Hf, -slack[fi])
        lam += dl
        # The dual's map back-substitutes from its forward pass: no new solve.
        d = d + factor.refine(primal(dl[keep]), _ct(p, q, dl, n))
    d -= d.mean()
    timings["recover"] = time.perf_counter() - t
    slack = d[p] - d[q] - b
    ct = _ct(p, q, lam, n)
    Ld = laplacian @ d
    resid = Ld - ct
    kkt = {
        "stationarity": float(np.abs(resid).max() / max(1.0, np.abs(ct).max())) if n else 0.0,
        "primal": float(max(0.0, (-slack[ineq]).max(initial=0.0),
                            np.abs(slack[~ineq]).max(initial=0.0))),
        "dual": float(max(0.0, (-lam[ineq]).max(initial=0.0))),
        "complementarity": float(np.abs(lam[ineq] * slack[ineq]).max(initial=0.0)),
    }
    worst = max(kkt, key=kkt.get)
    if kkt[worst] > tol:
        raise StageError(f"depth QP: KKT {worst} residual {kkt[worst]:.2e} exceeds {tol:g} "
                         "(the Laplacian is too ill-conditioned; raise the weight floor)")
    active = (~ineq) | (np.abs(slack) <= max(tol, 1e-9 * epsilon))
    objective = 0.5 * float(d @ Ld)
    return QPResult(depth=d, multipliers=lam, active=active, objective=objective, kkt=kkt,
                    iterations=iterations, timings=timings)


def _ct(p, q, lam, n):
    """``C^T lam`` for constraint rows ``e_p - e_q``."""
    return np.bincount(p, lam, minlength=n) - np.bincount(q, lam, minlength=n)


def _pinv_solve(H, r):
    """Minimum-norm least-squares solution of ``H x = r`` for a symmetric PSD ``H``."""
    w, V = np.linalg.eigh(H)
    cut = 1e-12 * max(1.0, w.max(initial=0.0))
    c = V.T @ r
    c = np.where(w > cut, c / np.where(w > cut, w, 1.0), 0.0)
    return V @ c


def dual_active_set(H, b, inequality, *, what="QP", start=None):
    """Exact minimizer of the small dual ``1/2 x^T H x - b^T x``, ``x_i >= 0`` where ``inequality``.

    The multiplier problem of any QP ``min 1/2 y^T Q y`` subject to ``C y = b``
    (rows where ``inequality`` is False) and ``C y >= b`` (True), with
    ``H = C Q^-1 C^T``; the primal solution is ``y = Q^-1 C^T x``. Used by the
    depth QP here and by :mod:`inkray.stitch`.

    Parameters
    ----------
    H : (m, m) symmetric positive semi-definite array
    b : (m,) array
    inequality : (m,) bool array
    what : str, default "QP"
        Names the problem in error messages.
    start : (m,) array, optional
        A feasible warm start (``>= 0`` on the inequalities), e.g. the
        multipliers of a smaller working set padded with zeros: rows with a
        positive value start free, which saves most iterations when a
        constraint-generation loop adds a few rows at a time.

    Returns
    -------
    (m,) float array
        The multipliers.

    Raises
    ------
    StageError
        When the dual is unbounded (contradictory constraints) or the method
        does not converge.

    Examples
    --------
    >>> import numpy as np
    >>> dual_active_set(np.eye(2), np.array([1.0, -1.0]), np.array([True, True])).tolist()
    [1.0, 0.0]
    """
    # One BLAS thread: these matrices are small (hundreds), and on a busy
    # machine a multithreaded Cholesky of a 300x300 matrix was measured 400x
    # slower than a single-threaded one (0.67 s vs 1.8 ms).
    with threadpool_limits(limits=1, user_api="blas"):
        x, _ = _active_set(np.asarray(H, float), np.asarray(b, float),
                           np.asarray(inequality, bool), what, start=start)
    return x


def _active_set(H, b, ineq, what="depth QP", start=None):
    """Exact minimizer of ``1/2 x^T H x - b^T x`` s.t. ``x_i >= 0`` where ``ineq``.

    A primal active-set method on the bounds (the inequality multipliers held
    at 0 form the working set). ``H`` may be singular (dependent constraints):
    on a face the step is the Newton step on the range of ``H_FF``, or, when
    the gradient has a component in its null space, a zero-curvature descent
    direction followed to the nearest bound. Where ``H_FF`` is positive
    definite (the usual case) the step comes from a Cholesky factor, far
    cheaper than the eigendecomposition the singular case needs.
    """
    m = len(b)
    x = np.zeros(m)
    fixed = ineq.copy()
    if start is not None:
        x = np.where(ineq, np.maximum(np.asarray(start, float), 0.0), np.asarray(start, float))
        fixed = ineq & (x <= 0.0)
    scale = max(1.0, np.abs(b).max(initial=0.0))
    gtol = 1e-11 * scale
    max_iter = 20 * m + 50
    for it in range(1, max_iter + 1):
        free = ~fixed
        if free.any():
            fi = np.flatnonzero(free)
            g = H[fi] @ x - b[fi]
            step = _cholesky_step(H[np.ix_(fi, fi)], g)
            if step is not None:
                alpha_max = 1.0
            else:
                step, alpha_max = _singular_step(H[np.ix_(fi, fi)], g, gtol)
            block = ineq[fi] & (step < -1e-15 * scale)
            alpha, j = alpha_max, -1
            if block.any():
                ratios = -x[fi[block]] / step[block]
                k = int(np.argmin(ratios))
                if ratios[k] < alpha:
                    alpha, j = max(0.0, float(ratios[k])), int(fi[block][k])
            if not np.isfinite(alpha):
                raise StageError(f"{what}: the dual is unbounded (contradictory constraints "
                                 "that the cycle test missed)")
            x[fi] += alpha * step
            if j >= 0:
                x[j] = 0.0
                fixed[j] = True
                continue
        g = H @ x - b
        cand = fixed & (g < -gtol)
        if not cand.any():
            return x, it
        fixed[int(np.argmin(np.where(cand, g, np.inf)))] = False
    raise StageError(f"{what}: the active-set method did not converge in {max_iter} iterations")


def _cholesky_step(Hff, g):
    """Newton step ``-Hff^-1 g``, or None when ``Hff`` is not safely positive definite."""
    from scipy.linalg import LinAlgError, cho_factor, cho_solve

    try:
        c = cho_factor(Hff, lower=True, check_finite=False)
    except LinAlgError:
        return None
    d = np.abs(np.diag(c[0]))
    if d.min() <= 1e-7 * d.max():  # nearly singular: the eigen path handles it exactly
        return None
    return -cho_solve(c, g, check_finite=False)


def _singular_step(Hff, g, gtol):
    """Step on a face whose ``Hff`` may be singular: Newton on its range, or a
    zero-curvature descent direction when the gradient leaves the range."""
    w, V = np.linalg.eigh(Hff)
    cut = 1e-12 * max(1.0, w.max(initial=0.0))
    rng = w > cut
    c = V.T @ g
    null_g = V[:, ~rng] @ c[~rng]
    if np.abs(null_g).max(initial=0.0) > gtol:
        return -null_g, np.inf
    return -(V[:, rng] @ (c[rng] / w[rng])), 1.0
