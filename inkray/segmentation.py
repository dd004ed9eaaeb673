"""Scribble segmentation that follows ink lines and closes gaps (LazyBrush).

Implements the segmentation of Sýkora, Dingliana, Collins, "LazyBrush:
Flexible Painting Tool for Hand-drawn Cartoons", Computer Graphics Forum
28(2), 2009, as used by Ink-and-Ray (Sýkora et al., TOG 2014, section 3).

Energy, with every cost measured in units of one cut edge across clean paper:

- smoothness: cutting the 4-neighbour edge ``p-q`` costs
  ``f(min(I_p, I_q)) + 1/K`` where ``f`` maps ink to 0 and paper to 1 and
  ``K = 2 (H + W)``, so a cut runs along dark lines, and across a gap in a line
  only where no line offers a cheaper way (a gap of ``g`` pixels costs ``g``);
- data: scribbles are soft where it matters, as in the paper: the part
  of a stroke that lies on ink or overshoots an ink line into another paper
  area pays only ``seed_strength`` (< 1) per pixel for taking another label,
  so it is cheaper to relabel than to cut around and a careless stroke does
  not leak its label across the line. The rest of the stroke, in the paper
  area that holds most of it, is hard, so that a short scribble or a dot in
  an area with a gap still holds its area (a soft dot would lose to any cut
  longer than one pixel).

The multi-label problem is solved as in the paper by a sequence of binary
graph cuts (PyMaxflow): label ``c`` against all labels not yet placed, on the
still unlabelled pixels only; connected pieces of those pixels that hold
seeds of one label only are assigned without a cut. Large images are solved
coarse-to-fine: the labelling of a 2x min-pooled copy (ink survives the
pooling) fixes every pixel far from a label boundary and the full-resolution
cuts run only in a band around the boundaries and the seeds.
"""

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from inkray.errors import InputError
from inkray.input.scribbles import BACKGROUND, UNSEEDED, polyline_pixels, seed_image

__all__ = ["Segmentation", "lazybrush", "segment", "ink_cost", "INK_THRESHOLD", "scribbles_on_ink"]

#: Grey level below which a pixel counts as ink for validation and warnings.
INK_THRESHOLD = 0.5


@dataclass
class Segmentation:
    """The result of :func:`segment`.

    Attributes
    ----------
    labels : (H, W) int32 array
        ``-1`` background, ``i`` the region ``annotations.regions[i]``; every
        pixel, ink included, carries a label.
    names : list of str
        Region names in annotation order (``names[i]`` is label ``i``).
    warnings : list of str
        One-line notes: unscribbled enclosed areas and what they were given.
    """

    labels: np.ndarray
    names: list
    warnings: list = field(default_factory=list)


def ink_cost(gray, *, ink_level=0.25, paper_level=0.9, gamma=2.0):
    """Per-pixel cost of a cut next to a pixel: 0 on ink, 1 on paper.

    Parameters
    ----------
    gray : (H, W) float array in [0, 1]
        Paper 1, ink near 0.
    ink_level : float, default 0.25
        Grey at or below which a pixel is full ink (cost 0); photographed
        marker lines rarely reach 0.
    paper_level : float, default 0.9
        Grey at or above which a pixel is full paper (cost 1).
    gamma : float, default 2.0
        Exponent on the normalized grey; > 1 makes faint strokes cheap to
        follow, so sketchy and antialiased lines still hold a cut.

    Returns
    -------
    (H, W) float64 array in [0, 1]

    Examples
    --------
    >>> import numpy as np
    >>> ink_cost(np.array([[0.0, 1.0]])).tolist()
    [[0.0, 1.0]]
    """
    g = np.asarray(gray, np.float64)
    t = np.clip((g - ink_level) / (paper_level - ink_level), 0.0, 1.0)
    return t ** gamma


