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
with its scribbles so carried agrees with best. Every entry of the
annotation moves with its part's motion:

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
from inkray.segmentation import INK_THRESHOLD, segment

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
    # A part that swings further than the smooth registration follows moves
    # by its own rigid motion, where that brings its ink clearly closer.
    rigid = rigid_segments(key_ink, frame_ink, key_labels, reg, radius=reach)
    moved = {k: m for k, m in rigid.items() if m.cost < m.base_cost}
    local = arap_segments(key_ink, frame_ink, key_labels, moved, spacing=max(2, spacing // 2))
    motions = {}
    for k, m in moved.items():
        best = min((m, local.get(k, m)), key=lambda x: x.cost)
        if best.cost < _OWN * m.base_cost:
            motions[k] = best
    # How well each part's lines land on the frame's, from the mean distance
    # of its ink to the frame's ink under the motion it moved by.
    fit = {k: float(np.exp(-((motions[k].cost if k in motions else m.base_cost)
                             / (spacing / 4)) ** 2)) for k, m in rigid.items()}
    pulled = _pull_back(key_labels, reg.displacement)
    paper = frame.gray >= INK_THRESHOLD
    carried = _paint_parts(pulled, key_labels, motions)
    places = _Places(carried, paper, reach)
    nearest = {}

    def nearest_paper(q):
        if "index" not in nearest:  # rarely needed: computed once, when it is
            nearest["index"] = ndimage.distance_transform_edt(
                frame.gray < INK_THRESHOLD, return_distances=False, return_indices=True)
        iy, ix = nearest["index"]
        x = int(np.clip(np.rint(q[0]), 0, w - 1))
        y = int(np.clip(np.rint(q[1]), 0, h - 1))
        return np.array([ix[y, x], iy[y, x]], float)
    conf = reg.confidence
    frame_far = (ndimage.distance_transform_edt(frame.gray >= INK_THRESHOLD) > spacing).astype(float)
    h, w = key_labels.shape

    def label_at(p):
        x = int(np.clip(np.rint(p[0]), 0, w - 1))
        y = int(np.clip(np.rint(p[1]), 0, h - 1))
        return int(key_labels[y, x])

    def carry(points, labels, trial=None):
        """Points carried into their parts: new points, distances moved, scores
        (``trial``: other ``(motions, places)`` to carry them by)."""
        by, at = (motions, places) if trial is None else trial
        points = np.asarray(points, float).reshape(-1, 2)
        moved = warp_points(reg, points)
        for lab in set(labels) & set(by):
            on = np.asarray(labels) == lab
            moved[on] = by[lab].apply(points[on])
        out = np.empty_like(moved)
        snap = np.empty(len(points))
        for i, (q, lab) in enumerate(zip(moved, labels)):
            out[i], snap[i] = at.place(q, lab)
            if not np.isfinite(snap[i]):
                # No paper of its part within reach: off the ink at least (and
                # scored 0), so that the frame can be segmented.
                out[i] = nearest_paper(q)
        # A point of a part matches as well as its part does (and no better than
        # the drawings agree around it, where it moved with the registration);
        # a background point far from any line of the frame is surely background.
        local = _sample(conf, points)
        labels = np.asarray(labels)
        part = np.array([fit.get(lab, 1.0) for lab in labels])
        own = np.isin(labels, list(motions))
        match = np.where(own, part, np.minimum(local, part))
        clear = _sample(frame_far, out, order=0) > 0.5
        match = np.where((labels < 0) & clear, 1.0, match)
        match = match * np.exp(-(np.minimum(snap, 1e9) / (2 * spacing)) ** 2)
        return out, np.linalg.norm(out - points, axis=1), match

    entries, warnings = [], []

    prior = {} if prior is None else prior

    def check(key_path, moved, match, name=None):
        match = float(np.clip(match, 0, 1)) * float(prior.get(key_path, 1.0))
        flagged = match < threshold
        entries.append(EntryCheck(key=key_path, moved=float(moved), match=match, flagged=flagged,
                                  name=name))
        if flagged:
            label = f"{key_path} ({name})" if name else key_path
            warnings.append(f"{label}: moved {moved:.0f} px, match {match:.2f}: check it")

    def carry_polyline(line, label, trial=None):
        dense = line if len(line) == 1 else resample_polyline(line, _STEP)
        out, moved, match = carry(dense, [label] * len(dense), trial)
        return _simplify(out, 1.0), moved, match

    def carry_region(i, trial=None):
        r = annotations.regions[i]
        scribbles, moved, match = [], [], []
        for s in r.scribbles:
            out, mv, mt = carry_polyline(s, i, trial)
            scribbles.append(_inside(out, size))
            moved.append(mv)
            match.append(mt)
        return (replace(r, scribbles=scribbles, pixels=None),
                (np.concatenate(moved).mean(), np.concatenate(match).mean()))

    regions, region_scores = [], []
    for i in range(len(annotations.regions)):
        region, score = carry_region(i)
        regions.append(region)
        region_scores.append(score)
    background, background_scores = [], []
    for s in annotations.background:
        out, mv, mt = carry_polyline(s, -1)
        background.append(_inside(out, size))
        background_scores.append((mv.mean(), mt.mean()))

    def carry_pairs(items, a, b):
        out, scores = [], []
        for e in items:
            pa, pb = getattr(e, a), getattr(e, b)
            parts = [label_at(pa), label_at(pb)]
            pts, mv, mt = carry([pa, pb], parts)
            pts = _inside(pts, size)
            if np.allclose(pts[0], pts[1]):  # both into one pixel: keep them apart
                pts = _inside(warp_points(reg, np.array([pa, pb], float)), size)
            out.append((e, pts, parts, np.array([pa, pb], float)))
            scores.append((mv.mean(), mt.min()))
        return out, scores

    draft = replace(annotations, size=size, regions=regions, background=background, order=[],
                    equal=[], boundaries=[], background_pixels=None, drawing=None, source=None)
    # The frame is segmented again for each pose tried: what it alone decides is kept.
    memo = {}
    labels = segment(draft, frame, memo=memo).labels
    # A part whose carried region the frame's segmentation does not give it may
    # have been posed on another part's lines (chamfer matching of a small limb
    # is ambiguous) or folded beyond the search: other poses are tried, each
    # judged by how well the carried parts and the frame segmented with the
    # part's scribbles so posed agree (a right pose puts them in the enclosed
    # area its region fills).
    n = len(annotations.regions)
    doubt, first = _overlaps(carried, labels, n), labels
    agree = _agreement(carried, labels)
    for i in range(n):
        if doubt[i] >= _REPOSE:
            continue
        for pose in rigid_poses(key_ink, frame_ink, key_labels, i, reg, count=_POSES,
                                radius=reach):
            trial = {**motions, i: pose}
            t_carried = _paint_parts(pulled, key_labels, trial)
            region, score = carry_region(i, (trial, _Places(t_carried, paper, reach)))
            t_draft = replace(draft, regions=draft.regions[:i] + [region] + draft.regions[i + 1:])
            t_labels = segment(t_draft, frame, memo=memo).labels
            t_agree = _agreement(t_carried, t_labels)
            if t_agree > agree + _GAIN:
                agree, motions, carried = t_agree, trial, t_carried
                draft, labels = t_draft, t_labels
                regions[i], region_scores[i] = region, score
                fit[i] = float(np.exp(-(pose.cost / (spacing / 4)) ** 2))
    if labels is not first:
        # A part that another's new pose took pixels from (or gave them to) is as
        # unsure.
        doubt = np.minimum(doubt, _overlaps(first, labels, n))
    places = _Places(carried, paper, reach)
    order, order_scores = carry_pairs(annotations.order, "front", "back")
    equal, equal_scores = carry_pairs(annotations.equal, "a", "b")
    # A point of an order or equal entry goes into its part as the frame is
    # segmented: where the carried parts and the segmentation differ, the
    # segmentation is what the relief will use.
    # Paper joined to the image's border is outside every closed part: a
    # relation's point goes off it where its part has paper that is not (a
    # part hidden in the frame leaves its point on the open paper beside it).
    segmented = _Places(labels, paper, reach, avoid=_outside(paper))

    def settle(items, scores, a, b):
        out = []
        for k, (e, pts, parts, was) in enumerate(items):
            for j in (0, 1):
                pts[j], d = segmented.place(pts[j], parts[j])
                if d > 0:
                    mv, mt = scores[k]
                    scores[k] = (mv, mt * np.exp(-(min(d, 1e9) / (2 * spacing)) ** 2))
            if np.allclose(pts[0], pts[1]):
                pts = _inside(warp_points(reg, was), size)
            out.append(replace(e, **{a: tuple(map(float, pts[0])), b: tuple(map(float, pts[1]))}))
        return out

    named = [item[2] for item in order + equal]
    order = settle(order, order_scores, "front", "back")
    equal = settle(equal, equal_scores, "a", "b")
    draft = replace(draft, order=order, equal=equal)
    part_match = {-1: 1.0}
    overlaps = _overlaps(carried, labels, n)
    for i, (r, (mv, mt)) in enumerate(zip(regions, region_scores)):
        # A part posed again is no surer than its first pose was: the pose that
        # agrees best with the segmentation is a guess to check.
        part_match[i] = min(mt, overlaps[i], doubt[i])
        check(f"regions[{i}]", mv, part_match[i], name=r.name)
    for j, (mv, mt) in enumerate(background_scores):
        # Paper between parts is as sure as the parts around it.
        near = _labels_near(labels, background[j], frame_far, spacing)
        check(f"background[{j}]", mv, min([mt] + [part_match[p] for p in near]))
    # A relation is no surer than the parts it names.
    for e, (mv, mt), parts in zip(order + equal, order_scores + equal_scores, named):
        kind = "order" if e in order else "equal"
        check(f"{kind}[{e.index}]", mv, min([mt] + [part_match[p] for p in parts]))

    def move_beside(points, pair):
        # A boundary beside a part that moved on its own moves with that part.
        own = [k for k in pair if k in motions]
        return motions[own[0]].apply(points) if own else warp_points(reg, points)

    boundaries = []
    for b in annotations.boundaries:
        path, mv, mt = _carry_boundary(b.path, key_labels, labels, move_beside, conf, reach)
        boundaries.append(replace(b, path=_inside(path, size)))
        check(f"boundaries[{b.index}]", mv, mt)

    character = (key_labels >= 0) & (key.gray < INK_THRESHOLD)
    confidence = float(conf[character].mean()) if character.any() else float(conf.mean())
    carried_ann = replace(draft, boundaries=boundaries)
    return Transfer(annotations=carried_ann, entries=entries, confidence=confidence,
                    warnings=warnings, labels=labels)


# -- helpers -------------------------------------------------------------------

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


def _carry_boundary(path, key_labels, labels, move, conf, reach):
    """A boundary path carried and put back on the frame's outline between its two parts.

    ``move(points, pair)`` carries key points beside the two parts ``pair``.
    """
    dense = resample_polyline(path, _STEP)
    h, w = key_labels.shape
    # The two parts the path separates in the key: the commonest labels near it.
    seen = []
    for x, y in dense:
        x0, y0 = int(np.clip(round(x), 0, w - 1)), int(np.clip(round(y), 0, h - 1))
        seen.append(key_labels[max(0, y0 - 3):y0 + 4, max(0, x0 - 3):x0 + 4].ravel())
    values, counts = np.unique(np.concatenate(seen), return_counts=True)
    pair = [int(v) for v in values[np.argsort(-counts)][:2]]
    moved = move(dense, pair)
    match = _sample(conf, dense)
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
