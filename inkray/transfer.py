"""Carrying a key frame's annotation to another frame of the same shot.

The key's drawing is registered onto the frame as rigidly as possible
(:func:`inkray.numerics.registration.arap_register`, after Sýkora, Dingliana
and Collins, "As-rigid-as-possible image registration for hand-drawn cartoon
animations", NPAR 2009, the application its Fig. 1 names). A part the smooth
registration does not follow (a leg swinging far while the body stays) gets
its own motion: a rigid chamfer search from the registration's fit, then the
part's own ARAP registration (Borgefors, "Hierarchical chamfer matching",
PAMI 1988, for the matching). Chamfer matching of a small limb among another
limb's lines is ambiguous, and a limb may fold further than the search: a
part whose carried region the frame's segmentation (LazyBrush of the carried
scribbles) does not give it is posed again, among its best distinct chamfer
fits and turns about its attachment, by which of them the frame segmented
with its scribbles so carried agrees with best; such a part whose scribbles
land at one end of its carried region is seeded again inside it, where the
frame's lines enclose what that gives it. Every entry of the annotation moves
with its part's motion:

- region and background scribbles, resampled every few pixels so that a
  stroke follows a bending part; a point that lands on ink, or across a line
  in a part it does not belong to, moves to the nearest paper of its own part
  (the key's segmentation, carried to the frame by the registration);
- ``order`` and ``equal`` points likewise, each into the part it marks in the
  key, then into that part of the frame's segmentation, off paper joined to
  the image's border where the part has other paper;
- boundary paths onto the frame's outline between the two parts they
  separate in the key (the frame segmented with the carried scribbles).

Names, inflation and profile are kept. Each entry gets a match score: how
close its part's lines land to the frame's (and, where it moved with the
registration, how well the drawings agree around its points), lowered where a
point had to move far to find its part, and for a region by how much of the
part carried from the key the frame's segmentation gives it; a relation is no
surer than the parts it names, paper between parts no surer than the parts
around it; along a chain of frames the scores multiply. Entries scoring below
a threshold are named in warnings, ``"order[3]: moved 14 px, match 0.41:
check it"``.
"""

from dataclasses import dataclass, field, replace

import numpy as np
from scipy import ndimage

from inkray.errors import InputError
from inkray.input.annotations import Annotations
from inkray.numerics.polyline import resample_polyline
from inkray.numerics.registration import (arap_register, arap_segments, lattice_interpolate,
                                          rigid_poses, rigid_segments, warp_points)
from inkray.segmentation import INK_THRESHOLD, ink_cost, segment

__all__ = ["EntryCheck", "Transfer", "transfer_annotations", "CHECK"]

#: Entries whose match score is below this are named in the warnings.
CHECK = 0.6
#: Scribbles are carried as points this far apart (pixels), then simplified.
_STEP = 3.0
#: A part moves by its own rigid motion when that leaves its ink at most this
#: share of the distance from the frame's ink the registration leaves it.
_OWN = 0.7
#: A part whose region carried from the key and segmented region of the frame
#: overlap less than this (intersection over union) is posed again.
_REPOSE = 0.5
#: Other poses judged for such a part.
_POSES = 4
#: A pose is taken when it raises the agreement of the carried parts with the
#: frame's segmentation by more than this share of the character's pixels.
_GAIN = 0.002
#: A part the segmentation disowns is seeded again at its carried region's
#: deepest pixel it lost, when that lies at least this far (pixels) inside...
_CORE = 3.0
#: ... and the lines of the frame enclose at least this share of what it gains.
_ENCLOSED = 0.7


@dataclass
class EntryCheck:
    """How one entry of the annotation was carried.

    Attributes
    ----------
    key : str
        The entry's key path: ``regions[2]``, ``background[0]``,
        ``order[3]``, ``equal[0]`` or ``boundaries[1]``.
    moved : float
        Mean distance its points moved, in pixels.
    match : float
        In [0, 1]; below the threshold the entry is flagged.
    flagged : bool
    name : str or None
        The region's name (``regions[...]`` entries only).
    """

    key: str
    moved: float
    match: float
    flagged: bool
    name: str = None


@dataclass
class Transfer:
    """The result of :func:`transfer_annotations`.

    Attributes
    ----------
    annotations : inkray.input.annotations.Annotations
        The carried annotation, for the frame (``drawing`` left to the caller).
    entries : list of EntryCheck
        One per entry, in the file's order (regions, background, order,
        equal, boundaries).
    confidence : float
        In [0, 1]: the registration's match over the character's ink.
    warnings : list of str
        One line per flagged entry.
    labels : (H, W) int32 array
        The frame segmented with the carried scribbles (``-1`` background);
        the key labels of the next frame when a shot is carried frame to frame.
    """

    annotations: Annotations
    entries: list
    confidence: float
    warnings: list = field(default_factory=list)
    labels: np.ndarray = None


