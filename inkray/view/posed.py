"""Pictures of a posed relief: the drawing carried by its deformed triangles, front part on top.

A posed relief (:mod:`inkray.relief.posing`) has the rest relief's parts,
faces and heights with moved ``(x, y)``. Drawing it follows the front view of
Ink-and-Ray (Sýkora et al., TOG 2014, section 6) and the layered deformation
of Igarashi et al. ("As-rigid-as-possible shape manipulation", SIGGRAPH
2005): every output pixel shows the part whose surface is highest there (a
z-buffer over the relief's heights, so local order such as interlocking
rings holds pixel by pixel), and its colour is the part's completed cut-out
layer (:mod:`inkray.relief.cutout`) at the pixel's rest position, found
through the affine map of the triangle that covers it. Each part's front
mesh is scan-converted on its own so that it covers every pixel centre in it
exactly once (no cracks between its triangles; where a pose folds a strip of
a part over the part itself, its highest triangle whose layer shows there),
and a band of ``_SKIRT`` px around it carries the part's layer beyond its
triangles (the triangles follow the outline, the layer the ink's
anti-aliasing; wider where the layer draws the part's outline over the part
behind it, which the segmentation may have given to that part; where the
band overlaps itself,
its most opaque piece; the relief has no height there, so between parts of one
drawing the layer stack orders the band against the others). The layers' soft edges are
kept: per pixel the two highest surfaces that are not fully transparent are
composited, so the edge of a part shows the part under it, or nothing at the
silhouette; at rest the picture is the flattened layer stack. Where posed parts
slide a pixel apart and leave a speck inside the picture that only their
transparent rims reach, and the drawing has ink there, the speck is drawn from
its neighbours (paper the pose encloses stays transparent).
"""

import copy
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from inkray.errors import InputError
from inkray.relief.cutout import Cutout, CutoutLayer, cut_out
from inkray.relief.model import Relief
from inkray.relief.posing import Posing, front_mesh, rig_relief

__all__ = ["DrawnMesh", "PosedDrawing", "posed_image", "posed_layers"]

_SKIRT = 2.5  # px: how far a layer's soft edge may reach beyond its part's triangles
# px: the widest skirt, for a layer whose strokes reach past its part's triangles (the outline
# a part in front draws over the part behind, a stub): the widest stroke the cut-out measures
# (32 px) and its soft edge
_SKIRT_MOST = 34.0
_PAD = int(np.ceil(_SKIRT))  # px: how far the layers go on under the parts in front
_SNAP = 1e-6  # px: a posed vertex this close to its rest position is drawn at it


