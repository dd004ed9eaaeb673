"""Cut-out layers: every part on its own layer, completed where it is hidden.

Cut-out rigs (Live2D, Spine, Inochi2D, Krita or Photoshop layer stacks) move
each part of a character separately, so a part must exist where another one
hides it. Ink-and-Ray (Sýkora et al., TOG 2014, section 4) already completes
every region under its occluders (:mod:`inkray.relief.completion`) and orders
neighbours locally (:mod:`inkray.relief.ordering`); this module turns that
into a stack of RGBA layers:

- a layer holds its region's completed shape: the drawing's pixels where the
  region is visible and, where it is hidden, its own colours continued
  inward by a harmonic fill (the membrane interpolant of the part's paper
  next to the hidden part: ink, however thick or soft, left out of the
  boundary values), with its outline continued along the completed
  silhouette in the colour and width of the part's own outline strokes,
  measured at the scale of the drawing's strokes; the stubs of a part's
  strokes that the segmentation left in the part over it (cut short of that
  part's outline) belong to the part whose strokes they are, and so does the
  stroke along a part's outline over a part behind it, wherever the
  segmentation cut across it (the part behind fills it in as hidden);
- the layers are stacked back to front by the depth order; a region behind
  none comes first;
- local order that no single stack can hold (two interlocking rings: A over
  B at one crossing, B over A at the other) is reported with the part that
  must be split; with ``split_local`` that part's pixels around the crossing
  become a layer of their own just above the other part.
"""

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.sparse as sp
from scipy import ndimage

from inkray.errors import InputError, Notice
from inkray.numerics.grid import grid_laplacian
from inkray.numerics.order_graph import OrderGraph
from inkray.numerics.spd import MinQuadWithFixed
from inkray.relief.silhouette import INK_LEVEL, grow_over_ink, pad_ink_edge

__all__ = ["CutoutLayer", "Cutout", "Split", "cut_out", "stack_order", "stroke_style"]

_INK_CONTRAST = 0.15  # ink: this much darker than the closing of the grey image (its surroundings)
_STROKE_MAX = 8       # px: the widest stroke the ink detection and the outline assume
_WIDE_STROKE_MAX = 4 * _STROKE_MAX  # px: the widest stroke a continued outline takes
_PEN_SPREAD = 1.5  # the closing that finds a part's strokes, in their median widths
_REGULARIZE = 1e-6  # pull toward the region's mean colour: fills parts no visible colour reaches
_SOFT_EDGE = 0.75   # grey level up to which a stroke's soft edge belongs to its part's contour
_RIM_STEPS = 64  # at most this many pixels from the paper into a layer's rim
_CLEAR = 0.05  # coverage below which a pixel beyond a part is paper
_MATTE = 24  # levels: a pixel this close to a mix of paper and ink is that mix
_PAPER_SPREADS = 2.0  # how far below its median tone (in spreads) a part's paper reaches
_EDGE_SMOOTHING = 0.7  # px: Gaussian over a silhouette's stair-steps for its anti-aliased edge


@dataclass
class CutoutLayer:
    """One layer of a cut-out stack.

    Attributes
    ----------
    name : str
        The region's name (a split piece: ``"<name> over <other>"``;
        ``"background"``).
    region : int
        The region's index, -1 for the background.
    top, left : int
        Position of ``rgba``'s first pixel in the drawing.
    rgba : (h, w, 4) uint8 array
        Opaque on the layer's shape, transparent elsewhere.
    hidden : (h, w) bool array
        The pixels filled in (not taken from the drawing).
    """

    name: str
    region: int
    top: int
    left: int
    rgba: np.ndarray
    hidden: np.ndarray

    @property
    def box(self):
        """``(y0, y1, x0, x1)`` in the drawing, end exclusive."""
        h, w = self.rgba.shape[:2]
        return (self.top, self.top + h, self.left, self.left + w)


@dataclass
class Split:
    """A local order no single stack can hold: ``region`` over ``under`` at one place only.

    Attributes
    ----------
    region, under : int
    name, under_name : str
    where : (float, float)
        ``(x, y)`` of the place.
    place : int or None
    """

    region: int
    under: int
    name: str
    under_name: str
    where: tuple
    place: int = None

    @property
    def message(self):
        """One line: the part that must be split, where, and why."""
        x, y = self.where
        return Notice(f"region {self.name!r} must be split: it is over {self.under_name!r} near "
                      f"({x:.0f}, {y:.0f}) but under it elsewhere, which no single layer stack "
                      f"holds", fix=("{} splits it", "split_local"))


@dataclass
class Cutout:
    """A stack of cut-out layers, back to front.

    Attributes
    ----------
    layers : list of CutoutLayer
        Back (first) to front (last).
    size : (int, int)
        ``(W, H)`` of the drawing.
    splits : list of Split
        Local orders the stack breaks (``split_local`` False) or split.
    split : bool
        Whether the splits were made (one extra layer each).
    """

    layers: list
    size: tuple
    splits: list = field(default_factory=list)
    split: bool = False

    @property
    def warnings(self):
        """One line per unresolved local order."""
        return [] if self.split else [s.message for s in self.splits]

    def flatten(self):
        """The stack composited back to front ("normal" blending) as (H, W, 4) uint8.

        Examples
        --------
        >>> red = np.zeros((1, 1, 4), np.uint8); red[..., 0] = red[..., 3] = 255
        >>> c = Cutout([CutoutLayer("a", 0, 0, 1, red, np.zeros((1, 1), bool))], (2, 1))
        >>> c.flatten()[0].tolist()
        [[0, 0, 0, 0], [255, 0, 0, 255]]
        """
        w, h = self.size
        out = np.zeros((h, w, 4))
        for layer in self.layers:
            y0, y1, x0, x1 = layer.box
            # A layer read from a file may reach past the canvas: only the overlap shows.
            cy0, cy1, cx0, cx1 = max(y0, 0), min(y1, h), max(x0, 0), min(x1, w)
            if cy0 >= cy1 or cx0 >= cx1:
                continue
            src = layer.rgba[cy0 - y0:cy1 - y0, cx0 - x0:cx1 - x0] / 255.0
            dst = out[cy0:cy1, cx0:cx1]
            a = src[..., 3:4]
            alpha = a + dst[..., 3:4] * (1 - a)
            rgb = src[..., :3] * a + dst[..., :3] * dst[..., 3:4] * (1 - a)
            dst[..., :3] = np.divide(rgb, alpha, out=np.zeros_like(rgb), where=alpha > 0)
            dst[..., 3:4] = alpha
        return np.rint(out * 255).astype(np.uint8)