def lazybrush(gray, seeds, *, frame_background=False, seed_strength=0.95, ink_level=0.25,
              paper_level=0.9, gamma=2.0, coarse_to_fine=None, progress=None, memo=None):
    """Multi-label LazyBrush segmentation of a drawing from seed pixels.

    Parameters
    ----------
    gray : (H, W) float array in [0, 1]
        The drawing: paper 1, ink near 0 (as :class:`inkray.input.drawing.Drawing`).
    seeds : (H, W) int array
        ``-2`` unseeded, ``-1`` background, ``0..R-1`` region labels (the
        convention of :func:`inkray.input.scribbles.seed_image`); any subset of the
        labels may be present.
    frame_background : bool, default False
        Seed the unseeded pixels of the image border as background (``-1``),
        except where the frame cuts a part: in a paper area, other than the
        outer one, that holds a region seed.
    seed_strength : float, default 0.95
        Cost of relabelling one seed pixel that lies on ink or outside the
        paper area holding most of its scribble, in units of one paper edge
        cut; below 1 such overshoots are soft, above ~2 they act as hard
        constraints. Seed pixels inside that area are always hard.
    ink_level, paper_level, gamma : float
        The grey-to-cost mapping, see :func:`ink_cost`.
    coarse_to_fine : bool, optional
        Solve a half-resolution problem first and refine only near its label
        boundaries; by default on for images above 0.5 Mpx.
    progress : inkray.progress.Progress, optional
        Receives ``update(done, total)`` after each binary cut.
    memo : dict, optional
        Kept by the caller between calls on the same drawing (an editor's
        scribbles), one call at a time: what depends on the drawing alone
        (ink cost, paper areas, edge capacities) is computed once, a binary
        cut whose graph differs from the kept one only by seeds that pull its
        pixels the way they went is not solved again, and the background
        cut resumes its kept flow (the same labels, see :func:`_min_cut`). A
        different drawing or different parameters empty it first.

    Returns
    -------
    (H, W) int32 array
        ``-1`` background (only where background was seeded), otherwise the
        region label; every pixel is labelled. A label whose seeds all lose
        to neighbours may be absent.

    Raises
    ------
    InputError
        Shapes that differ, a grey image with NaN, seed values below -2, or no
        seed at all.

    Examples
    --------
    >>> import numpy as np
    >>> gray = np.ones((20, 20)); gray[:, 10] = 0.0          # one vertical line
    >>> seeds = np.full((20, 20), -2); seeds[5, 3] = 0; seeds[5, 15] = 1
    >>> labels = lazybrush(gray, seeds)
    >>> int(labels[:, :10].max()), int(labels[:, 11:].min())
    (0, 1)
    """
    gray = np.asarray(gray, np.float64)
    seeds = np.asarray(seeds)
    if gray.ndim != 2:
        raise InputError(f"gray: expected an (H, W) image, got shape {gray.shape}")
    if seeds.shape != gray.shape:
        raise InputError(f"seeds: shape {seeds.shape} differs from the drawing's {gray.shape}")
    if seeds.dtype.kind not in "iu":
        raise InputError(f"seeds: expected an integer array, got {seeds.dtype}")
    if not np.isfinite(gray).all():
        y, x = np.argwhere(~np.isfinite(gray))[0]
        raise InputError(f"gray: pixel ({x}, {y}) is not a finite number")
    if seeds.size and seeds.min() < UNSEEDED:
        y, x = np.argwhere(seeds < UNSEEDED)[0]
        raise InputError(f"seeds: pixel ({x}, {y}) has label {seeds[y, x]} "
                         f"(expected -2, -1 or >= 0)")
    if seeds.size and seeds.max() > np.iinfo(np.int32).max:
        y, x = np.argwhere(seeds > np.iinfo(np.int32).max)[0]
        raise InputError(f"seeds: pixel ({x}, {y}) has label {seeds[y, x]}, beyond int32")
    # Region labels become 0..m-1 inside (any integers may come in, e.g. one
    # per constraint endpoint), and go back at the end.
    seeded = seeds >= 0
    regions = np.unique(seeds[seeded])
    seeds = seeds.astype(np.int32)
    seeds[seeded] = np.searchsorted(regions, seeds[seeded])  # the seed pixels alone: few
    memo = _checked(memo, gray, (seed_strength, ink_level, paper_level, gamma))
    area, n_areas = _paper_areas(gray, memo)
    if frame_background:
        seeds = _frame_seeds(seeds, area, n_areas)
    if not (seeds != UNSEEDED).any():
        raise InputError("seeds: no seed pixel at all (nothing to grow labels from)")
    cost = _kept(memo, "cost", lambda: ink_cost(gray, ink_level=ink_level,
                                                paper_level=paper_level, gamma=gamma))
    h, w = gray.shape
    if coarse_to_fine is None:
        coarse_to_fine = h * w > 500_000
    strength = _seed_strength(seeds, area, _quantized(seed_strength), memo)
    if coarse_to_fine and min(h, w) >= 64:
        # Paper areas are "grey >= INK_THRESHOLD" at every level.
        paper = float(ink_cost(INK_THRESHOLD, ink_level=ink_level, paper_level=paper_level,
                               gamma=gamma))
        labels = _coarse_to_fine(cost, seeds, strength, paper, progress, memo=memo)
    else:
        labels = _solve(cost, seeds, strength, 1.0 / (2 * (h + w)), progress=progress, memo=memo)
    if len(regions) and regions[-1] != len(regions) - 1:  # not already 0..m-1
        labels = np.where(labels >= 0, regions[np.maximum(labels, 0)], labels)
    return labels.astype(np.int32, copy=False)


_HARD = 1e9  # a seed cost no cut can pay
# Capacities are multiples of 2**-22 (below 2**30 with _HARD): every sum and
# difference the max-flow solver forms is then exact in float64, so its labels
# are those of the exact minimum cut (the pixels that cannot reach the sink in
# any maximum flow's residual graph), whatever the order of its augmentations.
_QUANTUM = 2.0 ** -22


def _quantized(x):
    """``x`` rounded to a multiple of :data:`_QUANTUM`."""
    return np.round(np.asarray(x, np.float64) / _QUANTUM) * _QUANTUM


def _checked(memo, gray, params):
    """``memo``, emptied first unless it was kept for this very drawing and these
    parameters (the comparison costs a millisecond at 1 Mpx, a digest ten)."""
    if memo is None:
        return None
    kept = memo.get("gray")
    if (kept is None or memo.get("params") != params or kept.shape != gray.shape
            or not np.array_equal(kept, gray)):
        memo.clear()
        memo["gray"] = gray.copy()
        memo["params"] = params
    return memo


def _kept(memo, key, make):
    """``memo[key]``, made by ``make()`` the first time (every time without a memo)."""
    if memo is None:
        return make()
    value = memo.get(key)
    if value is None:
        value = memo[key] = make()
    return value


def _paper_areas(gray, memo):
    """The 4-connected paper areas (``grey >= INK_THRESHOLD``) and their count."""
    return _kept(memo, "areas", lambda: ndimage.label(gray >= INK_THRESHOLD))


