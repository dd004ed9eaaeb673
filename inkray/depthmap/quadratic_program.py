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

from inkray.errors import InputError, StageError
from inkray.numerics.active_set import dual_active_set, psd_lstsq
from inkray.numerics.grid_cholesky import GridCholesky
from inkray.numerics.order_graph import constraint_cycle
from inkray.numerics.spd import spd_factor

__all__ = ["GroundedLaplacian", "QPResult", "solve_depth_qp", "check_constraints"]

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
    >>> from inkray.numerics.grid import grid_laplacian
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
                self._lu = spd_factor(A)
            except np.linalg.LinAlgError as e:  # singular: the graph is not connected
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
        >>> from inkray.numerics.grid import grid_laplacian
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
        >>> from inkray.numerics.grid import grid_laplacian
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
        :func:`inkray.numerics.order_graph.constraint_cycle`.

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
    >>> from inkray.numerics.grid import grid_laplacian
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
        klam, iterations = dual_active_set(H, kb, kin, what="depth QP", return_iterations=True)
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
        dl[fi] = psd_lstsq(Hf, -slack[fi])
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
