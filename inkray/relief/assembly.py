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
manifold3d.
"""

import numpy as np

from inkray.errors import StageError
from inkray.relief.model import Part, Relief

__all__ = ["assemble", "close_part", "union_parts"]

_SEPARATION = 1e-3  # px between parts in the union (see union_parts)


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
    if union:
        if not closed:
            raise StageError("assemble: union needs closed parts")
        parts = [union_parts(parts)]
    return Relief(parts=parts, size=tuple(size), texture=texture)


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


def union_parts(parts, *, name="union"):
    """One watertight solid: the union of closed parts (manifold3d).

    Parameters
    ----------
    parts : list of Part
        Closed parts.
    name : str, default "union"

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
    return Part(name=name, vertices=verts, faces=np.asarray(mesh.tri_verts, np.int64), closed=True)


def _boundary_edges(faces):
    """Directed boundary edges (as the faces run them)."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key = np.sort(e, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return e[counts[inv.ravel()] == 1]