def _frame_seeds(seeds, area, n_areas):
    """Seed the unseeded border pixels as background, except in paper areas
    other than the outer one (the area most of the border runs through) that
    hold a region seed: there the frame cuts a part of the character."""
    border = np.zeros(seeds.shape, bool)
    border[[0, -1], :] = True
    border[:, [0, -1]] = True
    on_paper = area[border]
    on_paper = on_paper[on_paper > 0]
    part = np.zeros(n_areas + 1, bool)
    part[area[seeds >= 0]] = True
    part[0] = False
    if len(on_paper):
        part[np.argmax(np.bincount(on_paper))] = False
    out = seeds.copy()
    out[border & (seeds == UNSEEDED) & ~part[area]] = BACKGROUND
    return out


def _seed_strength(seeds, area, soft, memo=None):
    """Per-pixel cost of relabelling a seed: hard in the paper ``area`` (a
    label image) that holds most of the pixels of its scribble (an
    8-connected run of one label), ``soft`` on ink and in other paper areas
    (overshoots). With a ``memo``, a label whose seed pixels did not change
    keeps its costs."""
    out = np.zeros(seeds.shape)
    at = np.flatnonzero(seeds.ravel() != UNSEEDED)  # a few pixels
    rows, cols = np.divmod(at, seeds.shape[1])
    label = seeds.ravel()[at]
    for c in np.unique(label):
        r, k = rows[label == c], cols[label == c]
        box = (slice(int(r.min()), int(r.max()) + 1), slice(int(k.min()), int(k.max()) + 1))
        mask = seeds[box] == c
        kept = None if memo is None else memo.get(("strength", c))
        if kept is not None and kept[0] == box and np.array_equal(kept[1], mask):
            values = kept[2]
        else:
            values = _label_strength(mask, area[box], soft)
            if memo is not None:
                memo[("strength", c)] = (box, mask, values)
        out[box][mask] = values
    return out


def _label_strength(mask, area, soft):
    """:func:`_seed_strength` of one label's seed pixels ``mask`` in a box of
    the paper ``area`` image: the costs of the pixels of ``mask``, in order."""
    stroke, n = ndimage.label(mask, structure=np.ones((3, 3)))
    st, ar = stroke[mask], area[mask]
    on = ar > 0
    home = np.zeros(n + 1, np.int64)
    if on.any():
        # The (stroke, area) pairs in lexicographic order, as one sorted key.
        span = int(ar.max()) + 1
        key, counts = np.unique(st[on].astype(np.int64) * span + ar[on], return_counts=True)
        pairs = np.divmod(key, span)
        # Ties go to the lowest area number: deterministic.
        best = np.lexsort((pairs[1], -counts, pairs[0]))
        first = np.unique(pairs[0][best], return_index=True)[1]
        home[pairs[0][best][first]] = pairs[1][best][first]
    return np.where(on & (ar == home[st]), _HARD, soft)


def segment(annotations, drawing, *, seed_strength=0.95, coarse_to_fine=None, min_area=30,
            progress=None, memo=None):
    """Segment a drawing into the annotation's regions and the background.

    Parameters
    ----------
    annotations : inkray.input.annotations.Annotations
        Region scribbles and background scribbles; without background
        scribbles the image frame is background.
    drawing : inkray.input.drawing.Drawing or (H, W) float array
        The drawing (or its ``gray``), of the annotation's ``size``.
    seed_strength : float, default 0.95
        Softness of scribbles, see :func:`lazybrush`.
    coarse_to_fine : bool, optional
        See :func:`lazybrush`.
    min_area : int, default 30
        Paper areas (grey >= ``INK_THRESHOLD``, 4-connected) of at least this
        many pixels that no scribble touches are reported in ``warnings``.
    progress : inkray.progress.Progress, optional
        Progress bar of the binary cuts.
    memo : dict, optional
        Kept by the caller between segmentations of the same drawing (an
        editor's edits), see :func:`lazybrush`; the result is the same with
        or without it.

    Returns
    -------
    Segmentation

    Raises
    ------
    InputError
        No region, a drawing of the wrong size, a blank or all-ink drawing, or
        a scribble lying entirely on ink (named by its key path).

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.input.annotations import parse_annotations
    >>> gray = np.ones((40, 40)); gray[10:30, 10] = gray[10:30, 30] = 0
    >>> gray[10, 10:31] = gray[30, 10:31] = 0                  # a closed square
    >>> ann = parse_annotations({"format": "inkray-annotations", "version": 1,
    ...     "size": [40, 40], "regions": [{"name": "box", "scribbles": [[[15, 20], [25, 20]]]}]})
    >>> seg = segment(ann, gray)
    >>> seg.names, int(seg.labels[20, 20]), int(seg.labels[2, 2])
    (['box'], 0, -1)
    """
    gray = np.asarray(getattr(drawing, "gray", drawing), np.float64)
    w, h = annotations.size
    if gray.shape != (h, w):
        raise InputError(f"size: the annotation is for a {w}x{h} drawing but the drawing is "
                         f"{gray.shape[1]}x{gray.shape[0]}")
    if not annotations.regions:
        raise InputError("regions: no region scribbles (segmentation needs at least one region)")
    floor = max(1, int(1e-4 * gray.size))
    if int((gray < INK_THRESHOLD).sum()) < floor:
        raise InputError(f"drawing: blank (fewer than {floor} pixels darker than "
                         f"{INK_THRESHOLD}): no lines to segment along")
    if int((gray >= INK_THRESHOLD).sum()) < floor:
        raise InputError(f"drawing: all ink (fewer than {floor} pixels lighter than "
                         f"{INK_THRESHOLD}): no paper to segment")
    on_ink = scribbles_on_ink(annotations, gray)
    if on_ink:
        raise InputError(on_ink[0])
    gray = _with_boundary_cuts(gray, annotations.boundaries)
    seeds = seed_image(annotations)
    warnings = []
    names = [r.name for r in annotations.regions]
    present = np.zeros(len(names) + 1, bool)
    present[np.unique(seeds[seeds >= 0])] = True
    for i, name in enumerate(names):
        if not present[i]:
            warnings.append(f"regions[{i}] ({name}): no seed pixel left: every pixel of its "
                            f"scribbles is also under another region's scribble")
    frame = not (annotations.background or (annotations.background_pixels is not None
                                            and len(annotations.background_pixels)))
    labels = lazybrush(gray, seeds, frame_background=frame, seed_strength=seed_strength,
                       coarse_to_fine=coarse_to_fine, progress=progress, memo=memo)
    area = np.bincount(labels[labels >= 0].ravel(), minlength=len(names))
    seeded = np.bincount(seeds[seeds >= 0].ravel(), minlength=len(names))
    for i, name in enumerate(names):
        if present[i] and not area[i]:
            warnings.append(f"regions[{i}] ({name}): lost every pixel to its neighbours "
                            f"(do its scribbles only overshoot ink lines?)")
        elif present[i] and area[i] <= 2 * seeded[i] and area[i] < min_area:
            # The region kept little more than its own scribble.
            warnings.append(f"regions[{i}] ({name}): only {area[i]} pixels (does its scribble lie "
                            f"on the background or on ink?)")
    warnings += _unscribbled_areas(_paper_areas(gray, memo), seeds, labels, names, frame,
                                   min_area)
    return Segmentation(labels=labels.astype(np.int32, copy=False), names=names, warnings=warnings)