def stack_order(count, relations):
    """Back-to-front order of regions under local relations, and the ones it breaks.

    Relations are taken user's first, then by confidence; one that would
    close a cycle with those taken before (interlocking parts) is left out.
    The regions are sorted by their level in the order graph, ties by index.

    Parameters
    ----------
    count : int
        Number of regions.
    relations : list of inkray.relief.ordering.Relation

    Returns
    -------
    order : list of int
        Region indices, back first.
    broken : list of Relation
        The ``order`` relations the stack contradicts.

    Examples
    --------
    >>> from inkray.relief.ordering import Relation
    >>> r = [Relation(0, 1, "a", "b", (0, 0), "user", 1.0),
    ...      Relation(2, 0, "c", "a", (0, 0), "user", 1.0)]
    >>> stack_order(3, r)
    ([1, 0, 2], [])
    """
    graph = OrderGraph()
    for i in range(count):
        graph.add(i, i, strict=False)  # every region a node
    refused = []
    ranked = sorted((r for r in relations if r.front != r.back),
                    key=lambda r: (r.source != "user", -r.confidence))
    for r in ranked:
        strict = r.kind == "order"
        back_up = graph.path(r.back, r.front)
        if strict:
            clash = back_up is not None
        else:  # an equality clashes with a strict relation either way
            paths = (back_up, graph.path(r.front, r.back))
            clash = any(p is not None and any(s for _, s in p) for p in paths)
        if clash:
            refused.append(r)
            continue
        graph.add(r.front, r.back, strict=strict)
    levels = graph.levels()
    order = sorted(range(count), key=lambda i: (levels.get(i, 0), i))
    rank = {region: k for k, region in enumerate(order)}
    broken = [r for r in refused if r.kind == "order" and rank[r.front] < rank[r.back]]
    return order, broken


def stroke_style(rgb, gray, *, where=None):
    """The drawing's ink: the colour of its strokes' cores and their width in pixels.

    Ink is what is darker than its surroundings by a stroke's width (a grey
    closing). The colour is the median of the drawing along the ink's
    skeleton (the darkest line of each stroke, not its soft edges); the width
    is the ink's coverage (how far each pixel goes from its surroundings'
    tone to that core tone, 0..1) summed across the strokes, over the
    skeleton's length: the width of a solid stroke of the core colour that
    puts as much ink on the paper, soft edges included. Strokes wider than
    8 px (a marker's, a thick clean line) leave their middles to a closing
    of that size, which then finds only their soft edges: where the
    skeleton of the ink a four times wider closing finds lies mostly off
    that ink and is at least as dark as its core (near black without such
    ink; a colour of the drawing's own is lighter), the strokes are
    measured at that scale. Clipped to 1..8 px
    (1..32 px for wide strokes); black and 1 px without ink.

    Parameters
    ----------
    rgb : (H, W, 3) uint8 array
    gray : (H, W) float array
        Paper 1, ink near 0.
    where : (H, W) bool array, optional
        Measure only the strokes whose skeleton lies here (e.g. near a
        part's hidden area); the whole drawing's when it holds too little
        ink (a skeleton shorter than 8 px).

    Returns
    -------
    colour : (3,) uint8 array
    width : float

    Examples
    --------
    >>> gray = np.ones((20, 90)); gray[5:8, 5:85] = 0.0      # a 3 px stroke
    >>> gray[4, 5:85] = gray[8, 5:85] = 0.5                  # with a soft edge each side
    >>> rgb = np.repeat((gray[..., None] * 255).astype(np.uint8), 3, axis=2)
    >>> colour, width = stroke_style(rgb, gray)
    >>> colour.tolist(), round(width)
    ([0, 0, 0], 4)
    """
    gray = np.asarray(gray, np.float64)
    rgb = np.asarray(rgb)
    ink, skeleton = _strokes(gray)
    wide = _strokes(gray, size=_WIDE_STROKE_MAX)
    if _wider(gray, ink, skeleton, wide[1], where, core=_INK_CONTRAST):
        return _measure(rgb, gray, *wide, where, size=_WIDE_STROKE_MAX)
    return _measure(rgb, gray, ink, skeleton, where)


def _strokes(gray, *, size=_STROKE_MAX):
    """The ink (darker than its surroundings by a stroke's width, up to ``size``) and its
    skeleton."""
    from skimage.morphology import skeletonize

    ink = _ink(gray, size=size + 1)
    return ink, skeletonize(ink)


def _wider(gray, ink, skeleton, wide_skeleton, where, *, core=None):
    """Whether the strokes (``where``) are wider than the closing that found ``ink`` (with
    its ``skeleton``): the skeleton of the ink a wider closing finds runs mostly off it, at
    least as dark as its core (the grey ``core`` where no such ink is near; None: no
    strokes), along the strokes' middles between their soft edges (not over a colour
    darker than the paper around it, which is lighter than ink)."""
    local, narrow = _local(wide_skeleton, where), _local(skeleton, where)
    if narrow.any():
        core = float(np.median(gray[narrow]))
    if not local.any() or core is None:
        return False
    middle = ~ink[local] & (gray[local] <= core)
    return float(np.mean(middle)) > 0.5


def _local(skeleton, where):
    """The skeleton's pixels in ``where``, all of them where it holds too few (8)."""
    local = skeleton if where is None else skeleton & where
    return skeleton if local.sum() < 8 else local