class PosedDrawing:
    """An annotated drawing ready to pose: its rig, its cut-out layers and one set of handles.

    Parameters
    ----------
    relief : inkray.relief.model.Relief
    completion : inkray.relief.completion.Completion
        The ordered completion of the relief.
    relations : list of inkray.relief.ordering.Relation
    drawing : inkray.input.drawing.Drawing
    handles : (k, 2) float array or None
        Points on the drawing; None prepares the drawing without handles
        (:meth:`with_handles` gives it some).
    boundaries : list of inkray.input.annotations.Boundary, optional

    Attributes
    ----------
    rig : inkray.relief.posing.Rig
    posing : inkray.relief.posing.Posing or None
    cutout : inkray.relief.cutout.Cutout
        The rest layers (their colours are what the posed parts carry), each
        continued ``_PAD`` px under the parts in front of it.
    """

    def __init__(self, relief, completion, relations, drawing, handles, *, boundaries=()):
        self.rig = rig_relief(relief, completion, boundaries=boundaries)
        self.posing = None if handles is None else Posing(self.rig, handles)
        # Each layer goes on under the parts in front of it as far as its skirt can draw it:
        # a pose that moves a part in front a pixel or two shows the part behind, not a crack.
        self.cutout = cut_out(completion, relations, drawing, pad=_PAD)
        self.drawing = drawing
        self._sources = _Sources(relief, self.cutout, drawing.rgb)

    def with_handles(self, handles):
        """The same drawing prepared for ``handles`` (its rig, layers and colours shared)."""
        other = copy.copy(self)
        other.posing = Posing(self.rig, handles)
        return other

    def positions(self, targets, *, iterations=4):
        """Rig vertex positions with the handles at ``targets`` (warm-started, no folds)."""
        return self.posing.pose(targets, iterations=iterations)[0]

    def frames(self, pose, *, iterations=4):
        """Rig positions at every frame of ``pose``, each solve warm-started from the one before.

        Parameters
        ----------
        pose : inkray.input.pose.Pose
            Its handles must be this drawing's.
        iterations : int, default 4

        Returns
        -------
        list of (int, (n, 2) float array)
            ``(frame, positions)`` from the first key's frame to the last's.
        """
        if not np.allclose(pose.handles, self.posing.handles):
            raise InputError("pose: its handles differ from the ones this drawing was prepared for")
        self.posing.solver.reset()
        return [(f, self.positions(pose.at(f), iterations=iterations)) for f in pose.frames]

    def at(self, pose, frame=None, *, iterations=4):
        """Rig positions at one frame of ``pose`` (default its first key's), as in the animation.

        The frames before it warm-start the solve, so the frame is the same as
        in :meth:`frames`.
        """
        first, last = pose.keys[0].frame, pose.keys[-1].frame
        f = first if frame is None else frame
        if not (isinstance(f, (int, np.integer)) and first <= f <= last):
            raise InputError(f"frame: {f!r} is not a frame of the pose ({first}..{last})",
                             option="frame")
        self.posing.solver.reset()
        x = None
        for g in range(first, int(f) + 1):
            x = self.positions(pose.at(g), iterations=iterations)
        return x

    def relief(self, positions):
        """The posed relief (the rest relief's parts, vertices and faces, moved)."""
        return self.rig.posed_relief(positions)

    def image(self, positions, *, scale=1.0):
        """The posed picture, (H, W, 4) uint8 RGBA (see :func:`posed_image`).

        ``scale`` < 1 draws a smaller picture of the same pose (a quick
        preview while dragging).
        """
        return _draw(self.relief(positions), self._sources, scale=scale)[0]

    def layers(self, positions):
        """The posed cut-out stack (see :func:`posed_layers`)."""
        return posed_layers(self.relief(positions), self.rig.relief, self.cutout,
                            self.drawing.rgb)

    def meshes(self):
        """What a renderer needs to draw the posed picture itself: one :class:`DrawnMesh` per
        part, back to front by the layer stack (:meth:`drawn_vertices` moves them)."""
        out = []
        for i in self._sources.order:
            source = self._sources.parts[i]
            x0, y0, _ = source.texture
            if len(source.faces):
                at_rest = np.asarray(self.rig.relief.parts[i].vertices, float)
                _, _, rest, faces = source.posed(at_rest)
            else:
                rest, faces = np.zeros((0, 2)), np.zeros((0, 3), np.int64)
            out.append(DrawnMesh(name=self.rig.relief.parts[i].name, faces=faces,
                                 inner=len(source.faces), texcoords=rest,
                                 origin=(x0, y0), texture=source.image))
        return out

    def drawn_vertices(self, positions):
        """Per mesh of :meth:`meshes`, its posed vertices ``(x, y, height)`` at the rig
        positions ``positions``: the vertices the picture's triangles and skirts are drawn at."""
        posed = self.relief(positions)
        out = []
        for i in self._sources.order:
            source = self._sources.parts[i]
            if not len(source.faces):
                out.append(np.zeros((0, 3)))
                continue
            xy, z, _, _ = source.posed(np.asarray(posed.parts[i].vertices, float))
            out.append(np.column_stack([xy, z]))
        return out


@dataclass(frozen=True)
class DrawnMesh:
    """One part of a posed picture as a textured mesh (:meth:`PosedDrawing.meshes`).

    Drawn back to front, each pixel showing the highest front triangle (the
    ``inner`` first faces), its premultiplied colour over the ones below;
    the rest of the faces are the part's skirt, which carries its layer's soft
    edge and strokes beyond its triangles and has no height of its own: it
    goes over the parts drawn before it and under the ones drawn after.

    Attributes
    ----------
    name : str
    faces : (f, 3) int array
    inner : int
        How many of ``faces`` are the part's front triangles (the rest are its skirt).
    texcoords : (n, 2) float array
        Each vertex's rest position in drawing pixels (pixel ``(row i, column j)``
        centred at ``(j, i)``).
    origin : (int, int)
        The drawing pixel ``(x, y)`` at the texture's first row and column.
    texture : (h, w, 4) uint8 array
        The part's cut-out layer over its box, RGBA not premultiplied (the
        drawing, opaque, for a part without a layer).
    """

    name: str
    faces: np.ndarray
    inner: int
    texcoords: np.ndarray
    origin: tuple
    texture: np.ndarray


def posed_image(posed, rest, layers, drawing_rgb):
    """The posed drawing as RGBA: the character opaque, the rest transparent.

    Parameters
    ----------
    posed, rest : inkray.relief.model.Relief
        The same parts and faces; ``posed`` moved.
    layers : inkray.relief.cutout.Cutout
        The rest cut-out stack (one layer per region, named after it).
    drawing_rgb : (H, W, 3) uint8 array

    Returns
    -------
    rgba : (H, W, 4) uint8 array
    part : (H, W) int array
        The part each pixel shows, -1 where empty.

    Examples
    --------
    >>> from inkray.relief.model import Part
    >>> v = np.array([[0, 0, 1], [4, 0, 1], [4, 4, 1], [0, 4, 1]], float) - [0.5, 0.5, 0]
    >>> sq = Relief([Part("sq", v, np.array([[0, 3, 2], [0, 2, 1]]))], size=(8, 4))
    >>> moved = Relief([Part("sq", v + [4, 0, 0], sq.parts[0].faces)], size=(8, 4))
    >>> rgb = np.zeros((4, 8, 3), np.uint8); rgb[:, :4] = 200
    >>> img, part = posed_image(moved, sq, Cutout([], (8, 4)), rgb)
    >>> img[0, :, 0].tolist(), img[0, :, 3].tolist()
    ([0, 0, 0, 0, 200, 200, 200, 200], [0, 0, 0, 0, 255, 255, 255, 255])
    """
    _check(posed, rest)
    w, h = rest.size
    rgb = np.asarray(drawing_rgb)
    if rgb.shape[:2] != (h, w):
        raise InputError(f"drawing: {rgb.shape[1]}x{rgb.shape[0]} differs from the relief's "
                         f"{w}x{h}")
    return _draw(posed, _Sources(rest, layers, rgb))


