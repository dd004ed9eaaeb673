"""Poisson inflation of region meshes and cross-section functions.

Step 4 of Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for Adding Global
Illumination Effects to Hand-Drawn Characters" (TOG 2014): every completed
region is inflated by solving ``-lap f = c`` on its triangle mesh with the
cotangent Laplacian, ``f = 0`` on the silhouette (inked, invented and
``stitch`` outline: Dirichlet) and the natural condition ``df/dn = 0`` on
``flat``/``graft`` stretches and ink-less outline such as the image frame
(Neumann). A cross-section function turns the parabolic ``f`` into heights.

Discretisation (linear finite elements): ``-L f = M c`` with ``L`` the
cotangent matrix (``igl.cotmatrix``, negative semi-definite) and ``M`` the
Voronoi mass matrix (``igl.massmatrix``); the Neumann condition is the natural
one of this weak form, so those vertices are simply unknowns. The matrix
``-L`` restricted to the unknowns is factored once per region
(:class:`InflationSolver`) and reused for every right-hand side.

Heights are in pixels. ``f`` has units px^2 (``c`` is dimensionless); on a
disk of radius ``R``, ``f = c (R^2 - r^2) / 4``, so the ``sqrt`` profile
``h = s * sqrt(f)`` with ``s = 1`` gives ``h = (sqrt(c) / 2) sqrt(R^2 - r^2)``:
peak ``(sqrt(c) / 2) R``, a hemisphere for ``c = 4``, and ``h`` scales
linearly with the drawing. The ``linear`` profile is the parabola itself,
scaled to the same peak: ``h = f / sqrt(max f)``.

The ``sqrt`` profile has a vertical tangent where ``f = 0``: its faces next to
the silhouette stand at 70-85 degrees, where the planar texture coordinates
stretch the drawing's outline over the whole side of the part seen from three
quarters. :func:`inflate_region` makes that limit a short wall
(:func:`rim_wall`): every ``f = 0`` vertex gets a copy
:data:`WALL_INSET` px inside, so the outline's first ring of faces is a wall
of about zero area in the front view, steep enough to take the part's paper
colour in an export (``inkray.formats.meshes``), and :func:`walled_sqrt`
caps the profile's slope inside it at :data:`MAX_SLOPE` degrees: where
``s sqrt(f)`` is steeper, the profile is raised to its tangent of that slope,
which runs down to the wall (unchanged where it is gentler; the peak stays).
Near the outline ``s sqrt(f) ~ s sqrt(G d)`` (``G = |grad f|``, ``d`` the
distance in), so the tangent meets the wall at ``s^2 G / (4 k)``,
``k = tan(MAX_SLOPE)``: about a twelfth of a disk's radius at ``c = 2``, a
sixth at ``c = 4``.
"""

import math
from dataclasses import dataclass, replace

import igl
import numpy as np

from inkray.errors import InputError, StageError
from inkray.numerics.spd import MinQuadWithFixed
from inkray.relief.outline import DIRICHLET_KINDS, INTERIOR
from inkray.relief.triangulation import RegionMesh, mesh_region

__all__ = ["InflatedRegion", "InflationSolver", "dirichlet_vertices", "apply_profile", "inflate_mesh",
           "inflate_region", "rim_wall", "walled_sqrt", "PROFILES", "SQRT_SCALE", "MAX_SLOPE",
           "WALL_INSET"]

PROFILES = ("sqrt", "linear", "flat")
#: The ``s`` of the ``sqrt`` profile ``h = s * sqrt(f)``: 1 makes a disk's peak ``(sqrt(c)/2) R``.
SQRT_SCALE = 1.0
#: Steepest slope (degrees) of the ``sqrt`` profile inside its wall: seen from 45 degrees
#: a face this steep shows the drawing stretched at most about 2.8 times.
MAX_SLOPE = 70.0
#: How far (px) inside the silhouette the wall's top runs: its faces cover this much of
#: the front view per pixel of outline.
WALL_INSET = 0.02
_CAP_ROUNDS = 500  # rounds of drawing steep faces up (the band is a few rings wide)
_CAP_TOLERANCE = 1e-3  # relative slope left above the cap
_CORNER_STRETCH = 4.0  # a corner's copy moves at most this many insets along its bisector