def transfer_annotations(annotations, key, frame, *, key_labels=None, threshold=CHECK,
                         spacing=8, reach=None, prior=None):
    """Carry the annotation of a key frame onto another frame of the shot.

    Parameters
    ----------
    annotations : inkray.input.annotations.Annotations
        The key frame's annotation.
    key, frame : inkray.input.drawing.Drawing
        The key frame's drawing and the frame's, of the same size.
    key_labels : (H, W) int array, optional
        The key's segmentation by ``annotations`` (computed when not given).
    threshold : float, default :data:`CHECK`
        Entries whose match is below it are flagged.
    spacing : int, default 8
        Lattice spacing of the registration, in pixels.
    reach : float, optional
        How far (pixels) a point may move to reach its part; by default four
        lattice spacings.
    prior : dict, optional
        The key's own match per entry key (``{"order[3]": 0.4}``) when the key
        was itself carried: matches multiply along a chain of frames, so an
        entry that went wrong stays flagged on the frames carried after it.

    Returns
    -------
    Transfer

    Raises
    ------
    InputError
        When the drawings differ in size from each other or from the
        annotation, or the threshold is outside [0, 1].

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.input.annotations import parse_annotations
    >>> from inkray.input.drawing import drawing_from_array
    >>> def box(x):
    ...     g = np.full((60, 80), 255, np.uint8)
    ...     g[15:45, x] = g[15:45, x + 30] = g[15, x:x + 31] = g[44, x:x + 31] = 0
    ...     return drawing_from_array(g, normalize=False)
    >>> ann = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [80, 60],
    ...                          "regions": [{"name": "box", "scribbles": [[[25, 30], [35, 30]]]}]})
    >>> t = transfer_annotations(ann, box(15), box(25))
    >>> np.round(t.annotations.regions[0].scribbles[0][[0, -1]]).tolist()
    [[35.0, 30.0], [45.0, 30.0]]
    >>> t.entries[0].key, t.entries[0].flagged
    ('regions[0]', False)
    """
    size = (annotations.width, annotations.height)
    for what, d in (("key", key), ("frame", frame)):
        if d.size != size:
            raise InputError(f"{what}: the drawing is {d.size[0]}x{d.size[1]} but the annotation is "
                             f"for {size[0]}x{size[1]}")
    if not 0 <= threshold <= 1:
        raise InputError(f"threshold: expected a number in [0, 1], got {threshold!r}")
    reach = 4 * spacing if reach is None else float(reach)
    if key_labels is None:
        key_labels = segment(annotations, key).labels
    key_labels = np.asarray(key_labels)
    if key_labels.shape != key.gray.shape:
        raise InputError(f"key labels: shape {key_labels.shape} differs from the drawing's "
                         f"{key.gray.shape}")

    key_ink = np.clip(1.0 - key.gray, 0, 1)
    frame_ink = np.clip(1.0 - frame.gray, 0, 1)
    reg = arap_register(key_ink, frame_ink, spacing=spacing)
    motions, fit = _part_motions(key_ink, frame_ink, key_labels, reg, spacing=spacing, reach=reach)
    pulled = _pull_back(key_labels, reg.displacement)
    scene = _Scene(frame.gray, reg.confidence, spacing)
    carried = _paint_parts(pulled, key_labels, motions)
    carrier = _Carrier(reg=reg, motions=motions, places=_Places(carried, scene.paper, reach),
                       fit=fit, own=frozenset(motions), scene=scene)
    regions, region_scores = [], []
    for i, r in enumerate(annotations.regions):
        region, score = _carry_region(r, i, carrier, size)
        regions.append(region)
        region_scores.append(score)
    background, background_scores = [], []
    for s in annotations.background:
        out, mv, mt = _carry_polyline(s, -1, carrier)
        background.append(_inside(out, size))
        background_scores.append((mv.mean(), mt.mean()))

    draft = replace(annotations, size=size, regions=regions, background=background, order=[],
                    equal=[], boundaries=[], background_pixels=None, drawing=None, source=None)
    # The frame is segmented again for each pose tried: what it alone decides is kept.
    memo = {}
    first = segment(draft, frame, memo=memo).labels
    n = len(annotations.regions)
    doubt = _overlaps(carried, first, n)
    carrier, carried, draft, labels, region_scores = _repose(
        annotations.regions, np.flatnonzero(doubt < _REPOSE), carrier, carried, draft, first,
        region_scores, key_ink=key_ink, frame_ink=frame_ink, key_labels=key_labels, pulled=pulled,
        frame=frame, memo=memo, reach=reach, size=size)
    if labels is not first:
        # A part that another's new pose took pixels from (or gave them to) is as
        # unsure.
        doubt = np.minimum(doubt, _overlaps(first, labels, n))

    carrier = replace(carrier, places=_Places(carried, scene.paper, reach))
    order, order_scores = _carry_pairs(annotations.order, ("front", "back"), key_labels, carrier,
                                       size)
    equal, equal_scores = _carry_pairs(annotations.equal, ("a", "b"), key_labels, carrier, size)
    named = [item[2] for item in order + equal]
    # A point of an order or equal entry goes into its part as the frame is
    # segmented: where the carried parts and the segmentation differ, the
    # segmentation is what the relief will use.
    # Paper joined to the image's border is outside every closed part: a
    # relation's point goes off it where its part has paper that is not (a
    # part hidden in the frame leaves its point on the open paper beside it).
    segmented = _Places(labels, scene.paper, reach, avoid=_outside(scene.paper))
    order, order_scores = _settle(order, order_scores, ("front", "back"), segmented, reg, spacing,
                                  size)
    equal, equal_scores = _settle(equal, equal_scores, ("a", "b"), segmented, reg, spacing, size)
    draft = replace(draft, order=order, equal=equal)

    checks = _Checks(threshold, prior)
    part_match = _check_parts(checks, draft.regions, region_scores, _overlaps(carried, labels, n),
                              doubt)
    for j, (mv, mt) in enumerate(background_scores):
        # Paper between parts is as sure as the parts around it.
        near = _labels_near(labels, background[j], scene.far, spacing)
        checks.add(f"background[{j}]", mv, min([mt] + [part_match[p] for p in near]))
    # A relation is no surer than the parts it names.
    for e, (mv, mt), parts in zip(order + equal, order_scores + equal_scores, named):
        kind = "order" if e in order else "equal"
        checks.add(f"{kind}[{e.index}]", mv, min([mt] + [part_match[p] for p in parts]))
    boundaries = []
    for b in annotations.boundaries:
        path, mv, mt = _carry_boundary(b.path, key_labels, labels, carrier, reach)
        boundaries.append(replace(b, path=_inside(path, size)))
        checks.add(f"boundaries[{b.index}]", mv, mt)

    character = (key_labels >= 0) & (key.gray < INK_THRESHOLD)
    conf = reg.confidence
    confidence = float(conf[character].mean()) if character.any() else float(conf.mean())
    return Transfer(annotations=replace(draft, boundaries=boundaries), entries=checks.entries,
                    confidence=confidence, warnings=checks.warnings, labels=labels)