def _draw(posed, sources, *, scale=1.0):
    """The picture of ``posed`` coloured by ``sources`` at the rest positions, and its parts.

    Every part's front triangles, and a skirt around them where it has a
    layer, are scan-converted on their own; per pixel the two highest
    surfaces whose colour is not fully transparent are kept and composited
    (a skirt against another part of its drawing: the later in the stack is higher),
    the upper over the lower, with their layers' alpha (a soft edge of the
    upper part shows the part under it). Parts are taken back to front by
    the stack, so that of two equally high surfaces the one in front shows.
    At ``scale`` (output pixels per drawing pixel) the output is
    ``round(W * scale) x round(H * scale)``.
    """
    if not (np.isfinite(scale) and 0.01 <= scale <= 16):
        raise InputError(f"scale: expected a number within 0.01..16, got {scale!r}")
    w, h = (max(1, round(v * scale)) for v in posed.size)
    z1 = np.full(h * w, -np.inf)
    z2 = np.full(h * w, -np.inf)
    i1 = np.full(h * w, -1, np.int64)
    i2 = np.full(h * w, -1, np.int64)
    # per slot: whether its fragment lies beyond its part's triangles, and (in a scene of
    # several drawings) the drawing it belongs to
    s1, s2 = np.zeros(h * w, bool), np.zeros(h * w, bool)
    many = len(set(sources.drawing)) > 1
    g1, g2 = (np.full(h * w, -1, np.int64) for _ in range(2)) if many else (None, None)
    colours, owners, count = [], [], 0
    clear = []
    for i in sources.order:
        got = sources.parts[i].surface(np.asarray(posed.parts[i].vertices, float), scale, (w, h))
        if got is None:
            continue
        pix, z, rgba, skirt, gone = got
        clear.append((i, *gone))
        ids = count + np.arange(len(pix))
        count += len(pix)
        colours.append(rgba)
        owners.append(np.full(len(pix), i, np.int32))
        g = sources.drawing[i]
        # Pixels are distinct within a part; equal heights go to the later part (in front).
        # Beyond a part's triangles the relief has no height: there, between parts of one
        # drawing, the layer stack decides (this part is in front of those drawn before it).
        old1 = z1[pix]
        stack = skirt | s1[pix]
        top = (z >= old1) | (stack & (g1[pix] == g) if many else stack)
        below = np.flatnonzero(~top)
        at = pix[below]
        stack = s2[at] & (g2[at] == g) if many else s2[at]
        second = below[(z[below] >= z2[at]) | stack]
        top = np.flatnonzero(top)
        at = pix[top]
        z2[at], i2[at], s2[at] = old1[top], i1[at], s1[at]
        z1[at], i1[at], s1[at] = z[top], ids[top], skirt[top]
        if many:
            g2[at], g1[at] = g1[at], g
        at = pix[second]
        z2[at], i2[at], s2[at] = z[second], ids[second], False
        if many:
            g2[at] = g
    out = np.zeros((h * w, 4), np.uint8)
    shown = np.full(h * w, -1, np.int32)
    covered = np.flatnonzero(i1 >= 0)
    if covered.size:
        store = np.concatenate(colours)
        shown[covered] = np.concatenate(owners)[i1[covered]]
        c = np.take(store, i1[covered], axis=0)  # premultiplied, alpha in 0..255
        under = i2[covered]
        blend = np.flatnonzero((under >= 0) & (c[:, 3] < 255))
        c[blend] += (1.0 - c[blend, 3:] / 255.0) * np.take(store, under[blend], axis=0)
        soft = np.flatnonzero(c[:, 3] < 255)
        c[soft, :3] *= 255.0 / np.maximum(c[soft, 3:], 1e-12)
        rgba = np.clip(np.rint(c), 0, 255).astype(np.uint8)
        rgba[rgba[:, 3] == 0, :3] = 0
        out[covered] = rgba
    _seal(out, shown, (w, h), clear, sources.parts)
    return out.reshape(h, w, 4), shown.reshape(h, w)


