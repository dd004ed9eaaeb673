"""As-rigid-as-possible deformation of 2D triangle meshes with positional handles.

The energy is the triangle-element form of as-rigid-as-possible (ARAP)
deformation (Sorkine and Alexa, "As-rigid-as-possible surface modeling", SGP
2007; the per-triangle rotations of Liu, Zhang, Xu, Gotsman and Gortler, "A
local/global approach to mesh parameterization", SGP 2008):

.. math::

    E(x, R) = \\sum_t \\sum_{(i, j) \\in t} \\tfrac12 \\cot\\theta^t_{ij}
              \\lVert (x_i - x_j) - R_t (p_i - p_j) \\rVert^2
              + w \\sum_g \\lVert G_g x \\rVert^2,

the cotangent-weighted difference between every triangle's deformed edges
and its rest edges ``p`` turned by one rotation ``R_t`` per triangle (per
triangle this is the triangle's area times ``|J_t - R_t|_F^2``, so it is
convex in ``x`` for any triangle shape). Optional glue rows ``G`` tie a
vertex to a point of another triangle (e.g. two overlapping meshes solved as
one system); they vanish at rest. Glue rows are held exactly where they can
be, by substitution (each solved for its vertex of largest weight, as
libigl's ``min_quad_with_fixed`` eliminates linear equality constraints),
so that glued meshes do not part even by a fraction of a pixel; the
weight ``w`` keeps the others. Handles are points of the mesh (a vertex or
barycentric point of a triangle) whose positions are prescribed: they are met
exactly, as equality rows of the KKT system of the global step.

The minimizer alternates a local step (each ``R_t``: the closest rotation to
the triangle's edge covariance, in closed form in 2D, so never a reflection)
and a global step (a sparse linear solve with a matrix that does not depend
on the handle positions: factored once in :class:`Arap`, reused for every
drag). A drag warm-starts from the previous pose, so a few iterations suffice.
"""

import copy

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu

from inkray.numerics.spd import spd_factor

__all__ = ["Arap", "arap", "arap_energy", "best_rotations", "signed_areas", "cotangent_weights",
           "pieces"]


def signed_areas(vertices, faces):
    """Signed area of every triangle: positive when its corners run counter-clockwise in ``(x, y)``.

    Parameters
    ----------
    vertices : (n, 2) float array
    faces : (m, 3) int array

    Returns
    -------
    (m,) float array

    Examples
    --------
    >>> signed_areas(np.array([[0.0, 0], [1, 0], [0, 1]]), np.array([[0, 1, 2], [0, 2, 1]])).tolist()
    [0.5, -0.5]
    """
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    # per coordinate: 1-D gathers are many times faster than gathering rows
    x, y = np.ascontiguousarray(v[:, 0]), np.ascontiguousarray(v[:, 1])
    ax, ay = x[f[:, 0]], y[f[:, 0]]
    return 0.5 * ((x[f[:, 1]] - ax) * (y[f[:, 2]] - ay) - (x[f[:, 2]] - ax) * (y[f[:, 1]] - ay))


def cotangent_weights(vertices, faces):
    """Half the cotangent of the angle opposite each triangle edge.

    Edge ``k`` of face ``t`` runs from corner ``k + 1`` to corner ``k + 2``
    (mod 3), opposite corner ``k``.

    Parameters
    ----------
    vertices : (n, 2) float array
    faces : (m, 3) int array

    Returns
    -------
    (m, 3) float array

    Examples
    --------
    >>> w = cotangent_weights(np.array([[0.0, 0], [1, 0], [0, 1]]), np.array([[0, 1, 2]]))
    >>> np.round(w, 6).tolist()    # the right angle's edge gets cot(90) = 0
    [[0.0, 0.5, 0.5]]
    """
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    w = np.empty(f.shape)
    area2 = np.abs(2.0 * signed_areas(v, f))
    for k in range(3):
        u = v[f[:, (k + 1) % 3]] - v[f[:, k]]
        s = v[f[:, (k + 2) % 3]] - v[f[:, k]]
        # cot = dot / |cross|; a degenerate triangle contributes nothing
        w[:, k] = 0.5 * np.divide(np.einsum("ij,ij->i", u, s), area2,
                                  out=np.zeros(len(f)), where=area2 > 0)
    return w


