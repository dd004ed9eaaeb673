"""Assembly of the bas-relief: stitched layers -> one mesh per part.

Step 6 of Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for Adding Global
Illumination Effects to Hand-Drawn Characters" (TOG 2014): the stack of
inflated, stitched layers is the relief; seen from the front it reproduces the
drawing, and planar UVs map the drawing onto it.

The open relief has one front surface per part at ``z = h + g``. The closed
variant mirrors each part to the back about its offset field: the back is at
``z = g - h - t``, so the two surfaces share the silhouette vertices where
``h = 0`` (welded, no wall) and are joined by a wall where the outline is
Neumann (``flat``/``graft`` stretches, the image frame), where ``h > 0``.
``t`` is zero except for ``flat`` parts, which get a slab of thickness
``epsilon``. Every closed part is a watertight, consistently oriented
manifold; ``union=True`` merges them into one solid with manifold3d.
"""

import numpy as np

from .errors import StageError
from .relief import Part, Relief

__all__ = ["assemble", "close_part", "union_parts"]


def assemble(layers, *, size, texture=None, closed=False, union=False):
    """Turn stitched layers into a :class:`~inkray.relief.Relief`.

    Parameters
    ----------
    layers : inkray.stitch.Layers
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
    >>> from inkray.inflate import inflate_region
    >>> from inkray.stitch import stitch
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
            flat = bool(np.all(region.height == 0))
            part = close_part(part, layers.offset[i] - region.height
                              - (layers.epsilon if flat else 0.0))
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
    """Close an open front surface with a back surface and walls.

    Parameters
    ----------
    part : Part
        Open front surface: an outline-bounded triangle mesh, faces toward the
        viewer.
    back_z : (n,) float array
        Height of the back below each front vertex (``<=`` the front's).

    Returns
    -------
    Part
        A closed part: front vertices, then back vertices where the back does
        not coincide with the front; walls along the outline where they differ.

    Raises
    ------
    StageError
        When ``back_z`` lies above the front somewhere.
    """
    v = np.asarray(part.vertices, float)
    f = np.asarray(part.faces, np.int64)
    n = len(v)
    back_z = np.asarray(back_z, float)
    gap = v[:, 2] - back_z
    if (gap < -1e-9).any():
        raise StageError(f"part {part.name}: the back lies above the front")
    edges = _boundary_edges(f)
    on_outline = np.zeros(n, bool)
    on_outline[edges.ravel()] = True
    weld = on_outline & (gap <= 1e-9)
    back_index = np.where(weld, np.arange(n), -1)
    new = np.flatnonzero(~weld)
    back_index[new] = n + np.arange(len(new))
    back_v = np.column_stack([v[new, :2], back_z[new]])
    back_f = back_index[f][:, ::-1]
    walls = []
    for a, b in edges:  # front edge a -> b as the front faces run it
        ba, bb = back_index[a], back_index[b]
        if ba != a and bb != b:
            walls += [(b, a, ba), (b, ba, bb)]
        elif ba != a:
            walls.append((b, a, ba))
        elif bb != b:
            walls.append((b, a, bb))
    faces = np.concatenate([f, back_f, np.asarray(walls, np.int64).reshape(-1, 3)])
    return Part(name=part.name, vertices=np.concatenate([v, back_v]), faces=faces, closed=True)


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
    for p in parts:
        # manifold3d works in a right-handed frame: flip y (down -> up) and back.
        verts = np.asarray(p.vertices, np.float32) * np.array([1, -1, 1], np.float32)
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