def _seal(out, shown, size, clear, parts):
    """Specks that two parts' soft edges leave transparent inside the picture, drawn from the
    drawing: ``out`` and ``shown`` (flat) in place.

    Where posed parts meet, each one's layer fades out at its outline: a pose that slides
    them a pixel apart can leave pixels that they reach only with their transparent rims
    (their skirts, or triangles where a layer is transparent or so faint that the picture
    rounds it to transparent), enclosed by the picture,
    where the drawing (the flattened layer stack) has ink or a soft edge at every rest
    position a part carries them from. Such a pixel is drawn from its neighbours
    (:func:`_inpaint`) and shows the highest of those parts; one that any part covering it
    takes back to paper (paper the pose encloses, a leg closed on the other) stays
    transparent, and so does one joined to the outside. At rest every part carries a pixel
    from its own place, so a transparent pixel is paper there: the picture is unchanged.
    """
    w, h = size
    if not clear:
        return
    part = np.concatenate([np.full(len(c[1]), c[0], np.int64) for c in clear])
    pix = np.concatenate([c[1] for c in clear])
    z = np.concatenate([c[2] for c in clear])
    at = np.concatenate([c[3] for c in clear])
    alpha = out[:, 3]
    lone = alpha[pix] == 0
    if not lone.any():
        return
    solid = (alpha > 0).reshape(h, w)
    rows, cols = np.flatnonzero(solid.any(axis=1)), np.flatnonzero(solid.any(axis=0))
    if not rows.size:
        return
    # transparent pixels not joined (8-connected) to the outside of the picture's box
    y0, y1, x0, x1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    empty = np.pad(~solid[y0:y1, x0:x1], 1, constant_values=True)
    found, _ = ndimage.label(empty, structure=np.ones((3, 3), bool))
    inside = np.zeros((h, w), bool)
    inside[y0:y1, x0:x1] = (found != found[0, 0])[1:-1, 1:-1] & empty[1:-1, 1:-1]
    pick = np.flatnonzero(lone & inside.ravel()[pix])
    if not pick.size:
        return
    part, pix, z, at = part[pick], pix[pick], z[pick], at[pick]
    colour = np.empty((len(pix), 4), np.float32)
    for i in np.unique(part):
        one = part == i
        colour[one] = _bilinear(parts[i].backdrop.texture, at[one])
    paper = np.zeros(out.shape[0], bool)
    paper[pix[colour[:, 3] < 1.0]] = True
    keep = ~paper[pix]
    if not keep.any():
        return
    pix, z, part = pix[keep], z[keep], part[keep]
    order = np.lexsort((z, pix))
    last = order[np.r_[pix[order][1:] != pix[order][:-1], True]]
    pix = pix[last]
    shown[pix] = part[last]
    _inpaint(out.reshape(h, w, 4), *np.divmod(pix, w))


def _inpaint(out, rows, cols):
    """The pixels ``(rows, cols)`` of ``out`` (RGBA uint8, in place) from their drawn
    8-neighbours, layer by layer inward: the mean of the ones drawn so far (premultiplied)."""
    h, w = out.shape[:2]
    y0, y1 = max(rows.min() - 1, 0), min(rows.max() + 2, h)
    x0, x1 = max(cols.min() - 1, 0), min(cols.max() + 2, w)
    c = out[y0:y1, x0:x1].astype(float)
    c[..., :3] *= c[..., 3:] / 255.0
    todo = np.zeros(c.shape[:2], bool)
    todo[rows - y0, cols - x0] = True
    known = (c[..., 3] > 0) & ~todo
    ring = np.ones((3, 3, 1))
    while todo.any():
        count = ndimage.correlate(known.astype(float), ring[..., 0], mode="constant")
        total = ndimage.correlate(c * known[..., None], ring, mode="constant")
        ready = todo & (count > 0)
        if not ready.any():
            break
        c[ready] = total[ready] / count[ready, None]
        known |= ready
        todo &= ~ready
    c[..., :3] *= 255.0 / np.maximum(c[..., 3:], 1e-12)
    filled = np.zeros(c.shape[:2], bool)
    filled[rows - y0, cols - x0] = True
    out[y0:y1, x0:x1][filled] = np.clip(np.rint(c[filled]), 0, 255).astype(np.uint8)