class Arap:
    """ARAP deformation of one 2D triangle mesh for one set of handles, factored once.

    Parameters
    ----------
    vertices : (n, 2) float array
        Rest positions.
    faces : (m, 3) int array
    handles : (k, n) sparse matrix or (k,) int array
        Each row a handle as a combination of vertices (barycentric weights of
        the point in its triangle), or vertex indices.
    glue : (g, n) sparse matrix, optional
        Rows whose deformed values should vanish (they must vanish at rest):
        e.g. a vertex of one mesh minus the barycentric point of another.
    glue_weight : float, default 10.0
        Weight of the glue rows that are not held exactly against the
        (area-scaled) ARAP energy.
    exact_glue : bool, default True
        Hold glue rows exactly where they can be: a row is solved for its
        vertex of largest weight (its pivot) when that vertex is not fixed and
        no other held row involves it, and none of its other vertices is
        another held row's pivot (so the substitution is one level deep and
        keeps the system sparse). The others are weighted by ``glue_weight``.
    fixed : (n,) bool array or int array, optional
        Vertices held at their rest positions (e.g. pieces no handle reaches).
    stiffness : (m,) float array, optional
        Per face, a factor on its energy (default 1): stiffer faces keep
        their shape at the expense of softer ones.

    Attributes
    ----------
    pose : (n, 2) float array
        The last solution (the warm start of the next solve).
    glue_held : (g,) bool array
        The glue rows held exactly (the others are weighted).

    Examples
    --------
    A bar turned by its two end handles turns rigidly:

    >>> x = np.linspace(0.0, 10.0, 11)
    >>> v = np.concatenate([np.column_stack([x, np.zeros(11)]), np.column_stack([x, np.ones(11)])])
    >>> f = np.concatenate([[[i, i + 1, i + 12], [i, i + 12, i + 11]] for i in range(10)])
    >>> solver = Arap(v, f, handles=[0, 10])
    >>> out = solver.solve([[0.0, 0.0], [0.0, 10.0]], iterations=30)  # a quarter turn
    >>> (np.round(out[[0, 5, 10, 11]], 4) + 0.0).tolist()
    [[0.0, 0.0], [0.0, 5.0], [0.0, 10.0], [-1.0, 0.0]]
    """

    def __init__(self, vertices, faces, *, handles, glue=None, glue_weight=10.0,
                 exact_glue=True, fixed=None, stiffness=None):
        p = np.asarray(vertices, float)
        f = np.asarray(faces, np.int64)
        if p.ndim != 2 or p.shape[1] != 2 or not np.all(np.isfinite(p)):
            raise ValueError("vertices: expected a finite (n, 2) array")
        n = len(p)
        if f.ndim != 2 or f.shape[1] != 3 or (f.size and (f.min() < 0 or f.max() >= n)):
            raise ValueError(f"faces: expected an (m, 3) array of indices 0..{n - 1}")
        C = _rows(handles, n, "handles")
        G = sp.csr_matrix((0, n)) if glue is None else _rows(glue, n, "glue")
        if not glue_weight > 0:
            raise ValueError(f"glue_weight: expected > 0, got {glue_weight}")
        mask = np.zeros(n, bool)
        if fixed is not None:
            mask[np.asarray(fixed)] = True
        self.rest = p
        self.faces = f
        self.handles = C
        self.pose = p.copy()
        self._cold = True
        self._cot = cotangent_weights(p, f)
        k = np.ones(len(f)) if stiffness is None else np.array(stiffness, float).reshape(-1)
        if k.shape != (len(f),) or not np.all(np.isfinite(k) & (k > 0)):
            raise ValueError(f"stiffness: expected {len(f)} positive numbers, one per face")
        # Rest edges, edge k of face t runs corner k+1 -> k+2.
        self._edges = _edge_vectors(p, f)
        loose = _unheld(f, G, C, mask)
        if loose is not None:
            raise ValueError(f"handles: the piece of the mesh holding vertex {loose} has no handle "
                             f"and is not fixed")
        # x = T z over the vertices z that no exact glue row is solved for
        self._T, self._keep, held = _substitution(G, mask) if exact_glue else (
            sp.identity(n, format="csr"), np.arange(n), np.zeros(G.shape[0], bool))
        self.glue_held = held
        Gs = G[np.flatnonzero(~held)]
        self._glue_energy = glue_weight * (Gs.T @ Gs)
        self._fixed = np.flatnonzero(mask)
        self._held = ((C @ self._T).tocsr(), mask[self._keep])
        self._tail = np.concatenate([f[:, (c + 1) % 3] for c in range(3)])
        self._head = np.concatenate([f[:, (c + 2) % 3] for c in range(3)])
        self._stiffening = None
        self._assemble(k)

    def _assemble(self, stiffness):
        """The global step's factored matrix and right-hand side for these face stiffnesses."""
        f, n, m = self.faces, len(self.rest), len(self.faces)
        self._weigh(stiffness)
        L = _cotmatrix(f, self._weights, n)
        self._Q = (self._T.T @ (L + self._glue_energy) @ self._T).tocsr()
        self._eliminate(*self._held)
        # The global step's right-hand side b = sum over face edges of R_t w e, into the
        # edge's head (+) and tail (-): b_x = M0 cos - M1 sin, b_y = M0 sin + M1 cos.
        face = np.tile(np.arange(m), 3)
        rows = np.concatenate([self._head, self._tail])
        M = [sp.csr_matrix((np.concatenate([v, -v]), (rows, np.concatenate([face, face]))),
                           shape=(n, m)) for v in (self._we0, self._we1)]
        M = [self._T.T @ Mi for Mi in M]
        if not self._kkt:
            M = [self._P.T @ Mi for Mi in M]
        self._M0, self._M1 = (Mi.tocsr() for Mi in M)

    def _weigh(self, stiffness):
        """The cotangent weights times ``stiffness``, per face and per edge (the local step's)."""
        self._stiffness = stiffness
        self._weights = self._cot * stiffness[:, None]
        w = np.concatenate([self._weights[:, c] for c in range(3)])
        edges = np.concatenate([self._edges[:, c] for c in range(3)])
        self._we0 = w * edges[:, 0]  # edge k of every face, then k + 1, ...
        self._we1 = w * edges[:, 1]

    def _reweighted(self, stiffness):
        """This solver with other face stiffnesses (the same handles, glue and held rows).

        Its matrices are linear in the stiffnesses: the maps are built once
        (:class:`_Stiffening`) and each reweighting evaluates them and factors
        in the first factor's fill-reducing order.
        """
        other = copy.copy(self)
        if self._kkt or self._factor is None:
            other._assemble(stiffness)
            return other
        if self._stiffening is None:
            self._stiffening = other._stiffening = _Stiffening(self)
        self._stiffening.apply(other, stiffness)
        return other

    def _eliminate(self, C, mask):
        """Factor the global step with the handle rows met exactly.

        Each handle row ``c . x = t`` is solved for one of its vertices (the
        pivot, its largest weight) where pivots can be chosen apart (no pivot
        in another row): ``x = P y + D t + H x_fixed`` over the remaining
        vertices ``y``, and ``P^T Q P`` is symmetric positive definite.
        Otherwise (handles sharing all their vertices) the rows are Lagrange
        rows of a KKT system.
        """
        n = C.shape[1]
        Ccsr = C.tocsr()
        used = np.zeros(n, int)
        np.add.at(used, C.tocoo().col, 1)
        pivots = []
        for j in range(C.shape[0]):
            cols = Ccsr.indices[Ccsr.indptr[j]:Ccsr.indptr[j + 1]]
            vals = Ccsr.data[Ccsr.indptr[j]:Ccsr.indptr[j + 1]]
            ok = (used[cols] == 1) & ~mask[cols] & (np.abs(vals) > 1e-3)
            pivots.append(int(cols[ok][np.argmax(np.abs(vals[ok]))]) if ok.any() else -1)
        Q = self._Q
        fixed = np.flatnonzero(mask)
        self._fixed_z = fixed
        if all(p >= 0 for p in pivots) and len(set(pivots)) == len(pivots):
            piv = np.array(pivots, np.int64)
            free = np.setdiff1d(np.flatnonzero(~mask), piv)
            k = len(piv)
            cp = np.asarray(Ccsr[np.arange(k), piv]).ravel()
            scaled = sp.diags(1.0 / cp) @ Ccsr
            # pivot rows of x: t / c_p - sum over the other columns of c / c_p
            S = sp.csr_matrix((np.ones(k), (piv, np.arange(k))), shape=(n, k))
            rest = scaled.tolil()
            rest[np.arange(k), piv] = 0.0
            rest = rest.tocsr()
            E = sp.csr_matrix((np.ones(len(free)), (free, np.arange(len(free)))),
                              shape=(n, len(free)))
            Fx = sp.csr_matrix((np.ones(len(fixed)), (fixed, np.arange(len(fixed)))),
                               shape=(n, len(fixed)))
            self._P = (E - S @ (rest @ E)).tocsr()
            self._D = (S @ sp.diags(1.0 / cp)).tocsr()
            self._H = (Fx - S @ (rest @ Fx)).tocsr()
            PtQ = (self._P.T @ Q).tocsr()
            A = PtQ @ self._P
            self._PtQD = (PtQ @ self._D).toarray()
            self._PtQH = (PtQ @ self._H).tocsr()
            self._factor = spd_factor(A) if A.shape[0] else None
            self._kkt = False
        else:
            free = np.flatnonzero(~mask)
            Cf = C[:, free].tocsr()
            if C.shape[0] and sp.linalg.norm(Cf) == 0 and len(free):
                raise ValueError("handles: every handle lies on fixed vertices")
            self._K = Q[free][:, fixed]
            self._Ck = C[:, fixed].tocsr()
            kkt = sp.bmat([[Q[free][:, free], Cf.T], [Cf, None]], format="csc")
            try:
                self._factor = splu(kkt) if kkt.shape[0] else None
            except RuntimeError:
                raise ValueError("handles: the system is singular (two handles pin the same "
                                 "point)") from None
            self._kkt = True
        self._free = free

    def reset(self):
        """Forget the last pose: the next solve starts cold (from the rigid fit of the handles)."""
        self.pose = self.rest.copy()
        self._cold = True

    def rotations(self, x):
        """Per face, the rotation angle that best fits ``x``'s edges to the rest edges (local step).

        Parameters
        ----------
        x : (n, 2) float array

        Returns
        -------
        (m,) float array
            Angles in radians (counter-clockwise in ``(x, y)``).
        """
        xs, ys = np.ascontiguousarray(x[:, 0]), np.ascontiguousarray(x[:, 1])
        d0 = xs[self._head] - xs[self._tail]
        d1 = ys[self._head] - ys[self._tail]
        # S = sum_k w_k e_k d_k^T; the best rotation maximizes tr(R S) = c (S00 + S11) + s (S01 - S10).
        sin = (self._we0 * d1 - self._we1 * d0).reshape(3, -1).sum(axis=0)
        cos = (self._we0 * d0 + self._we1 * d1).reshape(3, -1).sum(axis=0)
        return np.arctan2(sin, cos)

    def solve(self, targets, *, initial=None, iterations=4):
        """Deform so that the handles reach ``targets``.

        Parameters
        ----------
        targets : (k, 2) float array
            The handles' positions.
        initial : (n, 2) float array, optional
            Start of the local/global iterations; default the last pose, or
            before the first solve the rest shape moved by the rigid motion
            that best fits the handles (Procrustes).
        iterations : int, default 4
            Local/global rounds.

        Returns
        -------
        (n, 2) float array
            The deformed vertices; the handles are met exactly.
        """
        t = np.asarray(targets, float).reshape(-1, 2)
        if t.shape[0] != self.handles.shape[0] or not np.all(np.isfinite(t)):
            raise ValueError(f"targets: expected {self.handles.shape[0]} finite (x, y) points, "
                             f"got shape {np.shape(targets)}")
        if initial is not None:
            x = np.asarray(initial, float).copy()
        elif self._cold:
            x = _rigid_fit(self.handles @ self.rest, t, self.rest)
        else:
            x = self.pose.copy()
        self._cold = False
        x[self._fixed] = self.rest[self._fixed]
        for _ in range(max(1, int(iterations))):
            x = self._global(self.rotations(x), x, t)
        self.pose = x
        return x

    def solve_injective(self, targets, *, initial, iterations=40):
        """Like :meth:`solve` from a pose that folds no face, never folding one.

        Each round weights every face by how much it is compressed (the
        isotropic part of the reweighting that turns local/global rounds into
        a minimizer of the symmetric Dirichlet energy, which grows without
        bound as a face flattens: Rabinovich, Poranne, Panozzo and
        Sorkine-Hornung, "Scalable locally injective mappings", TOG 2017),
        factors the global step again and moves along it only as far as no
        face flips (Smith and Schaefer, "Bijective parameterization with free
        boundaries", TOG 2015), 0.8 of the way to the first flip. The handles
        approach their targets; they are met where the last steps are whole.
        As many rounds of the unweighted energy follow, cut the same way, back
        towards its pose where that folds nothing.

        Parameters
        ----------
        targets : (k, 2) float array
        initial : (n, 2) float array
            A pose in which every face keeps its rest orientation (faces of
            zero area at rest aside).
        iterations : int, default 40
            Rounds, each with its own factorization (the rounds stop early
            once a whole step moves no vertex by more than 1e-6).

        Returns
        -------
        (n, 2) float array

        Examples
        --------
        A square held along its left side, its centre dragged to half a unit
        from that side: the plain solve folds faces there, this one none, and
        the centre reaches its target.

        >>> x, y = np.meshgrid(np.arange(7.0), np.arange(7.0))
        >>> v = np.column_stack([x.ravel(), y.ravel()])
        >>> f = np.concatenate([[[a, a + 1, a + 8], [a, a + 8, a + 7]]
        ...                     for a in [j * 7 + i for j in range(6) for i in range(6)]])
        >>> handles = [0, 7, 14, 21, 28, 35, 42, 24]
        >>> targets = np.vstack([v[handles[:-1]], [[0.5, 3.0]]])
        >>> solver = Arap(v, f, handles=handles)
        >>> int(np.sum(signed_areas(solver.solve(targets, iterations=40), f) <= 0))
        2
        >>> out = solver.solve_injective(targets, initial=v)
        >>> int(np.sum(signed_areas(out, f) <= 0)), bool(np.abs(out[24] - [0.5, 3.0]).max() < 1e-4)
        (0, True)
        """
        t = np.asarray(targets, float).reshape(-1, 2)
        if t.shape[0] != self.handles.shape[0] or not np.all(np.isfinite(t)):
            raise ValueError(f"targets: expected {self.handles.shape[0]} finite (x, y) points, "
                             f"got shape {np.shape(targets)}")
        x = np.asarray(initial, float).copy()
        sign = np.sign(signed_areas(self.rest, self.faces))
        area = signed_areas(x, self.faces)
        if np.any(sign * area < 0) or np.any((sign != 0) & (area == 0)):
            raise ValueError("initial: a face is flipped or flat")
        x[self._fixed] = self.rest[self._fixed]
        for _ in range(max(1, int(iterations))):
            solver = self._reweighted(
                self._stiffness * _compression_weights(self.rest, self.faces, x))
            step = solver._global(solver.rotations(x), x, t) - x
            a = min(1.0, 0.8 * _first_flip(x, self.faces, sign, step))
            x = x + a * step
            if a == 1.0 and np.abs(step).max() < 1e-6:
                break
        # back towards the unweighted energy's pose, steps still cut before a flip (handles
        # once met stay met: each step ends where the global step meets them)
        for _ in range(max(1, int(iterations))):
            step = self._global(self.rotations(x), x, t) - x
            a = min(1.0, 0.8 * _first_flip(x, self.faces, sign, step))
            x = x + a * step
            if np.abs(a * step).max() < 1e-6:
                break
        self.pose = x
        self._cold = False
        return x

    def energy(self, x):
        """The ARAP energy of ``x`` with its best-fitting rotations (0 for a rigid motion).

        Without the stiffness factors: comparable between solvers of one mesh.
        """
        return arap_energy(self.rest, self.faces, x, weights=self._cot,
                           angles=self.rotations(np.asarray(x, float)))

    def _global(self, angles, x, targets):
        c, s = np.cos(angles), np.sin(angles)
        a, b = self._M0 @ c, self._M1 @ s
        e, g = self._M0 @ s, self._M1 @ c
        rhs = np.column_stack([a - b, e + g])
        z = x[self._keep]
        if self._factor is None:
            return self._T @ z
        zk = z[self._fixed_z]
        if self._kkt:
            rhs = np.concatenate([rhs[self._free] - self._K @ zk, targets - self._Ck @ zk])
            z[self._free] = self._factor.solve(rhs)[:len(self._free)]
            return self._T @ z
        y = self._factor.solve(rhs - self._PtQD @ targets - self._PtQH @ zk)
        return self._T @ (self._P @ y + self._D @ targets + self._H @ zk)