def _with_boundary_cuts(gray, boundaries):
    """The grey image with every ``graft``/``stitch`` path drawn in as ink.

    A boundary entry is where the user says two parts meet, often across an
    open stroke; as ink it makes the cut run exactly there, so the region
    outlines (and the relief's seams) follow the entry.
    """
    marks = [b for b in boundaries if b.type in ("graft", "stitch")]
    if not marks:
        return gray
    gray = gray.copy()
    for b in marks:
        gray[polyline_pixels(b.path, gray.shape)] = 0.0
    return gray


def scribbles_on_ink(annotations, gray):
    """Every scribble lying entirely on ink: it marks no area.

    Parameters
    ----------
    annotations : inkray.input.annotations.Annotations
    gray : (H, W) float array
        The drawing's grey levels (ink below :data:`INK_THRESHOLD`).

    Returns
    -------
    list of str
        One message per such scribble, starting with its key path.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.input.annotations import parse_annotations
    >>> gray = np.ones((10, 10)); gray[5] = 0
    >>> ann = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [10, 10],
    ...     "regions": [{"name": "a", "scribbles": [[[1, 5], [8, 5]], [[1, 2], [8, 2]]]}]})
    >>> scribbles_on_ink(ann, gray)
    ['regions[0].scribbles[0]: the scribble lies entirely on ink (from pixel (1, 5)); draw it inside the area it marks']
    """
    from inkray.input.scribbles import polyline_pixels

    out = []

    def check(rows, cols, where):
        if len(rows) and (gray[rows, cols] < INK_THRESHOLD).all():
            out.append(f"{where}: the scribble lies entirely on ink (from pixel "
                       f"({cols[0]}, {rows[0]})); draw it inside the area it marks")

    for i, region in enumerate(annotations.regions):
        for j, line in enumerate(region.scribbles):
            check(*polyline_pixels(line, gray.shape), f"regions[{i}].scribbles[{j}]")
        if region.pixels is not None and len(region.pixels):
            check(region.pixels[:, 1], region.pixels[:, 0], f"regions[{i}] ({region.name}) layer")
    for j, line in enumerate(annotations.background):
        check(*polyline_pixels(line, gray.shape), f"background[{j}]")
    return out


def _unscribbled_areas(areas, seeds, labels, names, frame, min_area):
    """Warnings for paper areas (``areas``: their label image and count) of
    ``min_area`` pixels or more without a seed."""
    comp, n = areas
    if n == 0:
        return []
    seeded = np.zeros(n + 1, bool)
    seeded[comp[seeds != UNSEEDED]] = True
    if frame:
        seeded[comp[[0, -1], :]] = True
        seeded[comp[:, [0, -1]]] = True
    area = np.bincount(comp.ravel(), minlength=n + 1)
    boxes = ndimage.find_objects(comp)
    out = []
    for k in np.flatnonzero((~seeded) & (area >= min_area)):
        if k == 0:
            continue
        box = boxes[k - 1]
        ys, xs = np.nonzero(comp[box] == k)
        ys, xs = ys + box[0].start, xs + box[1].start
        mid = np.argmin((ys - ys.mean()) ** 2 + (xs - xs.mean()) ** 2)
        votes = np.bincount(labels[ys, xs] + 1, minlength=len(names) + 1)
        got = int(np.argmax(votes)) - 1
        whom = "the background" if got == BACKGROUND else f"region '{names[got]}'"
        out.append(f"unscribbled area of {area[k]} px at ({xs[mid]}, {ys[mid]}) given to {whom}")
    return out


def _order(seeds):
    """Labels present in ``seeds`` (any shape): background first (the biggest, it removes
    most pixels from the later cuts), then regions ascending."""
    # Labels run from UNSEEDED up (regions are 0..R-1 inside lazybrush): counting
    # them is a sort-free np.unique.
    present = np.flatnonzero(np.bincount(np.subtract(seeds.ravel(), UNSEEDED, dtype=np.intp))[1:])
    present = present + UNSEEDED + 1
    return [int(v) for v in present]  # -1 sorts first