@dataclass
class InflatedRegion:
    """A region mesh with its inflated heights.

    Attributes
    ----------
    mesh : RegionMesh
    height : (n,) float array
        Height toward the viewer per vertex, in px.
    f : (n,) float array
        The Poisson solution (px^2) the profile was applied to.
    solver : InflationSolver or None
        The factored system, for re-solving on the same mesh (None for the
        ``flat`` profile, which solves nothing).
    """

    mesh: RegionMesh
    height: np.ndarray
    f: np.ndarray
    solver: object = None


class InflationSolver:
    """``-lap f = c`` on one region mesh, factored once.

    Parameters
    ----------
    mesh : RegionMesh
    dirichlet : (n,) bool array, optional
        Vertices with prescribed values; defaults to
        :func:`dirichlet_vertices` of the mesh.

    Attributes
    ----------
    laplacian : (n, n) sparse matrix
        Cotangent matrix ``L`` (negative semi-definite).
    mass : (n, n) sparse diagonal matrix
        Voronoi mass matrix ``M``.
    dirichlet : (n,) bool array

    Raises
    ------
    StageError
        When no vertex is Dirichlet: ``-lap f = c`` with only Neumann
        outline has no solution (use the ``flat`` profile for such a region).

    Examples
    --------
    >>> from inkray.relief.triangulation import mesh_region
    >>> yy, xx = np.mgrid[:120, :120]
    >>> solver = InflationSolver(mesh_region((xx - 60) ** 2 + (yy - 60) ** 2 <= 50 ** 2))
    >>> f = solver.solve(4.0)
    >>> bool(abs(f.max() - 50 ** 2) / 50 ** 2 < 0.02)
    True
    """

    def __init__(self, mesh, *, dirichlet=None):
        v = np.asarray(mesh.vertices, float)
        faces = np.asarray(mesh.faces, np.int64)
        if dirichlet is None:
            dirichlet = dirichlet_vertices(mesh)
        self.dirichlet = np.asarray(dirichlet, bool)
        if not self.dirichlet.any():
            raise StageError(f"region {mesh.name}: no silhouette to inflate from (its whole outline "
                             f"is flat, graft or image frame); give it the 'flat' profile")
        self.laplacian = igl.cotmatrix(v, faces).tocsr()
        self.mass = igl.massmatrix(v, faces, igl.MASSMATRIX_TYPE_VORONOI).tocsr()
        # -lap f = c with f fixed on the Dirichlet vertices: the minimizer of
        # 1/2 f^T (-L) f - f^T M c (the cotangent Laplacian L is negative semi-definite).
        self._solver = MinQuadWithFixed(-self.laplacian, self.dirichlet)

    def solve(self, source=2.0, *, values=None):
        """Solve ``-lap f = source`` with ``f = values`` on the Dirichlet vertices.

        Parameters
        ----------
        source : float or (n,) array, default 2
            The right-hand side ``c`` (constant or per vertex).
        values : (n,) array, optional
            Dirichlet values (only entries at Dirichlet vertices are read);
            zero when omitted.

        Returns
        -------
        (n,) float array
        """
        n = self.laplacian.shape[0]
        src = np.broadcast_to(np.asarray(source, float), (n,))
        fixed = None if values is None else np.asarray(values, float)[self._solver.known]
        return self._solver.solve(-(self.mass @ src), fixed)


def dirichlet_vertices(mesh):
    """Vertices where ``f = 0``: the silhouette and the ends of Neumann stretches.

    A vertex is Dirichlet when its kind is in
    :data:`inkray.relief.outline.DIRICHLET_KINDS` (inked, invented, stitch), or when
    an outline edge joins it to such a vertex: that edge lies on the
    silhouette, so both its ends have zero height. This pins the end points of
    ``flat``/``graft`` stretches and of the image frame where a silhouette
    meets them, as in the continuous problem (the Dirichlet part of the
    boundary is closed).

    Parameters
    ----------
    mesh : RegionMesh

    Returns
    -------
    (n,) bool array

    Examples
    --------
    >>> from inkray.relief.triangulation import mesh_region
    >>> yy, xx = np.mgrid[:40, :40]
    >>> mesh = mesh_region((xx - 20) ** 2 + (yy - 20) ** 2 <= 15 ** 2)
    >>> bool(np.array_equal(dirichlet_vertices(mesh), mesh.outline))
    True
    """
    base = np.isin(mesh.kind, DIRICHLET_KINDS)
    directed, once = _outline_edges(np.asarray(mesh.faces, np.int64))
    a, b = directed[once].T
    out = base.copy()
    out[a[base[b]]] = True
    out[b[base[a]]] = True
    return out