def arap(vertices, faces, handles, targets, *, iterations=20):
    """One ARAP deformation (see :class:`Arap` for repeated drags).

    Parameters
    ----------
    vertices : (n, 2) float array
    faces : (m, 3) int array
    handles : (k,) int array or (k, n) sparse matrix
    targets : (k, 2) float array
    iterations : int, default 20

    Returns
    -------
    (n, 2) float array

    Examples
    --------
    >>> v = np.array([[0.0, 0], [1, 0], [0, 1]])
    >>> np.round(arap(v, [[0, 1, 2]], [0, 1], [[5.0, 5], [6, 5]]), 6).tolist()  # a translation
    [[5.0, 5.0], [6.0, 5.0], [5.0, 6.0]]
    """
    return Arap(vertices, faces, handles=handles).solve(targets, iterations=iterations)


def arap_energy(rest, faces, x, *, weights=None, angles=None):
    """ARAP energy of a deformation: cotangent-weighted squared edge misfit after the best rotations.

    Parameters
    ----------
    rest, x : (n, 2) float array
    faces : (m, 3) int array
    weights : (m, 3) float array, optional
        :func:`cotangent_weights` of ``rest`` (computed when omitted).
    angles : (m,) float array, optional
        Per-face rotations (the best fit when omitted).

    Returns
    -------
    float

    Examples
    --------
    >>> v = np.array([[0.0, 0], [1, 0], [0, 1]])
    >>> round(arap_energy(v, [[0, 1, 2]], v @ [[0.0, 1], [-1, 0]] + 3), 12)   # a rigid motion
    0.0
    """
    p = np.asarray(rest, float)
    f = np.asarray(faces, np.int64)
    x = np.asarray(x, float)
    w = cotangent_weights(p, f) if weights is None else weights
    e, d = _edge_vectors(p, f), _edge_vectors(x, f)
    if angles is None:
        angles = best_rotations(p, f, x, weights=w)
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    re = np.stack([c * e[..., 0] - s * e[..., 1], s * e[..., 0] + c * e[..., 1]], -1)
    return float(0.5 * np.sum(w * np.sum((d - re) ** 2, axis=-1)))