def _level(cost, fixed, floor):
    """What the cuts of one level need of the pixels to label (``fixed`` UNSEEDED).

    Returns a dict: ``idx`` their flat indices (ascending), ``rows`` and
    ``cols``; ``right`` and ``down``, for the edge from each to that
    neighbour, its capacity (0 where there is no neighbour) and the
    neighbour's position in ``idx`` (``len(idx)`` where it is not to be
    labelled); ``nbrs``, for the 4 directions where any neighbour is fixed,
    the neighbour's fixed label (UNSEEDED when none or free), the capacity of
    the edge to it (only where it is fixed) and its flat-index offset; and
    ``placed`` the fixed labels. The capacities are ``min`` of the two ends'
    ``cost`` plus ``floor``, quantized, computed at these pixels only (at 1
    Mpx the band is a small part of the grid).
    """
    h, w = fixed.shape
    flat_fixed = fixed.ravel()
    free = flat_fixed == UNSEEDED
    idx = np.flatnonzero(free)
    n = len(idx)
    rows, cols = np.divmod(idx, w)
    out = {"idx": idx, "rows": rows, "cols": cols, "nbrs": [], "placed": _order(fixed)}
    if n == h * w:  # the whole grid: capacities by slices, neighbours by offsets
        for name, a, b in (("right", np.s_[:, :-1], np.s_[:, 1:]),
                           ("down", np.s_[:-1, :], np.s_[1:, :])):
            cap = np.zeros((h, w))
            cap[a] = _quantized(np.minimum(cost[a], cost[b]) + floor)
            pos = np.full((h, w), n, np.intp)
            pos[a] = np.arange(n).reshape(h, w)[b]
            out[name] = (cap.ravel(), pos.ravel())
        return out
    c = cost.ravel()
    c_idx = c[idx]
    for name, offset, ok in (("right", 1, cols < w - 1), ("left", -1, cols > 0),
                             ("down", w, rows < h - 1), ("up", -w, rows > 0)):
        at = np.flatnonzero(ok)
        nb = idx[at] + offset
        lab = np.full(n, UNSEEDED, np.int32)
        lab[at] = flat_fixed[nb]
        cap = np.zeros(n)
        if name in ("right", "down"):
            cap[at] = _quantized(np.minimum(c_idx[at], c[nb]) + floor)
            inner = lab[at] == UNSEEDED
            pos = np.full(n, n, np.intp)
            # the next free pixel is the next position; the one below, found by
            # bisection (the queries ascend: numpy narrows each search by the last)
            pos[at[inner]] = at[inner] + 1 if offset == 1 else np.searchsorted(idx, nb[inner])
            out[name] = (cap, pos)
        else:
            has = lab != UNSEEDED
            cap[has] = _quantized(np.minimum(c_idx[has], c[idx[has] + offset]) + floor)
        out["nbrs"].append((lab, cap, offset))
    return out


def _solve(cost, seeds, strength, floor, *, fixed=None, progress=None, memo=None):
    """Sequential binary cuts on the pixels where ``fixed`` is UNSEEDED.

    Labels are placed in ascending order, so "a label still to be placed"
    is simply "a label greater than ``c``". Fixed pixels (coarse-to-fine: the
    labels far from any boundary) keep their label and pull their free
    neighbours toward it through the edge between them, as a neighbour of
    that label would."""
    h, w = cost.shape
    if fixed is None:
        fixed = np.full((h, w), UNSEEDED, np.int32)
    labels = fixed.copy()
    kept = None if memo is None else memo.get(("free", h, w))
    if kept is not None and np.array_equal(kept[0], fixed):
        level = kept[1]
    else:
        level = _level(cost, fixed, floor)
        if memo is not None:
            memo[("free", h, w)] = (fixed.copy(), level)
    idx, rows, cols, nbrs, placed = (level[k] for k in ("idx", "rows", "cols", "nbrs", "placed"))
    seed_idx, strength_idx = seeds.ravel()[idx], strength.ravel()[idx]
    order = sorted(set(placed) | set(_order(seed_idx)))
    flat_labels = labels.ravel()
    alive = np.ones(len(idx), bool)  # which of ``idx`` are still unlabelled
    # The 4-connected pieces of the unlabelled pixels, numbered from 1, by
    # position in ``idx``. A cut splits only the pieces it ran on, and a piece
    # that is assigned whole goes: only the rest of those is labelled again.
    piece, count, again = np.zeros(len(idx), np.int32), 0, None
    for step, c in enumerate(order):
        pos = np.flatnonzero(alive)
        if not len(pos):
            break
        kept = None if memo is None else memo.get(("pieces", h, w, c))
        if kept is not None and np.array_equal(kept[0], idx[pos]):
            piece[pos], count = kept[1], kept[2]
        else:
            at = pos if again is None else again[alive[again]]
            if len(at):
                more, n = _pieces(rows[at], cols[at])
                piece[at] = more + (0 if again is None else count)
                count = n + (0 if again is None else count)
            if memo is not None:
                memo[("pieces", h, w, c)] = (idx[pos], piece[pos], count)
        ci, n, again = piece[pos], count, pos[:0]
        si = seed_idx[pos]
        own = np.bincount(ci[si == c], minlength=n + 1)
        other = np.bincount(ci[si > c], minlength=n + 1)
        for lab, _, _ in nbrs:
            la = lab[pos]
            own += np.bincount(ci[la == c], minlength=n + 1)
            other += np.bincount(ci[la > c], minlength=n + 1)
        own[0] = other[0] = 0
        alone = pos[((own > 0) & (other == 0))[ci]]
        flat_labels[idx[alone]] = c
        alive[alone] = False
        cut = (own > 0) & (other > 0)
        if c != order[-1] and cut.any():
            on = pos[cut[ci]]
            # Outline ink goes to the character, not to the background: a cut
            # with an ink pixel on its background side costs 4 floors more
            # (directed capacities, so the graph stays the same size), enough
            # that following the outer edge of a thick outline around a
            # rounded end beats a chord through the ink.
            pull = (lambda p: _quantized(4.0 * floor * (1.0 - cost.ravel()[p]))) \
                if c == BACKGROUND else None
            flat = idx[on]
            sub = [(lab[on], wt[on], off) for lab, wt, off in nbrs]
            src, snk = _terminals(flat, seed_idx[on], strength_idx[on], c, sub, pull)
            won = on[_min_cut(flat, (h, w), c, lambda: _cut_edges(level, on, pull), src, snk,
                              memo)]
            flat_labels[idx[won]] = c
            alive[won] = False
            again = on
        if progress is not None:
            progress.update(step + 1, len(order))
    free = labels == UNSEEDED
    if free.any():
        # Pieces holding no seed of a label still to be placed (walled in by
        # placed labels): they take the label around them.
        _, (iy, ix) = ndimage.distance_transform_edt(free, return_indices=True)
        labels = labels[iy, ix]
    return labels


