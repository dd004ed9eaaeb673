"""Scribbles as pixels: rasterized polylines and scribble PNG layers.

The seeds of the LazyBrush segmentation (Sýkora, Dingliana, Collins, CGF
2009) are the pixels under the user's strokes. Strokes come either as
polylines in the annotation file or as a scribble PNG layer: an image of the
drawing's size, transparent except for strokes, one flat colour per region.
"""

import json
import re
import numpy as np
from PIL import Image

from inkray.errors import InputError
from inkray.input.annotations import Region
from inkray.input.files import read_bytes, regular_file

__all__ = ["UNSEEDED", "BACKGROUND", "polyline_pixels", "seed_image", "load_scribble_layer"]

UNSEEDED = -2
BACKGROUND = -1
_HEX = re.compile(r"#[0-9a-fA-F]{6}")
_LEGEND_BYTES = 1 << 20


def polyline_pixels(points, shape, *, radius=0):
    """Pixels covered by a polyline drawn with a round brush.

    Parameters
    ----------
    points : (k, 2) array
        ``[x, y]`` vertices; a single point is a dot.
    shape : (int, int)
        ``(H, W)`` of the image.
    radius : int, default 0
        Brush radius in pixels (0: one-pixel line).

    Returns
    -------
    rows, cols : int arrays
        Unique pixel indices inside the image, in raster order.

    Examples
    --------
    >>> r, c = polyline_pixels([[0, 0], [3, 0]], (4, 4))
    >>> c.tolist()
    [0, 1, 2, 3]
    """
    from skimage.draw import line

    h, w = shape
    # Points on the drawing's edge (x = W - 0.5) round into its last pixel, not past it.
    p = np.rint(np.asarray(points, float)).astype(np.int64).reshape(-1, 2)
    p = np.clip(p, 0, [max(w - 1, 0), max(h - 1, 0)])
    rr, cc = [p[:1, 1]], [p[:1, 0]]
    for (x0, y0), (x1, y1) in zip(p[:-1], p[1:]):
        r, c = line(y0, x0, y1, x1)
        rr.append(r)
        cc.append(c)
    rr = np.concatenate(rr)
    cc = np.concatenate(cc)
    if radius > 0:
        dy, dx = np.mgrid[-radius:radius + 1, -radius:radius + 1]
        disk = dy ** 2 + dx ** 2 <= radius ** 2 + radius
        rr = (rr[:, None] + dy[disk][None, :]).ravel()
        cc = (cc[:, None] + dx[disk][None, :]).ravel()
    keep = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
    flat = np.unique(rr[keep] * w + cc[keep])
    return flat // w, flat % w


def seed_image(ann, *, radius=0, include_background=True):
    """Rasterize every scribble of an annotation into one label image.

    Parameters
    ----------
    ann : Annotations
    radius : int, default 0
        Brush radius for polylines.
    include_background : bool, default True
        Rasterize the ``background`` scribbles (label ``BACKGROUND``).

    Returns
    -------
    (H, W) int32 array
        ``i`` under a scribble of ``ann.regions[i]``, ``BACKGROUND`` (-1) under
        a background scribble, ``UNSEEDED`` (-2) elsewhere. A pixel claimed by
        two different labels is left unseeded: crossing strokes carry no
        information there.

    Examples
    --------
    >>> from inkray.input.annotations import parse_annotations
    >>> ann = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [4, 3],
    ...     "regions": [{"name": "a", "scribbles": [[[0, 0], [3, 0]]]}]})
    >>> seed_image(ann).tolist()
    [[0, 0, 0, 0], [-2, -2, -2, -2], [-2, -2, -2, -2]]
    """
    w, h = ann.size
    seeds = np.full((h, w), UNSEEDED, np.int32)
    conflict = np.zeros((h, w), bool)

    def paint(rows, cols, label):
        cur = seeds[rows, cols]
        clash = (cur != UNSEEDED) & (cur != label)
        conflict[rows[clash], cols[clash]] = True
        seeds[rows, cols] = label

    for i, region in enumerate(ann.regions):
        for s in region.scribbles:
            paint(*polyline_pixels(s, (h, w), radius=radius), i)
        if region.pixels is not None and len(region.pixels):
            paint(region.pixels[:, 1], region.pixels[:, 0], i)
    if include_background:
        for s in ann.background:
            paint(*polyline_pixels(s, (h, w), radius=radius), BACKGROUND)
        if ann.background_pixels is not None and len(ann.background_pixels):
            paint(ann.background_pixels[:, 1], ann.background_pixels[:, 0], BACKGROUND)
    seeds[conflict] = UNSEEDED
    return seeds