def _scan(points, triangles, size):
    """Scan conversion: the pixels whose centres each triangle covers.

    Pixel ``(row i, column j)`` is centred at ``(j, i)``. A pixel centre is
    inside a triangle for rows ``ceil(y_top) <= i < ceil(y_bottom)`` and
    columns ``ceil(x_left) <= j < ceil(x_right)``, the crossings of every
    edge computed from its upper end, so two triangles sharing an edge
    compute the same crossing: a triangle mesh covers every pixel centre in
    it exactly once (no cracks, no doubles).

    Parameters
    ----------
    points : (n, 2) float array
    triangles : (m, 3) int array
    size : (int, int)
        ``(w, h)``.

    Returns
    -------
    pix : (k,) int array
        Flat pixel indices ``i * w + j``.
    tri : (k,) int array
        The triangle of each.
    """
    w, h = size
    m = len(triangles)
    if not m:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    px, py = np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1])
    x, y = list(px[triangles].T), list(py[triangles].T)
    for a, b in ((0, 1), (1, 2), (0, 1)):  # the corners ordered by y
        swap = y[b] < y[a]
        x[a], x[b] = np.where(swap, x[b], x[a]), np.where(swap, x[a], x[b])
        y[a], y[b] = np.where(swap, y[b], y[a]), np.where(swap, y[a], y[b])
    (x0, x1, x2), (y0, y1, y2) = x, y

    def slope(xa, ya, xb, yb):
        return np.divide(xb - xa, yb - ya, out=np.zeros(m), where=yb > ya)

    s01, s12, s02 = slope(x0, y0, x1, y1), slope(x1, y1, x2, y2), slope(x0, y0, x2, y2)
    first, middle, last = (np.clip(np.ceil(y), 0, h).astype(np.int64) for y in (y0, y1, y2))
    rows = last - first
    t = np.repeat(np.arange(m), rows)
    r = np.repeat(first, rows) + _ramp(rows)
    y = r.astype(float)
    long_edge = x0[t] + (y - y0[t]) * s02[t]
    upper = r < middle[t]
    short_edge = np.where(upper, x0[t] + (y - y0[t]) * s01[t], x1[t] + (y - y1[t]) * s12[t])
    left = np.clip(np.ceil(np.minimum(long_edge, short_edge)), 0, w).astype(np.int64)
    right = np.clip(np.ceil(np.maximum(long_edge, short_edge)), 0, w).astype(np.int64)
    span = np.maximum(right - left, 0)
    pix = np.repeat(r * w + left, span) + _ramp(span)
    return pix, np.repeat(t, span)


def _ramp(counts):
    """``0, 1, .., c - 1`` for every count ``c``, one after the other."""
    total = int(counts.sum())
    return np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)


def _affine(points, triangles, values):
    """Per triangle, ``values`` (n, c) as affine functions of (x, y): (m, 3c) ``[d/dx, d/dy, at 0]``."""
    a, b, c = (np.ascontiguousarray(t) for t in np.asarray(triangles).T)
    px, py = np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1])
    x0, y0 = px[a], py[a]
    e1x, e1y, e2x, e2y = px[b] - x0, py[b] - y0, px[c] - x0, py[c] - y0
    det = e1x * e2y - e2x * e1y
    inv = np.divide(1.0, det, out=np.zeros_like(det), where=np.abs(det) > 1e-12)
    k = values.shape[1]
    out = np.empty((len(a), 3 * k))
    for j in range(k):
        v = np.ascontiguousarray(values[:, j])
        v0 = v[a]
        d1, d2 = v[b] - v0, v[c] - v0
        gx, gy = (d1 * e2y - d2 * e1y) * inv, (d2 * e1x - d1 * e2x) * inv
        out[:, j], out[:, k + j], out[:, 2 * k + j] = gx, gy, v0 - gx * x0 - gy * y0
    return out


def posed_layers(posed, rest, layers, drawing_rgb):
    """The cut-out stack with every part's layer carried by its posed triangles.

    Parameters
    ----------
    posed, rest : inkray.relief.model.Relief
    layers : inkray.relief.cutout.Cutout
        The rest stack; its order (back to front) and names are kept. A
        layer whose part the relief lacks (the background) is left out.
    drawing_rgb : (H, W, 3) uint8 array

    Returns
    -------
    inkray.relief.cutout.Cutout
    """
    _check(posed, rest)
    names = [p.name for p in rest.parts]
    out = []
    for layer in layers.layers:
        base = layer.name.split(" over ")[0]
        if base not in names:
            continue
        i = names.index(base)
        one = Relief([posed.parts[i]], size=posed.size)
        img, part = posed_image(one, Relief([rest.parts[i]], size=rest.size),
                                Cutout([layer], layers.size), drawing_rgb)
        keep = img[..., 3] > 0
        if not keep.any():
            continue
        rows, cols = np.flatnonzero(keep.any(axis=1)), np.flatnonzero(keep.any(axis=0))
        win = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
        out.append(CutoutLayer(name=layer.name, region=layer.region, top=int(rows[0]),
                               left=int(cols[0]), rgba=img[win],
                               hidden=np.zeros(img[win].shape[:2], bool)))
    return Cutout(layers=out, size=layers.size, splits=list(layers.splits), split=layers.split)


def _check(posed, rest):
    if not (isinstance(posed, Relief) and isinstance(rest, Relief)):
        raise InputError("posed, rest: expected inkray.relief.model.Relief objects")
    if len(posed.parts) != len(rest.parts) or any(
            len(a.vertices) != len(b.vertices) or np.shape(a.faces) != np.shape(b.faces)
            for a, b in zip(posed.parts, rest.parts)):
        raise InputError("posed: its parts, vertices and faces differ from the rest relief's")