def _cut_edges(level, on, pull=None):
    """The edges of a binary cut on the pixels ``level["idx"][on]`` (``on``
    ascending positions), as :func:`_binary_cut` takes them: to the right,
    then to the lower neighbour, in the raster order of the first end, both
    ends among those pixels. ``pull(p)`` (or None) is the extra cost of a
    cut edge whose source side is the pixel of flat index ``p``."""
    n_level = len(level["idx"])
    every = len(on) == n_level  # then a pixel's node is its position
    if not every:
        node = np.full(n_level + 1, -1, np.intp)  # the last: "no neighbour to label"
        node[on] = np.arange(len(on))
    pull_on = None if pull is None else pull(level["idx"][on])
    out = []
    for cap, pos in (level["right"], level["down"]):
        if every:
            both = np.flatnonzero(pos < n_level)
            b = pos
        else:
            b = node[pos[on]]
            both = np.flatnonzero(b >= 0)
        if not len(both):
            continue
        fwd = rev = cap[both if every else on[both]]
        if pull is not None:  # a -> b is cut when a takes c and b does not
            fwd = fwd + pull_on[both]
            rev = rev + pull_on[b[both]]
        out.append((both, b[both], fwd, rev))
    return out


def _pieces(rows, cols):
    """The 4-connected pieces of the pixels at ``(rows, cols)``: each one's,
    numbered from 1, and their count; labelled within their bounding box only."""
    y0, x0 = rows.min(), cols.min()
    width = cols.max() - x0 + 1
    at = (rows - y0) * width + (cols - x0)
    box = np.zeros((rows.max() - y0 + 1, width), bool)
    box.ravel()[at] = True
    comp, n = ndimage.label(box)
    return comp.ravel()[at], n


def _terminals(flat, s, st, c, nbrs, pull):
    """Source (take ``c``) and sink (a greater label) capacities of the pixels
    ``flat`` of a binary cut, whose seeds are ``s`` and seed strengths ``st``;
    ``nbrs`` are their fixed neighbours, ``pull(p)`` (or None) the extra cost of
    a cut edge whose ``c`` side is the pixel of flat index ``p``."""
    src = np.where(s == c, st, 0.0)
    snk = np.where(s > c, st, 0.0)
    for lab, wt, offset in nbrs:
        # The edge to a fixed neighbour becomes a terminal link, with the
        # directed ``pull`` of whichever end would be on the ``c`` side.
        to_c, to_rest = lab == c, lab > c
        src[to_c] += wt[to_c]
        snk[to_rest] += wt[to_rest]
        if pull is not None:
            src[to_c] += pull(flat[to_c] + offset)
            snk[to_rest] += pull(flat[to_rest])
    return src, snk


def _min_cut(flat, shape, c, edges, src, snk, memo):
    """Which of the pixels ``flat`` take ``c`` (a mask); ``edges()`` gives the
    graph's edges (:func:`_cut_edges`) when it is to be built.

    With a ``memo``, the kept cut of ``c`` at this level answers when
    :func:`_unchanged_cut` or :func:`_grown_cut` shows it still does. The
    background cut (the first
    and largest) also keeps its solved graph: on the same pixels only the
    terminal capacities can differ, and those are changed on the solved graph
    and the flow resumed from the kept search trees (Kohli and Torr,
    "Efficiently solving dynamic Markov random fields using graph cuts",
    ICCV 2005). Either way the labels are those of a fresh solve: the pixels
    that cannot reach the sink in a maximum flow's residual graph are the
    same for every maximum flow, and with capacities that are multiples of
    :data:`_QUANTUM` the solver's arithmetic is exact.
    """
    key = ("cut", shape, c)
    kept = None if memo is None else memo.get(key)
    same = kept is not None and len(kept[0]) == len(flat) and np.array_equal(kept[0], flat)
    if same and _unchanged_cut(kept, src, snk):
        return kept[3]
    won = None if same or kept is None else _grown_cut(kept, flat, shape, src, snk)
    if won is not None:
        graph = None
    elif same and kept[4] is not None:
        graph = kept[4]
        del memo[key]  # changed below: kept again only once it is consistent
        # Only the difference of a pixel's two terminal capacities matters to the cut
        # (both larger by the same amount: every cut costs that much more).
        more = (src - kept[1]) - (snk - kept[2])
        changed = np.flatnonzero(more)
        graph.add_grid_tedges(changed, np.maximum(more[changed], 0.0),
                              np.maximum(-more[changed], 0.0))
        graph.mark_grid_nodes(changed)
        graph.maxflow(reuse_trees=True)
        won = ~graph.get_grid_segments(np.arange(len(flat)))
    else:
        graph, won = _binary_cut(len(flat), edges(), src, snk)
    if memo is not None:
        memo[key] = (flat, src, snk, won, graph if c == BACKGROUND else None)
    return won


