"""Several posed drawings in one picture: placed by similarity transforms, in front by their reliefs.

Fragment composition with layered reliefs (Sýkora et al., "Ink-and-Ray", TOG
2014, section 1): each drawing's relief (posed or at rest,
:mod:`inkray.view.posed`) is turned, scaled and moved into the scene, its
heights scaled alike and raised by the drawing's depth offset; the scene is
then drawn as one posed relief, so that at every pixel the highest surface of
any drawing shows (one character's arm can pass in front of another's body
while its leg stays behind). A placement follows
:class:`inkray.input.scene.Placement`: the drawing's centre ``((W - 1) / 2,
(H - 1) / 2)`` goes to ``at``.
"""

from dataclasses import dataclass

import numpy as np

from inkray.errors import InputError
from inkray.relief.cutout import Cutout
from inkray.relief.model import Part, Relief
from inkray.view.posed import _draw, _Sources, posed_layers

__all__ = ["Placed", "place", "scene_depths", "scene_image", "scene_layers", "scene_relief"]

_GAP = 1.0  # scene px between a drawing and the one in front of it by order


@dataclass
class Placed:
    """One drawing ready for a scene.

    Attributes
    ----------
    posed : inkray.relief.model.Relief
        Its relief, posed or at rest, in its drawing's pixels.
    rest : inkray.relief.model.Relief
        The rest relief (same parts, vertices, faces).
    cutout : inkray.relief.cutout.Cutout
        Its rest layers.
    rgb : (H, W, 3) uint8 array
        Its drawing.
    at : (float, float)
    rotate, scale : float
    depth : float or None
    name : str
        Prefix of its parts' and layers' names in the scene.
    """

    posed: Relief
    rest: Relief
    cutout: Cutout
    rgb: np.ndarray
    at: tuple
    rotate: float = 0.0
    scale: float = 1.0
    depth: float = None
    name: str = "d0"


def place(placed, size, depth=0.0):
    """A drawing's posed relief moved into the scene.

    Parameters
    ----------
    placed : Placed
    size : (int, int)
        The scene's ``(W, H)``.
    depth : float, default 0
        Height added after scaling.

    Returns
    -------
    inkray.relief.model.Relief
        Parts named ``<name>-<part>``, texture coordinates kept.

    Examples
    --------
    >>> v = np.array([[0.0, 0, 1], [3, 0, 1], [0, 3, 1]])
    >>> r = Relief([Part("a", v, np.array([[0, 2, 1]]))], size=(4, 4))
    >>> p = Placed(r, r, Cutout([], (4, 4)), np.zeros((4, 4, 3), np.uint8), at=(11.5, 1.5),
    ...            rotate=90.0, scale=2.0)
    >>> s = place(p, (20, 10), depth=5.0)
    >>> s.parts[0].name, s.parts[0].vertices.tolist()
    ('d0-a', [[14.5, -1.5, 7.0], [14.5, 4.5, 7.0], [8.5, -1.5, 7.0]])
    """
    w, h = placed.posed.size
    centre = np.array([(w - 1) / 2.0, (h - 1) / 2.0])
    a = np.radians(placed.rotate)
    turn = placed.scale * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    parts = []
    for p, r in zip(placed.posed.parts, placed.rest.parts):
        v = np.array(p.vertices, float)
        v[:, :2] = (v[:, :2] - centre) @ turn.T + placed.at
        v[:, 2] = v[:, 2] * placed.scale + depth
        tex = np.asarray(r.vertices, float)[:, :2] if p.texcoords is None else p.texcoords
        parts.append(Part(f"{placed.name}-{p.name}", v, p.faces, closed=p.closed, texcoords=tex))
    return Relief(parts=parts, size=tuple(size))


