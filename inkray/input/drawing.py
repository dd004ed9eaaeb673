"""Loading line drawings: PNG, JPG and SVG, colour or grey, scanned or photographed.

Every drawing becomes a grey image in [0, 1] with white paper (1) and dark ink,
the form every later stage assumes (LazyBrush, Sýkora et al. CGF 2009, cuts
along dark pixels). Transparent pixels are composited on white. Photographed
paper with uneven shading is flattened by dividing by an estimate of the paper
brightness (a grey closing over a window much larger than a stroke, i.e. a
local maximum filter that removes the ink and keeps the illumination).
"""

import io
import re
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from inkray.errors import InputError
from inkray.input.files import read_bytes, regular_file
from inkray.input.limits import DEFAULT_LIMITS

__all__ = ["Drawing", "load_drawing", "drawing_from_array", "flatten_paper"]

_RASTER = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp"}


@dataclass
class Drawing:
    """A loaded drawing.

    Attributes
    ----------
    gray : (H, W) float32 array
        Normalized intensity: paper 1, ink near 0.
    rgb : (H, W, 3) uint8 array
        The original colours composited on white (the texture).
    path : pathlib.Path or None
    """

    gray: np.ndarray
    rgb: np.ndarray
    path: Path = None

    @property
    def size(self):
        """``(width, height)`` in pixels."""
        return (self.gray.shape[1], self.gray.shape[0])


def load_drawing(path, *, normalize=True, svg_width=None, limits=DEFAULT_LIMITS):
    """Load a drawing from a PNG, JPG or SVG file.

    The image size is read from the file's header (for SVG, from the root
    element) and checked against ``limits.pixels`` before anything is decoded
    or rasterized, so an oversized file costs nothing.

    Parameters
    ----------
    path : str or pathlib.Path
    normalize : bool, default True
        Flatten uneven paper shading (see :func:`flatten_paper`).
    svg_width : int, optional
        Raster width for SVG input; by default the SVG's own size.
    limits : inkray.input.limits.Limits, optional
        Bounds on the pixel count (and, for SVG, the file size).

    Returns
    -------
    Drawing

    Raises
    ------
    InputError
        Missing or not a regular file, unknown format, an image over the
        pixel limit, or an unreadable image.

    Examples
    --------
    >>> d = load_drawing("examples/turtle/drawing.png")  # doctest: +SKIP
    >>> d.size  # doctest: +SKIP
    (512, 512)
    """
    path, _ = regular_file(path, "drawing file")
    suffix = path.suffix.lower()
    if suffix == ".svg":
        image = _rasterize_svg(path, svg_width, limits)
    elif suffix in _RASTER:
        image = _decode_raster(path, limits)
    else:
        raise InputError(f"{path}: unsupported drawing format {suffix!r} "
                         f"(expected PNG, JPG, TIFF, BMP, WebP or SVG)")
    drawing = drawing_from_array(_to_rgb_on_white(image), normalize=normalize)
    drawing.path = path
    return drawing


def drawing_from_array(image, *, normalize=True):
    """Make a :class:`Drawing` from an array.

    Parameters
    ----------
    image : (H, W) or (H, W, 3) array
        Grey or RGB; uint8 in [0, 255] or float in [0, 1].
    normalize : bool, default True
        Flatten uneven paper shading.

    Returns
    -------
    Drawing

    Examples
    --------
    >>> import numpy as np
    >>> d = drawing_from_array(np.full((8, 8), 255, np.uint8))
    >>> float(d.gray.min())
    1.0
    """
    a = np.asarray(image)
    if a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[2] not in (3, 4)):
        raise InputError(f"drawing: expected an (H, W) or (H, W, 3) image, got shape {a.shape}")
    if a.dtype.kind == "f":
        a = np.clip(np.round(a * 255), 0, 255).astype(np.uint8)
    a = a.astype(np.uint8, copy=False)
    if a.ndim == 2:
        a = np.repeat(a[:, :, None], 3, axis=2)
    rgb = np.ascontiguousarray(a[:, :, :3])
    gray = (rgb.astype(np.float32) @ np.array([0.299, 0.587, 0.114], np.float32)) / 255.0
    if normalize:
        gray = flatten_paper(gray)
    return Drawing(gray=gray.astype(np.float32), rgb=rgb)


