"""Cues to which of two neighbouring parts is in front, measured at one place.

Ink-and-Ray (Sýkora et al., ACM TOG 33(2), 2014, section 4) reads the order
from the completion of illusory surfaces (Geiger, Pao, Rubin, CVPR 1998): a
part whose completion continues its outline under the other is behind it.
Four cues, each signed so that a positive value says the place's region
``a`` is in front of ``b``:

- ``junction``: at every T- or Y-junction of the place (where the pair's
  common outline ends at a third label, away from ``graft`` and ``stitch``
  seams), how much more completing ``b`` under ``a`` straightens ``b``'s
  outline than the other way round, in units of an ideal T-junction (the
  stem region gains 90 degrees, the bar loses 45). At a T the bar, whose
  outline runs on past the junction, is the part in front.
- ``area``: the paper's "B' larger than B under A",
  ``(|B' in A| - |A' in B|) / (|B' in A| + |A' in B|)``.
- ``surround``: ``s_a**2 - s_b**2`` with ``s_x`` the share of ``x``'s whole
  outline that runs along this contact. A part drawn over another is
  bounded by it along much of its outline (an eye, a nose, an arm across a
  body: the contact is that part's outline), while a part that goes behind
  another meets it only where it disappears (an ear, a far leg). An enclosed
  part has share 1.
- ``continuation``: which part owns the ink line between them. At a
  T-junction the front part's outline runs on along the contact line and
  the back part's outline leaves it. A parabola (a line where the contact is
  shorter than that) is fitted to the contact within ``continuation_widths``
  stroke widths of each junction, walked along the outlines; with
  ``d_x`` the mean distance of ``x``'s other outline there from it, the cue
  is ``(d_b - d_a) / (d_a + d_b)``, averaged over the junctions, times the
  drawing's :meth:`inkray.relief.ink_style.InkStyle.clarity`: on sketchy,
  gappy or doubled strokes the outlines follow the strokes' wobble and the
  cue is a coin toss. Without the drawing's ink style it is 0.

The cues are combined in :func:`inkray.relief.ordering.predict_place`.
"""

import numpy as np
from scipy import ndimage

from inkray.numerics.polyline import point_polyline_distance

__all__ = ["CUES", "contact_continuation", "order_cues", "outline_lengths"]

#: Names of the cues :func:`order_cues` returns, in order.
CUES = ("junction", "area", "surround", "continuation")
_T_SCORE = 135.0  # straightening difference at an ideal T-junction (degrees)


def outline_lengths(labels):
    """Outline length of every region: its pixels with a 4-neighbour of another label.

    Parameters
    ----------
    labels : (H, W) int array
        ``-1`` background, ``0..R-1`` regions.

    Returns
    -------
    (R,) int64 array
        Pixels on the image's edge count as outline.

    Examples
    --------
    >>> import numpy as np
    >>> labels = np.full((6, 6), -1); labels[1:5, 1:5] = 0
    >>> outline_lengths(labels).tolist()
    [12]
    """
    labels = np.asarray(labels)
    count = int(labels.max()) + 1 if labels.size else 0
    if count <= 0:
        return np.zeros(0, np.int64)
    padded = np.pad(labels, 1, constant_values=-2)
    core = padded[1:-1, 1:-1]
    edge = ((padded[:-2, 1:-1] != core) | (padded[2:, 1:-1] != core)
            | (padded[1:-1, :-2] != core) | (padded[1:-1, 2:] != core))
    return np.bincount(core[edge & (core >= 0)], minlength=count).astype(np.int64)