def scene_depths(placed):
    """Each drawing's height offset: its own ``depth``, or in front of the drawings before it.

    Parameters
    ----------
    placed : list of Placed

    Returns
    -------
    list of float

    Examples
    --------
    >>> v = np.array([[0.0, 0, 0], [3, 0, 4], [0, 3, 0]])
    >>> r = Relief([Part("a", v, np.array([[0, 2, 1]]))], size=(4, 4))
    >>> p = Placed(r, r, Cutout([], (4, 4)), np.zeros((4, 4, 3), np.uint8), at=(2, 2))
    >>> scene_depths([p, p, p])
    [0.0, 5.0, 10.0]
    """
    out, top = [], None
    for p in placed:
        heights = np.concatenate([np.asarray(q.vertices)[:, 2] for q in p.posed.parts]) * p.scale
        if p.depth is not None:
            d = float(p.depth)
        elif top is None:
            d = 0.0
        else:
            d = top + _GAP - float(heights.min())
        out.append(d)
        t = float(heights.max()) + d
        top = t if top is None else max(top, t)
    return out


def scene_image(placed, size):
    """The scene as RGBA: every drawing placed, the highest surface in front at each pixel.

    Parameters
    ----------
    placed : list of Placed
    size : (int, int)

    Returns
    -------
    (H, W, 4) uint8 array
    """
    if not placed:
        raise InputError("drawings: a scene needs at least one drawing")
    depths = scene_depths(placed)
    posed = [place(p, size, d) for p, d in zip(placed, depths)]
    scene = Relief([q for r in posed for q in r.parts], size=tuple(size))
    sources = _Sources.join([_Sources(p.rest, p.cutout, p.rgb) for p in placed])
    return _draw(scene, sources)[0]


def scene_layers(placed, size):
    """The scene's layers: every drawing's posed layers in the scene, back drawings first.

    Parameters
    ----------
    placed : list of Placed
    size : (int, int)

    Returns
    -------
    inkray.relief.cutout.Cutout
    """
    depths = scene_depths(placed)
    layers = []
    for k in np.argsort(depths, kind="stable"):
        p = placed[k]
        stack = posed_layers(place(p, size, depths[k]), p.rest, p.cutout, p.rgb)
        for layer in stack.layers:
            layer.name = f"{p.name}-{layer.name}"
            layers.append(layer)
    return Cutout(layers=layers, size=tuple(size))


def scene_relief(placed, size):
    """The scene as one relief: every drawing's parts placed, textured from an atlas of the drawings.

    The texture is the drawings stacked top to bottom (left-aligned, white
    elsewhere); texture coordinates point into it, so :attr:`Relief.size
    <inkray.relief.model.Relief.size>` is the atlas's. Vertices are in scene
    pixels: export with ``anchor="top-left"`` to keep them.

    Parameters
    ----------
    placed : list of Placed
    size : (int, int)
        The scene's ``(W, H)``.

    Returns
    -------
    inkray.relief.model.Relief

    Examples
    --------
    >>> v = np.array([[0.0, 0, 1], [3, 0, 1], [0, 3, 1]])
    >>> r = Relief([Part("a", v, np.array([[0, 2, 1]]))], size=(4, 4))
    >>> p = Placed(r, r, Cutout([], (4, 4)), np.zeros((4, 4, 3), np.uint8), at=(5.5, 1.5))
    >>> s = scene_relief([p, p], (20, 10))
    >>> s.size, [q.name for q in s.parts], s.parts[1].texcoords[2].tolist()
    ((4, 8), ['d0-a', 'd0-a'], [0.0, 7.0])
    """
    depths = scene_depths(placed)
    width = max(p.rgb.shape[1] for p in placed)
    height = sum(p.rgb.shape[0] for p in placed)
    atlas = np.full((height, width, 3), 255, np.uint8)
    parts, top = [], 0
    for p, d in zip(placed, depths):
        h, w = p.rgb.shape[:2]
        atlas[top:top + h, :w] = p.rgb
        for q in place(p, size, d).parts:
            parts.append(Part(q.name, q.vertices, q.faces, closed=q.closed,
                              texcoords=np.asarray(q.texcoords, float) + [0.0, top]))
        top += h
    return Relief(parts=parts, size=(width, height), texture=atlas)
