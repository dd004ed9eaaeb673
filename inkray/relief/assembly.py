"""Assembly of the bas-relief: stitched layers -> one mesh per part.

Step 6 of Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for Adding Global
Illumination Effects to Hand-Drawn Characters" (TOG 2014): the stack of
inflated, stitched layers is the relief; seen from the front it reproduces the
drawing, and planar UVs map the drawing onto it.

The open relief has one front surface per part at ``z = h + g``. The closed
variant mirrors each part to the back about its offset field: the back is at
``z = g - h - t`` below the same outline, joined to the front by a wall of
height ``2 h + t`` along it. ``t`` is the depth step ``epsilon``: at the
silhouette (``h = 0``) the wall is a thin rim instead of a knife edge, which
keeps every part a proper 2-manifold (a knife edge pinches wherever a
triangle has all its corners on the silhouette) and gives ``flat`` parts a
slab of thickness ``epsilon``. Every closed part is watertight and
consistently oriented; ``union=True`` merges them into one solid with
manifold3d and remeshes it (PyMeshLab's isotropic remeshing, then again
while a triangle has an angle below 10 degrees): a boolean union
cuts triangles into slivers along every intersection curve, and the steep
rims of inflated parts are slivers in 3D too. Slivers remain only where two
sheets nearly touch (along a graft's seam, the grafted part's wall meets its
base's surface within a fraction of a pixel). Parts that do not touch the
rest (a piece floating in front of the part it belongs to) stay separate
shells, named in :attr:`~inkray.relief.model.Relief.warnings`.
"""

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from inkray.errors import StageError
from inkray.relief.model import Part, Relief

__all__ = ["assemble", "close_part", "union_parts", "remesh_solid", "shell_parts",
           "MIN_ANGLE"]

_SEPARATION = 1e-3  # px between parts in the union (see union_parts)
#: Smallest triangle angle (degrees) the union's remeshing aims for.
MIN_ANGLE = 10.0
_FIX_ROUNDS = 3  # local remeshing rounds around triangles still below MIN_ANGLE


def assemble(layers, *, size, texture=None, closed=False, union=False):
    """Turn stitched layers into a :class:`~inkray.relief.model.Relief`.

    Parameters
    ----------
    layers : inkray.relief.stitching.Layers
    size : (int, int)
        ``(width, height)`` of the drawing.
    texture : (H, W, 3) uint8 array, optional
        The drawing's colours.
    closed : bool, default False
        Make every part a closed solid (mirrored back).
    union : bool, default False
        With ``closed``: one watertight solid, the union of all parts, named
        ``"union"``.

    Returns
    -------
    Relief
        Parts in region order, named after the regions; heights shifted so
        the lowest front (or back, when closed) vertex is at ``z = 0``.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.inflation import inflate_region
    >>> from inkray.relief.stitching import stitch
    >>> yy, xx = np.mgrid[:60, :60]
    >>> layers = stitch([inflate_region((xx - 30) ** 2 + (yy - 30) ** 2 <= 20 ** 2, name="disk")], [], None)
    >>> relief = assemble(layers, size=(60, 60), closed=True)
    >>> relief.parts[0].name, relief.parts[0].closed
    ('disk', True)
    """
    parts = []
    for i, region in enumerate(layers.regions):
        if region is None:
            continue
        mesh = region.mesh
        z = layers.z(i)
        v = np.column_stack([mesh.vertices, z])
        part = Part(name=mesh.name, vertices=v, faces=np.asarray(mesh.faces, np.int64))
        if closed:
            part = close_part(part, layers.offset[i] - region.height - layers.epsilon)
        parts.append(part)
    if not parts:
        raise StageError("assemble: no region has a mesh")
    low = min(float(p.vertices[:, 2].min()) for p in parts)
    for p in parts:
        p.vertices[:, 2] -= low
    warnings = []
    if union:
        if not closed:
            raise StageError("assemble: union needs closed parts")
        solid = union_parts(parts)
        groups = shell_parts(solid, parts)
        if len(groups) > 1:
            apart = "; ".join(", ".join(g) for g in groups[1:])
            warnings.append(f"union: {len(groups)} separate shells: {apart} do not touch "
                            f"{', '.join(groups[0])} (they float in front of the parts behind "
                            f"them or are drawn apart)")
        parts = [solid]
    return Relief(parts=parts, size=tuple(size), texture=texture, warnings=warnings)