def order_cues(completion, place, *, outlines=None, seams=(), junction_radius=40.0,
               seam_distance=6.0, ink=None, continuation_widths=6.0, stroke_end_scale=1.0):
    """The order cues of one place, positive when ``place.a`` is in front.

    Parameters
    ----------
    completion : inkray.relief.completion.Completion
        Candidate completions (from :func:`inkray.relief.completion.complete_regions`).
    place : inkray.relief.completion.Place
    outlines : (R,) array, optional
        :func:`outline_lengths` of ``completion.labels`` (computed when not given).
    seams : sequence of (k, 2) arrays
        Polylines ``[x, y]`` of the ``graft`` and ``stitch`` boundaries: there
        one region grows out of the other, so their junctions are no cue.
    junction_radius : float, default 40.0
        Largest radius of the disk measured around a junction; it shrinks to
        three half-widths of the thinner region there (a disk much wider than
        a thin part measures its surroundings).
    seam_distance : float, default 6.0
        Junctions this close to a seam are left out.
    ink : inkray.relief.ink_style.InkStyle, optional
        The drawing's stroke width and stroke ends (from
        :func:`inkray.relief.ink_style.ink_style`); without it the
        ``continuation`` cue is 0.
    continuation_widths : float, default 6.0
        Radius, in stroke widths, around each junction over which the contact
        line and the outlines leaving it are compared.
    stroke_end_scale : float, default 1.0
        The ``continuation`` cue is weighted by ``ink.clarity(stroke_end_scale)``
        (``inf``: not weighted).

    Returns
    -------
    dict or None
        ``{"junction", "area", "surround", "continuation"}``, each in [-1, 1]
        (``junction`` may exceed 1 a little); None when every junction of the
        place lies on a seam.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.completion import complete_regions
    >>> square = np.zeros((60, 80), bool); square[10:50, 10:45] = True
    >>> bar = np.zeros((60, 80), bool); bar[24:36, 30:75] = True   # drawn over the square
    >>> c = complete_regions(np.where(bar, 1, np.where(square, 0, -1)))
    >>> cues = order_cues(c, c.places[0])
    >>> cues["junction"] < 0, cues["surround"] < 0     # both say: the bar (b) is in front
    (True, True)
    """
    a, b = place.a, place.b
    if outlines is None:
        outlines = outline_lengths(completion.labels)
    junctions = _free_junctions(place, seams, seam_distance)
    if place.junctions and not junctions:
        return None
    turn = 0.0
    for j in junctions:
        radius = _junction_scale(completion.labels, a, b, j, junction_radius)
        turn += (_straightening(completion, b, a, j, radius)
                 - _straightening(completion, a, b, j, radius))
    turn = turn / len(junctions) / _T_SCORE if junctions else 0.0
    y0, y1, x0, x1 = place.box
    lab = completion.labels[y0:y1, x0:x1]
    share = [float((place.contact & (lab == x)).sum()) / max(int(outlines[x]), 1) for x in (a, b)]
    owns = 0.0
    if ink is not None:
        owns = contact_continuation(completion.labels, place, ink=ink, seams=seams,
                                    continuation_widths=continuation_widths,
                                    seam_distance=seam_distance)
        owns *= ink.clarity(stroke_end_scale)
    return {"junction": float(turn), "area": float(_extension(completion, place)),
            "surround": min(share[0], 1.0) ** 2 - min(share[1], 1.0) ** 2, "continuation": owns}


def contact_continuation(labels, place, *, ink, seams=(), continuation_widths=6.0,
                         seam_distance=6.0):
    """Which part of a place owns the ink line between them, not weighted by the ink's clarity.

    Parameters
    ----------
    labels : (H, W) int array
        The segmentation (``completion.labels``).
    place : inkray.relief.completion.Place
    ink : inkray.relief.ink_style.InkStyle
        The drawing's lines: the comparison runs over ``continuation_widths``
        times ``ink.width`` pixels around each junction.
    seams, seam_distance
        As for :func:`order_cues`: junctions near ``graft`` and ``stitch``
        seams are left out.
    continuation_widths : float, default 6.0

    Returns
    -------
    float
        In [-1, 1], positive when ``place.a``'s outline continues the contact
        line (``a`` in front), averaged over the junctions; 0 without a
        junction or ink.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.completion import complete_regions
    >>> from inkray.relief.ink_style import InkStyle
    >>> labels = np.full((70, 80), -1); labels[30:, 30:50] = 1     # a leg ...
    >>> labels[10:50, 10:70] = 0                                    # ... under a box
    >>> c = complete_regions(labels)
    >>> owns = contact_continuation(labels, c.places[0], ink=InkStyle(width=2.0, stroke_ends=0.0))
    >>> owns > 0.5        # the box's outline runs on past the leg: the box (a) is in front
    True
    """
    if ink.width <= 0:
        return 0.0
    values = [_continuation(np.asarray(labels), place.a, place.b, np.asarray(j, float),
                            continuation_widths * ink.width)
              for j in _free_junctions(place, seams, seam_distance)]
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else 0.0


def _free_junctions(place, seams, seam_distance):
    """The place's junctions farther than ``seam_distance`` from every seam."""
    return [j for j in place.junctions
            if all(point_polyline_distance(j, s) > seam_distance for s in seams)]


def _junction_scale(labels, a, b, point, limit):
    """Disk radius for a junction: three half-widths of the thinner of ``a`` and ``b`` nearby."""
    h, w = labels.shape
    r = int(np.ceil(limit))
    y0, y1 = max(int(point[1]) - r, 0), min(int(point[1]) + r + 2, h)
    x0, x1 = max(int(point[0]) - r, 0), min(int(point[0]) + r + 2, w)
    crop = np.pad(labels[y0:y1, x0:x1], 1, constant_values=-2)
    widths = [ndimage.distance_transform_edt(crop == x).max() for x in (a, b)]
    return float(np.clip(3.0 * min(widths), 4.0, limit))


