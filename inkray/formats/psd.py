"""Photoshop documents (.psd) of cut-out stacks, through psd-tools.

A PSD file (Adobe Photoshop File Formats Specification) holds one pixel
layer per part of a cut-out stack (:mod:`inkray.relief.cutout`), bottom
first, each with its own position and transparency, and the flattened image
as the document's composite, as Photoshop, Krita, GIMP, Affinity and the
cut-out animation tools that import PSD (Live2D Cubism, Spine's PSD script,
Toon Boom, Inochi2D) read it. Writing and reading go through ``psd-tools``.
"""

import io
from pathlib import Path

import numpy as np

from inkray.errors import InputError
from inkray.relief.cutout import Cutout, CutoutLayer

__all__ = ["psd_bytes", "read_psd"]

_NAME_MAX = 255  # characters of a layer name


def psd_bytes(cutout):
    """The PSD file of a cut-out stack, as bytes (RGB with transparency, 8 bits, RLE layers,
    the flattened stack as the merged image with its transparency).

    Parameters
    ----------
    cutout : inkray.relief.cutout.Cutout

    Returns
    -------
    bytes

    Examples
    --------
    >>> from inkray.relief.cutout import Cutout, CutoutLayer
    >>> px = np.full((2, 2, 4), 255, np.uint8)
    >>> psd_bytes(Cutout([CutoutLayer("a", 0, 1, 1, px, np.zeros((2, 2), bool))], (4, 3)))[:4]
    b'8BPS'
    """
    from PIL import Image
    from psd_tools import PSDImage
    from psd_tools.api.layers import PixelLayer

    # An RGB document with a transparency channel: layers keep their alpha as
    # transparency (in an "RGB" one psd-tools would turn it into layer masks).
    document = PSDImage.new("RGBA", tuple(int(s) for s in cutout.size))
    for layer in cutout.layers:  # appended bottom first
        if len(layer.name) > _NAME_MAX:
            raise InputError(f"layer {layer.name[:40]!r}...: name longer than PSD's "
                             f"{_NAME_MAX} characters (write .ora instead)")
        added = PixelLayer.frompil(Image.fromarray(layer.rgba, "RGBA"), document,
                                   top=int(layer.top), left=int(layer.left))
        # The name property keeps any name in the Unicode name block (and a
        # legacy Mac Roman name beside it), which frompil's argument does not.
        added.name = layer.name
    # The composite over nothing (not over new()'s black), its alpha flagged as transparency
    # as Photoshop does: a negative layer count says the first extra channel of the merged
    # image is its transparency (GIMP, ImageMagick and thumbnailers read it so; otherwise
    # GIMP shows an "Extra" channel and previews show the character on black).
    document.background_color = None
    info = document._record.layer_and_mask_information.layer_info
    info.layer_count = -abs(info.layer_count)
    buf = io.BytesIO()
    document.save(buf)
    return buf.getvalue()


def read_psd(path):
    """Read a PSD file's pixel layers (bottom first) and size with psd-tools.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    inkray.relief.cutout.Cutout
        Layers with ``region`` None and ``hidden`` None (a file does not say).

    Raises
    ------
    InputError
        Not a PSD file psd-tools can read.
    """
    from psd_tools import PSDImage

    path = Path(path)
    try:
        document = PSDImage.open(path)
        layers = []
        for layer in document.descendants():
            if layer.kind != "pixel":
                continue
            image = layer.topil()
            rgba = np.asarray(image.convert("RGBA")) if image is not None else np.zeros((0, 0, 4),
                                                                                     np.uint8)
            layers.append(CutoutLayer(name=layer.name, region=None, top=int(layer.top),
                                      left=int(layer.left), rgba=rgba, hidden=None))
    except (OSError, ValueError, AssertionError) as e:
        raise InputError(f"{path}: unreadable PSD file ({type(e).__name__}: {e})") from None
    return Cutout(layers=layers, size=(int(document.width), int(document.height)))