def _grown_cut(kept, flat, shape, src, snk):
    """The kept cut ``(flat0, src0, snk0, won0, ...)`` grown to the pixels
    ``flat`` (a superset of ``flat0``, both ascending), or None when that is
    not shown to be the answer.

    On the kept pixels the terminal capacities may grow as in
    :func:`_unchanged_cut`. The new pixels ``X`` must have no source capacity
    and no neighbour that took the label. Then every cut of the new graph
    costs at least as much as its kept part did, and the kept cut with the
    pieces of ``X`` that reach neither a sink capacity nor a kept pixel that
    did not take the label (they cost nothing on either side; the solver puts
    them on the source side) costs the same: it is the solver's answer.
    """
    flat0, src0, snk0, won0 = kept[:4]
    if len(flat0) >= len(flat):
        return None
    at = np.searchsorted(flat, flat0)
    if at[-1] >= len(flat) or not np.array_equal(flat[at], flat0):
        return None  # a kept pixel left the cut
    new = np.ones(len(flat), bool)
    new[at] = False
    if (src[new] > 0).any() or not _unchanged_cut(kept, src[at], snk[at]):
        return None
    h, w = shape
    x = flat[new]
    taken, left = flat0[won0], flat0[~won0]
    touches_left = snk[new] > 0
    for nb, ok in ((x + 1, x % w < w - 1), (x - 1, x % w > 0), (x + w, x < (h - 1) * w),
                   (x - w, x >= w)):
        if _among(nb[ok], taken).any():
            return None
        touches_left[ok] |= _among(nb[ok], left)
    # The 4-connected pieces of the new pixels, within their bounding box.
    rows, cols = np.divmod(x, w)
    y0, x0 = rows.min(), cols.min()
    box = np.zeros((rows.max() - y0 + 1, cols.max() - x0 + 1), bool)
    box[rows - y0, cols - x0] = True
    piece, n = ndimage.label(box)
    piece = piece[rows - y0, cols - x0]
    reaching = np.zeros(n + 1, bool)
    reaching[piece[touches_left]] = True
    won = np.zeros(len(flat), bool)
    won[at] = won0
    won[new] = ~reaching[piece]
    return won


def _among(values, sorted_values):
    """Which of ``values`` are in the ascending array ``sorted_values``."""
    at = np.minimum(np.searchsorted(sorted_values, values), max(len(sorted_values) - 1, 0))
    return (sorted_values[at] == values) if len(sorted_values) else np.zeros(len(values), bool)


def _unchanged_cut(kept, src, snk):
    """Whether the kept cut ``(flat, src, snk, won, ...)`` answers the cut of
    the same pixels with terminal capacities ``src`` and ``snk``.

    Its edges are the same (they depend on the pixels, the level and the
    label only). When the capacities differ only by more source capacity at
    pixels that took the label and more sink capacity at pixels that did
    not, the kept maximum flow is still maximum (the kept cut's cost did not
    change, no other's fell) and the pixels that can reach the sink in its
    residual graph are the same: those are the pixels the solver leaves out,
    exactly, since the capacities are multiples of :data:`_QUANTUM`.
    """
    src0, snk0, won = kept[1:4]
    more_src, more_snk = src - src0, snk - snk0
    return not ((more_src < 0).any() or (more_snk < 0).any() or (more_src[~won] > 0).any()
                or (more_snk[won] > 0).any())


def _binary_cut(n, edges, src, snk):
    """Min cut of one label against the greater labels on ``n`` pixels with
    terminal capacities ``src`` and ``snk`` and the ``edges`` ``(a, b, fwd,
    rev)`` of :func:`_cut_edges` (node indices, capacities a -> b and b -> a).
    Returns the solved graph and which of the pixels are on the source side."""
    import maxflow

    g = maxflow.Graph[float](n, 2 * n)
    g.add_nodes(n)
    for a, b, fwd, rev in edges:
        g.add_edges(a, b, fwd, rev)
    ids = np.arange(n)
    g.add_grid_tedges(ids, src, snk)
    g.maxflow()
    return g, ~g.get_grid_segments(ids)