def _measure(rgb, gray, ink, skeleton, where, *, size=_STROKE_MAX, inside=None):
    """:func:`stroke_style` on the strokes found once, at most ``size`` px wide; only their
    ink ``inside`` counts (all of it when None)."""
    local = _local(skeleton, where)
    if not local.any():
        return np.zeros(3, np.uint8), 1.0
    colour = np.median(rgb[local], axis=0).astype(np.uint8)
    cover = _coverage(gray, float(np.median(gray[local])), size=size + 1)
    # The coverage of the ink (and its soft edge) whose nearest skeleton pixel is measured.
    dist, (iy, ix) = ndimage.distance_transform_edt(~skeleton, return_indices=True)
    mine = local[iy, ix] & (dist <= size / 2 + 1) & ndimage.binary_dilation(ink, iterations=2)
    if inside is not None:
        mine &= inside
    width = float(np.clip(cover[mine].sum() / _curve_length(local), 1.0, size))
    return colour, width


def _curve_length(skeleton):
    """Length (px) of thin 8-connected curves: 1 per step along a row or column, sqrt(2) per
    diagonal step (not a diagonal that cuts the corner of two such steps); a pixel counts
    once. Counting pixels instead would make a diagonal stroke look 1.4 times as wide."""
    s = np.pad(skeleton, 1)
    c = s[1:-1, 1:-1]
    right, down = c & s[1:-1, 2:], c & s[2:, 1:-1]
    links = float(right.sum() + down.sum())
    for dx, a, b in ((1, s[1:-1, 2:], s[2:, 1:-1]), (-1, s[1:-1, :-2], s[2:, 1:-1])):
        diagonal = c & s[2:, 1 + dx:s.shape[1] - 1 + dx] & ~a & ~b
        links += np.sqrt(2.0) * float(diagonal.sum())
    return max(links, 1.0)


def _coverage(gray, core, *, size):
    """How much of each pixel is ink: 0 at its surroundings' tone, 1 at the strokes' ``core`` tone."""
    around = ndimage.grey_closing(gray, size=(size, size))
    return np.clip((around - gray) / np.maximum(around - core, _INK_CONTRAST), 0.0, 1.0)


def cut_out(completion, relations, drawing, *, pad=0, split_local=False, background=False):
    """The cut-out layer stack of a completed, ordered segmentation.

    Parameters
    ----------
    completion : inkray.relief.completion.Completion
        After the depth order (:meth:`~inkray.relief.completion.Completion.ordered`).
    relations : list of inkray.relief.ordering.Relation
    drawing : inkray.input.drawing.Drawing
    pad : int, default 0
        Continue every part this many pixels beyond its completed shape where
        a part in front of it covers it, so that moving the front part a
        little shows no gap. The flattened stack is unchanged.
    split_local : bool, default False
        Split the parts that a local order needs over another at one place
        only (see :class:`Split`).
    background : bool, default False
        Add an opaque bottom layer: the drawing outside the character, the
        paper's colours continued under it.

    Returns
    -------
    Cutout

    Examples
    --------
    >>> from inkray.input.drawing import drawing_from_array
    >>> from inkray.relief.completion import complete_regions
    >>> from inkray.relief.ordering import Relation
    >>> labels = np.full((20, 30), -1, np.int32)
    >>> labels[5:15, 3:27] = 0; labels[2:18, 12:18] = 1   # a bar (1) across a band (0)
    >>> c = complete_regions(labels, names=["band", "bar"])
    >>> rel = [Relation(1, 0, "bar", "band", (15, 10), "user", 1.0, place=c.places[0].index)]
    >>> stack = cut_out(c.ordered(rel), rel, drawing_from_array(np.full((20, 30), 0.8)))
    >>> [layer.name for layer in stack.layers], int(stack.layers[0].hidden.sum())
    (['band', 'bar'], 60)
    """
    labels = completion.labels
    rgb = np.asarray(drawing.rgb)
    gray = np.asarray(drawing.gray, np.float64)
    if labels.shape != gray.shape:
        raise InputError(f"drawing: {gray.shape[1]}x{gray.shape[0]} differs from the "
                         f"segmentation's {labels.shape[1]}x{labels.shape[0]}")
    if int(pad) != pad or pad < 0:
        raise InputError(f"pad: expected a whole number of pixels >= 0, got {pad!r}")
    names = completion.names
    order, broken = stack_order(completion.count, relations)
    # One split per place: a crossing given twice (an entry and a prediction) is one split.
    once = {(r.front, r.back, r.place): r for r in reversed(broken)}
    splits = [Split(r.front, r.back, names[r.front], names[r.back],
                  tuple(float(v) for v in r.where), r.place) for r in reversed(once.values())]
    strokes = _Strokes(rgb, gray)
    # A part's stroke that runs up to the outline of a part over it belongs to it to its end:
    # the segmentation may cut it off short of that outline.
    labels = _stubs_given(labels, strokes.pen)
    # The contour ink beyond the labels goes to the part nearest it before the outlines move:
    # they keep clear of the paper, and where they run up to it the part behind keeps its edge.
    silhouette = pad_ink_edge(grow_over_ink(labels, strokes.soft), strokes.soft)
    # The stroke along a front part's outline is the front part's, wherever the
    # segmentation put it: moved with it, not left behind on the part it covers.
    rank = {region: k for k, region in enumerate(order)}
    labels = _outlines_given(labels, completion.places, relations, strokes, rank)
    moved = labels != completion.labels
    depth_rank = np.array([rank[r] for r in range(completion.count)] + [-1])  # -1: paper
    fringe = (silhouette >= 0) & (labels < 0)  # a part's contour ink beyond its label
    air = labels < 0
    layers = []
    if background:
        everywhere = np.ones(labels.shape, bool)
        layers.append(_layer("background", -1, (labels < 0) & ~fringe, everywhere, everywhere,
                             strokes, outline=False))
    above = np.zeros(labels.shape, bool)  # visible pixels of the regions above, front first
    # Where the parts above are opaque: not on their soft rims along the paper.
    solid = ndimage.distance_transform_edt(~air) > np.ceil(strokes.width) + 2
    covers = {}
    for region in reversed(order):
        covers[region] = above & solid
        above |= labels == region
    shapes = {}
    for region in order:
        shape = completion.completed(region)
        if moved.any():
            # A stub given to a part behind lies beyond this part's outline; one given to a
            # part in front lies over this part, which continues under it.
            behind = moved & (completion.labels == region) & (depth_rank[labels] < rank[region])
            shape = (shape & ~behind) | (moved & (labels == region))
        if not shape.any():
            continue
        grown = shape
        if pad:
            grown = shape | (ndimage.binary_dilation(shape, iterations=int(pad)) & covers[region])
        shapes[region] = _layer(names[region], region, labels == region, shape, grown, strokes,
                                air=air, under=covers[region],
                                fringe=fringe & (silhouette == region),
                                stubs=moved & (labels == region))
    cuts = [(s, _piece(completion, shapes[s.region], s)) for s in splits
            if split_local and s.region in shapes]
    for region in (r for r in order if r in shapes):
        taken = [piece for s, piece in cuts if s.region == region]
        layer = _without(shapes[region], np.any(taken, axis=0)) if taken else shapes[region]
        if layer is not None:
            layers.append(layer)
        # The split pieces of a part over this one (one per crossing) go just above it, as
        # one layer.
        over = {}
        for s, piece in cuts:
            if s.under == region:
                over[s.region] = over.get(s.region, False) | piece
        for front, piece in over.items():
            part = _without(shapes[front], ~piece, name=f"{names[front]} over {names[region]}")
            if part is not None:
                layers.append(part)
    _unique_names(layers)
    return Cutout(layers=layers, size=(labels.shape[1], labels.shape[0]), splits=splits,
                  split=bool(split_local))


