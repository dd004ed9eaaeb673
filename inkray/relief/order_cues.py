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

from inkray.errors import InputError
from inkray.numerics.polyline import point_polyline_distance

__all__ = ["CUES", "FEATURES", "contact_continuation", "contact_runon", "contact_spur",
           "order_cues", "outline_lengths", "place_features", "region_stats"]

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
    return _mean_continuation(_along(labels, place, continuation_widths * ink.width, seams,
                                     seam_distance))


def _along(labels, place, radius, seams, seam_distance):
    """``[(junction, value)]``: :func:`_continuation` at each junction of the place away
    from the seams (None where there is too little outline)."""
    return [(j, _continuation(np.asarray(labels), place.a, place.b, np.asarray(j, float), radius))
            for j in _free_junctions(place, seams, seam_distance)]


def _mean_continuation(along):
    values = [v for _, v in along if v is not None]
    return float(np.mean(values)) if values else 0.0


def contact_spur(labels, place, *, ink, seams=(), seam_distance=6.0):
    """Which part a line runs on into at the contact, read in the ink.

    At a junction of the place, the front part's outline carries on along the
    contact line and the back part's stroke ends at it; drawn by hand, the
    back part's stroke often runs a little on into the front part (an
    overshoot), a spur of ink inside it. Within ``1.5 w`` of each junction
    (``w`` the stroke width, at least 4 pixels), the share of ``a``'s inside
    (farther than ``0.75 w`` from its outline, so not its own line) that is
    ink, minus the same for ``b``.

    Parameters
    ----------
    labels : (H, W) int array
        The segmentation (``completion.labels``).
    place : inkray.relief.completion.Place
    ink : inkray.relief.ink_style.InkStyle
        The drawing's lines with their ``mask``.
    seams, seam_distance
        As for :func:`order_cues`: junctions near ``graft`` and ``stitch``
        seams are left out.

    Returns
    -------
    float
        In [-1, 1], positive when a line runs on into ``a`` (``a`` in front),
        averaged over the junctions; 0 without a junction, or without the
        ink's mask.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.completion import complete_regions
    >>> from inkray.relief.ink_style import ink_style
    >>> labels = np.full((70, 80), -1); labels[30:, 30:50] = 1     # a leg ...
    >>> labels[10:50, 10:70] = 0                                    # ... under a box
    >>> gray = np.ones((70, 80)); gray[9:12, 9:71] = gray[48:51, 9:71] = 0   # the box's lines
    >>> gray[9:51, 9:12] = gray[9:51, 68:71] = 0
    >>> gray[42:, 29:32] = gray[42:, 48:51] = 0         # the leg's lines run on into the box
    >>> c = complete_regions(labels)
    >>> spur = contact_spur(labels, c.places[0], ink=ink_style(gray))
    >>> spur > 0.1         # the box (a) is in front
    True
    """
    if ink.mask is None or ink.width <= 0:
        return 0.0
    labels, mask = np.asarray(labels), np.asarray(ink.mask, bool)
    if mask.shape != labels.shape:
        raise InputError(f"ink: the {mask.shape[1]}x{mask.shape[0]} ink mask is not the size "
                         f"of the {labels.shape[1]}x{labels.shape[0]} label image")
    values = [_spur(labels, mask, place.a, place.b, np.asarray(j, float), ink.width)
              for j in _free_junctions(place, seams, seam_distance)]
    return float(np.mean(values)) if values else 0.0