def _outline_edges(faces):
    """The directed edges of ``faces`` (three per face, in order) and whether each is an
    outline edge (its undirected edge in one face only)."""
    directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    if directed.size == 0:
        return directed, np.zeros(0, bool)
    # One integer per undirected edge: much faster than unique rows.
    key = directed.min(axis=1) * (int(directed.max()) + 1) + directed.max(axis=1)
    _, inverse, count = np.unique(key, return_inverse=True, return_counts=True)
    return directed, count[inverse] == 1


def apply_profile(f, profile="sqrt"):
    """Turn a Poisson solution into heights with a cross-section function.

    Parameters
    ----------
    f : (n,) float array
        Solution of ``-lap f = c`` (px^2).
    profile : {"sqrt", "linear", "flat"} or callable, default "sqrt"
        ``sqrt``: ``h = s * sqrt(f)`` with ``s`` = :data:`SQRT_SCALE` (round);
        ``linear``: ``h = f / sqrt(max f)`` (the parabola, same peak as sqrt);
        ``flat``: ``h = 0``; a callable gets ``f`` and returns ``(n,)`` heights.

    Returns
    -------
    (n,) float array
        Heights in px.

    Raises
    ------
    InputError
        Unknown profile name, or a callable returning the wrong shape or
        non-finite values.

    Examples
    --------
    >>> apply_profile(np.array([0.0, 4.0, 16.0]))
    array([0., 2., 4.])
    >>> apply_profile(np.array([0.0, 4.0, 16.0]), "linear")
    array([0., 1., 4.])
    """
    f = np.asarray(f, float)
    pos = np.maximum(f, 0.0)  # tiny negatives from obtuse cotangent weights
    if callable(profile):
        h = np.asarray(profile(f.copy()), float)
        if h.shape != f.shape or not np.all(np.isfinite(h)):
            raise InputError(f"profile: the callable must return {f.shape[0]} finite heights, got "
                             f"shape {h.shape}")
        return h
    if profile == "sqrt":
        return SQRT_SCALE * np.sqrt(pos)
    if profile == "linear":
        peak = pos.max() if len(pos) else 0.0
        return pos / np.sqrt(peak) if peak > 0 else np.zeros_like(pos)
    if profile == "flat":
        return np.zeros_like(f)
    raise InputError(f"profile: unknown profile {profile!r} (expected one of {', '.join(PROFILES)} "
                     f"or a callable)")


def inflate_mesh(mesh, *, inflation=2.0, profile="sqrt", solver=None):
    """Inflate a region mesh.

    Parameters
    ----------
    mesh : RegionMesh
    inflation : float, default 2
        The constant ``c`` of ``-lap f = c``.
    profile : str or callable, default "sqrt"
        See :func:`apply_profile`.
    solver : InflationSolver, optional
        A factorisation of this mesh to reuse.

    Returns
    -------
    InflatedRegion

    Raises
    ------
    InputError
        Non-positive or non-finite ``inflation``, unknown profile.

    Examples
    --------
    >>> from inkray.relief.triangulation import mesh_region
    >>> yy, xx = np.mgrid[:120, :120]
    >>> mesh = mesh_region((xx - 60) ** 2 + (yy - 60) ** 2 <= 50 ** 2)
    >>> bool(abs(inflate_mesh(mesh, inflation=4.0).height.max() / 50 - 1) < 0.02)
    True
    """
    _check_options(inflation, profile, mesh.name)
    if profile == "flat":
        zero = np.zeros(len(mesh.vertices))
        return InflatedRegion(mesh=mesh, height=zero, f=zero.copy(), solver=solver)
    solver = solver if solver is not None else InflationSolver(mesh)
    f = solver.solve(float(inflation))
    height = (walled_sqrt(mesh, f, dirichlet=solver.dirichlet) if profile == "sqrt"
              else apply_profile(f, profile))
    return InflatedRegion(mesh=mesh, height=height, f=f, solver=solver)