def close_part(part, back_z):
    """Close an open front surface with a back surface and a wall along its outline.

    Parameters
    ----------
    part : Part
        Open front surface: an outline-bounded triangle mesh, faces toward the
        viewer.
    back_z : (n,) float array
        Height of the back below each front vertex; strictly below the front
        on the outline (the wall has positive height everywhere, so no face
        is degenerate and every edge has exactly two faces).

    Returns
    -------
    Part
        Front vertices, then their back copies; front faces, reversed back
        faces, and two wall triangles per outline edge.

    Raises
    ------
    StageError
        When ``back_z`` is not below the front.
    """
    v = np.asarray(part.vertices, float)
    f = np.asarray(part.faces, np.int64)
    n = len(v)
    back_z = np.asarray(back_z, float)
    if (v[:, 2] - back_z <= 0).any():
        raise StageError(f"part {part.name}: the back does not lie below the front")
    a, b = _boundary_edges(f).T  # front edge a -> b as the front faces run it
    # the wall runs the shared edges the other way: b -> a on the front, a' -> b' on the back
    walls = np.concatenate([np.stack([b, a, a + n], 1), np.stack([b, a + n, b + n], 1)])
    faces = np.concatenate([f, f[:, ::-1] + n, walls])
    back = np.column_stack([v[:, :2], back_z])
    return Part(name=part.name, vertices=np.concatenate([v, back]), faces=faces, closed=True)


def union_parts(parts, *, name="union", remesh=True):
    """One watertight solid: the union of closed parts (manifold3d), remeshed.

    Parameters
    ----------
    parts : list of Part
        Closed parts.
    name : str, default "union"
    remesh : bool, default True
        Remesh the union (:func:`remesh_solid`) with edges a third as long
        as the parts' median edge.

    Returns
    -------
    Part

    Raises
    ------
    StageError
        When manifold3d rejects a part as not a manifold solid.
    """
    import manifold3d as m3d

    total = None
    for k, p in enumerate(parts):
        # manifold3d works in a right-handed frame: flip y (down -> up) and back.
        # Part k is lifted by k * 1e-3 px: a graft band makes two front surfaces
        # coincide exactly, and coincident faces pinch the union into
        # duplicate-position vertices that other tools weld into non-manifold edges.
        verts = (np.asarray(p.vertices, float) + [0.0, 0.0, k * _SEPARATION]) * [1, -1, 1]
        verts = verts.astype(np.float32)
        solid = m3d.Manifold(m3d.Mesh(vert_properties=verts,
                                      tri_verts=np.asarray(p.faces, np.uint32)))
        if solid.status() != m3d.Error.NoError:
            raise StageError(f"part {p.name}: not a manifold solid for the union ({solid.status().name})")
        total = solid if total is None else total + solid
    mesh = total.to_mesh()
    verts = np.asarray(mesh.vert_properties, float)[:, :3] * np.array([1, -1, 1])
    faces = np.asarray(mesh.tri_verts, np.int64)
    if remesh and len(faces):
        edges = np.concatenate([np.linalg.norm(p.vertices[p.faces] - p.vertices[np.roll(p.faces, 1, 1)],
                                               axis=2).ravel() for p in parts])
        verts, faces = remesh_solid(verts, faces, target=float(np.median(edges)) / 3.0)
    return Part(name=name, vertices=verts, faces=faces, closed=True)