def best_rotations(rest, faces, x, *, weights=None):
    """Per face, the angle of the rotation that best takes its rest edges to ``x``'s (the local step).

    Parameters
    ----------
    rest, x : (n, 2) float array
    faces : (m, 3) int array
    weights : (m, 3) float array, optional
        Per edge (opposite each corner); 1 when omitted.

    Returns
    -------
    (m,) float array
        Angles in radians, counter-clockwise in ``(x, y)``.

    Examples
    --------
    >>> v = np.array([[0.0, 0], [1, 0], [0, 1]])
    >>> best_rotations(v, np.array([[0, 1, 2]]), v @ [[0.0, 1], [-1, 0]] + 3).round(6).tolist()
    [1.570796]
    """
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    e, d = _edge_vectors(np.asarray(rest, float), f), _edge_vectors(np.asarray(x, float), f)
    w = np.ones(f.shape) if weights is None else weights
    # S = sum_k w_k e_k d_k^T; the best rotation maximizes tr(R S) = c (S00 + S11) + s (S01 - S10).
    S = np.einsum("mki,mkj->mij", w[..., None] * e, d)
    return np.arctan2(S[:, 0, 1] - S[:, 1, 0], S[:, 0, 0] + S[:, 1, 1])


def _compression_weights(rest, faces, x):
    """Per face, ``(s + 1)(s^2 + 1) / (4 s^3)`` of its smaller singular value ``s`` (at least 1).

    The weight the reweighting of the symmetric Dirichlet energy gives a face
    compressed to ``s`` (1 at rest): it grows as ``s^-3`` as the face flattens.
    """
    e, d = _edge_vectors(rest, faces), _edge_vectors(x, faces)
    # J maps rest edges 1, 2 to posed ones: J = D E^-1 with the edges as columns, in closed form
    (a, c), (b, dd) = e[:, 1].T, e[:, 2].T  # E = [[a, b], [c, dd]]
    (p, r), (q, t) = d[:, 1].T, d[:, 2].T  # D = [[p, q], [r, t]]
    det = a * dd - b * c
    ok = np.abs(det) > 1e-12
    inv = np.divide(1.0, det, out=np.zeros_like(det), where=ok)
    j00, j01 = (p * dd - q * c) * inv, (q * a - p * b) * inv
    j10, j11 = (r * dd - t * c) * inv, (t * a - r * b) * inv
    fro = j00 * j00 + j01 * j01 + j10 * j10 + j11 * j11
    dj = np.abs(j00 * j11 - j01 * j10)
    s = np.sqrt(np.maximum(0.5 * (fro - np.sqrt(np.maximum(fro * fro - 4 * dj * dj, 0.0))), 0.0))
    s = np.maximum(s, 1e-3)
    w = (s + 1) * (s * s + 1) / (4 * s ** 3)
    return np.where(ok, np.maximum(w, 1.0), 1.0)