class _Sources:
    """What a posed picture samples, prepared once per drawing: one :class:`_PartSource` per
    part, and the order to draw them in (back to front by the layer stack)."""

    @classmethod
    def join(cls, sources):
        """The sources of several reliefs' parts, one after the other."""
        out = cls.__new__(cls)
        out.parts, out.order, out.drawing = [], [], []
        for k, s in enumerate(sources):
            out.order += [len(out.parts) + i for i in s.order]
            out.parts += s.parts
            out.drawing += [k] * len(s.parts)
        return out

    def __init__(self, rest, layers, rgb):
        by_name = {layer.name: layer for layer in layers.layers
                   if layer.region is None or layer.region >= 0}
        backdrop = _Backdrop(layers)
        self.parts = [_PartSource(part, by_name.get(part.name), rgb, backdrop)
                      for part in rest.parts]
        stack = [layer.name for layer in layers.layers]
        rank = {name: k for k, name in enumerate(stack)}
        self.order = sorted(range(len(rest.parts)),
                            key=lambda i: rank.get(rest.parts[i].name, -1))
        self.drawing = [0] * len(rest.parts)


class _Backdrop:
    """The drawing as its layer stack flattens it, premultiplied, made when first asked for
    (only a pose that leaves a speck between parts needs it)."""

    def __init__(self, layers):
        self._layers, self._texture = layers, None

    @property
    def texture(self):
        if self._texture is None:
            flat = self._layers.flatten().astype(np.float32)
            flat[..., :3] *= flat[..., 3:] / 255.0
            self._texture = flat
        return self._texture


class _PartSource:
    """One part's front mesh, its rest positions and colours, and the skirt of its layer.

    Colours: the part's cut-out layer over its rest box, premultiplied RGBA
    (the drawing, opaque, for a part without a layer). A layer's soft edge
    reaches up to ``_SKIRT`` px beyond the part's triangles (they follow the
    outline, the layer the ink's anti-aliasing), its strokes drawn past them
    further (its outline over a part behind it, a stub; ``_skirt_width``): a
    band of that width along
    the mesh's border, carried by the border's posed normals, draws it.
    """

    def __init__(self, part, layer, rgb, backdrop):
        self.backdrop = backdrop
        first, _, _, self.faces = front_mesh(part)
        self.vertex = first
        v = np.asarray(part.vertices, float)
        self.home = v[first, :2]
        self.rest = (v[:, :2] if part.texcoords is None else
                     np.asarray(part.texcoords, float))[first]
        h, w = rgb.shape[:2]
        self.skirt = (None if layer is None or not len(self.faces)
                      else _Skirt(self.faces, self.rest, layer))
        reach = self.skirt.width.max() + 2 if self.skirt is not None else 2
        x0, y0 = (max(int(np.floor(c - reach)), 0) for c in self.rest.min(axis=0))
        x1, y1 = (int(np.ceil(c + reach)) + 1 for c in self.rest.max(axis=0))
        x1, y1 = min(max(x1, x0 + 1), w), min(max(y1, y0 + 1), h)
        if layer is None:  # no layer: the drawing, opaque
            tex = np.dstack([rgb[y0:y1, x0:x1], np.full((y1 - y0, x1 - x0), 255)])
            tex = tex.astype(np.float32)
        else:
            tex = np.zeros((y1 - y0, x1 - x0, 4), np.float32)
            ly0, ly1, lx0, lx1 = layer.box
            cy0, cy1, cx0, cx1 = max(ly0, y0), min(ly1, y1), max(lx0, x0), min(lx1, x1)
            if cy0 < cy1 and cx0 < cx1:
                tex[cy0 - y0:cy1 - y0, cx0 - x0:cx1 - x0] = layer.rgba[
                    cy0 - ly0:cy1 - ly0, cx0 - lx0:cx1 - lx0]
        # two pixels at least each way, as bilinear sampling reads them
        tex = np.pad(tex, ((0, max(2 - tex.shape[0], 0)), (0, max(2 - tex.shape[1], 0)), (0, 0)),
                     mode="edge")
        self.image = tex.astype(np.uint8)
        # premultiplied, so that bilinear sampling does not bleed the colour of nothing
        tex[..., :3] *= tex[..., 3:] / 255.0
        self.texture = (x0, y0, tex)

    def posed(self, vertices):
        """The mesh drawn at ``vertices`` (the posed part's): its vertices, heights, rest
        positions and faces, with the skirt (its faces last)."""
        xy, z = vertices[self.vertex, :2], vertices[self.vertex, 2]
        # A vertex a solve brings back to rest within round-off is drawn at rest: a pixel
        # centre on a triangle's edge there (a straight outline along a pixel row) must not
        # flip to the next row and open a slit between two parts.
        xy = np.where(np.all(np.abs(xy - self.home) <= _SNAP, axis=1)[:, None], self.home, xy)
        if self.skirt is None:
            return xy, z, self.rest, self.faces
        return self.skirt.around(xy, z, self.rest, self.faces)

    def surface(self, vertices, scale, size):
        """Its covered pixels (flat, distinct), their heights and premultiplied RGBA, at
        ``vertices`` (the posed part's), which of them lie beyond its triangles, and the
        pixels where its layer is fully transparent (flat, heights and rest positions
        (x, y)); None when it covers none."""
        w, h = size
        if not len(self.faces):
            return None
        xy, z, rest, faces = self.posed(vertices)
        out = (xy + 0.5) * scale - 0.5
        lo = np.maximum(np.floor(out.min(axis=0)).astype(int), 0)
        hi = np.minimum(np.ceil(out.max(axis=0)).astype(int) + 1, [w, h])
        if (hi <= lo).any():
            return None
        bw, bh = hi - lo
        local = out - lo
        tx, ty, tex = self.texture
        # per triangle: height and texture position, affine in the pixel's position
        coef = _affine(local, faces, np.column_stack([z, rest - [tx, ty]]))
        # the skirt first: where the part's own triangles cover a pixel, they draw it
        frags = np.full(bw * bh, -1, np.int32)
        inner = len(self.faces)
        for chosen in (slice(inner, None), slice(0, inner)):
            pix, tri = _scan(local, faces[chosen], (bw, bh))
            tri = tri + chosen.start
            frags[pix] = tri
            if chosen.start:
                _most_opaque(frags, pix, tri, coef, tex, bw)
        _highest(frags, pix, tri, coef, tex, bw)
        pix = np.flatnonzero(frags >= 0)
        if not pix.size:
            return None
        tri = frags[pix]
        row, col = np.divmod(pix, bw)
        at = _at(coef, tri, row, col)
        rgba = _bilinear(tex, at[:, 1:])
        # what is fully transparent is not there: the surface under it shows
        keep = rgba[:, 3] > 0
        flat = (row + lo[1]) * w + col + lo[0]
        # what the picture rounds to transparent may leave a speck to seal
        clear = rgba[:, 3] < 0.5
        return (flat[keep], at[keep, 0], rgba[keep], tri[keep] >= inner,
                (flat[clear], at[clear, 0], at[clear, 1:] + [tx, ty]))


