"""Sprite maps: normal, height, ambient occlusion and part-ID images of a relief.

2D engines light sprites with a *normal map* (Godot's ``CanvasTexture``,
Unity's secondary textures, Laigter, Sprite DLight, SpriteIlluminator);
compositors add a *height* pass, an *ambient occlusion* pass and an ID pass
to select parts. An Ink-and-Ray relief (Sýkora et al., TOG 2014) gives all of
them from its front view. ``inkray maps`` writes, at the drawing's size::

    DIR/normal.png   8-bit RGBA  tangent-space normal, rgb = round((n + 1) * 127.5)
    DIR/height.png   16-bit grey 0 no surface, 1..65535 low..high (range in "inkray:depth")
    DIR/ao.png       8-bit LA    ambient light, 255 open, 0 fully occluded
    DIR/parts.png    8-bit palette, index 0 transparent background, index i + 1 region i
    DIR/maps.json    the convention, the height range and the part legend

The normal's frame is *x right, y up, z toward the viewer* for the OpenGL
convention (``"opengl"``, also Godot, Blender, Unity) and *x right, y down*
for DirectX (``"directx"``, Unreal): the two differ in the sign of the green
channel. The alpha of every image (and code 0 of the height) is the
character mask: the pixels the segmentation gave a region. In ``normal.png``
the empty pixels hold the edge's normals for 8 px around the character and
the flat normal (128, 128, 255) beyond, so that filtering and mipmaps do not
bleed a false normal into the sprite's edge.
"""

import io
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from inkray.errors import InputError
from inkray.formats.atomic import atomic_outputs
from inkray.formats.depth_png import codes_png, read_depth_png
from inkray.formats.labels import label_image, label_palette
from inkray.numerics.quantization import quantize16
from inkray.view.ambient_occlusion import ambient_occlusion
from inkray.view.rasterization import rasterize

__all__ = ["SpriteMaps", "CONVENTIONS", "sprite_maps", "write_sprite_maps", "read_sprite_maps"]

#: Normal-map conventions: the sign of the normal's y (green) in the image.
CONVENTIONS = {"opengl": 1.0, "directx": -1.0}
_EDGE_PAD = 8  # px of edge normals around the character in normal.png (3 mipmap levels)
_FILES = {"normal": "normal.png", "height": "height.png", "ao": "ao.png", "parts": "parts.png"}
_AO_RADIUS_FRACTION = 0.03  # of the drawing's longer side


@dataclass
class SpriteMaps:
    """The maps of one relief at the drawing's resolution.

    Attributes
    ----------
    normal : (H, W, 3) float array
        Unit normals in the convention's frame; zero outside ``mask``.
    height : (H, W) float array
        Front height in drawing pixels; NaN outside ``mask``.
    ao : (H, W) float array
        Ambient light in [0, 1]; 1 outside ``mask``.
    parts : (H, W) int array
        Region index, -1 outside ``mask``.
    names : list of str
        ``names[i]`` names region ``i``.
    convention : str
        ``"opengl"`` (y up) or ``"directx"`` (y down).
    """

    normal: np.ndarray
    height: np.ndarray
    ao: np.ndarray
    parts: np.ndarray
    names: list
    convention: str = "opengl"

    @property
    def mask(self):
        """(H, W) bool array: the character."""
        return self.parts >= 0


