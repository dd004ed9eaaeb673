"""What an open relief shows from behind, and how deep it is.

An open bas-relief (Ink-and-Ray, Sýkora et al. 2014) is one front surface per
part; seen from behind in a viewer with single-sided materials it vanishes.
:func:`back_plate` closes every part against one flat plane behind the whole
relief, like a relief carved from a slab: the front, its outline walled down
to the plane, and a flat back. :func:`depth_scaled` compresses the heights
while keeping every depth order (a uniform scale keeps every ``front > back``).
"""

from dataclasses import replace

import numpy as np

from inkray.errors import InputError
from inkray.relief.model import Part, Relief

__all__ = ["back_plate", "depth_scaled"]


def depth_scaled(relief, scale):
    """The relief with every height multiplied by ``scale``.

    Parameters
    ----------
    relief : Relief
    scale : float
        In ``(0, 10]``: below 1 flattens (a shallower relief), above 1 deepens.

    Returns
    -------
    Relief

    Examples
    --------
    >>> tri = Part("a", np.array([[0., 0, 2], [0, 9, 4], [9, 0, 0]]), np.array([[0, 1, 2]]))
    >>> depth_scaled(Relief([tri], (10, 10)), 0.5).parts[0].vertices[:, 2].tolist()
    [1.0, 2.0, 0.0]
    """
    if not 0 < scale <= 10:
        raise InputError(f"depth scale {scale:g}: expected a number in (0, 10]")
    parts = [replace(p, vertices=np.asarray(p.vertices, float) * [1.0, 1.0, scale])
             for p in relief.parts]
    return replace(relief, parts=parts)


def back_plate(relief, *, z=None):
    """Every open part closed down to one flat back plane.

    Parameters
    ----------
    relief : Relief
        Open parts (closed parts are kept as they are).
    z : float, optional
        Height of the back plane; default one pixel below the lowest vertex of
        the relief (so no wall collapses where the front touches the plane).

    Returns
    -------
    Relief
        Each open part watertight: its front, a wall along every boundary
        loop and a flat back at ``z`` (faces facing outward).

    Examples
    --------
    >>> tri = Part("a", np.array([[0., 0, 2], [0, 9, 2], [9, 0, 2]]), np.array([[0, 2, 1]]))
    >>> closed = back_plate(Relief([tri], (10, 10)), z=0.0).parts[0]
    >>> len(closed.vertices), len(closed.faces), closed.closed
    (6, 8, True)
    """
    if z is None:
        z = min((float(np.min(p.vertices[:, 2])) for p in relief.parts if len(p.vertices)),
                default=0.0) - 1.0
    return replace(relief, parts=[p if p.closed else _close(p, z) for p in relief.parts])


def _close(part, z):
    v = np.asarray(part.vertices, float)
    f = np.asarray(part.faces, np.int64)
    n = len(v)
    back = v.copy()
    back[:, 2] = z
    # Boundary edges: used by one face only, kept in that face's direction.
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    rim = edges[counts[inverse.ravel()] == 1]
    a, b = rim[:, 0], rim[:, 1]
    # The wall runs down from each boundary edge: same orientation as the front's
    # face on that edge, so the solid stays consistently oriented.
    walls = np.concatenate([np.stack([b, a, a + n], 1), np.stack([b, a + n, b + n], 1)])
    faces = np.concatenate([f, f[:, ::-1] + n, walls])
    return Part(part.name, np.concatenate([v, back]), faces, closed=True)