def _highest(frags, pix, tri, coef, texture, width):
    """Where a part's posed triangles overlap each other, the highest one whose layer shows
    there (alpha not rounding to 0; else the highest): ``frags`` in place.

    A pose can fold a strip of a mesh over its own interior with every
    triangle kept the right way round (a border held by its glue while the
    part turns); the strip, lower than the interior it slides over (an
    inflated part is lowest at its outline), goes under it, as a part under
    another does, instead of whichever triangle was scanned last. What does
    not show is not there, as between parts: a piece of the part that
    carries paper (an open mouth swung over the neck) or only the faint end
    of its soft edge shows the piece under it.
    """
    many = np.bincount(pix, minlength=frags.size)[pix] > 1
    if not many.any():
        return
    pix, tri = pix[many], tri[many]
    at = _at(coef, tri, *np.divmod(pix, width))
    # shown: its alpha does not round to 0 in the picture
    _largest(frags, pix, tri, at[:, 0], _bilinear(texture, at[:, 1:])[:, 3] > 0.5)


def _most_opaque(frags, pix, tri, coef, texture, width):
    """Where a part's skirt overlaps itself, the piece whose layer is most opaque: ``frags`` in
    place.

    The band folds over itself where the border turns inward or two stretches of it come
    close; posed, its pieces there take a pixel back to different rest positions, and one
    that reaches only the paper beyond the layer's edge must not hide one that reaches its ink.
    """
    many = np.bincount(pix, minlength=frags.size)[pix] > 1
    if not many.any():
        return
    pix, tri = pix[many], tri[many]
    at = _at(coef, tri, *np.divmod(pix, width), columns=slice(1, 3))
    _largest(frags, pix, tri, _bilinear(texture, at)[:, 3])


def _at(coef, tri, row, col, *, columns=slice(None)):
    """The affine values ``coef`` (per triangle, as :func:`_affine` gives them) of the
    triangles ``tri`` at the pixels ``(row, col)``, one per pixel: (k, c), only the values'
    ``columns`` when given."""
    c = coef.shape[1] // 3
    a, b, _ = columns.indices(c)
    k = np.take(coef, tri, axis=0)
    return (k[:, a:b] * col.astype(float)[:, None] + k[:, c + a:c + b] * row.astype(float)[:, None]
            + k[:, 2 * c + a:2 * c + b])


def _largest(frags, pix, tri, *keys):
    """Per pixel of ``pix``, the triangle of ``tri`` with the largest ``keys`` (the last one
    first, as in :func:`numpy.lexsort`): ``frags`` in place."""
    order = np.lexsort((*keys, pix))
    pix, tri = pix[order], tri[order]
    top = np.r_[pix[1:] != pix[:-1], True]
    frags[pix[top]] = tri[top]