def _first_flip(x, faces, sign, step):
    """The smallest ``a > 0`` at which a face of ``x + a step`` loses its orientation ``sign``."""
    f = faces
    p, q = x[f], step[f]
    e1, e2, g1, g2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]

    def cross(u, v):
        return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]

    # sign * area(a) = c0 + c1 a + c2 a^2 with c0 > 0
    c0, c1, c2 = sign * cross(e1, e2), sign * (cross(e1, g2) + cross(g1, e2)), sign * cross(g1, g2)
    live = sign != 0
    c0, c1, c2 = c0[live], c1[live], c2[live]
    first = np.full(len(c0), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        tiny = np.abs(c2) <= 1e-12 * (np.abs(c1) + np.abs(c0))
        lin = tiny & (c1 < 0)
        first[lin] = -c0[lin] / c1[lin]
        disc = c1 * c1 - 4 * c2 * c0
        quad = ~tiny & (disc >= 0)
        r = np.sqrt(np.where(quad, disc, 0.0))
        roots = np.stack([(-c1 - r) / (2 * c2), (-c1 + r) / (2 * c2)])
        roots = np.where(roots > 0, roots, np.inf).min(axis=0)
        first[quad] = roots[quad]
    return float(first.min(initial=np.inf))


class _Stiffening:
    """A solver's global step as linear maps of its face stiffnesses, for solves that weight
    the faces again every round.

    The eliminated system ``A = R^T (L + G) R`` (``R = T P``: the glue's and the
    handles' substitutions), its handle and fixed-vertex columns and the
    right-hand side's operators are each a sum over faces of the face's
    stiffness times a fixed matrix: evaluated by one sparse product per
    reweighting instead of assembled, and factored in the fill-reducing order
    of the solver's own factor (the pattern does not change).
    """

    def __init__(self, solver):
        s = solver
        m = len(s.faces)
        i, j = s._tail, s._head
        w = np.concatenate([s._cot[:, c] for c in range(3)])
        face = np.tile(np.arange(m), 3)
        g = s._glue_energy.tocoo()
        # L = sum over face edges of w (e_i - e_j)(e_i - e_j)^T, the glue a last "face" of 1
        self._rows = np.concatenate([i, j, i, j, g.row])
        self._cols = np.concatenate([i, j, j, i, g.col])
        self._coef = np.concatenate([w, w, -w, -w, g.data])
        self._face = np.concatenate([face, face, face, face, np.full(g.nnz, m)])
        self._columns = m + 1  # the stiffnesses and the glue's 1
        R = (s._T @ s._P).tocsr()
        self._order = np.argsort(s._factor.perm_c)
        rank = np.empty_like(self._order)
        rank[self._order] = np.arange(len(rank))
        self._A = self._map(R, R, rank)
        self._D = self._map(R, (s._T @ s._D).tocsr())
        self._H = self._map(R, (s._T @ s._H).tocsr())
        self._M = (s._M0, s._M1, s._stiffness.copy())

    def _map(self, X, Y, rank=None):
        """``X^T L(k) Y`` as ``(B, pattern)``: its entries are ``B @ k`` in CSR order of
        ``pattern`` (``rank``: both indices renumbered so)."""
        e, p, xv = _row_entries(X, self._rows)
        e2, q, yv = _row_entries(Y, self._cols[e])
        e, p, xv = e[e2], p[e2], xv[e2]
        if rank is not None:
            p, q = rank[p], rank[q]
        width = Y.shape[1]
        keys, slot = np.unique(p.astype(np.int64) * width + q, return_inverse=True)
        B = sp.csr_matrix((self._coef[e] * xv * yv, (slot.ravel(), self._face[e])),
                          shape=(len(keys), self._columns))
        rows = keys // width
        indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=X.shape[1]))])
        return B, (keys % width, indptr, (X.shape[1], width))

    @staticmethod
    def _evaluate(mapped, k):
        B, (indices, indptr, shape) = mapped
        return sp.csr_matrix((B @ k, indices, indptr), shape=shape)

    def apply(self, solver, stiffness):
        """Give ``solver`` (a copy of the one the maps were made from) these stiffnesses."""
        k = np.append(stiffness, 1.0)
        solver._weigh(stiffness)
        M0, M1, k0 = self._M
        scale = sp.diags(stiffness / k0)
        solver._M0, solver._M1 = (M0 @ scale).tocsr(), (M1 @ scale).tocsr()
        solver._PtQD = self._evaluate(self._D, k).toarray()
        solver._PtQH = self._evaluate(self._H, k)
        # symmetric: its CSR arrays read as CSC are the same matrix
        A = self._evaluate(self._A, k)
        solver._factor = _Ordered(sp.csc_matrix((A.data, A.indices, A.indptr), shape=A.shape),
                                  self._order)
        solver._Q = None  # not assembled


