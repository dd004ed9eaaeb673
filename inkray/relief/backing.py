"""What an open relief shows from behind, and how deep it is.

An open bas-relief (Ink-and-Ray, Sýkora et al. 2014) is one front surface per
part; seen from behind in a viewer with single-sided materials it vanishes, and
one that draws both sides shows the drawing mirrored. Both functions here give
every open part a back of its own, so that the exporters can give the back the
part's paper colour and the front the drawing:

- :func:`back_sheet` makes each part a sheet: its front, a copy of it a little
  behind (the back), and a narrow wall along its outline. The back never
  coincides with the front, so a path tracer (which culls nothing) sees the
  front from the front and the back from behind.
- :func:`back_plate` closes every part with a flat plate just behind it: the
  front, its outline walled down to the plate, and a flat back; the plates are
  stacked in the parts' depth order, never two in one plane.

:func:`depth_scaled` compresses the heights while keeping every depth order (a
uniform scale keeps every ``front > back``).
"""

from dataclasses import replace

import numpy as np

from inkray.errors import InputError
from inkray.relief.model import Part, Relief

__all__ = ["back_plate", "back_sheet", "depth_scaled"]


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


def back_plate(relief, *, depth=1.0, step=0.25):
    """Every open part closed by a flat plate just behind its own lowest point.

    Each part's plate lies ``depth`` behind the part's lowest vertex, so a
    small part in front stays a thin solid instead of a prism reaching back
    to the deepest part. The plates are stacked by the parts' depth order
    (lowest vertex, then mean height): walking from the front, each plate
    lies at least ``step`` behind the one before, so no two parts' backs are
    coplanar (coplanar backs z-fight in depth-buffered viewers).

    Parameters
    ----------
    relief : Relief
        Open parts (closed parts are kept as they are).
    depth : float, default 1
        Distance (px) from a part's lowest vertex to its plate: positive, so
        no wall collapses where the front touches the plate.
    step : float, default 0.25
        Smallest distance (px) between two parts' plates.

    Returns
    -------
    Relief
        Each open part watertight: its front, a wall along every boundary
        loop and a flat back (faces facing outward).

    Examples
    --------
    >>> tri = Part("a", np.array([[0., 0, 2], [0, 9, 2], [9, 0, 2]]), np.array([[0, 2, 1]]))
    >>> low = Part("b", tri.vertices - [0, 0, 2], tri.faces)
    >>> plated = back_plate(Relief([tri, low], (10, 10)))
    >>> [float(p.vertices[:, 2].min()) for p in plated.parts]
    [1.0, -1.0]
    >>> len(plated.parts[0].vertices), len(plated.parts[0].faces), plated.parts[0].closed
    (6, 8, True)
    """
    if not (np.isfinite(depth) and depth > 0 and np.isfinite(step) and step > 0):
        raise InputError(f"depth {depth!r}, step {step!r}: expected positive numbers")
    open_ = [i for i, p in enumerate(relief.parts) if not p.closed and len(p.vertices)]
    z = np.array([float(np.min(relief.parts[i].vertices[:, 2])) for i in open_])
    mean = np.array([float(np.mean(relief.parts[i].vertices[:, 2])) for i in open_])
    plates = {}
    previous = np.inf
    for k in np.lexsort((-mean, -z)).tolist():  # front to back
        previous = min(z[k] - depth, previous - step)
        plates[open_[k]] = previous
    return replace(relief, parts=[_close(p, plates[i]) if i in plates else p
                                  for i, p in enumerate(relief.parts)])


def back_sheet(relief, *, gap=1.0):
    """Every open part closed by a copy of its front ``gap`` pixels behind it.

    Each part becomes a thin sheet: the front as it is, the back (the front
    moved ``gap`` along ``-z``, faces reversed) and a wall ``gap`` tall along
    every boundary loop. Seen from the front nothing changes (the back and
    the walls lie behind the front and under its outline); seen from behind,
    the back is what shows. Moving along ``-z`` keeps the back of a height
    field strictly behind its front, so the sheet never crosses itself.

    Parameters
    ----------
    relief : Relief
        Open parts (closed parts are kept as they are).
    gap : float, default 1
        Thickness of the sheet (px): positive, so that front and back never
        coincide (coincident faces flicker in depth-buffered viewers and are
        hit at random by a path tracer's rays).

    Returns
    -------
    Relief
        Each open part watertight (faces facing outward); its first vertices
        and faces are the front, unchanged.

    Examples
    --------
    >>> tri = Part("a", np.array([[0., 0, 2], [0, 9, 3], [9, 0, 4]]), np.array([[0, 2, 1]]))
    >>> sheet = back_sheet(Relief([tri], (10, 10))).parts[0]
    >>> sheet.vertices[3:, 2].tolist(), len(sheet.faces), sheet.closed
    ([1.0, 2.0, 3.0], 8, True)
    """
    if not (np.isfinite(gap) and gap > 0):
        raise InputError(f"gap {gap!r}: expected a positive number")
    return replace(relief, parts=[
        p if p.closed or not len(p.vertices) else
        _close(p, np.asarray(p.vertices, float)[:, 2] - gap) for p in relief.parts])


def _close(part, z):
    """``part`` closed by a copy of its vertices at heights ``z`` (one, or one per vertex)."""
    v = np.asarray(part.vertices, float)
    f = np.asarray(part.faces, np.int64)
    n = len(v)
    back = v.copy()
    back[:, 2] = z
    # Boundary edges: used by one face only, kept in that face's direction.
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    _, inverse, counts = np.unique(key[:, 0] * n + key[:, 1], return_inverse=True,
                                   return_counts=True)
    rim = edges[counts[inverse.ravel()] == 1]
    a, b = rim[:, 0], rim[:, 1]
    # The wall runs down from each boundary edge: same orientation as the front's
    # face on that edge, so the solid stays consistently oriented.
    walls = np.concatenate([np.stack([b, a, a + n], 1), np.stack([b, a + n, b + n], 1)])
    faces = np.concatenate([f, f[:, ::-1] + n, walls])
    # a posed part's back and walls take their texture where its front does
    texcoords = None if part.texcoords is None else np.concatenate([part.texcoords] * 2)
    return replace(part, vertices=np.concatenate([v, back]), faces=faces, closed=True,
                   texcoords=texcoords)