def contact_runon(completion, place, *, ink, seams=(), continuation_widths=6.0,
                  seam_distance=6.0, outlines=None):
    """Whose line runs on at the contact: the part's, or a third part's in front of it.

    At a junction of the place with a third part ``z``, the outline of the part
    ``x`` that runs on past the junction (the bar of a T, read as by
    :func:`contact_continuation`) goes on as its contact with ``z``. When ``z``
    is in front of ``x`` (``z``'s outline owns their contact at its other
    junctions) and the place's other part ``y`` lies on ``z`` (much of ``y``'s
    outline runs along ``z``), the line is ``z``'s silhouette and ``y``, drawn
    on ``z`` up to it, is in front of ``x``: a forelock on a head, ending on its
    outline where an ear behind the head meets it. The value at a junction is
    ``|c| q s``, ``c`` the continuation there, ``q`` how much ``z`` owns its
    contact with ``x`` elsewhere (0 when ``x`` owns it) and ``s`` the share of
    ``y``'s outline on its contact with ``z``, signed for ``y`` in front;
    averaged over the junctions with a third part.

    Parameters
    ----------
    completion : inkray.relief.completion.Completion
    place : inkray.relief.completion.Place
    ink : inkray.relief.ink_style.InkStyle
        The drawing's stroke width.
    seams, continuation_widths, seam_distance
        As for :func:`contact_continuation`.
    outlines : (R,) array, optional
        :func:`outline_lengths` of ``completion.labels`` (computed when needed).

    Returns
    -------
    float
        In [-1, 1], positive when ``place.a`` is in front; 0 without a junction
        with a third part, or without ink.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.completion import complete_regions
    >>> from inkray.relief.ink_style import InkStyle
    >>> labels = np.full((90, 100), -1)
    >>> labels[5:50, 30:70] = 0                     # an ear behind ...
    >>> labels[30:85, 10:90] = 1                    # ... a head, with ...
    >>> labels[30:50, 10:50] = 2                    # ... a cap on it, up to its outline
    >>> c = complete_regions(labels)
    >>> ear_cap = next(p for p in c.places if (p.a, p.b) == (0, 2))
    >>> contact_runon(c, ear_cap, ink=InkStyle(width=2.0, stroke_ends=0.0)) < 0   # the cap (b)
    True
    """
    if ink.width <= 0:
        return 0.0
    radius = continuation_widths * ink.width
    return _runon(completion, place, _along(completion.labels, place, radius, seams,
                                            seam_distance),
                  radius=radius, seams=seams, seam_distance=seam_distance, outlines=outlines)


def _runon(completion, place, along, *, radius, seams, seam_distance, outlines):
    """:func:`contact_runon` from the continuations ``along`` the place's junctions."""
    labels = np.asarray(completion.labels)
    values, lies = [], {}  # lies[x, z]: q s, how much y lies on z in front of x
    for j, c in along:
        j = np.asarray(j, float)
        third = _third_part(labels, place.a, place.b, j)
        if third is None or not c:
            continue
        # The part whose outline runs on, and how much the third part owns their contact.
        x, y, sign = (place.a, place.b, -1.0) if c > 0 else (place.b, place.a, 1.0)
        if (x, third) not in lies:  # several junctions of a place often meet the same part
            share = _shared(completion, labels, y, third)
            owned = (_owned_elsewhere(completion, labels, x, third, y, radius, seams,
                                      seam_distance) if share else 0.0)
            if owned > 0 and outlines is None:
                outlines = outline_lengths(labels)
            lies[x, third] = owned * share / max(int(outlines[y]), 1) if owned > 0 else 0.0
        values.append(sign * abs(c) * lies[x, third])
    return float(np.mean(values)) if values else 0.0


def _shared(completion, labels, y, z):
    """Outline pixels of ``y`` on its contact with ``z``, over all their places."""
    count = 0
    for p in completion.places:
        if (p.a, p.b) == (min(y, z), max(y, z)):
            y0, y1, x0, x1 = p.box
            count += int((p.contact & (labels[y0:y1, x0:x1] == y)).sum())
    return count


def _third_part(labels, a, b, point):
    """The region other than ``a`` and ``b`` (not the background) most present within 3
    pixels of a junction ``point``; None when there is none."""
    h, w = labels.shape
    x, y = int(round(point[0])), int(round(point[1]))
    crop = labels[max(y - 3, 0):y + 4, max(x - 3, 0):x + 4].ravel()
    crop = crop[(crop >= 0) & (crop != a) & (crop != b)]
    return int(np.bincount(crop).argmax()) if len(crop) else None