class _Ordered:
    """A factor of a matrix given in a fill-reducing order ``order`` (row and column ``i`` of
    the matrix are ``order[i]`` of the system): its ``solve`` takes the system's order."""

    def __init__(self, A, order):
        self._order = order
        self._lu = spd_factor(A, ordered=True)

    def solve(self, b):
        out = np.empty_like(b)
        out[self._order] = self._lu.solve(b[self._order])
        return out


def _row_entries(M, rows):
    """The nonzeros of ``M`` (CSR) in each of ``rows``: the position in ``rows`` each belongs
    to, its column and its value."""
    counts = np.diff(M.indptr)[rows]
    at = np.repeat(M.indptr[rows], counts) + (
        np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts))
    return np.repeat(np.arange(len(rows)), counts), M.indices[at], M.data[at]


def _edge_vectors(v, f):
    """(m, 3, 2): each face's edge opposite each corner."""
    return np.stack([v[f[:, (k + 2) % 3]] - v[f[:, (k + 1) % 3]] for k in range(3)], 1)


def pieces(n, faces, glue=None):
    """Connected pieces of a mesh whose vertices faces and glue rows connect.

    Parameters
    ----------
    n : int
        Number of vertices.
    faces : (m, 3) int array
    glue : (g, n) sparse matrix, optional
        Each row connects the vertices it involves.

    Returns
    -------
    (n,) int array
        The piece of every vertex.

    Examples
    --------
    >>> pieces(7, np.array([[0, 1, 2], [3, 4, 5]])).tolist()
    [0, 0, 0, 1, 1, 1, 2]
    """
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    i = [f[:, 0], f[:, 1], f[:, 2]]
    j = [f[:, 1], f[:, 2], f[:, 0]]
    if glue is not None:
        g = sp.csr_matrix(glue).tocoo()
        touch = sp.csr_matrix((np.ones(g.nnz), (g.row, g.col)), shape=g.shape)
        links = (touch.T @ touch).tocoo()
        i.append(links.row)
        j.append(links.col)
    i, j = np.concatenate(i), np.concatenate(j)
    graph = sp.csr_matrix((np.ones(len(i)), (i, j)), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def _unheld(faces, glue, handles, fixed):
    """A vertex of a connected piece that no handle or fixed vertex holds, or None."""
    piece = pieces(len(fixed), faces, glue)
    held = np.zeros(piece.max() + 1 if len(piece) else 0, bool)
    held[piece[fixed]] = True
    held[piece[handles.tocoo().col]] = True
    free = np.flatnonzero(~held[piece])
    return int(free[0]) if free.size else None


def _substitution(glue, fixed):
    """Glue rows held exactly by substitution, one level deep: ``x = T z``.

    Rows are taken in order; a row is held when its pivot (its vertex of
    largest weight) is not fixed, not another held row's pivot and not among
    another held row's vertices, and none of its other vertices is a pivot.
    Then every pivot is a combination of vertices that are no pivots, and the
    held rows vanish for any ``z``.

    Returns
    -------
    T : (n, r) sparse matrix
    keep : (r,) int array
        The vertices ``z`` stands for (``T`` is the identity on them).
    held : (g,) bool array
        The rows held exactly.
    """
    G = sp.csr_matrix(glue)
    n = G.shape[1]
    pivot = np.full(n, -1)
    involved = np.zeros(n, bool)
    held = np.zeros(G.shape[0], bool)
    subs = []
    for r in range(G.shape[0]):
        cols = G.indices[G.indptr[r]:G.indptr[r + 1]]
        vals = G.data[G.indptr[r]:G.indptr[r + 1]]
        big = np.abs(vals) > 1e-12 * max(np.abs(vals).max(initial=0.0), 1e-300)
        cols, vals = cols[big], vals[big]
        if not len(cols):
            continue
        k = int(np.argmax(np.abs(vals)))
        p, others = int(cols[k]), np.delete(cols, k)
        if fixed[p] or pivot[p] >= 0 or involved[p] or (pivot[others] >= 0).any():
            continue
        pivot[p] = r
        involved[others] = True
        held[r] = True
        subs.append((p, others, -np.delete(vals, k) / vals[k]))
    keep = np.flatnonzero(pivot < 0)
    z = np.full(n, -1)
    z[keep] = np.arange(len(keep))
    rows, cols, vals = [keep], [np.arange(len(keep))], [np.ones(len(keep))]
    for p, others, w in subs:
        rows.append(np.full(len(others), p))
        cols.append(z[others])
        vals.append(w)
    T = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n, len(keep)))
    return T, keep, held