def inflate_region(mask, *, visible=None, labels=None, region=None, name=None, boundaries=(),
                   inflation=2.0, profile="sqrt", options=None):
    """Mesh and inflate one completed region.

    Parameters
    ----------
    mask : (H, W) bool array
        The completed region.
    visible, labels, region, name, boundaries
        As in :func:`inkray.relief.outline.region_outline`.
    inflation : float, default 2
        ``c`` of ``-lap f = c``.
    profile : str or callable, default "sqrt"
        See :func:`apply_profile`.
    options : inkray.relief.outline.MeshOptions, optional
        How the region is meshed (see :func:`inkray.relief.triangulation.mesh_region`).

    Returns
    -------
    InflatedRegion

    Examples
    --------
    >>> yy, xx = np.mgrid[:200, :200]
    >>> disk = (xx - 100) ** 2 + (yy - 100) ** 2 <= 80 ** 2
    >>> res = inflate_region(disk, inflation=4.0)
    >>> bool(abs(res.height.max() - 80) < 1.2)
    True
    """
    _check_options(inflation, profile, name if name is not None else "region")
    mesh = mesh_region(mask, visible=visible, labels=labels, region=region, name=name,
                       boundaries=boundaries, options=options)
    if profile == "sqrt":
        mesh = rim_wall(mesh)
    return inflate_mesh(mesh, inflation=inflation, profile=profile)


def rim_wall(mesh, *, inset=WALL_INSET):
    """The mesh with a strip of faces along its silhouette, ``inset`` px wide.

    Every vertex with ``f = 0`` (:func:`dirichlet_vertices`) on the outline gets
    a copy ``inset`` px inside, along the bisector of its two outline edges
    (farther at a corner, so that the copy is ``inset`` from both edges, but
    never so far that a face turns over). The faces of the mesh move onto the
    copies and two faces per outline edge join each edge to the copies: the
    outline keeps its vertices, indices, kinds and stations, and a profile
    that is zero on them and positive at the copies stands there as a wall
    covering ``inset`` px of the front view per px of outline. Vertices where
    more than two outline edges meet (two loops touching) keep no copy.

    Parameters
    ----------
    mesh : RegionMesh
    inset : float, default :data:`WALL_INSET`
        Width of the strip in px.

    Returns
    -------
    RegionMesh
        The copies follow the mesh's vertices, interior (no outline kind, no
        entry, no station).

    Raises
    ------
    InputError
        A non-positive or non-finite ``inset``.

    Examples
    --------
    >>> from inkray.relief.triangulation import mesh_region
    >>> yy, xx = np.mgrid[:40, :40]
    >>> mesh = mesh_region((xx - 20) ** 2 + (yy - 20) ** 2 <= 15 ** 2)
    >>> walled = rim_wall(mesh, inset=0.05)
    >>> n, k = len(mesh.vertices), int(mesh.outline.sum())
    >>> len(walled.vertices) == n + k, len(walled.faces) == len(mesh.faces) + 2 * k
    (True, True)
    >>> bool(np.allclose(np.linalg.norm(walled.vertices[n:] - walled.vertices[:n][mesh.outline], axis=1), 0.05, rtol=0.05))
    True
    """
    if not (isinstance(inset, (int, float, np.number)) and np.isfinite(inset) and inset > 0):
        raise InputError(f"region {mesh.name}: inset: expected a positive width in px, got {inset!r}")
    v = np.asarray(mesh.vertices, float)
    faces = np.asarray(mesh.faces, np.int64)
    directed, edge = _outline_edges(faces)
    opposite = faces[:, [2, 0, 1]].ravel()
    (a, b), c = directed[edge].T, opposite[edge]
    # The inward normal of each outline edge: toward its face's third vertex.
    t = v[b] - v[a]
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
    normal = np.column_stack([-t[:, 1], t[:, 0]])
    normal *= np.sign(np.einsum("ij,ij->i", normal, v[c] - v[a]))[:, None]
    n = len(v)
    degree = np.bincount(np.concatenate([a, b]), minlength=n)
    walled = dirichlet_vertices(mesh) & (degree == 2)
    summed = np.zeros((n, 2))
    np.add.at(summed, a, normal)
    np.add.at(summed, b, normal)
    length = np.linalg.norm(summed, axis=1)
    walled &= length > 1e-9  # a spike folding back on itself has no inside direction
    moved = np.flatnonzero(walled)
    bisector = summed[moved] / length[moved, None]
    # At a corner, ``inset`` from both edges: 1 / cos of the half turn between them.
    stretch = np.minimum(2.0 / length[moved], _CORNER_STRETCH)
    step = inset * stretch
    copy = np.full(n, -1, np.int64)
    copy[moved] = n + np.arange(len(moved))
    inner = np.where(copy[faces] >= 0, copy[faces], faces)
    for _ in range(8):  # shorten the steps that turn a face over (a sharp spike)
        w = np.vstack([v, v[moved] + step[:, None] * bisector])
        flipped = _signed_area(w, inner) * _signed_area(v, faces) <= 0
        if not flipped.any():
            break
        bad = np.unique(inner[flipped])
        step[bad[bad >= n] - n] *= 0.5
    u, w_ = copy[a], copy[b]
    both = (u >= 0) & (w_ >= 0)
    strip = [np.column_stack([a, b, w_])[w_ >= 0],
             np.column_stack([a, w_, u])[both],
             np.column_stack([a, b, u])[(u >= 0) & (w_ < 0)]]
    extra = len(moved)
    return replace(
        mesh, vertices=np.vstack([v, v[moved] + step[:, None] * bisector]),
        faces=np.vstack([inner, *strip]),
        kind=np.concatenate([mesh.kind, np.full(extra, INTERIOR, np.asarray(mesh.kind).dtype)]),
        boundary_index=np.concatenate([mesh.boundary_index, np.full(extra, -1)]),
        station=np.concatenate([mesh.station, np.full(extra, -1)]),
        neighbour=np.concatenate([mesh.neighbour, np.full(extra, -1)]))