def sprite_maps(relief, labels, names, *, convention="opengl", ao_radius=None, ao_directions=16):
    """The sprite maps of a relief whose character mask is ``labels >= 0``.

    Normals and heights come from the relief's front view
    (:func:`inkray.view.rasterization.rasterize`); the few mask pixels the
    meshes miss at the silhouette (a pixel centre just outside a triangle)
    take their nearest rasterized neighbour's, so the alpha is exactly the
    segmentation's character.

    Parameters
    ----------
    relief : inkray.relief.model.Relief
    labels : (H, W) int array
        The segmentation: -1 background, ``i`` region ``names[i]``.
    names : list of str
    convention : {"opengl", "directx"}, default "opengl"
        Sign of the normal's y: up (OpenGL, Godot, Unity) or down (DirectX, Unreal).
    ao_radius : float, optional
        Occlusion radius in pixels; default 3 % of the drawing's longer side.
    ao_directions : int, default 16

    Returns
    -------
    SpriteMaps

    Examples
    --------
    >>> from inkray.relief.model import Part, Relief
    >>> v = np.array([[0, 0, 2], [4, 0, 2], [4, 4, 2], [0, 4, 2]], float) - [0.5, 0.5, 0]
    >>> relief = Relief([Part("sq", v, np.array([[0, 3, 2], [0, 2, 1]]))], size=(4, 4))
    >>> maps = sprite_maps(relief, np.zeros((4, 4), int), ["sq"])
    >>> maps.normal[1, 1].tolist(), float(maps.height[1, 1]), float(maps.ao.min())
    ([0.0, 0.0, 1.0], 2.0, 1.0)
    """
    if convention not in CONVENTIONS:
        raise InputError(f"convention: expected one of {', '.join(CONVENTIONS)}, "
                         f"got {convention!r}")
    labels = np.asarray(labels)
    w, h = (int(s) for s in relief.size)
    if labels.shape != (h, w):
        raise InputError(f"labels: shape {labels.shape} differs from the relief's {h}x{w} drawing")
    if labels.size and labels.max() >= len(names):
        raise InputError(f"labels: region {int(labels.max())} has no name ({len(names)} names)")
    mask = labels >= 0
    raster = rasterize(relief)
    hit = raster.mask
    # The relief's y grows downward; + 0.0 turns the flipped zeros' -0.0 into 0.0.
    normal = raster.normal * [1.0, -CONVENTIONS[convention], 1.0] + 0.0
    height = raster.depth
    if hit.any() and not hit.all():
        _, (ri, ci) = ndimage.distance_transform_edt(~hit, return_indices=True)
        normal, height = normal[ri, ci], height[ri, ci]
    elif not hit.any():
        normal = np.broadcast_to([0.0, 0.0, 1.0], normal.shape).copy()
        height = np.zeros(mask.shape)
    normal = np.where(mask[..., None], normal, 0.0)
    height = np.where(mask, height, np.nan)
    radius = max(1.0, _AO_RADIUS_FRACTION * max(w, h)) if ao_radius is None else float(ao_radius)
    ao = ambient_occlusion(np.nan_to_num(height), mask=mask, radius=radius,
                           directions=ao_directions)
    return SpriteMaps(normal=normal, height=height, ao=ao, parts=np.where(mask, labels, -1),
                      names=list(names), convention=convention)