def _owned_elsewhere(completion, labels, x, z, y, radius, seams, seam_distance):
    """How much ``z``'s outline owns its contact with ``x`` (in [0, 1]) at the junctions of
    their places away from ``y``; 0 where ``x``'s does or none is."""
    pair = (min(x, z), max(x, z))
    values = []
    for p in completion.places:
        if (p.a, p.b) != pair:
            continue
        for j in _free_junctions(p, seams, seam_distance):
            # Where ``y`` meets them too, the line is the one in question.
            if _third_part(labels, x, z, j) == y:
                continue
            v = _continuation(labels, z, x, np.asarray(j, float), radius)
            if v is not None:
                values.append(v)
    return max(float(np.mean(values)), 0.0) if values else 0.0


def _spur(labels, mask, a, b, point, width):
    """:func:`contact_spur` at one junction ``point`` ``(x, y)``."""
    h, w = labels.shape
    radius = max(1.5 * width, 4.0)
    # The crop reaches one stroke width past the disk: the distance to a part's outline
    # is measured within it.
    r = int(np.ceil(radius + width)) + 1
    x0, x1 = max(int(point[0]) - r, 0), min(int(point[0]) + r + 1, w)
    y0, y1 = max(int(point[1]) - r, 0), min(int(point[1]) + r + 1, h)
    lab, ink = labels[y0:y1, x0:x1], mask[y0:y1, x0:x1]
    yy, xx = np.ogrid[y0:y1, x0:x1]
    disk = np.hypot(xx - point[0], yy - point[1]) <= radius
    shares = []
    for x in (a, b):
        inner = disk & (ndimage.distance_transform_edt(lab == x) > 0.75 * width)
        shares.append(float(ink[inner].mean()) if inner.any() else 0.0)
    return shares[0] - shares[1]


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
    crop = labels[y0:y1, x0:x1]
    widths = [_inscribed_radius(crop == x) for x in (a, b)]
    return float(np.clip(3.0 * min(widths), 4.0, limit))