class _Strokes:
    """The drawing and its ink, measured once for every layer."""

    def __init__(self, rgb, gray):
        self.rgb, self.gray = rgb, gray
        self.ink, self.skeleton = _strokes(gray)
        self.colour, self.width = _measure(rgb, gray, self.ink, self.skeleton, None)
        # The strokes' core tone; without narrow strokes, a wide one's middle is near black.
        self.core = float(np.median(gray[self.skeleton])) if self.skeleton.any() else None
        core = 0.0 if self.core is None else self.core
        self.soft = gray < _SOFT_EDGE
        paper = ~ndimage.binary_dilation(self.ink, iterations=2) & (gray >= _SOFT_EDGE)
        self.paper = np.median(rgb[paper], axis=0) if paper.any() else np.full(3, 255.0)
        tone = float(np.median(gray[paper])) if paper.any() else 1.0
        # Against the paper: the layers' soft edges lie on it.
        self.cover = np.clip((tone - gray) / max(tone - core, _INK_CONTRAST), 0.0, 1.0)
        # Pixels that are ink over paper (not a colour of their own) can fade with the ink.
        mix = self.paper + self.cover[..., None] * (self.colour.astype(float) - self.paper)
        self.matte = np.abs(rgb - mix).max(axis=2) <= _MATTE
        # The colours of ink on this paper, also darker than the strokes' measured core (a
        # thick stroke's middle).
        toward = self.colour.astype(float) - self.paper
        step = np.clip((rgb - self.paper) @ toward / max(float(toward @ toward), 1.0), 0.0, None)
        self.inky = np.abs(rgb - self.paper - step[..., None] * toward).max(axis=2) <= _MATTE

    def style(self, hidden, own, label):
        """Colour and width of the part's strokes (``own``: its pixels, (H, W)) where its
        outline enters its ``hidden`` area ((H, W)): within four stroke scales
        (:attr:`scale`) of it, not at the junctions (within one), where the occluder's
        outline meets them, and within a stroke scale of the part's edge: its outline's
        strokes, not hatching or shading inside it.

        The strokes are found by a closing half as wide again as their median width
        (:func:`_pen_width`) there, so that a drawing upscaled twice has its strokes
        measured alike, and only their ink on the part's ``label`` counts: the continued
        outline lies inside the completed shape, which ends at the label's edge, however
        far the stroke reaches beyond it. Where that closing is the least one (8 px), a
        stroke wider than it finds is measured at a scale four times as wide. The width is
        at least the strokes' median width on the label: the skeleton of a mottled stroke
        (a dry brush, hatching run into the outline) loops round its light holes, longer
        than the stroke, and the ink over that length falls short.
        """
        scale = self.scale
        rows, cols = np.flatnonzero(hidden.any(axis=1)), np.flatnonzero(hidden.any(axis=0))
        m = 5 * scale
        big = (slice(max(rows[0] - m, 0), rows[-1] + m + 1),
               slice(max(cols[0] - m, 0), cols[-1] + m + 1))
        near = hidden[big]
        zone = ndimage.binary_dilation(near, iterations=4 * scale) & own[big] & \
            ~ndimage.binary_dilation(near, iterations=scale)
        depth = _depth(own[big] | near)
        rgb, gray = self.rgb[big], self.gray[big]
        # The closing must find the part's strokes whole (those along the paper reach
        # beyond its label); the continued outline is as wide as their ink on the label.
        contour = zone & (depth <= scale)
        whole = _pen_width(gray, contour, own[big], margin=2 * scale)
        size = scale if whole is None else max(_STROKE_MAX, int(np.ceil(_PEN_SPREAD * whole)))
        pen = _pen_width(gray, contour, label[big], margin=2 * scale)
        reach = zone & (depth <= size)
        if size > _STROKE_MAX:
            ink, skeleton = self._around(big, size)
            colour, width = _measure(rgb, gray, ink, skeleton, reach, size=size,
                                     inside=label[big])
        elif _wider(gray, self.ink[big], self.skeleton[big], self.wide[1][big], reach,
                    core=_INK_CONTRAST if self.core is None else self.core):
            colour, width = _measure(rgb, gray, self.wide[0][big], self.wide[1][big], reach,
                                     size=_WIDE_STROKE_MAX, inside=label[big])
        else:
            colour, width = _measure(rgb, gray, self.ink[big], self.skeleton[big], reach)
        return colour, width if pen is None else max(width, pen)

    def _around(self, window, size):
        """The ink and its skeleton at ``size`` in ``window``: found on the window grown by
        the closing, so that the window's edge does not change them."""
        h, w = self.gray.shape
        grow = size + 1
        outer = tuple(slice(max(s.start - grow, 0), min(s.stop + grow, n))
                      for s, n in zip(window, (h, w)))
        inner = tuple(slice(s.start - o.start, s.stop - o.start) for s, o in zip(window, outer))
        return tuple(a[inner] for a in _strokes(self.gray[outer], size=size))

    @cached_property
    def pen(self):
        """The ink darker than mid grey, its depth (px to its edge) and its skeleton."""
        from skimage.morphology import skeletonize

        ink = self.gray < INK_LEVEL
        return ink, ndimage.distance_transform_edt(ink), skeletonize(ink)

    @cached_property
    def scale(self):
        """The drawing's stroke scale (px): half as wide again as its strokes' median width
        (twice the depth of :attr:`pen` along its skeleton), at least 8."""
        _, depth, skeleton = self.pen
        if skeleton.sum() < 8:
            return _STROKE_MAX
        return max(_STROKE_MAX, int(np.ceil(_PEN_SPREAD * _median_width(depth, skeleton))))

    @cached_property
    def wide(self):
        """The ink and its skeleton of strokes up to four times as wide as the closing of
        8 px finds (thick strokes whose middles it leaves out), found once when needed."""
        return _strokes(self.gray, size=_WIDE_STROKE_MAX)


