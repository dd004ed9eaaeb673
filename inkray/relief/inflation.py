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
"""

from dataclasses import dataclass

import igl
import numpy as np

from inkray.errors import InputError, StageError
from inkray.numerics.spd import MinQuadWithFixed
from inkray.relief.outline import DIRICHLET_KINDS
from inkray.relief.triangulation import RegionMesh, mesh_region

__all__ = ["InflatedRegion", "InflationSolver", "dirichlet_vertices", "apply_profile", "inflate_mesh", "inflate_region",
           "PROFILES", "SQRT_SCALE"]

PROFILES = ("sqrt", "linear", "flat")
#: The ``s`` of the ``sqrt`` profile ``h = s * sqrt(f)``: 1 makes a disk's peak ``(sqrt(c)/2) R``.
SQRT_SCALE = 1.0


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
    edges = np.sort(np.asarray(mesh.faces)[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    uniq, count = np.unique(edges, axis=0, return_counts=True)
    a, b = uniq[count == 1].T
    out = base.copy()
    out[a[base[b]]] = True
    out[b[base[a]]] = True
    return out


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
    return InflatedRegion(mesh=mesh, height=apply_profile(f, profile), f=f, solver=solver)


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
    return inflate_mesh(mesh, inflation=inflation, profile=profile)


def _check_options(inflation, profile, name):
    ok = (isinstance(inflation, (int, float, np.number)) and not isinstance(inflation, bool)
          and np.isfinite(inflation) and inflation > 0)
    if not ok:
        raise InputError(f"region {name}: inflation: expected a positive number, got {inflation!r}")
    if not callable(profile) and profile not in PROFILES:
        raise InputError(f"region {name}: profile: unknown profile {profile!r} (expected one of "
                         f"{', '.join(PROFILES)} or a callable)")