def _extension(completion, place):
    """Area cue in [-1, 1]: how much more ``b`` extends under ``a`` than ``a`` under ``b``."""
    y0, y1, x0, x1 = place.box
    win = (slice(y0, y1), slice(x0, x1))
    lab, own = completion.labels[win], completion.owner[win]
    b_under_a = int((place.mask & (lab == place.a) & (own == place.b)).sum())
    a_under_b = int((place.mask & (lab == place.b) & (own == place.a)).sum())
    return (b_under_a - a_under_b) / max(b_under_a + a_under_b, 1)


def _straightening(completion, x, other, point, radius):
    """Degrees by which completing ``x`` under ``other`` straightens its outline at ``point``."""
    labels, owner = completion.labels, completion.owner
    h, w = labels.shape
    px, py = point
    r = int(np.ceil(radius))
    y0, y1 = max(int(np.floor(py)) - r, 0), min(int(np.ceil(py)) + r + 1, h)
    x0, x1 = max(int(np.floor(px)) - r, 0), min(int(np.ceil(px)) + r + 1, w)
    yy, xx = np.mgrid[y0:y1, x0:x1]
    disk = (yy - py) ** 2 + (xx - px) ** 2 <= radius * radius
    lab, own = labels[y0:y1, x0:x1][disk], owner[y0:y1, x0:x1][disk]
    visible = lab == x
    completed = visible | ((lab == other) & (own == x))
    t = 360.0 * visible.mean()
    tc = 360.0 * completed.mean()
    return abs(t - 180.0) - abs(tc - 180.0)


def _continuation(labels, a, b, point, radius):
    """Which of ``a`` and ``b`` owns the contact line near ``point``, in [-1, 1] (None: too
    little outline there): positive when ``a``'s outline beyond the contact stays on it."""
    h, w = labels.shape
    r = int(np.ceil(radius)) + 1
    x0, x1 = max(int(point[0]) - r, 0), min(int(point[0]) + r + 1, w)
    y0, y1 = max(int(point[1]) - r, 0), min(int(point[1]) + r + 1, h)
    lab = labels[y0:y1, x0:x1]
    yy, xx = np.mgrid[y0:y1, x0:x1]
    dist = np.hypot(xx - point[0], yy - point[1])
    start = dist <= _SEED_RADIUS

    def along(mask):
        # Walked along the outline from the junction, not cut out by the disk: the far
        # side of a thin part (a hat's brim) lies within the disk but not along its outline.
        y, x = np.nonzero(_walk(mask & (dist <= radius), start, radius))
        return np.stack([x + x0, y + y0], 1).astype(float)

    def third(n):
        return (n != a) & (n != b) & (n != _OUTSIDE)

    contact = along(_border(lab, a, lambda n: n == b) | _border(lab, b, lambda n: n == a))
    other_a, other_b = along(_border(lab, a, third)), along(_border(lab, b, third))
    if len(contact) < 4 or not len(other_a) or not len(other_b):
        return None
    # The contact's own frame: along its main direction u, across it v = p(u).
    mean = contact.mean(0)
    frame = np.linalg.svd(contact - mean, full_matrices=False)[2]

    def uv(pts):
        q = (pts - mean) @ frame.T
        return q[:, 0], q[:, 1]

    u, v = uv(contact)
    # A contact shorter than the radius (a band crossing another) does not fix a
    # curvature, and a parabola through it swings away over the radius: a line then.
    degree = 2 if u.max() - u.min() >= radius else 1
    coef = np.polynomial.polynomial.polyfit(u, v, degree)

    def off(pts):
        pu, pv = uv(pts)
        return float(np.abs(pv - np.polynomial.polynomial.polyval(pu, coef)).mean())

    da, db = off(other_a), off(other_b)
    return (db - da) / max(da + db, 1e-9)


def _walk(mask, start, steps):
    """Pixels of ``mask`` reached from ``start`` in at most ``steps`` 8-connected steps."""
    from skimage.graph import MCP

    seeds = np.argwhere(start & mask)
    if not len(seeds):
        return np.zeros(mask.shape, bool)
    # One shortest-path pass (a path costs one per pixel, its start included), not one
    # dilation per step: 0.6 s of the fox's 4.2 s relief at 1 Mpx went to those.
    cost, _ = MCP(np.where(mask, 1.0, np.inf), fully_connected=True).find_costs(seeds)
    return mask & (cost <= steps + 1.5)

_SEED_RADIUS = 3.0  # pixels around a junction where the walks along the outlines start
_OUTSIDE = -3  # beyond the image's edge: no outline there


def _border(lab, x, touches):
    """Pixels of ``x`` with a 4-neighbour for which ``touches(label)`` holds."""
    padded = np.pad(lab, 1, constant_values=_OUTSIDE)
    found = np.zeros(lab.shape, bool)
    for n in (padded[:-2, 1:-1], padded[2:, 1:-1], padded[1:-1, :-2], padded[1:-1, 2:]):
        found |= touches(n)
    return found & (lab == x)