def _stubs_given(labels, pen):
    """``labels`` with the stubs of strokes given to the part whose strokes they are.

    Where a part's strokes meet the outline of another part (a leg's outline
    running up to the body's), the segmentation may cut them short of it,
    leaving their last stretch in the other part's label: a stub of ink beyond
    that part's own outline stroke, which its layer would carry as dark specks
    with straight cut ends. Such ink (darker than mid grey, farther from the
    part's paper than its strokes are wide there and than their median width,
    and a pixel) whose connected piece touches the stroke's own part (its ink)
    goes to that part; the outline stroke and the corners where the strokes
    join it stay. ``pen``: the ink, its depth and its skeleton
    (:attr:`_Strokes.pen`).
    """
    ink, depth, skeleton = pen
    out = labels.copy()
    parts = labels >= 0
    for region in np.unique(labels[parts]):
        mine = labels == region
        rows, cols = np.flatnonzero(mine.any(axis=1)), np.flatnonzero(mine.any(axis=0))
        win = (slice(max(rows[0] - 1, 0), rows[-1] + 2), slice(max(cols[0] - 1, 0), cols[-1] + 2))
        m, k = mine[win], ink[win]
        paper = m & ~k
        along = skeleton[win] & m & k
        if not paper.any() or along.sum() < 8:
            continue
        width = _median_width(depth[win], along)
        away = ndimage.distance_transform_edt(~paper)
        # Beyond the part's strokes as wide as they are there (at the nearest skeleton
        # pixel) and as their median.
        _, (iy, ix) = ndimage.distance_transform_edt(~along, return_indices=True)
        beyond = m & k & (away > np.maximum(2.0 * depth[win][iy, ix], width) + 1)
        if not beyond.any():
            continue
        pieces, _ = ndimage.label(beyond, structure=np.ones((3, 3), bool))
        lab = labels[win]
        # The other parts' ink 4-touching each piece.
        touch = np.zeros_like(pieces)
        padded = np.pad(pieces, 1)
        h, w = pieces.shape
        for dy, dx in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            beside = padded[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
            edge = (beside > 0) & (lab >= 0) & (lab != region) & k
            touch = np.where(edge & (touch == 0), beside, touch)
        for piece in np.unique(touch[touch > 0]):
            contact = touch == piece
            owners = np.unique(lab[contact])
            # A stroke cut across (the contact no longer than twice its width, not two
            # outlines run together along a seam), sticking out beyond the outline by about
            # a stroke's width (not the part's own stroke a little wider than the median,
            # nor a protrusion of its own).
            stick = away[pieces == piece].max() - width
            if len(owners) == 1 and contact.sum() <= 2 * width and \
                    width / 2 + 1 < stick <= 1.5 * width:
                out[win][pieces == piece] = owners[0]
    return out


def _outlines_given(labels, places, relations, strokes, rank):
    """``labels`` with the stroke along a front part's outline given to it where it lies over
    the part behind.

    The segmentation cuts between two touching parts anywhere across the
    stroke between them, often wholly on the part behind. At each place where
    a relation puts a part ``F`` in front of a part ``B`` (the first of the
    relations there, the user's first, then by confidence) and the stack does
    too (``rank``: each part's place in it, back first; where it breaks the
    relation the part behind is drawn over ``F`` there anyway), ``B``'s ink
    (darker than mid grey, in the colour of ink on this paper: not a dark
    colour of its own) goes to ``F`` where it is connected through that
    ink to their contact at the place, lies within its stroke's width of
    ``F``'s paper there, and its stroke (its nearest skeleton pixel) borders
    that paper: the stroke that draws ``F``'s outline, not ``B``'s own
    strokes that end on it (a crease, a stub) beyond that width. The
    stroke's soft edge on ``B``'s side (the pixels within two of it that are
    any darker than the paper) goes with it; where the contact meets the paper, ``B`` keeps
    the pixels beside the paper and those of the stroke's soft edge that
    fade into it (its layer's alpha below 1 there). ``strokes``: the
    drawing's :class:`_Strokes`; the stroke is looked for within two stroke
    scales of the place.
    """
    ink, depth, skeleton = strokes.pen
    ink = ink & strokes.inky
    tinted = strokes.cover > _CLEAR
    margin = 2 * strokes.scale
    ranked = sorted((r for r in relations if r.kind == "order" and r.place is not None
                     and r.front != r.back), key=lambda r: (r.source != "user", -r.confidence))
    first = {}
    for r in ranked:
        first.setdefault(r.place, r)
    out = labels.copy()
    h, w = labels.shape
    eight = np.ones((3, 3), bool)
    for index in sorted(first):
        front, back, place = first[index].front, first[index].back, places[index]
        if rank[front] < rank[back]:
            continue
        y0, y1, x0, x1 = place.box
        win = (slice(max(y0 - margin, 0), min(y1 + margin, h)),
               slice(max(x0 - margin, 0), min(x1 + margin, w)))
        at = (slice(y0 - win[0].start, y1 - win[0].start),
              slice(x0 - win[1].start, x1 - win[1].start))
        lab, k = labels[win], ink[win]
        here = np.zeros(lab.shape, bool)
        here[at] = place.mask
        contact = np.zeros(lab.shape, bool)
        contact[at] = place.contact
        paper = (lab == front) & ~k & ndimage.binary_dilation(here, iterations=2)
        mine = (lab == back) & k
        if not paper.any() or not (mine & contact).any():
            continue
        near = ndimage.distance_transform_edt(~paper)
        sk = skeleton[win] & k
        if not sk.any():
            continue
        _, (sy, sx) = ndimage.distance_transform_edt(~sk, return_indices=True)
        # Its stroke (at its nearest skeleton pixel, ``mid`` from the front part's paper,
        # ``half`` its half width) reaches that paper, a quarter of its half width off
        # centre at most (a thick stroke's skeleton wanders), and it lies within the stroke.
        mid, half = near[sy, sx], depth[win][sy, sx]
        candidates = mine & (mid <= 1.25 * half + 1.5) & (near <= mid + half + 1)
        pieces, _ = ndimage.label(candidates, structure=eight)
        touching = np.unique(pieces[contact & candidates])
        take = np.isin(pieces, touching[touching > 0])
        if not take.any():
            continue
        # The stroke's end past the contact (its cap), cut off from the part's other ink:
        # no longer than the stroke is wide.
        rest, _ = ndimage.label(mine & ~take, structure=eight)
        reach = ndimage.distance_transform_edt(~take)
        width = 2.0 * float(np.median(half[take]))
        beside = np.unique(rest[ndimage.binary_dilation(take, structure=eight)])
        beside = beside[beside > 0]
        if beside.size:
            far = ndimage.maximum(reach, rest, beside)
            take |= np.isin(rest, beside[np.asarray(far) <= width])
        # Not where the contact meets the paper: the part behind keeps the stroke's soft edge
        # that fades into the paper there (and the pixels beside the paper), so that its
        # layer does not fill in an opaque edge under the one the front part draws.
        air = lab < 0
        fades = _drawn_alpha(~air, air, np.zeros_like(air), strokes.matte[win],
                             strokes.cover[win], strokes.ink[win], strokes.width) < 1
        take &= ~(fades | ndimage.binary_dilation(air, structure=eight))
        rim = (lab == back) & tinted[win] & ~k & (near <= mid + half + 3) & ~fades & \
            ndimage.binary_dilation(take, structure=eight, iterations=2)
        out[win][take | rim] = front
    return out


def _pen_width(gray, where, inside, *, margin):
    """The median width (px) of the ink (darker than mid grey) ``inside`` along its skeleton
    in ``where``: twice the distance to its edge, which scales with the drawing. Found
    within ``margin`` px of ``where``; None where the skeleton has fewer than 8 pixels."""
    from skimage.morphology import skeletonize

    rows, cols = np.flatnonzero(where.any(axis=1)), np.flatnonzero(where.any(axis=0))
    if not rows.size:
        return None
    box = (slice(max(rows[0] - margin, 0), rows[-1] + margin + 1),
           slice(max(cols[0] - margin, 0), cols[-1] + margin + 1))
    ink = (gray[box] < INK_LEVEL) & inside[box]
    skeleton = skeletonize(ink) & where[box]
    if skeleton.sum() < 8:
        return None
    return _median_width(ndimage.distance_transform_edt(ink), skeleton)


def _median_width(depth, skeleton):
    """The median width (px) of strokes: twice their ink's ``depth`` (distance to its edge)
    along their ``skeleton``."""
    return 2.0 * float(np.median(depth[skeleton]))


def _depth(mask):
    """Distance (px) from each pixel of ``mask`` to its edge (the array's edge not one)."""
    return ndimage.distance_transform_edt(np.pad(mask, 1, mode="edge"))[1:-1, 1:-1]


def _layer(name, region, visible, shape, grown, strokes, *, air=None, under=None, fringe=None,
           outline=True, stubs=None):
    """One layer: drawing pixels where visible, fill (and outline) elsewhere in ``grown``.

    ``stubs`` are visible pixels given to the part from another's label (its strokes'
    stubs): ink, they give the fill no colour.

    Its alpha is the drawing's own soft edge where the layer ends at a drawn
    outline (the ink's coverage beyond the stroke's darkest line) and an
    anti-aliased edge (from the silhouette's smoothed signed distance) where
    it ends at a continued outline. ``under`` are the pixels that the parts
    in front cover opaquely: the padding lies there, and so whatever it
    changes, so that the flattened stack does not depend on it.
    """
    h, w = visible.shape
    footprint = grown if fringe is None else grown | fringe
    rows, cols = np.flatnonzero(footprint.any(axis=1)), np.flatnonzero(footprint.any(axis=0))
    # One pixel beyond the continued outline for its anti-aliasing, one of air around it.
    y0, y1 = max(rows[0] - 2, 0), min(rows[-1] + 3, h)
    x0, x1 = max(cols[0] - 2, 0), min(cols[-1] + 3, w)
    win = (slice(y0, y1), slice(x0, x1))
    vis, shp, grw = visible[win], shape[win], grown[win]
    frg = np.zeros_like(grw) if fringe is None else fringe[win] & ~grw
    below = np.zeros_like(grw) if under is None else under[win]
    colours = strokes.rgb[win].astype(np.float64)
    hidden = grw & ~vis
    out = np.where((vis | frg)[..., None], colours, 0.0)
    if hidden.any():
        known = vis if stubs is None else vis & ~stubs[win]
        out = np.where(hidden[..., None], _fill(colours, strokes.gray[win], strokes.inky[win],
                                                known, shp & ~vis, hidden, strokes.width), out)
    if not outline:
        alpha = grw.astype(np.float64)
    else:
        own = (shape & ~visible, visible if fringe is None else visible | fringe, visible)
        alpha, out = _edges(win, vis, shp, grw, frg, below, air[win], out, colours, strokes, own)
    a8 = np.rint(alpha * 255).astype(np.uint8)
    rgba = np.dstack([np.where(a8[..., None] > 0, np.clip(np.rint(out), 0, 255), 0), a8])
    rgba = rgba.astype(np.uint8)
    keep = a8 > 0
    rows, cols = np.flatnonzero(keep.any(axis=1)), np.flatnonzero(keep.any(axis=0))
    crop = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
    return CutoutLayer(name=name, region=region, top=int(y0 + rows[0]), left=int(x0 + cols[0]),
                       rgba=rgba[crop], hidden=hidden[crop])


def _fill(colours, gray, inky, vis, hidden, padded, width):
    """The part's colours continued into its ``hidden`` pixels, then into the padding.

    Only the part's paper (:func:`_paper`) gives boundary values: ink next to the hidden
    part (the occluder's outline, the part's own strokes, however thick or soft) is not the
    part's colour and is filled over like the hidden part.
    """
    ink = ndimage.binary_dilation(_ink(gray, size=2 * int(np.ceil(width)) + 3))
    paper = _paper(gray, inky, vis & ~ink)
    # The fill runs over the ink beside the hidden part to the paper beyond it.
    near = ndimage.binary_dilation(hidden, iterations=2 * _STROKE_MAX + 1)
    unknown = hidden | (vis & ~paper & near)
    known = paper & ndimage.binary_dilation(unknown)
    # Where no paper touches the hidden part, the regularization gives it the paper's colour.
    mean = np.median(colours[paper], axis=0) if paper.any() else (
        colours[vis].mean(axis=0) if vis.any() else np.full(3, 255.0))
    fill = _harmonic_fill(colours, known, unknown, mean) if unknown.any() else colours
    pad = padded & ~hidden
    if pad.any():  # the padding continues the completed part, which it does not change
        done = paper | hidden
        fill = np.where(done[..., None], fill, colours)
        fill = np.where(pad[..., None],
                        _harmonic_fill(fill, done & ndimage.binary_dilation(pad), pad, mean), fill)
    return fill


def _paper(gray, inky, candidates):
    """The pixels of ``candidates`` at the part's own tone (paper or its colour), not ink.

    Ink too wide for the closing that finds strokes (a marker's, a filled
    black shape) and the soft edges of strokes are darker than the part's
    tone and have the colour of ink on this paper (``inky``) or are darker
    than their surroundings up to four strokes' width. The tone is the median
    grey of the pixels beyond such wide ink (a thin part's thick outline may
    cover most of it), and darker means more than twice its spread below (the
    spread from the pixels lighter than the median, which no ink reaches), or
    a grey level where the paper is flat. A colour of the part's own, however
    dark, is kept.
    """
    wide = _ink(gray, size=4 * _STROKE_MAX + 1)
    values = gray[candidates & ~wide]
    if not values.size:
        values = gray[candidates]
    if not values.size:
        return candidates
    tone = float(np.median(values))
    # A normal distribution's deviation from its median absolute deviation.
    spread = 1.4826 * float(np.median(values[values >= tone] - tone))
    dark = gray < tone - max(_PAPER_SPREADS * spread, 1 / 255)
    return candidates & ~(dark & (inky | wide))


def _edges(win, vis, shp, grw, frg, below, air, out, colours, strokes, own):
    """The layer's alpha and colours at its edges: drawn (the ink's soft edge) and continued."""
    drawn = grw | frg   # the layer's pixels whose edge the drawing gives
    edge = np.zeros_like(grw)
    sd = np.zeros(grw.shape)
    hidden = shp & ~vis
    if hidden.any():
        # The continued outline's edge: pixels whose nearest pixel of the part is hidden, beyond
        # the part only under the parts in front; the padding's own edge only there.
        padded = not np.array_equal(grw, shp)
        for part in (shp, grw) if padded else (shp,):
            d = _signed_distance(part)
            if part is shp:
                d_shape = d
            _, (iy, ix) = ndimage.distance_transform_edt(~part, return_indices=True)
            mine = (part & ~vis) | (~part & below & (part & ~vis)[iy, ix] & (d > -1.5))
            if part is not shp:
                mine &= below
            edge |= mine
            sd = np.where(mine, d, sd)
        drawn &= ~edge
    alpha = np.where(drawn, _drawn_alpha(drawn, air, frg, strokes.matte[win], strokes.cover[win],
                                         strokes.ink[win], strokes.width), 0.0)
    # A soft edge pixel holds the ink that makes the drawing over the paper.
    soft = drawn & (alpha < 1)
    safe = np.where(alpha > 1e-3, alpha, 1.0)[..., None]
    out = np.where(soft[..., None], (colours - (1 - safe) * strokes.paper) / safe, out)
    if hidden.any():
        # The continued outline: the colour and width of the part's own strokes where its
        # outline enters the hidden area, its edge as soft as the drawn edge (inset by as
        # much as the drawn edge's pixels are clear on average).
        colour, width = strokes.style(*own)
        inset = _inset(alpha, drawn)
        a = np.clip(sd + 0.5 - inset, 0.0, 1.0)
        # The stroke lies within ``width`` of the completed silhouette (not of the padding).
        ss = d_shape - inset
        cover = np.clip(np.minimum(ss + 0.5, width) - np.maximum(ss - 0.5, 0.0), 0.0, 1.0)
        k = np.divide(cover, a, out=np.zeros_like(a), where=a > 0).clip(0.0, 1.0)[..., None]
        out = np.where(edge[..., None], out * (1 - k) + colour * k, out)
        alpha = np.where(edge, a, alpha)
    return alpha, out


def _inset(alpha, drawn):
    """How far (px) the drawn edge's alpha falls inside the layer: the mean clear share of
    its edge pixels (opaque at all, beside a clear one), 0 for a crisp edge."""
    solid = alpha > 0
    clear = np.pad(~solid, 1, constant_values=True)
    beside = clear[:-2, 1:-1] | clear[2:, 1:-1] | clear[1:-1, :-2] | clear[1:-1, 2:]
    rim = drawn & solid & beside
    return float(np.mean(1.0 - alpha[rim])) if rim.any() else 0.0


def _signed_distance(mask):
    """Distance (px) from each pixel's centre to the edge of ``mask``, positive inside,
    smoothed over the pixel stair-steps."""
    sd = np.where(mask, ndimage.distance_transform_edt(mask) - 0.5,
                  0.5 - ndimage.distance_transform_edt(~mask))
    return ndimage.gaussian_filter(sd, _EDGE_SMOOTHING)


def _drawn_alpha(footprint, air, fringe, matte, cover, ink, width):
    """Alpha of a layer where its edge is drawn: the ink's coverage outside the stroke's core.

    Transparency flows in from the paper around the layer (``air``) through
    pixels of its rim near ink and stops at the stroke's darkest line (a
    morphological reconstruction of ``1 - cover``): what lies outside that
    line fades with the ink as in the drawing; the paper inside the stroke
    stays opaque. Where no ink lines the edge, and along a seam with another
    part, the layer stays opaque to its edge.
    """
    outside = ~footprint & air
    rim = footprint & (ndimage.distance_transform_edt(~outside) <= np.ceil(width) + 1)
    rim = (rim & ndimage.binary_dilation(ink, iterations=2) & matte) | fringe
    # Paper beyond the part's label is clear also where strokes enclose it.
    seed = (outside | (fringe & (cover < _CLEAR))).astype(np.float64)
    mask = np.maximum(np.where(rim, 1.0 - cover, 0.0), seed)
    # Reconstruction by dilation, step by step: the rim is a few pixels deep, so it settles in
    # a few steps (a sorting reconstruction over the whole window cost 5 times as much).
    clear = seed
    for _ in range(_RIM_STEPS):
        grown = np.minimum(ndimage.maximum_filter(clear, size=3), mask)
        if np.array_equal(grown, clear):
            break
        clear = grown
    return 1.0 - clear


def _ink(gray, *, size):
    """Pixels darker than their surroundings: thin dark strokes, not dark flat colour."""
    return ndimage.grey_closing(gray, size=(size, size)) - gray > _INK_CONTRAST


def _harmonic_fill(colours, known, unknown, mean):
    """Colours on ``unknown`` minimizing squared 4-neighbour differences, ``known`` fixed."""
    nodes = known | unknown
    h, w = nodes.shape
    wx = (nodes[:, 1:] & nodes[:, :-1]).astype(np.float64)
    wy = (nodes[1:, :] & nodes[:-1, :]).astype(np.float64)
    index = np.flatnonzero(nodes.ravel())
    L = grid_laplacian(wx, wy).tocsr()[index][:, index]
    n = len(index)
    Q = L + _REGULARIZE * sp.identity(n, format="csr")
    fixed = np.flatnonzero(known.ravel()[index])
    B = -_REGULARIZE * np.broadcast_to(mean, (n, 3))
    flat = colours.reshape(-1, 3)[index]
    x = MinQuadWithFixed(Q, fixed).solve(B, flat[fixed])
    out = np.zeros((h * w, 3))
    out[index] = x
    return out.reshape(h, w, 3)


def _unique_names(layers):
    """Number the second and later layers of one name ("arm 2"): rigs key layers by name."""
    seen = {layer.name for layer in layers}
    count = {}
    for layer in layers:
        count[layer.name] = count.get(layer.name, 0) + 1
        if count[layer.name] > 1:
            k = count[layer.name]
            while f"{layer.name} {k}" in seen:
                k += 1
            seen.add(f"{layer.name} {k}")
            layer.name = f"{layer.name} {k}"


def _piece(completion, layer, split):
    """The pixels of ``layer`` around the place where its region must come forward."""
    y0, y1, x0, x1 = layer.box
    # Not the padding: it lies under the parts in front, the other part among them.
    mask = completion.completed(split.region)[y0:y1, x0:x1]
    if split.place is None:
        return np.zeros(mask.shape, bool)
    places = [p for p in completion.places
              if {p.a, p.b} == {split.region, split.under}]
    here = completion.places[split.place]
    shape = completion.labels.shape

    def distance(place):
        return ndimage.distance_transform_edt(~place.full_mask(shape))[y0:y1, x0:x1]

    d = distance(here)
    py0, py1, px0, px1 = here.box
    reach = 0.5 * max(py1 - py0, px1 - px0) + 2.0
    piece = mask & (d <= reach)
    for other in places:
        if other.index != here.index:
            piece &= d < distance(other)
    return piece


def _without(layer, drop, *, name=None):
    """``layer`` without the pixels of ``drop`` (in its box), cropped; None if empty."""
    keep = (layer.rgba[..., 3] > 0) & ~drop
    if not keep.any():
        return None
    rows, cols = np.flatnonzero(keep.any(axis=1)), np.flatnonzero(keep.any(axis=0))
    win = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
    rgba = np.where(keep[..., None], layer.rgba, 0).astype(np.uint8)[win]
    return CutoutLayer(name=name or layer.name, region=layer.region,
                       top=layer.top + int(rows[0]), left=layer.left + int(cols[0]),
                       rgba=rgba, hidden=(layer.hidden & keep)[win])