# -- the steps -----------------------------------------------------------------

def _part_motions(key_ink, frame_ink, key_labels, reg, *, spacing, reach):
    """The parts that move by their own motion, and how well each part's lines land.

    A part that swings further than the smooth registration follows moves by
    its own rigid motion (refined by its own ARAP registration), where that
    brings its ink clearly closer to the frame's. Returns ``motions`` (part ->
    motion) and ``fit`` (part -> score in [0, 1] from the mean distance of its
    ink to the frame's ink under the motion it moves by).
    """
    rigid = rigid_segments(key_ink, frame_ink, key_labels, reg, radius=reach)
    moved = {k: m for k, m in rigid.items() if m.cost < m.base_cost}
    local = arap_segments(key_ink, frame_ink, key_labels, moved, spacing=max(2, spacing // 2))
    motions = {}
    for k, m in moved.items():
        best = min((m, local.get(k, m)), key=lambda x: x.cost)
        if best.cost < _OWN * m.base_cost:
            motions[k] = best
    fit = {k: _fit_score(motions[k].cost if k in motions else m.base_cost, spacing)
           for k, m in rigid.items()}
    return motions, fit


def _fit_score(cost, spacing):
    """Score of a part whose ink lies ``cost`` pixels (mean) from the frame's ink."""
    return float(np.exp(-(cost / (spacing / 4)) ** 2))


def _moved_score(distance, spacing):
    """Factor of the score of a point that had to move ``distance`` pixels into its part."""
    return np.exp(-(np.minimum(distance, 1e9) / (2 * spacing)) ** 2)


class _Scene:
    """The frame as a carried point meets it: its paper, the registration's match
    (``conf``), and the paper farther than ``spacing`` from any line (``far``)."""

    def __init__(self, gray, conf, spacing):
        self.gray, self.conf, self.spacing = gray, conf, spacing
        self.paper = gray >= INK_THRESHOLD
        self.far = (ndimage.distance_transform_edt(self.paper) > spacing).astype(float)
        self._index = None

    def nearest_paper(self, q):
        """The paper pixel nearest ``q``."""
        if self._index is None:  # rarely needed: computed once, when it is
            self._index = ndimage.distance_transform_edt(
                self.gray < INK_THRESHOLD, return_distances=False, return_indices=True)
        iy, ix = self._index
        h, w = self.gray.shape
        x = int(np.clip(np.rint(q[0]), 0, w - 1))
        y = int(np.clip(np.rint(q[1]), 0, h - 1))
        return np.array([ix[y, x], iy[y, x]], float)


@dataclass(frozen=True)
class _Carrier:
    """How a key point is carried into its part of the frame, and scored.

    ``motions`` (part -> its own motion; the other parts move with the
    registration ``reg``) and ``places`` (the nearest paper of each part as
    carried) move the points; ``fit`` (part -> score) and ``own`` (the parts
    scored by their fit alone) score them.
    """

    reg: object
    motions: dict
    places: object
    fit: dict
    own: frozenset
    scene: _Scene


def _carry_points(points, labels, carrier):
    """Points of parts ``labels`` carried into their parts: new points, distances
    moved, scores."""
    points = np.asarray(points, float).reshape(-1, 2)
    moved = warp_points(carrier.reg, points)
    for lab in set(labels) & set(carrier.motions):
        on = np.asarray(labels) == lab
        moved[on] = carrier.motions[lab].apply(points[on])
    out = np.empty_like(moved)
    snap = np.empty(len(points))
    for i, (q, lab) in enumerate(zip(moved, labels)):
        out[i], snap[i] = carrier.places.place(q, lab)
        if not np.isfinite(snap[i]):
            # No paper of its part within reach: off the ink at least (and
            # scored 0), so that the frame can be segmented.
            out[i] = carrier.scene.nearest_paper(q)
    # A point of a part matches as well as its part does (and no better than
    # the drawings agree around it, where it moved with the registration);
    # a background point far from any line of the frame is surely background.
    local = _sample(carrier.scene.conf, points)
    labels = np.asarray(labels)
    part = np.array([carrier.fit.get(lab, 1.0) for lab in labels])
    own = np.isin(labels, list(carrier.own))
    match = np.where(own, part, np.minimum(local, part))
    clear = _sample(carrier.scene.far, out, order=0) > 0.5
    match = np.where((labels < 0) & clear, 1.0, match)
    match = match * _moved_score(snap, carrier.scene.spacing)
    return out, np.linalg.norm(out - points, axis=1), match


def _carry_polyline(line, label, carrier):
    """A scribble of part ``label`` carried as points a few pixels apart, then simplified."""
    dense = line if len(line) == 1 else resample_polyline(line, _STEP)
    out, moved, match = _carry_points(dense, [label] * len(dense), carrier)
    return _simplify(out, 1.0), moved, match


def _carry_region(region, label, carrier, size):
    """The region with its scribbles carried, and its (mean distance moved, mean score)."""
    scribbles, moved, match = [], [], []
    for s in region.scribbles:
        out, mv, mt = _carry_polyline(s, label, carrier)
        scribbles.append(_inside(out, size))
        moved.append(mv)
        match.append(mt)
    return (replace(region, scribbles=scribbles, pixels=None),
            (np.concatenate(moved).mean(), np.concatenate(match).mean()))


def _repose(regions, parts, carrier, carried, draft, labels, region_scores, *, key_ink,
            frame_ink, key_labels, pulled, frame, memo, reach, size):
    """The ``parts`` posed, or seeded, again where that agrees better with the frame.

    Such a part (its carried region not what the frame's segmentation gives
    it) may have been posed on another part's lines (chamfer matching of a
    small limb is ambiguous) or folded beyond the search: its best distinct
    chamfer fits are tried, each judged by how well the carried parts and the
    frame segmented with the part's scribbles so posed agree (a right pose puts
    them in the enclosed area its region fills). Or its region is carried
    right but its scribbles land at one end of it: a scribble point is added
    where the carried region lies deepest among the pixels the part lost (see
    :func:`_core_point`), taken when the agreement rises and the frame's lines
    enclose most of what the part gains (:func:`_enclosed`). Returns the
    carrier, the carried parts, the draft, the frame's labels and the region
    scores after.
    """
    agree = _agreement(carried, labels)
    region_scores = list(region_scores)
    cost = None
    for i in parts:
        i = int(i)
        for pose in rigid_poses(key_ink, frame_ink, key_labels, i, carrier.reg, count=_POSES,
                                radius=reach):
            trial = {**carrier.motions, i: pose}
            t_carried = _paint_parts(pulled, key_labels, trial)
            # Moved by the pose, scored as the part is now.
            t_carrier = replace(carrier, motions=trial,
                                places=_Places(t_carried, carrier.scene.paper, reach))
            region, score = _carry_region(regions[i], i, t_carrier, size)
            t_draft = _with_region(draft, i, region)
            t_labels = segment(t_draft, frame, memo=memo).labels
            t_agree = _agreement(t_carried, t_labels)
            if t_agree > agree + _GAIN:
                agree, carried, draft, labels = t_agree, t_carried, t_draft, t_labels
                region_scores[i] = score
                fit = _fit_score(pose.cost, carrier.scene.spacing)
                carrier = replace(t_carrier, own=frozenset(trial), fit={**carrier.fit, i: fit})
        # A scribble carried to the narrow end of its part loses the rest of the
        # part to a neighbour's scribble across a gap in the lines: the part is
        # seeded again where its carried region lies deepest among the pixels it
        # lost, when the frame's lines enclose what that gains it.
        point = _core_point(carried, labels, carrier.scene.paper, i)
        if point is None:
            continue
        if cost is None:
            cost = ink_cost(frame.gray)
        r = draft.regions[i]
        t_draft = _with_region(draft, i, replace(r, scribbles=[*r.scribbles, np.array([point])]))
        t_labels = segment(t_draft, frame, memo=memo).labels
        t_agree = _agreement(carried, t_labels)
        if t_agree > agree + _GAIN and _enclosed(labels, t_labels, i, cost) >= _ENCLOSED:
            agree, draft, labels = t_agree, t_draft, t_labels
    return carrier, carried, draft, labels, region_scores


def _with_region(draft, i, region):
    """``draft`` with region ``i`` replaced by ``region``."""
    return replace(draft, regions=draft.regions[:i] + [region] + draft.regions[i + 1:])


def _core_point(carried, labels, paper, label):
    """The paper pixel of part ``label`` as carried, not given to it by ``labels``, that lies
    deepest inside the carried part; None when none lies ``_CORE`` pixels inside."""
    mask = (carried == label) & paper
    ys, xs = np.nonzero(mask)
    if not len(xs):
        return None
    y0, x0 = max(ys.min() - 1, 0), max(xs.min() - 1, 0)
    window = (slice(y0, ys.max() + 2), slice(x0, xs.max() + 2))
    depth = ndimage.distance_transform_edt(mask[window])
    depth[labels[window] == label] = 0
    k = int(depth.argmax())
    y, x = np.unravel_index(k, depth.shape)
    if depth[y, x] < _CORE:
        return None
    return (float(x + x0), float(y + y0))


def _enclosed(labels, t_labels, label, cost):
    """Share of the outline of what part ``label`` gains from ``labels`` to ``t_labels``
    that runs along a line (a cut next to a pixel of ink cost under one half)."""
    mine = t_labels == label
    gained = mine & (labels != label)
    on_line = total = 0
    for axis in (0, 1):
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        lo, hi = tuple(lo), tuple(hi)
        edge = (mine[lo] != mine[hi]) & (gained[lo] | gained[hi])
        total += np.count_nonzero(edge)
        on_line += np.count_nonzero(edge & (np.minimum(cost[lo], cost[hi]) < 0.5))
    return on_line / total if total else 0.0


def _carry_pairs(items, keys, key_labels, carrier, size):
    """``order`` or ``equal`` entries (their two points named ``keys``) with each point
    carried into the part it marks in the key: ``(entry, points, parts, key points)`` and
    ``(mean distance moved, lowest score)`` per entry."""
    out, scores = [], []
    for e in items:
        pa, pb = (getattr(e, k) for k in keys)
        parts = [_label_at(key_labels, pa), _label_at(key_labels, pb)]
        pts, mv, mt = _carry_points([pa, pb], parts, carrier)
        pts = _inside(pts, size)
        if np.allclose(pts[0], pts[1]):  # both into one pixel: keep them apart
            pts = _inside(warp_points(carrier.reg, np.array([pa, pb], float)), size)
        out.append((e, pts, parts, np.array([pa, pb], float)))
        scores.append((mv.mean(), mt.min()))
    return out, scores


def _settle(items, scores, keys, segmented, reg, spacing, size):
    """Carried pairs (from :func:`_carry_pairs`) with each point moved into its part as
    ``segmented`` places it: the entries, and their scores lowered by how far they moved."""
    out, scores = [], list(scores)
    for k, (e, pts, parts, was) in enumerate(items):
        for j in (0, 1):
            pts[j], d = segmented.place(pts[j], parts[j])
            if d > 0:
                mv, mt = scores[k]
                scores[k] = (mv, mt * _moved_score(d, spacing))
        if np.allclose(pts[0], pts[1]):
            pts = _inside(warp_points(reg, was), size)
        out.append(replace(e, **{k: tuple(map(float, p)) for k, p in zip(keys, pts)}))
    return out, scores


class _Checks:
    """The entries' checks and the warnings of those below ``threshold``; a score is
    multiplied by the entry's ``prior`` one."""

    def __init__(self, threshold, prior):
        self.threshold, self.prior = threshold, {} if prior is None else prior
        self.entries, self.warnings = [], []

    def add(self, key_path, moved, match, name=None):
        match = float(np.clip(match, 0, 1)) * float(self.prior.get(key_path, 1.0))
        flagged = match < self.threshold
        self.entries.append(EntryCheck(key=key_path, moved=float(moved), match=match,
                                       flagged=flagged, name=name))
        if flagged:
            label = f"{key_path} ({name})" if name else key_path
            self.warnings.append(f"{label}: moved {moved:.0f} px, match {match:.2f}: check it")


def _check_parts(checks, regions, scores, overlaps, doubt):
    """The regions' checks: a part is no surer than the frame's segmentation gives it its
    carried region (``overlaps``), nor than before it was posed again (``doubt``: the pose
    that agrees best with the segmentation is a guess to check). Returns part -> score
    (``-1``, the background, scoring 1)."""
    part_match = {-1: 1.0}
    for i, (r, (mv, mt)) in enumerate(zip(regions, scores)):
        part_match[i] = min(mt, overlaps[i], doubt[i])
        checks.add(f"regions[{i}]", mv, part_match[i], name=r.name)
    return part_match


def _move_beside(points, pair, carrier):
    """Key points beside parts ``pair`` carried: a boundary beside a part that moved on
    its own moves with that part."""
    own = [k for k in pair if k in carrier.motions]
    return carrier.motions[own[0]].apply(points) if own else warp_points(carrier.reg, points)


# -- helpers -------------------------------------------------------------------

def _label_at(labels, p):
    h, w = labels.shape
    x = int(np.clip(np.rint(p[0]), 0, w - 1))
    y = int(np.clip(np.rint(p[1]), 0, h - 1))
    return int(labels[y, x])

class _Places:
    """Nearest paper pixel of each carried part, found within ``reach``.

    Looked for in a window around the point only (a few thousand pixels
    whatever the drawing's size).
    """

    def __init__(self, carried, paper, reach, avoid=None):
        self.carried, self.paper, self.reach, self.avoid = carried, paper, reach, avoid

    def place(self, q, label):
        """``q`` moved to the nearest paper of part ``label`` (a margin inside it where the
        part is wide enough; off ``avoid`` where the part has paper within reach that is
        not), and how far; ``inf`` when none is within reach."""
        h, w = self.carried.shape
        x = int(np.clip(np.rint(q[0]), 0, w - 1))
        y = int(np.clip(np.rint(q[1]), 0, h - 1))
        r = int(np.ceil(self.reach)) + 3
        y0, x0 = max(y - r, 0), max(x - r, 0)
        window = (slice(y0, min(y + r + 1, h)), slice(x0, min(x + r + 1, w)))
        mask = self.paper[window] & (self.carried[window] == label)
        masks = [mask]
        if self.avoid is not None:
            masks.insert(0, mask & ~self.avoid[window])
        for mask in masks:
            found = self._nearest(q, mask, x - x0, y - y0, (x0, y0))
            if found is not None:
                return found
        return q, np.inf

    def _nearest(self, q, mask, x, y, origin):
        """``q`` (at ``(x, y)`` of the window) moved into ``mask`` as :meth:`place` says, or
        None when no pixel of it is within reach."""
        if not mask.any():
            return None
        # Already well inside its part (what the erosion below would keep): stays.
        ball = mask[max(y - 2, 0):y + 3, max(x - 2, 0):x + 3]
        cy, cx = min(y, 2), min(x, 2)
        near = np.abs(np.arange(ball.shape[0])[:, None] - cy) \
            + np.abs(np.arange(ball.shape[1])[None, :] - cx) <= 2
        if ball[near].all():
            return q, 0.0
        # Aim a little inside the part, not onto the pixel next to its line.
        inner = ndimage.binary_erosion(mask, iterations=2, border_value=1)
        for m in (inner, mask):
            if not m.any():
                continue
            if m[y, x]:
                return q, 0.0
            dist, (iy, ix) = ndimage.distance_transform_edt(~m, return_indices=True)
            if dist[y, x] <= self.reach:
                p = np.array([ix[y, x] + origin[0], iy[y, x] + origin[1]], float)
                return p, float(np.hypot(*(p - q)))
        return None


def _outside(paper):
    """Paper pixels connected (4-neighbours) to the image's border."""
    comp, _ = ndimage.label(paper)
    border = np.unique(np.r_[comp[0], comp[-1], comp[:, 0], comp[:, -1]])
    return np.isin(comp, border[border > 0])


def _paint_parts(carried, key_labels, motions):
    """``carried`` with each part of ``motions`` put where its own motion takes it.

    Larger parts first, so that a limb moved over the body stays on top.
    """
    out = carried.copy()
    h, w = out.shape
    area = {k: np.count_nonzero(key_labels == k) for k in motions}
    for k in sorted(motions, key=lambda k: -area[k]):
        out[out == k] = -2  # where the smooth registration put it: nobody's
        ky, kx = np.nonzero(key_labels == k)
        if not len(kx):
            continue
        q = np.rint(motions[k].apply(np.stack([kx, ky], axis=1).astype(float))).astype(int)
        q = q[(q[:, 0] >= 0) & (q[:, 1] >= 0) & (q[:, 0] < w) & (q[:, 1] < h)]
        if not len(q):
            continue
        x0, y0 = np.maximum(q.min(axis=0) - 2, 0)
        x1, y1 = np.minimum(q.max(axis=0) + 3, [w, h])
        mask = np.zeros((y1 - y0, x1 - x0), bool)
        mask[q[:, 1] - y0, q[:, 0] - x0] = True
        # Forward-moved pixels leave pinholes where the part stretches: close them.
        mask = ndimage.binary_closing(mask, iterations=1)
        out[y0:y1, x0:x1][mask] = k
    return out


def _pull_back(labels, displacement, iterations=8, step=4):
    """Key labels seen from the frame: label of the key pixel each frame pixel comes from.

    The inverse of the (smooth) displacement is solved on every ``step``-th
    pixel and interpolated in between.
    """
    h, w = labels.shape
    ys, xs = np.mgrid[0:h:step, 0:w:step].astype(float)
    px, py = xs.copy(), ys.copy()
    for _ in range(iterations):  # p + u(p) = y, solved by fixed-point iteration
        ux = ndimage.map_coordinates(displacement[..., 0], [py, px], order=1, mode="nearest")
        uy = ndimage.map_coordinates(displacement[..., 1], [py, px], order=1, mode="nearest")
        px, py = xs - ux, ys - uy
    v = lattice_interpolate(np.stack([px - xs, py - ys], axis=-1), step, (h, w))
    ix = np.clip(np.rint(np.arange(w)[None, :] + v[..., 0]), 0, w - 1).astype(int)
    iy = np.clip(np.rint(np.arange(h)[:, None] + v[..., 1]), 0, h - 1).astype(int)
    return labels[iy, ix]


def _sample(image, points, order=1):
    p = np.asarray(points, float).reshape(-1, 2)
    return ndimage.map_coordinates(image, [p[:, 1], p[:, 0]], order=order, mode="nearest")


def _agreement(carried, labels):
    """Share of the pixels of some part, carried or segmented, where the two agree."""
    either = (carried >= 0) | (labels >= 0)
    return np.count_nonzero((carried == labels) & either) / max(np.count_nonzero(either), 1)


def _overlaps(a, b, n):
    """Intersection over union of ``a == i`` and ``b == i`` for each label ``i < n`` (1 where
    both are empty), from one joint count of the two label images."""
    code = (np.clip(a, -1, n) + 1) * (n + 2) + np.clip(b, -1, n) + 1
    pair = np.bincount(code.ravel(), minlength=(n + 2) ** 2).reshape(n + 2, n + 2)
    both = np.diag(pair)[1:n + 1]
    union = pair.sum(axis=1)[1:n + 1] + pair.sum(axis=0)[1:n + 1] - both
    return np.where(union > 0, both / np.maximum(union, 1), 1.0)


def _inside(points, size):
    w, h = size
    return np.clip(np.asarray(points, float), 0, [w - 1, h - 1])


def _simplify(points, tolerance):
    """Douglas-Peucker: the vertices of ``points`` needed within ``tolerance``."""
    if len(points) <= 2:
        return points
    keep = np.zeros(len(points), bool)
    keep[0] = keep[-1] = True
    stack = [(0, len(points) - 1)]
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        a, b = points[i], points[j]
        ab = b - a
        n = np.hypot(*ab)
        seg = points[i + 1:j] - a
        d = (np.abs(ab[0] * seg[:, 1] - ab[1] * seg[:, 0]) / n if n > 0
             else np.hypot(seg[:, 0], seg[:, 1]))
        k = int(d.argmax())
        if d[k] > tolerance:
            keep[i + 1 + k] = True
            stack += [(i, i + 1 + k), (i + 1 + k, j)]
    return points[keep]


def _labels_near(labels, points, far, radius):
    """The labels ``>= 0`` within ``radius`` of the ``points`` not on ``far``."""
    h, w = labels.shape
    r = int(np.ceil(radius))
    found = set()
    for x, y in np.rint(np.asarray(points, float)).astype(int):
        x, y = min(max(x, 0), w - 1), min(max(y, 0), h - 1)
        if far[y, x] > 0.5:
            continue
        window = labels[max(y - r, 0):y + r + 1, max(x - r, 0):x + r + 1]
        found.update(int(v) for v in np.unique(window) if v >= 0)
    return sorted(found)


def _outline(labels, a, b):
    """Pixels of label ``a`` next to label ``b`` (4-neighbours), and the reverse; with
    ``a`` and ``b`` None, pixels of a part (label ``>= 0``) next to any other label."""
    out = np.zeros(labels.shape, bool)
    for axis in (0, 1):
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        p, q = labels[tuple(lo)], labels[tuple(hi)]
        if a is None:
            hit = (p != q) & ((p >= 0) | (q >= 0))
        else:
            hit = ((p == a) & (q == b)) | ((p == b) & (q == a))
        out[tuple(lo)] |= hit
        out[tuple(hi)] |= hit
    return out


def _carry_boundary(path, key_labels, labels, carrier, reach):
    """A boundary path carried and put back on the frame's outline (``labels``) between
    the two parts it separates in the key."""
    dense = resample_polyline(path, _STEP)
    h, w = key_labels.shape
    # The two parts the path separates in the key: the commonest labels near it.
    seen = []
    for x, y in dense:
        x0, y0 = int(np.clip(round(x), 0, w - 1)), int(np.clip(round(y), 0, h - 1))
        seen.append(key_labels[max(0, y0 - 3):y0 + 4, max(0, x0 - 3):x0 + 4].ravel())
    values, counts = np.unique(np.concatenate(seen), return_counts=True)
    pair = [int(v) for v in values[np.argsort(-counts)][:2]]
    moved = _move_beside(dense, pair, carrier)
    match = _sample(carrier.scene.conf, dense)
    moved_by = float(np.linalg.norm(moved - dense, axis=1).mean())
    outlines = _outline(labels, None, None)
    if not outlines.any():
        return _simplify(moved, 1.0), moved_by, 0.0
    qx = np.clip(np.rint(moved[:, 0]), 0, w - 1).astype(int)
    qy = np.clip(np.rint(moved[:, 1]), 0, h - 1).astype(int)
    line = _outline(labels, *pair) if len(pair) == 2 else np.zeros(labels.shape, bool)
    snapped = np.empty_like(moved)
    near = np.zeros(len(moved), bool)
    if line.any():
        dist, (iy, ix) = ndimage.distance_transform_edt(~line, return_indices=True)
        d = dist[qy, qx]
        near = d <= reach
        snapped[near] = np.stack([ix[qy, qx], iy[qy, qx]], axis=1)[near]
        match = match * np.where(near, np.exp(-(d / reach) ** 2), 0.0)
    else:
        match = np.zeros(len(moved))
    if not near.all():
        # No outline of its two parts within reach: onto the nearest outline at
        # all, so that the relief can still be built (and scored 0).
        _, (iy, ix) = ndimage.distance_transform_edt(~outlines, return_indices=True)
        snapped[~near] = np.stack([ix[qy, qx], iy[qy, qx]], axis=1)[~near]
    # Keep the path's order and drop repeats where several samples snapped together.
    keep = np.r_[True, np.any(np.diff(snapped, axis=0) != 0, axis=1)]
    snapped = snapped[keep]
    if len(snapped) < 2:
        snapped = np.vstack([snapped, snapped + [1.0, 0.0]])
    return _simplify(snapped, 1.0), moved_by, float(match.mean())
