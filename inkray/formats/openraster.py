"""OpenRaster (.ora): the open layered-image format of Krita, GIMP and MyPaint.

An OpenRaster file (OpenRaster specification 0.0.6, freedesktop.org) is a
ZIP archive whose first entry, stored uncompressed, is ``mimetype`` holding
``image/openraster``; ``stack.xml`` lists the layers top first, each a PNG
under ``data/`` placed at ``x``, ``y``; ``mergedimage.png`` is the flattened
image and ``Thumbnails/thumbnail.png`` a preview at most 256 px wide and
high. inkray writes a cut-out stack (:mod:`inkray.relief.cutout`) as one
layer per part, with fixed ZIP timestamps so that the same stack gives the
same bytes.
"""

import io
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np

from inkray.errors import InputError
from inkray.relief.cutout import Cutout, CutoutLayer

__all__ = ["ora_bytes", "read_ora"]

_MIMETYPE = b"image/openraster"
_EPOCH = (1980, 1, 1, 0, 0, 0)  # the ZIP format's earliest date: no clock in the file
_THUMBNAIL = 256


def ora_bytes(cutout):
    """The OpenRaster file of a cut-out stack, as bytes.

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
    >>> data = ora_bytes(Cutout([CutoutLayer("a", 0, 1, 1, px, np.zeros((2, 2), bool))], (4, 3)))
    >>> data[30:38 + 16]
    b'mimetypeimage/openraster'
    """
    from PIL import Image

    w, h = cutout.size
    root = ET.Element("image", {"version": "0.0.6", "w": str(w), "h": str(h),
                                "xres": "72", "yres": "72"})
    stack = ET.SubElement(root, "stack")
    files = []
    for k, layer in reversed(list(enumerate(cutout.layers))):  # stack.xml lists the top first
        src = f"data/layer{k:03d}.png"
        ET.SubElement(stack, "layer", {
            "name": layer.name, "src": src, "x": str(layer.left), "y": str(layer.top),
            "opacity": "1.000", "visibility": "visible", "composite-op": "svg:src-over"})
        files.append((src, _png(Image.fromarray(layer.rgba, "RGBA"))))
    merged = Image.fromarray(cutout.flatten(), "RGBA")
    thumb = merged.copy()
    thumb.thumbnail((_THUMBNAIL, _THUMBNAIL), Image.Resampling.LANCZOS)
    xml = ET.tostring(root, encoding="UTF-8", xml_declaration=True)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr(_entry("mimetype", zipfile.ZIP_STORED), _MIMETYPE)
        z.writestr(_entry("stack.xml"), xml)
        for name, data in files:
            z.writestr(_entry(name), data)
        z.writestr(_entry("mergedimage.png"), _png(merged))
        z.writestr(_entry("Thumbnails/thumbnail.png"), _png(thumb))
    return buf.getvalue()


def read_ora(path):
    """Read an OpenRaster file's layers (back to front) and size.

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
        Not an OpenRaster file, or a layer outside what the file holds.
    """
    from PIL import Image

    path = Path(path)
    try:
        with zipfile.ZipFile(path) as z:
            first = z.infolist()[0]
            if first.filename != "mimetype" or z.read(first).strip() != _MIMETYPE:
                raise InputError(f"{path}: not an OpenRaster file (no leading mimetype entry)")
            root = ET.fromstring(z.read("stack.xml"))
            size = (int(root.get("w")), int(root.get("h")))
            layers = []
            for node in reversed(root.find("stack").findall("layer")):
                with Image.open(io.BytesIO(z.read(node.get("src")))) as im:
                    rgba = np.asarray(im.convert("RGBA"))
                layers.append(CutoutLayer(name=node.get("name", ""), region=None,
                                          top=int(node.get("y", 0)), left=int(node.get("x", 0)),
                                          rgba=rgba, hidden=None))
    except (OSError, zipfile.BadZipFile, KeyError, ET.ParseError, ValueError, TypeError,
            AttributeError, IndexError) as e:
        raise InputError(f"{path}: unreadable OpenRaster file ({type(e).__name__}: {e})") from None
    return Cutout(layers=layers, size=size)


def _entry(name, compress=zipfile.ZIP_DEFLATED):
    info = zipfile.ZipInfo(name, date_time=_EPOCH)
    info.compress_type = compress
    info.external_attr = 0o644 << 16
    return info


def _png(image):
    buf = io.BytesIO()
    image.save(buf, format="PNG")
    return buf.getvalue()