def _skirt_width(rest, faces, layer, ring, ends):
    """How far beyond the part's rest triangles its layer holds drawn pixels, at each vertex of
    the mesh's border ``ring`` (``ends``: each border edge's two ring vertices): ``_SKIRT``
    px, or up to ``_SKIRT_MOST`` px where the layer draws the part's strokes past them (its
    outline over a part behind it, a stub; the triangles follow the labels, the layer the
    strokes). A drawn pixel counts at the border vertex nearest it and at that vertex's
    neighbours along the border; what the layer fills in under the parts in front,
    ``_PAD`` px of it, is not counted."""
    width = np.full(len(ring), _SKIRT)
    top, bottom, left, right = layer.box
    opaque = (layer.rgba[..., 3] > 0) & ~layer.hidden
    pix, _ = _scan(rest - [left, top], faces, (right - left, bottom - top))
    covered = np.zeros(opaque.size, bool)
    covered[pix] = True
    if not covered.any() or not opaque.any():
        return width
    far = ndimage.distance_transform_edt(~covered.reshape(opaque.shape))
    ys, xs = np.nonzero(opaque & (far + 0.5 > _SKIRT))
    if not ys.size:
        return width
    _, nearest = cKDTree(rest[ring] - [left, top]).query(np.column_stack([xs, ys]))
    np.maximum.at(width, nearest, np.minimum(far[ys, xs] + 0.5, _SKIRT_MOST))
    # a pixel beside a border edge may be nearer either of its ends
    wider = width.copy()
    np.maximum.at(wider, ends[:, 0], width[ends[:, 1]])
    np.maximum.at(wider, ends[:, 1], width[ends[:, 0]])
    return wider


class _Skirt:
    """The band along a mesh's border: per border edge two triangles out to its offset copy.

    Rest offsets are as wide as the part's ``layer`` draws beyond its triangles there
    (:func:`_skirt_width`) along the border's mitred normals; posed, the same along the
    posed normals, times the border's stretch.
    """

    def __init__(self, faces, rest, layer):
        edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        opposite = np.concatenate([faces[:, 2], faces[:, 0], faces[:, 1]])
        key = np.sort(edges, axis=1)
        _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        border = counts[inverse.reshape(-1)] == 1
        self.edges, self.opposite = edges[border], opposite[border]
        self.ring, ends = np.unique(self.edges, return_inverse=True)
        self.ends = ends.reshape(-1, 2)
        self.width = _skirt_width(rest, faces, layer, self.ring, self.ends)
        self.rest_offset = self.width[:, None] * self._normals(rest)[0]

    def _normals(self, xy):
        """Mitred outward unit normals at the ring's vertices, and each border edge's length."""
        a, b = xy[self.edges[:, 0]], xy[self.edges[:, 1]]
        d = b - a
        length = np.hypot(d[:, 0], d[:, 1])
        n = np.column_stack([d[:, 1], -d[:, 0]]) / np.maximum(length, 1e-12)[:, None]
        inward = np.einsum("ec,ec->e", n, xy[self.opposite] - a) > 0
        n[inward] *= -1
        total = np.column_stack([self._sum(n[:, 0]), self._sum(n[:, 1])])
        count = self._sum(np.ones(len(n)))
        norm = np.hypot(total[:, 0], total[:, 1])
        # the mitre: an average of unit normals is shorter where the border turns
        miter = np.minimum(count / np.maximum(norm, 1e-12), 2.0)
        return total / np.maximum(norm, 1e-12)[:, None] * miter[:, None], length

    def _sum(self, per_edge):
        """Per ring vertex, the sum of ``per_edge`` over the border edges at it."""
        n = len(self.ring)
        return (np.bincount(self.ends[:, 0], per_edge, minlength=n)
                + np.bincount(self.ends[:, 1], per_edge, minlength=n))

    def around(self, xy, z, rest, faces):
        """The mesh with its skirt: vertices, heights, rest positions and faces (skirt last)."""
        normal, length = self._normals(xy)
        rest_length = np.hypot(*(rest[self.edges[:, 1]] - rest[self.edges[:, 0]]).T)
        stretch = self._sum(length) / np.maximum(self._sum(rest_length), 1e-12)
        n = len(xy)
        a, b = self.edges[:, 0], self.edges[:, 1]
        a2, b2 = self.ends[:, 0] + n, self.ends[:, 1] + n
        band = np.concatenate([np.column_stack([a, b, b2]), np.column_stack([a, b2, a2])])
        return (np.concatenate([xy, xy[self.ring] + (self.width * stretch)[:, None] * normal]),
                np.concatenate([z, z[self.ring]]),
                np.concatenate([rest, rest[self.ring] + self.rest_offset]),
                np.concatenate([faces, band]))


def _bilinear(image, xy):
    """``image`` (h, w, c), h and w >= 2, at points ``xy`` (x column, y row), clamped to its edge."""
    h, w = image.shape[:2]
    flat = image.reshape(h * w, -1)
    x = np.clip(xy[:, 0], 0, w - 1)
    y = np.clip(xy[:, 1], 0, h - 1)
    x0 = np.minimum(x.astype(np.int64), w - 2)
    y0 = np.minimum(y.astype(np.int64), h - 2)
    fx, fy = (x - x0).astype(np.float32)[:, None], (y - y0).astype(np.float32)[:, None]
    i = y0 * w + x0
    # np.take: rows gathered many times faster than by fancy indexing
    top = np.take(flat, i, axis=0)
    top += fx * (np.take(flat, i + 1, axis=0) - top)
    bottom = np.take(flat, i + w, axis=0)
    bottom += fx * (np.take(flat, i + w + 1, axis=0) - bottom)
    top += fy * (bottom - top)
    return top