def _coarse_to_fine(cost, seeds, strength, paper, progress, band=4, small_area=5000, *, memo=None):
    """Solve on a 2x min-pooled copy, then only near its boundaries.

    Min-pooling keeps one-pixel lines closed at half resolution. The band of
    ``band`` pixels around every coarse label boundary is solved again at full
    resolution, and so are whole paper areas (``cost >= paper``) that the
    pooling may have cut wrongly: see below."""
    h, w = cost.shape
    small_cost = _kept(memo, ("pooled", h, w), lambda: _pool_min(cost))
    small_seeds = _pool_max(seeds, UNSEEDED)
    small_strength = _pool_max(strength, 0.0)
    sh, sw = small_cost.shape
    if sh * sw > 500_000 and min(sh, sw) >= 64:
        coarse = _coarse_to_fine(small_cost, small_seeds, small_strength, paper, None, band,
                                 small_area // 4, memo=memo)
    else:
        coarse = _solve(small_cost, small_seeds, small_strength, 1.0 / (2 * (sh + sw)), memo=memo)
    up = coarse.repeat(2, axis=0).repeat(2, axis=1)[:h, :w]
    # The band around the coarse boundaries: the same after most scribbles.
    kept = None if memo is None else memo.get(("band", h, w, band))
    if kept is not None and np.array_equal(kept[0], coarse):
        free = kept[1].copy()
    else:
        free = _near(_boundaries(up), band)
        if memo is not None:
            memo[("band", h, w, band)] = (coarse, free.copy())
    seed_at = np.flatnonzero(seeds.ravel() != UNSEEDED)  # a few pixels
    rows, cols = np.divmod(seed_at, w)
    wrong_at = seed_at[seeds.ravel()[seed_at] != coarse[rows // 2, cols // 2]]
    wrong = np.zeros((h, w), bool)
    wrong.ravel()[wrong_at] = True
    free |= _near(wrong, band)
    # Pooling may close a thin neck of a small paper area and split it there:
    # a small area whose fixed pixels and seeds hold two labels, or any area
    # holding a wrongly labelled seed, is solved again as a whole. (Large
    # areas that hold several labels are gap closures the band refines.)
    comp, n = _kept(memo, ("paper", h, w), lambda: ndimage.label(cost >= paper))
    flat_comp = comp.ravel()
    small = np.bincount(flat_comp, minlength=n + 1) <= small_area
    small[0] = False
    fixed_at = np.flatnonzero(small[comp] & ~free)
    rows, cols = np.divmod(fixed_at, w)
    small_seed_at = seed_at[small[flat_comp[seed_at]]]
    inner = flat_comp[np.concatenate([fixed_at, small_seed_at])]
    inner_up = np.concatenate([coarse[rows // 2, cols // 2], seeds.ravel()[small_seed_at]])
    some = np.zeros(n + 1, np.int32)
    some[inner] = inner_up  # one label of each small area (the last written)
    redo = small & (np.bincount(inner[inner_up != some[inner]], minlength=n + 1) > 0)
    redo[flat_comp[wrong_at]] = True
    redo[0] = False
    free |= redo[comp]
    fixed = np.where(free, UNSEEDED, up).astype(np.int32, copy=False)
    return _solve(cost, seeds, strength, 1.0 / (2 * (h + w)), fixed=fixed, progress=progress,
                  memo=memo)


def _boundaries(labels):
    """The pixels with a 4-neighbour of another label."""
    edge = np.zeros(labels.shape, bool)
    diff = labels[:, :-1] != labels[:, 1:]
    edge[:, :-1] |= diff
    edge[:, 1:] |= diff
    diff = labels[:-1, :] != labels[1:, :]
    edge[:-1, :] |= diff
    edge[1:, :] |= diff
    return edge


def _near(mask, band):
    """The pixels within ``band`` (Chebyshev) of a ``mask`` pixel: a maximum
    filter over the mask's bounding box and twice ``band`` around it only
    (the filter's mirrored border then holds no mask pixel)."""
    out = np.zeros(mask.shape, bool)
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if not len(rows):
        return out
    h, w = mask.shape
    box = (slice(max(rows[0] - 2 * band, 0), min(rows[-1] + 2 * band + 1, h)),
           slice(max(cols[0] - 2 * band, 0), min(cols[-1] + 2 * band + 1, w)))
    out[box] = ndimage.maximum_filter(mask[box].view(np.uint8), size=2 * band + 1).view(bool)
    return out


def _pool(a, op):
    """2x2 pooling of an even-sized array by ``op`` (np.minimum or np.maximum): the
    four strided quarters, a tenth of the time of a reduction over reshaped axes."""
    return op(op(a[0::2, 0::2], a[0::2, 1::2]), op(a[1::2, 0::2], a[1::2, 1::2]))


def _pool_max(a, fill):
    """2x2 maximum pooling of ``a`` padded with ``fill`` to an even size, by
    :func:`_pool`; when every other value is above ``fill`` (seeds, their
    strengths: a few pixels), from those pixels alone, the same values."""
    h, w = a.shape
    at = np.flatnonzero(a.ravel() != fill)
    values = a.ravel()[at]
    if len(values) and values.min() < fill:
        return _pool(np.pad(a, ((0, h % 2), (0, w % 2)), constant_values=fill), np.maximum)
    sw = (w + 1) // 2
    out = np.full(((h + 1) // 2, sw), fill, a.dtype)
    rows, cols = np.divmod(at, w)
    np.maximum.at(out.ravel(), rows // 2 * sw + cols // 2, values)
    return out


def _pool_min(a):
    """2x2 minimum pooling of ``a`` padded by repeating its last row and column
    to an even size; the odd row and column pooled on their own (no padded copy)."""
    h, w = a.shape
    he, we = h - h % 2, w - w % 2
    out = np.empty(((h + 1) // 2, (w + 1) // 2), a.dtype)
    out[:he // 2, :we // 2] = _pool(a[:he, :we], np.minimum)
    if w % 2:
        out[:he // 2, -1] = np.minimum(a[0:he:2, -1], a[1:he:2, -1])
    if h % 2:
        out[-1, :we // 2] = np.minimum(a[-1, 0:we:2], a[-1, 1:we:2])
    if h % 2 and w % 2:
        out[-1, -1] = a[-1, -1]
    return out