def load_scribble_layer(path, size, *, legend=None):
    """Read a scribble PNG layer into regions.

    Parameters
    ----------
    path : str or pathlib.Path
        RGBA PNG of the drawing's size, transparent except strokes. Pixels
        with alpha below 128 are ignored (antialiased stroke edges); every other
        pixel's RGB is its region's colour.
    size : (int, int)
        ``(width, height)`` the layer must have.
    legend : dict or str or pathlib.Path, optional
        ``{"#rrggbb": "name"}`` (or a JSON file of it). The name
        ``"background"`` marks background strokes. Without a legend a region is
        named ``region_rrggbb`` and no colour is background.

    Returns
    -------
    regions : list of Region
        One per colour, in order of first appearance in raster order, with
        ``pixels`` set and no polyline scribbles.
    background_pixels : (n, 2) int array
        ``[x, y]`` of background strokes (possibly empty).

    Raises
    ------
    InputError
        Wrong size, unreadable file, bad legend, or a colour missing from the legend.
    """
    path, _ = regular_file(path, "scribble layer")
    legend = _read_legend(legend)
    try:
        image = Image.open(path)
        # The header's size is checked before decoding: the drawing bounds it.
        if image.size != tuple(size):
            raise InputError(f"{path}: scribble layer is {image.size[0]}x{image.size[1]} "
                             f"but the drawing is {size[0]}x{size[1]}")
        image.load()
    except InputError:
        raise
    except Exception as e:  # Pillow raises many types on corrupt files
        raise InputError(f"{path}: not a readable image ({type(e).__name__}: "
                         f"{str(e) or 'corrupt data'})") from None
    rgba = np.asarray(image.convert("RGBA"))
    ys, xs = np.nonzero(rgba[:, :, 3] >= 128)
    if len(ys) == 0:
        raise InputError(f"{path}: the scribble layer has no opaque stroke pixels")
    rgb = rgba[ys, xs, :3].astype(np.int64)
    code = (rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2]
    colours, first = np.unique(code, return_index=True)
    regions, background = [], np.zeros((0, 2), np.int64)
    for colour in colours[np.argsort(first)]:
        hexcode = f"#{colour:06x}"
        sel = code == colour
        pixels = np.stack([xs[sel], ys[sel]], axis=1).astype(np.int64)
        if legend is None:
            name = f"region_{hexcode[1:]}"
        elif hexcode in legend:
            name = legend[hexcode]
        else:
            y, x = int(pixels[0, 1]), int(pixels[0, 0])
            raise InputError(f"{path}: colour {hexcode} at pixel ({x}, {y}) is not in the legend")
        if name == "background":
            background = np.concatenate([background, pixels])
        else:
            regions.append(Region(name=name, scribbles=[], pixels=pixels))
    return regions, background


def _read_legend(legend):
    if legend is None or isinstance(legend, dict):
        data, where = legend, "legend"
    else:
        where = str(legend)
        raw = read_bytes(legend, "legend file", limit=_LEGEND_BYTES)
        try:
            data = json.loads(raw.decode("utf-8"))
        except (ValueError, RecursionError) as e:
            raise InputError(f"{where}: not a JSON legend ({e})") from None
    if data is None:
        return None
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected an object {{\"#rrggbb\": \"name\"}}")
    out = {}
    for k, v in data.items():
        if not (isinstance(k, str) and _HEX.fullmatch(k)):
            raise InputError(f"{where}.{k}: expected a colour key like \"#ff0000\"")
        if not (isinstance(v, str) and re.fullmatch(r"[A-Za-z0-9_-]+", v)):
            raise InputError(f"{where}.{k}: expected a region name (letters, digits, '_', '-')")
        out[k.lower()] = v
    return out