def _rigid_fit(src, dst, points):
    """``points`` moved by the rotation and translation taking ``src`` closest to ``dst``."""
    if len(src) == 0:
        return points.copy()
    cs, cd = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - cs, dst - cd
    S = a.T @ b
    angle = np.arctan2(S[0, 1] - S[1, 0], S[0, 0] + S[1, 1]) if len(src) > 1 else 0.0
    c, s = np.cos(angle), np.sin(angle)
    return (points - cs) @ np.array([[c, s], [-s, c]]) + cd


def _cotmatrix(faces, weights, n):
    """The positive semi-definite cotangent Laplacian assembled from per-face edge weights."""
    i = np.concatenate([faces[:, (k + 1) % 3] for k in range(3)])
    j = np.concatenate([faces[:, (k + 2) % 3] for k in range(3)])
    w = np.concatenate([weights[:, k] for k in range(3)])
    off = sp.csr_matrix((-w, (i, j)), shape=(n, n))
    off = off + off.T
    return (off - sp.diags(np.asarray(off.sum(axis=1)).ravel())).tocsr()


def _rows(rows, n, name):
    """Constraint rows as a sparse (k, n) matrix (vertex indices become unit rows)."""
    if sp.issparse(rows):
        M = sp.csr_matrix(rows, dtype=float)
        if M.shape[1] != n:
            raise ValueError(f"{name}: expected {n} columns, got {M.shape[1]}")
        return M
    idx = np.asarray(rows, np.int64).reshape(-1)
    if idx.size and (idx.min() < 0 or idx.max() >= n):
        raise ValueError(f"{name}: vertex index out of range 0..{n - 1}")
    return sp.csr_matrix((np.ones(len(idx)), (np.arange(len(idx)), idx)), shape=(len(idx), n))