def flatten_paper(gray, *, window=None):
    """Divide out uneven paper brightness so paper becomes 1.

    Parameters
    ----------
    gray : (H, W) float array in [0, 1]
    window : int, optional
        Side of the closing window in pixels; default an eighth of the shorter
        side (at least 31), far wider than a stroke, so only the illumination
        survives the closing.

    Returns
    -------
    (H, W) float32 array in [0, 1]

    Notes
    -----
    A clean digital drawing (paper exactly white) is returned unchanged. The
    paper estimate is computed on a downsampled copy and smoothed, so the cost
    is a few milliseconds even at several megapixels.
    """
    from scipy import ndimage

    g = np.asarray(gray, np.float32)
    h, w = g.shape
    if window is None:
        window = max(31, min(h, w) // 8)
    step = max(1, window // 16)
    small = g[: h - h % step or h, : w - w % step or w]
    small = small.reshape(small.shape[0] // step, step, small.shape[1] // step, step).max(axis=(1, 3))
    k = max(3, window // step)
    paper = ndimage.grey_closing(small, size=(k, k), mode="nearest")
    paper = ndimage.uniform_filter(paper, size=k, mode="nearest")
    zoom = (h / paper.shape[0], w / paper.shape[1])
    paper = ndimage.zoom(paper, zoom, order=1, mode="nearest", grid_mode=True)[:h, :w]
    if paper.shape != g.shape:
        paper = np.pad(paper, ((0, h - paper.shape[0]), (0, w - paper.shape[1])), mode="edge")
    # Paper darker than 0.25 is not paper but a big dark fill; leave it alone.
    paper = np.clip(paper, 0.25, 1.0)
    if float(paper.min()) >= 0.999:
        return g
    return np.clip(g / paper, 0.0, 1.0).astype(np.float32)


def _decode_raster(path, limits):
    try:
        with warnings.catch_warnings():  # a corrupt file errs below or decodes; no noise
            warnings.simplefilter("ignore")
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            image = Image.open(path)
            limits.check_pixels(image.size, str(path))
            image.load()
    except InputError:
        raise
    except Image.DecompressionBombError as e:  # Pillow's own bound, met before ours
        n = re.search(r"\((\d+) pixels\)", str(e))
        raise InputError(f"{path}: {n.group(1) if n else 'too many'} pixels exceeds the limit of "
                         f"{limits.pixels}", fix=("raise it with {}", "limits.pixels")) from None
    except Exception as e:  # Pillow raises many types on corrupt or hostile files
        raise InputError(f"{path}: not a readable image ({type(e).__name__}: "
                         f"{str(e) or 'corrupt data'})") from None
    return image


# CSS absolute units in px (96 dpi), as SVG renderers resolve them.
_UNITS = {"": 1.0, "px": 1.0, "pt": 4 / 3, "pc": 16.0, "mm": 96 / 25.4, "cm": 96 / 2.54,
          "in": 96.0, "q": 96 / 101.6, "em": 16.0, "ex": 8.0}
_LENGTH = re.compile(r"\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*([a-zA-Z]*)\s*")


def _svg_length(value):
    m = _LENGTH.fullmatch(value or "")
    if not m or m.group(2).lower() not in _UNITS:
        return None
    return float(m.group(1)) * _UNITS[m.group(2).lower()]


def _svg_size(path, data):
    """The raster size an SVG declares on its root element, without rendering it."""
    try:
        parser = ET.XMLPullParser(events=("start",))
        parser.feed(data)
        root = next((el for _, el in parser.read_events()), None)
    except ET.ParseError as e:
        raise InputError(f"{path}: cannot rasterize SVG (not XML: {e})") from None
    if root is None or not root.tag.endswith("svg"):
        raise InputError(f"{path}: cannot rasterize SVG (the root element is not <svg>)")
    box = [_svg_length(v) for v in re.split(r"[\s,]+", (root.get("viewBox") or "").strip())]
    box = box[2:] if len(box) == 4 and None not in box else [None, None]
    w, h = _svg_length(root.get("width")), _svg_length(root.get("height"))
    w, h = (w if w is not None else box[0]), (h if h is not None else box[1])
    return w, h


def _rasterize_svg(path, width, limits):
    data = read_bytes(path, "drawing file", limit=limits.file_bytes)
    w, h = _svg_size(path, data)
    if w is not None and h is not None:
        if not (np.isfinite(w) and np.isfinite(h) and w > 0 and h > 0):
            raise InputError(f"{path}: the SVG's size {w}x{h} is not a positive size")
        if width is not None:
            w, h = width, h * width / w
        limits.check_pixels((min(np.ceil(w), 1e12), min(np.ceil(h), 1e12)), str(path))
    try:
        import cairosvg
    except (ImportError, OSError) as e:  # OSError: the cairo library is missing
        raise InputError(f"{path}: SVG input needs cairosvg and the cairo library ({e})") from None
    try:
        # Not ``unsafe``: no external files or entities are fetched.
        png = cairosvg.svg2png(bytestring=data, output_width=width, background_color="white")
    except Exception as e:  # cairosvg raises many types on malformed SVG
        raise InputError(f"{path}: cannot rasterize SVG ({type(e).__name__}: {e})") from None
    image = Image.open(io.BytesIO(png))
    limits.check_pixels(image.size, str(path))
    return image


def _to_rgb_on_white(image):
    if image.mode in ("I;16", "I;16B", "I;16L", "I", "F"):
        a = np.asarray(image, np.float64)
        a = np.where(np.isfinite(a), a, 0.0)
        top = float(a.max(initial=0.0))
        # Float images are usually in [0, 1]; integer ones in 8 or 16 bits.
        scale = 1.0 if image.mode == "F" and top <= 1.0 else 255.0 if top <= 255 else 65535.0
        a = a / scale
        return np.clip(np.round(a * 255), 0, 255).astype(np.uint8)
    if image.mode == "P" or image.mode == "LA" or "A" in image.getbands() or "transparency" in image.info:
        image = image.convert("RGBA")
    if image.mode == "RGBA":
        a = np.asarray(image, np.float32)
        alpha = a[:, :, 3:4] / 255.0
        rgb = a[:, :, :3] * alpha + 255.0 * (1.0 - alpha)
        return np.clip(np.round(rgb), 0, 255).astype(np.uint8)
    return np.asarray(image.convert("RGB"))
