"""Cut-out layers: every part on its own layer, completed where it is hidden.

Cut-out rigs (Live2D, Spine, Inochi2D, Krita or Photoshop layer stacks) move
each part of a character separately, so a part must exist where another one
hides it. Ink-and-Ray (Sýkora et al., TOG 2014, section 4) already completes
every region under its occluders (:mod:`inkray.relief.completion`) and orders
neighbours locally (:mod:`inkray.relief.ordering`); this module turns that
into a stack of RGBA layers:

- a layer holds its region's completed shape: the drawing's pixels where the
  region is visible and, where it is hidden, its own colours continued
  inward by a harmonic fill (the membrane interpolant of the visible colours
  next to the hidden part, with the ink of the occluder's outline left out
  of the boundary values), with its outline continued along the completed
  silhouette in the drawing's ink colour and stroke width;
- the layers are stacked back to front by the depth order; a region behind
  none comes first;
- local order that no single stack can hold (two interlocking rings: A over
  B at one crossing, B over A at the other) is reported with the part that
  must be split; with ``split_local`` that part's pixels around the crossing
  become a layer of their own just above the other part.
"""

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy import ndimage

from inkray.errors import InputError
from inkray.numerics.grid import grid_laplacian
from inkray.numerics.order_graph import OrderGraph
from inkray.numerics.spd import MinQuadWithFixed

__all__ = ["CutoutLayer", "Cutout", "Split", "cut_out", "stack_order", "stroke_style"]

_INK_CONTRAST = 0.15  # ink: this much darker than the closing of the grey image (its surroundings)
_STROKE_MAX = 8       # px: the widest stroke the ink detection and the outline assume
_REGULARIZE = 1e-6  # pull toward the region's mean colour: fills parts no visible colour reaches


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
        return (f"region {self.name!r} must be split: it is over {self.under_name!r} near "
                f"({x:.0f}, {y:.0f}) but under it elsewhere, which no single layer stack holds "
                f"(--split-local splits it)")


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


def stroke_style(rgb, gray):
    """The drawing's ink: its colour and its typical stroke width in pixels.

    Ink is what is darker than its surroundings by a stroke's width (a grey
    closing); the width is the ink's area over the length of its skeleton,
    clipped to 1..8 px; the colour the median of the ink pixels (black
    without ink).

    Parameters
    ----------
    rgb : (H, W, 3) uint8 array
    gray : (H, W) float array
        Paper 1, ink near 0.

    Returns
    -------
    colour : (3,) uint8 array
    width : float

    Examples
    --------
    >>> gray = np.ones((20, 20)); gray[5:8, 2:18] = 0.0      # a 3 px stroke
    >>> rgb = np.repeat((gray[..., None] * 255).astype(np.uint8), 3, axis=2)
    >>> colour, width = stroke_style(rgb, gray)
    >>> colour.tolist(), round(width)
    ([0, 0, 0], 3)
    """
    from skimage.morphology import skeletonize

    ink = _ink(np.asarray(gray, np.float64), size=_STROKE_MAX + 1)
    if not ink.any():
        return np.zeros(3, np.uint8), 1.0
    length = skeletonize(ink).sum()
    width = float(np.clip(ink.sum() / max(length, 1), 1.0, _STROKE_MAX))
    colour = np.median(np.asarray(rgb)[ink], axis=0).astype(np.uint8)
    return colour, width


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
    splits = [Split(r.front, r.back, names[r.front], names[r.back],
                    tuple(float(v) for v in r.where), r.place) for r in broken]
    ink_colour, width = stroke_style(rgb, gray)
    layers = []
    if background:
        everywhere = np.ones(labels.shape, bool)
        layers.append(_layer("background", -1, labels < 0, everywhere, everywhere, rgb, gray,
                             ink_colour, width, outline=False))
    above = np.zeros(labels.shape, bool)  # visible pixels of the regions above, front first
    covers = {}
    for region in reversed(order):
        covers[region] = above.copy()
        above |= labels == region
    shapes = {}
    for region in order:
        shape = completion.completed(region)
        if not shape.any():
            continue
        grown = shape
        if pad:
            grown = shape | (ndimage.binary_dilation(shape, iterations=int(pad)) & covers[region])
        shapes[region] = _layer(names[region], region, labels == region, shape, grown, rgb,
                                gray, ink_colour, width)
    cuts = [(s, _piece(completion, shapes[s.region], s)) for s in splits
            if split_local and s.region in shapes]
    for region in (r for r in order if r in shapes):
        taken = [piece for s, piece in cuts if s.region == region]
        layer = _without(shapes[region], np.any(taken, axis=0)) if taken else shapes[region]
        if layer is not None:
            layers.append(layer)
        for s, piece in cuts:  # a split piece goes just above the part it must cover
            if s.under == region:
                part = _without(shapes[s.region], ~piece, name=f"{s.name} over {s.under_name}")
                if part is not None:
                    layers.append(part)
    return Cutout(layers=layers, size=(labels.shape[1], labels.shape[0]), splits=splits,
                  split=bool(split_local))


def _layer(name, region, visible, shape, grown, rgb, gray, ink_colour, width, *, outline=True):
    """One layer: drawing pixels where visible, fill (and outline) elsewhere in ``grown``."""
    rows, cols = np.flatnonzero(grown.any(axis=1)), np.flatnonzero(grown.any(axis=0))
    y0, y1, x0, x1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    win = (slice(y0, y1), slice(x0, x1))
    vis, shp, grw = visible[win], shape[win], grown[win]
    colours = rgb[win].astype(np.float64)
    hidden = grw & ~vis
    out = np.zeros(grw.shape + (4,), np.uint8)
    out[..., :3] = np.where(vis[..., None], rgb[win], 0)
    if hidden.any():
        # Ink (the occluder's outline) is not the part's colour; one pixel of antialiased fringe.
        ink = vis & ndimage.binary_dilation(_ink(gray[win], size=2 * int(np.ceil(width)) + 3))
        # Ink next to the hidden part (the occluder's outline) is not the part's colour.
        near = ndimage.binary_dilation(hidden, iterations=int(np.ceil(2 * width)) + 1)
        unknown = hidden | (ink & near)
        known = vis & ~ink & ndimage.binary_dilation(unknown)
        if not known.any():
            known = vis & ndimage.binary_dilation(unknown)
        mean = colours[vis & ~ink].mean(axis=0) if (vis & ~ink).any() else (
            colours[vis].mean(axis=0) if vis.any() else np.full(3, 255.0))
        fill = _harmonic_fill(colours, known, unknown, mean)
        if outline:
            # The outline continues along the completed silhouette, over the fill.
            depth = ndimage.distance_transform_edt(shp)
            cover = np.clip(width - (depth - 1.0), 0.0, 1.0)[..., None]
            fill = fill * (1 - cover) + ink_colour * cover
        out[..., :3] = np.where(hidden[..., None], np.clip(np.rint(fill), 0, 255), out[..., :3])
    out[..., 3] = np.where(grw, 255, 0)
    return CutoutLayer(name=name, region=region, top=int(y0), left=int(x0), rgba=out,
                       hidden=hidden)


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