def walled_sqrt(mesh, f, *, dirichlet=None, max_slope=MAX_SLOPE):
    """The ``sqrt`` profile with its slope capped: raised to the tangent of that slope, then a wall.

    The heights are about the least that are at least ``h = s sqrt(f)`` (``s`` =
    :data:`SQRT_SCALE`) and nowhere steeper than ``k = tan(max_slope)`` on the
    faces whose vertices all have ``f > 0``. Where the profile is gentler it is unchanged;
    where it is steeper (next to the silhouette, where ``s sqrt(f)`` has a
    vertical tangent) it follows its tangent of slope ``k`` down toward the
    outline. The vertices with ``f = 0`` keep height 0, so the outline's
    first ring of faces rises by that tangent's height there: on a disk of
    radius ``R`` at ``c = 4``, ``R (cos a - (1 - sin a) tan a)`` with ``a`` the
    cap (about ``R / 6``), a wall when the ring is a strip of :func:`rim_wall`.

    On the mesh: every face (but the wall's) steeper than ``k`` has its
    heights drawn up toward its highest corner until it is ``k`` steep, a
    vertex taking the highest of its faces' heights, in rounds until none
    is steeper. Heights only rise, so the profile stays at least ``s sqrt(f)``
    and its peak is unchanged.

    Parameters
    ----------
    mesh : RegionMesh
    f : (n,) float array
        Solution of ``-lap f = c`` on the mesh.
    dirichlet : (n,) bool array, optional
        The vertices with ``f = 0``; default :func:`dirichlet_vertices`.
    max_slope : float, default :data:`MAX_SLOPE`
        Steepest face, degrees in (0, 90).

    Returns
    -------
    (n,) float array
        Heights in px.

    Examples
    --------
    >>> from inkray.relief.triangulation import mesh_region
    >>> yy, xx = np.mgrid[:120, :120]
    >>> mesh = rim_wall(mesh_region((xx - 60) ** 2 + (yy - 60) ** 2 <= 50 ** 2))
    >>> f = InflationSolver(mesh).solve(4.0)
    >>> h = walled_sqrt(mesh, f)
    >>> bool(abs(h.max() - 50) < 1)  # the peak as without the cap
    True
    >>> wall = h[len(h) - int(mesh.outline.sum()):]  # the wall's top (the copies come last)
    >>> # about 50 (cos a - (1 - sin a) tan a) = 8.8; less where the first ring lies farther in
    >>> bool(5 < wall.min() and wall.max() < 10)
    True
    """
    if not 0 < max_slope < 90:
        raise InputError(f"region {mesh.name}: max_slope: expected degrees in (0, 90), "
                         f"got {max_slope!r}")
    dirichlet = dirichlet_vertices(mesh) if dirichlet is None else np.asarray(dirichlet, bool)
    # tiny negatives of f from obtuse cotangent weights
    h = SQRT_SCALE * np.sqrt(np.maximum(np.asarray(f, float), 0.0))
    free = ~dirichlet
    faces = np.asarray(mesh.faces, np.int64)
    faces = faces[free[faces].all(axis=1)]  # the wall's faces stand as they are
    p = np.asarray(mesh.vertices, float)[faces]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    ok = np.abs(det) > 1e-12
    faces, e1, e2, det = faces[ok], e1[ok], e2[ok], det[ok]
    k = math.tan(math.radians(max_slope))
    for _ in range(_CAP_ROUNDS):
        # each face steeper than k has its heights drawn up toward its highest corner
        # until it is k steep; a vertex takes the highest of its faces' heights for it
        z = h[faces]
        d1, d2 = z[:, 1] - z[:, 0], z[:, 2] - z[:, 0]
        gx = (d1 * e2[:, 1] - d2 * e1[:, 1]) / det
        gy = (e1[:, 0] * d2 - e2[:, 0] * d1) / det
        slope = np.hypot(gx, gy)
        steep = slope > k * (1.0 + _CAP_TOLERANCE)
        if not steep.any():
            break
        zs, g = z[steep], np.column_stack([gx[steep], gy[steep]])
        top = zs.max(axis=1, keepdims=True)
        raised = top - (top - zs) * (k / slope[steep])[:, None]
        # raising the lowest corner alone is the least change, when that reaches k:
        # |g + t grad(phi)| = k, phi its hat function, t the smallest root
        low = np.argmin(zs, axis=1)
        phi = _hat_gradients(e1[steep], e2[steep], det[steep])[np.arange(len(low)), low]
        a, b = np.einsum("ij,ij->i", phi, phi), np.einsum("ij,ij->i", g, phi)
        disc = b * b - a * (np.einsum("ij,ij->i", g, g) - k * k)
        t = (-b - np.sqrt(np.maximum(disc, 0.0))) / a
        rows = np.arange(len(low))
        # (not beyond where drawing the whole face up would put it: a sliver's corner)
        alone = (disc >= 0) & (b < 0) & (zs[rows, low] + t <= raised[rows, low])
        raised[alone] = zs[alone]
        raised[rows[alone], low[alone]] += t[alone]
        np.maximum.at(h, faces[steep].ravel(), raised.ravel())
    h[dirichlet] = 0.0
    return h


def _hat_gradients(e1, e2, det):
    """Per face ``(m, 3, 2)``: the gradients of its corners' hat functions, from its edges
    ``e1 = p1 - p0``, ``e2 = p2 - p0`` and ``det = e1 x e2``."""
    g1 = np.column_stack([e2[:, 1], -e2[:, 0]]) / det[:, None]
    g2 = np.column_stack([-e1[:, 1], e1[:, 0]]) / det[:, None]
    return np.stack([-g1 - g2, g1, g2], axis=1)


def _signed_area(v, faces):
    p = v[faces]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    return e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]


def _check_options(inflation, profile, name):
    ok = (isinstance(inflation, (int, float, np.number)) and not isinstance(inflation, bool)
          and np.isfinite(inflation) and inflation > 0)
    if not ok:
        raise InputError(f"region {name}: inflation: expected a positive number, got {inflation!r}")
    if not callable(profile) and profile not in PROFILES:
        raise InputError(f"region {name}: profile: unknown profile {profile!r} (expected one of "
                         f"{', '.join(PROFILES)} or a callable)")
