"""Pictures of a posed relief: the drawing carried by its deformed triangles, front part on top.

A posed relief (:mod:`inkray.relief.posing`) has the rest relief's parts,
faces and heights with moved ``(x, y)``. Drawing it follows the front view of
Ink-and-Ray (Sýkora et al., TOG 2014, section 6) and the layered deformation
of Igarashi et al. ("As-rigid-as-possible shape manipulation", SIGGRAPH
2005): every output pixel shows the part whose surface is highest there (a
z-buffer over the relief's heights, so local order such as interlocking
rings holds pixel by pixel), and its colour is the part's completed cut-out
layer (:mod:`inkray.relief.cutout`) at the pixel's rest position, found
through the barycentric coordinates of the triangle that covers it. The
layers' soft edges are kept: per pixel the two highest surfaces are
composited, so the edge of a part shows the part under it, or nothing at the
silhouette (transparent as the layer is there).
"""

import numpy as np

from inkray.errors import InputError
from inkray.relief.cutout import Cutout, CutoutLayer, cut_out
from inkray.relief.model import Relief
from inkray.relief.posing import Posing, rig_relief
from inkray.view.rasterization import zbuffer

__all__ = ["PosedDrawing", "posed_image", "posed_layers"]


class PosedDrawing:
    """An annotated drawing ready to pose: its rig, its cut-out layers and one set of handles.

    Parameters
    ----------
    relief : inkray.relief.model.Relief
    completion : inkray.relief.completion.Completion
        The ordered completion of the relief.
    relations : list of inkray.relief.ordering.Relation
    drawing : inkray.input.drawing.Drawing
    handles : (k, 2) float array
        Points on the drawing.
    boundaries : list of inkray.input.annotations.Boundary, optional

    Attributes
    ----------
    rig : inkray.relief.posing.Rig
    posing : inkray.relief.posing.Posing
    cutout : inkray.relief.cutout.Cutout
        The rest layers (their colours are what the posed parts carry).
    """

    def __init__(self, relief, completion, relations, drawing, handles, *, boundaries=()):
        self.rig = rig_relief(relief, completion, boundaries=boundaries)
        self.posing = Posing(self.rig, handles)
        self.cutout = cut_out(completion, relations, drawing)
        self.drawing = drawing
        self._sources = _Sources(relief, self.cutout, drawing.rgb)

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

    Every part is rasterized on its own; per pixel the two highest surfaces
    are kept and composited, the upper over the lower, with their layers'
    alpha (a soft edge of the upper part shows the part under it). At
    ``scale`` (output pixels per drawing pixel) the output is
    ``round(W * scale) x round(H * scale)``.
    """
    if not (np.isfinite(scale) and 0.01 <= scale <= 16):
        raise InputError(f"scale: expected a number within 0.01..16, got {scale!r}")
    w, h = (max(1, round(v * scale)) for v in posed.size)
    verts = np.concatenate([np.asarray(p.vertices, float) for p in posed.parts])
    # output pixel centres at integer coordinates, as the drawing's
    xy_out = (verts[:, :2] + 0.5) * scale - 0.5
    z1 = np.full((h, w), -np.inf)
    z2 = np.full((h, w), -np.inf)
    c1 = np.zeros((h, w, 4), np.float32)
    c2 = np.zeros((h, w, 4), np.float32)
    shown = np.full((h, w), -1, np.int32)
    for i, faces in enumerate(sources.part_faces):
        got = _part_surface(xy_out, verts[:, 2], faces, sources, i, (w, h))
        if got is None:
            continue
        (r0, c0), z, rgba = got
        win = (slice(r0, r0 + z.shape[0]), slice(c0, c0 + z.shape[1]))
        top, second = z > z1[win], (z <= z1[win]) & (z > z2[win])
        z2[win] = np.where(top, z1[win], np.where(second, z, z2[win]))
        c2[win] = np.where(top[..., None], c1[win], np.where(second[..., None], rgba, c2[win]))
        z1[win] = np.where(top, z, z1[win])
        c1[win] = np.where(top[..., None], rgba, c1[win])
        shown[win] = np.where(top, i, shown[win])
    a1 = c1[..., 3:] / 255.0
    premult = c1 + (1.0 - a1) * c2   # both premultiplied: rgb * alpha, alpha in 0..255
    alpha = premult[..., 3:] / 255.0
    colour = np.divide(premult[..., :3], alpha, out=np.zeros_like(premult[..., :3]),
                       where=alpha > 0)
    out = np.zeros((h, w, 4), np.uint8)
    out[..., 3] = np.clip(np.rint(alpha[..., 0] * 255), 0, 255)
    out[..., :3] = np.where(out[..., 3:] > 0, np.clip(np.rint(colour), 0, 255), 0)
    return out, shown


def _part_surface(xy, z, faces, sources, part, size):
    """One part's surface over its box: ``((row, col) of the box, height, premultiplied RGBA)``."""
    w, h = size
    if not len(faces):
        return None
    used = np.unique(faces)
    lo = np.maximum(np.floor(xy[used].min(axis=0)).astype(int) - 1, 0)
    hi = np.minimum(np.ceil(xy[used].max(axis=0)).astype(int) + 2, [w, h])
    if (hi <= lo).any():
        return None
    bw, bh = hi - lo
    local = xy - lo
    tri = zbuffer(local + 0.5, z, faces, (bw, bh)).ravel()
    pix = np.flatnonzero(tri >= 0)
    height = np.full(bw * bh, -np.inf)
    rgba = np.zeros((bw * bh, 4), np.float32)
    if pix.size:
        f = faces[tri[pix]]
        corners = local[f]
        cx, cy = (pix % bw).astype(float), (pix // bw).astype(float)
        (x0, y0), (x1, y1), (x2, y2) = (corners[:, k].T for k in range(3))
        det = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        b1 = ((y2 - y0) * (cx - x0) - (x2 - x0) * (cy - y0)) / det
        b2 = ((x1 - x0) * (cy - y0) - (y1 - y0) * (cx - x0)) / det
        bary = np.clip(np.column_stack([1.0 - b1 - b2, b1, b2]), 0.0, None)
        bary /= bary.sum(axis=1, keepdims=True)
        height[pix] = np.einsum("nk,nk->n", bary, z[f])
        # the surface point's rest position: where on the part's layer it takes its colour
        rest = np.einsum("nk,nkc->nc", bary, sources.rest[f])
        tx, ty, tex = sources.textures[part]
        rgba[pix] = _bilinear(tex, rest - [tx, ty])
    return (int(lo[1]), int(lo[0])), height.reshape(bh, bw), rgba.reshape(bh, bw, 4)


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
    """What a posed picture samples, prepared once per drawing.

    Per part: the colours it carries over its rest box (its cut-out layer,
    premultiplied RGBA; the drawing, opaque, for a part without a layer), and
    all parts' faces and rest positions in one array each.
    """

    @classmethod
    def join(cls, sources):
        """The sources of several reliefs' parts, one after the other."""
        out = cls.__new__(cls)
        out.textures = [t for s in sources for t in s.textures]
        out._topology([s.rest for s in sources], [s.part_faces for s in sources])
        return out

    def _topology(self, rests, faces):
        """All parts' faces in one array (into ``rest``), and the part of each face."""
        self.rest = np.concatenate(rests) if rests else np.zeros((0, 2))
        starts = np.cumsum([0] + [len(r) for r in rests])
        self.part_faces = [f + base for group, base in zip(faces, starts) for f in group]
        self.faces = (np.concatenate(self.part_faces) if self.part_faces
                      else np.zeros((0, 3), np.int64))
        self.tri_part = np.repeat(np.arange(len(self.part_faces)),
                                  [len(f) for f in self.part_faces]).astype(np.int32)

    def __init__(self, rest, layers, rgb):
        by_name = {layer.name: layer for layer in layers.layers
                   if layer.region is None or layer.region >= 0}
        h, w = rgb.shape[:2]
        self.textures = []
        for part in rest.parts:
            v = np.asarray(part.vertices, float)[:, :2]
            x0, y0 = (max(int(np.floor(c)) - 2, 0) for c in v.min(axis=0))
            x1, y1 = (int(np.ceil(c)) + 3 for c in v.max(axis=0))
            x1, y1 = min(max(x1, x0 + 1), w), min(max(y1, y0 + 1), h)
            layer = by_name.get(part.name)
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
            # premultiplied, so that bilinear sampling does not bleed the colour of nothing
            tex[..., :3] *= tex[..., 3:] / 255.0
            self.textures.append((x0, y0, tex))
        rest_xy, faces, base = [], [], 0
        for part in rest.parts:
            v = np.asarray(part.vertices, float)[:, :2]
            rest_xy.append(v if part.texcoords is None else np.asarray(part.texcoords, float))
            faces.append(np.asarray(part.faces, np.int64).reshape(-1, 3) + base)
            base += len(v)
        self._topology([np.concatenate(rest_xy) if rest_xy else np.zeros((0, 2))], [faces])


def _bilinear(image, xy):
    """``image`` (h, w, c) at points ``xy`` (x column, y row), clamped to its edge."""
    h, w = image.shape[:2]
    x = np.clip(xy[:, 0], 0, w - 1)
    y = np.clip(xy[:, 1], 0, h - 1)
    x0 = np.minimum(x.astype(np.int64), max(w - 2, 0))
    y0 = np.minimum(y.astype(np.int64), max(h - 2, 0))
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    fx, fy = (x - x0).astype(np.float32)[:, None], (y - y0).astype(np.float32)[:, None]
    top = image[y0, x0] + fx * (image[y0, x1] - image[y0, x0])
    bottom = image[y1, x0] + fx * (image[y1, x1] - image[y1, x0])
    return top + fy * (bottom - top)