def remesh_solid(vertices, faces, *, target, min_angle=MIN_ANGLE):
    """Isotropic remeshing of a closed solid (PyMeshLab), slivers fixed where they remain.

    The whole surface is remeshed toward edges of length ``target``, and
    again (up to three times) while a triangle has an angle below
    ``min_angle`` (features thinner
    than about a tenth of ``target``, such as two nearly touching sheets, can
    keep a few slivers). Sharp creases are
    not kept as features (the rims of a relief are smooth in the drawing).
    The result is returned only when it is still watertight and
    edge-manifold; otherwise the input comes back unchanged.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
        A watertight, consistently oriented triangle mesh.
    target : float
        Edge length to aim for (same units as the vertices).
    min_angle : float, default 10

    Returns
    -------
    vertices : (n', 3) float array
    faces : (m', 3) int64 array

    Examples
    --------
    >>> import manifold3d as m3d
    >>> cube = m3d.Manifold.cube([10.0, 10.0, 1.0]).to_mesh()
    >>> v, f = remesh_solid(np.asarray(cube.vert_properties, float), np.asarray(cube.tri_verts), target=1.0)
    >>> bool(_min_angles(v, f).min() >= 10.0), len(f) > 100
    (True, True)
    """
    import pymeshlab

    v, f = np.asarray(vertices, float), np.asarray(faces, np.int32)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=v, face_matrix=f))
    length = pymeshlab.PureValue(float(target))
    ms.meshing_isotropic_explicit_remeshing(iterations=8, targetlen=length, featuredeg=89.0,
                                            checksurfdist=False)
    for _ in range(_FIX_ROUNDS):
        m = ms.current_mesh()
        m.compact()
        if _min_angles(m.vertex_matrix(), m.face_matrix()).min(initial=180.0) >= min_angle:
            break
        # (remeshing only the selected slivers would be cheaper, but PyMeshLab's
        # selected-only remeshing depends on earlier calls: the output would too)
        ms.meshing_isotropic_explicit_remeshing(iterations=4, targetlen=length, featuredeg=89.0,
                                                checksurfdist=False)
    m = ms.current_mesh()
    m.compact()
    nv, nf = np.asarray(m.vertex_matrix(), float), np.asarray(m.face_matrix(), np.int64)
    if not _closed_manifold(nf):
        return v, f.astype(np.int64)
    return nv, nf


def shell_parts(solid, parts):
    """The parts in each connected shell of a union, the largest shell first.

    Parameters
    ----------
    solid : Part
        The union.
    parts : list of Part
        The closed parts it was made of.

    Returns
    -------
    list of list of str
        Part names per shell (a part goes to the shell nearest to most of its
        vertices); one list when the union is one solid.

    Examples
    --------
    >>> import manifold3d as m3d
    >>> m = m3d.Manifold.cube([1.0, 1.0, 1.0]).to_mesh()
    >>> cube = Part("a", np.asarray(m.vert_properties, float), np.asarray(m.tri_verts, np.int64))
    >>> shell_parts(cube, [cube])
    [['a']]
    """
    f = np.asarray(solid.faces, np.int64)
    n = len(solid.vertices)
    graph = coo_matrix((np.ones(2 * len(f)), (np.r_[f[:, 0], f[:, 1]], np.r_[f[:, 1], f[:, 2]])),
                       shape=(n, n))
    _, label = connected_components(graph, directed=False)
    tree = cKDTree(np.asarray(solid.vertices, float))
    groups = {}
    for p in parts:
        _, near = tree.query(np.asarray(p.vertices, float))
        groups.setdefault(int(np.bincount(label[near]).argmax()), []).append(p.name)
    sizes = np.bincount(label)
    return [groups[k] for k in sorted(groups, key=lambda k: -sizes[k])]


def _min_angles(vertices, faces):
    """Smallest angle (degrees) of each triangle."""
    t = np.asarray(vertices, float)[np.asarray(faces)]
    out = []
    for i in range(3):
        a, b = t[:, (i + 1) % 3] - t[:, i], t[:, (i + 2) % 3] - t[:, i]
        norm = np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300)
        out.append(np.degrees(np.arccos(np.clip((a * b).sum(axis=1) / norm, -1.0, 1.0))))
    return np.min(out, axis=0)


def _closed_manifold(faces):
    """Every edge has exactly two faces, running it opposite ways."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    if len(faces) == 0 or (counts != 2).any():
        return False
    forward = np.bincount(inv.ravel(), weights=(e[:, 0] < e[:, 1]).astype(float))
    return bool(np.all(forward == 1))


def _boundary_edges(faces):
    """Directed boundary edges (as the faces run them)."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return e[counts[inv.ravel()] == 1]