def write_sprite_maps(maps, directory, *, outputs=None):
    """Write the maps into ``directory``: all files or none.

    Parameters
    ----------
    maps : SpriteMaps
    directory : str or Path
    outputs : optional
        An open :func:`inkray.formats.atomic.atomic_outputs` group.

    Returns
    -------
    list of Path
        normal.png, height.png, ao.png, parts.png and maps.json.

    Examples
    --------
    >>> import tempfile
    >>> maps = SpriteMaps(np.zeros((1, 2, 3)) + [0, 0, 1], np.array([[1.0, np.nan]]),
    ...                   np.ones((1, 2)), np.array([[0, -1]]), ["a"])
    >>> [p.name for p in write_sprite_maps(maps, tempfile.mkdtemp())]
    ['normal.png', 'height.png', 'ao.png', 'parts.png', 'maps.json']
    """
    from PIL import Image

    if outputs is None:
        with atomic_outputs() as group:
            return write_sprite_maps(maps, directory, outputs=group)
    directory = Path(directory)
    mask = maps.mask
    alpha = np.where(mask, 255, 0).astype(np.uint8)
    images = {}
    rgba = np.zeros(mask.shape + (4,), np.uint8)
    rgba[..., :3] = np.rint((np.clip(_padded_normals(maps.normal, mask), -1, 1) + 1) * 127.5)
    rgba[..., 3] = alpha
    images["normal"] = _png(Image.fromarray(rgba, "RGBA"))
    codes, height_range = quantize16(np.nan_to_num(maps.height), mask)
    images["height"] = codes_png(codes, height_range, units="drawing pixels")
    ao = np.where(mask, np.rint(np.clip(maps.ao, 0, 1) * 255), 0).astype(np.uint8)
    images["ao"] = _png(Image.fromarray(np.stack([ao, alpha], axis=-1), "LA"))
    images["parts"] = _png(label_image(maps.parts, len(maps.names)), transparency=0)
    written = []
    for key, data in images.items():
        outputs.write_bytes(directory / _FILES[key], data)
        written.append(directory / _FILES[key])
    palette = label_palette(len(maps.names))
    legend = {
        "format": "inkray-sprite-maps", "version": 1, "size": [mask.shape[1], mask.shape[0]],
        "files": dict(_FILES),
        "normal": {"convention": maps.convention,
                   "frame": "x right, y up, z toward the viewer" if maps.convention == "opengl"
                   else "x right, y down, z toward the viewer",
                   "encoding": "rgb = round((n + 1) * 127.5)"},
        "height": {"range": [height_range[0], height_range[1]], "units": "drawing pixels",
                   "encoding": "0 no surface, 1..65535 low..high"},
        "ao": {"encoding": "255 open, 0 fully occluded"},
        "parts": {name: {"index": i + 1, "colour": "#%02x%02x%02x" % tuple(palette[i + 1]),
                         "pixels": int((maps.parts == i).sum())}
                  for i, name in enumerate(maps.names)},
    }
    outputs.write_text(directory / "maps.json",
                       json.dumps(legend, indent=2, ensure_ascii=False) + "\n")
    written.append(directory / "maps.json")
    return written


def read_sprite_maps(directory):
    """Read maps written by :func:`write_sprite_maps` (values as stored, 8/16-bit).

    Parameters
    ----------
    directory : str or Path

    Returns
    -------
    SpriteMaps
        Normals decoded from 8 bits (unit length to about 0.01), heights
        from 16 bits.
    """
    from PIL import Image

    directory = Path(directory)
    try:
        legend = json.loads((directory / "maps.json").read_text(encoding="utf-8"))
        if legend.get("format") != "inkray-sprite-maps":
            raise InputError(f"{directory / 'maps.json'}: not an inkray sprite-maps legend")
        names = sorted(legend["parts"], key=lambda n: legend["parts"][n]["index"])
        with Image.open(directory / _FILES["normal"]) as im:
            rgba = np.asarray(im.convert("RGBA"))
        with Image.open(directory / _FILES["ao"]) as im:
            la = np.asarray(im.convert("LA"))
        with Image.open(directory / _FILES["parts"]) as im:
            index = np.asarray(im).astype(np.int64)
    except (OSError, ValueError, KeyError) as e:
        raise InputError(f"{directory}: unreadable sprite maps ({e})") from None
    height, _ = read_depth_png(directory / _FILES["height"])
    mask = rgba[..., 3] > 0
    normal = np.where(mask[..., None], rgba[..., :3] / 127.5 - 1.0, 0.0)
    return SpriteMaps(normal=normal, height=np.where(mask, height, np.nan),
                      ao=np.where(mask, la[..., 0] / 255.0, 1.0), parts=index - 1, names=names,
                      convention=legend["normal"]["convention"])


def _padded_normals(normal, mask):
    """Normals with the edge's normals carried ``_EDGE_PAD`` px into the empty pixels and the
    flat normal (0, 0, 1) beyond: texture filtering and mipmaps that mix in empty pixels
    then blend the sprite's edge with its own normals, not with (-1, -1, -1)."""
    if not mask.any():
        return np.broadcast_to([0.0, 0.0, 1.0], normal.shape)
    distance, (iy, ix) = ndimage.distance_transform_edt(~mask, return_indices=True)
    out = np.where((distance <= _EDGE_PAD)[..., None], normal[iy, ix], [0.0, 0.0, 1.0])
    return np.where(mask[..., None], normal, out)


def _png(image, **options):
    buf = io.BytesIO()
    image.save(buf, format="PNG", **options)
    return buf.getvalue()