def _inscribed_radius(mask):
    """Largest distance from a pixel of ``mask`` to the nearest pixel outside it (beyond the
    edge counts as outside); 0 for an empty mask."""
    rows, cols = np.flatnonzero(mask.any(1)), np.flatnonzero(mask.any(0))
    if not len(rows):
        return 0.0
    # Only the mask's bounding box: the ring just outside it lies outside the mask and is
    # nearer to every pixel of the mask than anything beyond it.
    box = mask[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]
    return float(ndimage.distance_transform_edt(np.pad(box, 1)).max())


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
    yy, xx = np.ogrid[y0:y1, x0:x1]
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
    yy, xx = np.ogrid[y0:y1, x0:x1]
    dist = np.hypot(xx - point[0], yy - point[1])
    start = dist <= _SEED_RADIUS
    disk = dist <= radius
    is_a, is_b = lab == a, lab == b
    touches_a, touches_b, touches_third = _touches(lab, a, b)

    # Walked along the outlines from the junction, not cut out by the disk: the far side
    # of a thin part (a hat's brim) lies within the disk but not along its outline.
    walked = _walk([(is_a & touches_b) | (is_b & touches_a), is_a & touches_third,
                    is_b & touches_third], disk, start, radius)
    contact, other_a, other_b = (np.stack([i % lab.shape[1] + x0, i // lab.shape[1] + y0],
                                          1).astype(float) for i in walked)
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


def _walk(masks, within, start, steps):
    """For each of ``masks``: flat indices, ascending, of its pixels in ``within`` reached
    from ``start`` in at most ``steps`` 8-connected steps within it."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    h, w = within.shape
    stack = np.stack(masks) & within
    pixels = np.flatnonzero(stack)  # over the layers: one graph, one pass for all masks
    seeds = np.flatnonzero(stack & start)
    if not len(seeds):
        return [seeds] * len(masks)
    # Breadth-first over the graph of the masks' pixels alone (a few thousand along the
    # outlines), not over the whole crop; its rows are written in order, not assembled.
    node = np.full(stack.size + 1, -1, np.int64)  # the extra last entry: off the layer
    node[pixels] = np.arange(len(pixels))
    y, x = np.divmod(pixels % (h * w), w)
    steps8 = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]
    near = np.stack([node[np.where((y + dy >= 0) & (y + dy < h) & (x + dx >= 0) & (x + dx < w),
                                   pixels + dy * w + dx, stack.size)] for dy, dx in steps8], 1)
    linked = near >= 0
    indptr = np.concatenate([[0], np.cumsum(linked.sum(1))])
    graph = csr_matrix((np.ones(int(indptr[-1])), near[linked], indptr),
                       shape=(len(pixels),) * 2)
    hops = dijkstra(graph, indices=node[seeds], unweighted=True, min_only=True,
                    limit=steps + 1.0)
    # A path of ``hops`` steps holds ``hops + 1`` pixels, its start included.
    reached = pixels[hops + 1.0 <= steps + 1.5]
    layer = np.searchsorted(reached, np.arange(1, len(masks)) * h * w)
    return [part % (h * w) for part in np.split(reached, layer)]


_SEED_RADIUS = 3.0  # pixels around a junction where the walks along the outlines start
_OUTSIDE = -3  # beyond the image's edge: no outline there


def _touches(lab, a, b):
    """Pixels with a 4-neighbour labelled ``a``, one labelled ``b``, and one of a third
    label (neither ``a`` nor ``b`` nor beyond the image's edge)."""
    padded = np.pad(lab, 1, constant_values=_OUTSIDE)
    found = np.zeros((3,) + lab.shape, bool)
    for n in (padded[:-2, 1:-1], padded[2:, 1:-1], padded[1:-1, :-2], padded[1:-1, 2:]):
        is_a, is_b = n == a, n == b
        found[0] |= is_a
        found[1] |= is_b
        found[2] |= ~is_a & ~is_b & (n != _OUTSIDE)
    return found


#: Names of the columns of :func:`place_features`, for one orientation ``(x, y)``
#: of a place: ``x`` the region supposed in front.
FEATURES = ("junction", "area", "surround", "continuation", "continuation_raw", "clarity",
            "log_area", "share_x", "share_y", "enclosed_x", "enclosed_y", "log_thickness",
            "inside", "hidden_y", "hidden_x", "near_x", "near_y", "far_x", "far_y", "junctions",
            "rise", "ink_spur", "runon")


def place_features(completion, place, *, outlines=None, stats=None, seams=(), ink=None,
                   junction_radius=40.0, continuation_widths=6.0, stroke_end_scale=10.0,
                   seam_distance=6.0):
    """What the learned order model reads at one place, for both orientations.

    Row 0 describes the place with ``x = place.a`` supposed in front of
    ``y = place.b``, row 1 the other way round; a model scores both and
    compares, so its answer does not depend on which region is ``a``.
    Columns (:data:`FEATURES`):

    - the four cues of :func:`order_cues` (signed for ``x`` in front), the
      ``continuation`` cue not weighted by the ink's clarity, and the clarity;
    - ``log_area``: ``log(|x| / |y|)``, the parts' sizes;
    - ``share_x``, ``share_y``: the share of each part's outline on the
      contact, and ``enclosed_x``, ``enclosed_y`` (share above 0.98);
    - ``log_thickness``: log ratio of the parts' largest inscribed radius
      within the place's box (a limb over a body is the thinner part);
    - ``inside``: which part lies inside the bend of the contact line (the
      front part's outline bounds it: the contact curves round the front
      part): ``(n_x - n_y) / (n_x + n_y)`` over the pixels of the contact's
      convex hull;
    - ``hidden_y``, ``hidden_x``: the candidate completion of ``y`` under
      ``x`` (and of ``x`` under ``y``) over the hidden part's visible area;
    - junction patches: ``near_x``, ``near_y`` (share of a disk of 3 stroke
      widths around each junction covered by each part) and ``far_x``,
      ``far_y`` (the same over 8 stroke widths), averaged over the junctions;
      at a T-junction the front part covers half the disk;
    - ``junctions``: how many junctions the place has (at most 4);
    - ``rise``: how far ``x``'s centre lies above ``y``'s, over the square
      root of their mean area;
    - ``ink_spur``: :func:`contact_spur` (signed for ``x`` in front), read in
      the ink at the junctions: the part a line runs on into;
    - ``runon``: :func:`contact_runon` (signed for ``x`` in front): the line
      running on at a junction is a third part's silhouette, in front of the
      part it bounds.

    Parameters
    ----------
    completion : inkray.relief.completion.Completion
    place : inkray.relief.completion.Place
    outlines : (R,) array, optional
        :func:`outline_lengths` of the labels (computed when not given).
    stats : ((R,) array, (R, 2) array), optional
        :func:`region_stats` of the labels (computed when not given).
    seams, ink, junction_radius, continuation_widths, stroke_end_scale, seam_distance
        As for :func:`order_cues`; without ``ink`` the stroke width is taken
        as 2 pixels and the continuation cues are 0, without its ``mask``
        the ink cues are 0.

    Returns
    -------
    (2, len(FEATURES)) float array or None
        None when every junction of the place lies on a seam.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.completion import complete_regions
    >>> labels = np.full((60, 80), -1); labels[10:50, 10:45] = 0
    >>> labels[24:36, 30:75] = 1                                   # a bar over a square
    >>> c = complete_regions(labels)
    >>> f = place_features(c, c.places[0])
    >>> f.shape, bool(f[0, FEATURES.index("log_area")] > 0)
    ((2, 23), True)
    """
    a, b = place.a, place.b
    labels = completion.labels
    if outlines is None:
        outlines = outline_lengths(labels)
    areas, centres = region_stats(labels) if stats is None else stats
    # The continuation at the junctions, read once for its cue and the run-on.
    cues = order_cues(completion, place, outlines=outlines, seams=seams,
                      junction_radius=junction_radius, seam_distance=seam_distance)
    if cues is None:
        return None
    along, radius = [], 0.0
    if ink is not None and ink.width > 0:
        radius = continuation_widths * ink.width
        along = _along(labels, place, radius, seams, seam_distance)
        cues["continuation"] = _mean_continuation(along) * ink.clarity(stroke_end_scale)
    clarity = ink.clarity(stroke_end_scale) if ink is not None else 0.0
    raw = cues["continuation"] / clarity if clarity > 0 else 0.0
    width = ink.width if ink is not None and ink.width > 0 else 2.0
    y0, y1, x0, x1 = place.box
    lab = labels[y0:y1, x0:x1]
    share = [min(float((place.contact & (lab == x)).sum()) / max(int(outlines[x]), 1), 1.0)
             for x in (a, b)]
    thick = [_inscribed_radius(lab == x) for x in (a, b)]
    inside = _inside_bend(place, lab, a, b)
    own = completion.owner[y0:y1, x0:x1]
    hidden = [float((place.mask & (lab == x) & (own == o)).sum()) / max(int(areas[o]), 1)
              for x, o in ((a, b), (b, a))]  # [y=b under x=a, a under b]
    junctions = _free_junctions(place, seams, seam_distance)
    patch = np.zeros((2, 2))  # [radius][part]
    for j in junctions:
        for k, r in enumerate((3.0 * width, 8.0 * width)):
            patch[k] += _disk_shares(labels, j, r, (a, b))
    patch /= max(len(junctions), 1)
    rise = (centres[b, 1] - centres[a, 1]) / np.sqrt((areas[a] + areas[b]) / 2.0 + 1.0)
    spur = (contact_spur(labels, place, ink=ink, seams=seams, seam_distance=seam_distance)
            if ink is not None else 0.0)
    runon = _runon(completion, place, along, radius=radius, seams=seams,
                   seam_distance=seam_distance, outlines=outlines)
    one = np.array([cues["junction"], cues["area"], cues["surround"], cues["continuation"], raw,
                    clarity, np.log((areas[a] + 1.0) / (areas[b] + 1.0)), share[0], share[1],
                    float(share[0] > 0.98), float(share[1] > 0.98),
                    np.log((thick[0] + 1.0) / (thick[1] + 1.0)), inside, hidden[0], hidden[1],
                    patch[0, 0], patch[0, 1], patch[1, 0], patch[1, 1],
                    float(min(len(junctions), 4)), rise, spur, runon])
    other = one.copy()
    for k in ("junction", "area", "surround", "continuation", "continuation_raw", "log_area",
              "log_thickness", "inside", "rise", "ink_spur", "runon"):
        other[FEATURES.index(k)] *= -1.0
    for u, v in (("share_x", "share_y"), ("enclosed_x", "enclosed_y"), ("hidden_y", "hidden_x"),
                 ("near_x", "near_y"), ("far_x", "far_y")):
        i, j = FEATURES.index(u), FEATURES.index(v)
        other[i], other[j] = one[j], one[i]
    return np.stack([one, other])


def region_stats(labels):
    """Pixel count and centre of every region.

    Parameters
    ----------
    labels : (H, W) int array
        ``-1`` background, ``0..R-1`` regions.

    Returns
    -------
    areas : (R,) float array
    centres : (R, 2) float array
        ``[x, y]`` of each region's centre (0 for an empty region).

    Examples
    --------
    >>> import numpy as np
    >>> labels = np.full((4, 6), -1); labels[1:3, 2:6] = 0
    >>> areas, centres = region_stats(labels)
    >>> areas.tolist(), centres.tolist()
    ([8.0], [[3.5, 1.5]])
    """
    labels = np.asarray(labels)
    count = int(labels.max()) + 1 if labels.size else 0
    inside = labels >= 0
    lab = labels[inside]
    yy, xx = np.nonzero(inside)
    areas = np.bincount(lab, minlength=count).astype(float)
    centres = np.stack([np.bincount(lab, xx, minlength=count),
                        np.bincount(lab, yy, minlength=count)], 1) / np.maximum(areas, 1.0)[:, None]
    return areas, centres


def _inside_bend(place, lab, a, b):
    """``(n_a - n_b) / (n_a + n_b)`` over the pixels in the convex hull of the contact."""
    from skimage.morphology import convex_hull_image

    if place.contact.sum() < 3:
        return 0.0
    # The hull lies within the contact's bounding box: only that is searched.
    (box,) = ndimage.find_objects(place.contact.astype(np.int8))
    contact, lab = place.contact[box], lab[box]
    hull = convex_hull_image(contact) & ~contact
    na, nb = int((hull & (lab == a)).sum()), int((hull & (lab == b)).sum())
    return (na - nb) / max(na + nb, 1)


def _disk_shares(labels, point, radius, regions):
    """Share of a disk around ``point`` ``(x, y)`` covered by each of ``regions``."""
    h, w = labels.shape
    r = int(np.ceil(radius))
    px, py = point
    y0, y1 = max(int(py) - r, 0), min(int(py) + r + 2, h)
    x0, x1 = max(int(px) - r, 0), min(int(px) + r + 2, w)
    yy, xx = np.ogrid[y0:y1, x0:x1]
    disk = (yy - py) ** 2 + (xx - px) ** 2 <= radius * radius
    lab = labels[y0:y1, x0:x1][disk]
    n = max(int(disk.sum()), 1)
    return np.array([float((lab == x).sum()) / n for x in regions])
