"""16-bit depth PNGs: one convention for the 2010 depth maps and relief renders.

A depth PNG is 16-bit greyscale: ``0`` where there is no surface
(background), ``1`` the farthest and ``65535`` the nearest depth, linear in
between. The text chunk ``inkray:depth`` holds the range as JSON,
``{"background": 0, "far": [1, depth_min], "near": [65535, depth_max],
"units": ...}``, so that ``depth = depth_min + (value - 1) * scale`` with
``scale = (depth_max - depth_min) / 65534``. Depth grows toward the viewer
(Sýkora et al., CGF 2010; Ink-and-Ray, TOG 2014).

``inkray depth`` writes a sidecar ``NAME.json`` beside the PNG with the same
range (``depth_min``, ``depth_max``, ``scale``), the method and its
diagnostics.
"""

import io
import json
from pathlib import Path

import numpy as np

from inkray.errors import InputError
from inkray.formats.atomic import atomic_outputs
from inkray.numerics.quantization import dequantize16, quantize16
from inkray.view.shading import encode_normals, height_normals, lambert

__all__ = ["depth_png", "codes_png", "read_depth_png", "write_depth_outputs", "depth_files", "depth_normals",
           "shaded_preview"]

_TOP = 65535


def depth_png(depth, mask=None, *, units="depth units", compress_level=6):
    """Encode a depth map as a 16-bit PNG with its range in the ``inkray:depth`` chunk.

    Parameters
    ----------
    depth : (H, W) float array
    mask : (H, W) bool array, optional
        Where there is a surface (default everywhere).
    units : str, default "depth units"
        Recorded in the text chunk.
    compress_level : int, default 6
        zlib level 0-9: the editor's previews take 1 (about half the
        encoding time, larger files, the same decoded values).

    Returns
    -------
    png : bytes
    meta : dict
        ``{"depth_min", "depth_max", "scale"}``: ``depth = depth_min + (value - 1) * scale``.

    Examples
    --------
    >>> import numpy as np
    >>> png, meta = depth_png(np.array([[0.0, 2.0]]))
    >>> meta["depth_max"], png[:4] == b"\\x89PNG"
    (2.0, True)
    """
    codes, (lo, hi) = quantize16(depth, mask)
    png = codes_png(codes, (lo, hi), units=units, compress_level=compress_level)
    return png, {"depth_min": lo, "depth_max": hi, "scale": (hi - lo) / (_TOP - 1)}


def codes_png(codes, depth_range, *, units="depth units", compress_level=6):
    """A depth PNG of codes already quantized by :func:`inkray.numerics.quantization.quantize16`.

    Parameters
    ----------
    codes : (H, W) uint16 array
    depth_range : (float, float)
        The depths of codes 1 and 65535.
    units : str, default "depth units"
    compress_level : int, default 6
        zlib level 0-9.

    Returns
    -------
    bytes
    """
    from PIL import Image
    from PIL.PngImagePlugin import PngInfo

    lo, hi = (float(x) for x in depth_range)
    info = PngInfo()
    info.add_text("inkray:depth", json.dumps(
        {"background": 0, "far": [1, lo], "near": [_TOP, hi], "units": units}))
    buf = io.BytesIO()
    Image.fromarray(np.asarray(codes, np.uint16)).save(buf, format="PNG", pnginfo=info,
                                                   compress_level=compress_level)
    return buf.getvalue()


def read_depth_png(path):
    """Read a depth PNG written by :func:`depth_png`.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    depth : (H, W) float64 array
        NaN where there is no surface.
    meta : dict
        The ``inkray:depth`` record.

    Raises
    ------
    InputError
        Not a 16-bit PNG with an ``inkray:depth`` record.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "d.png"
    >>> _ = p.write_bytes(depth_png(np.array([[1.0, 3.0]]))[0])
    >>> read_depth_png(p)[0].tolist()
    [[1.0, 3.0]]
    """
    from PIL import Image

    path = Path(path)
    try:
        with Image.open(path) as im:
            codes = np.asarray(im)
            meta = json.loads(im.text["inkray:depth"])
            value_range = (float(meta["far"][1]), float(meta["near"][1]))
    except (OSError, KeyError, ValueError, TypeError, IndexError) as e:
        raise InputError(f"{path}: not an inkray depth PNG ({type(e).__name__}: {e})") from None
    return dequantize16(codes, value_range), meta


def depth_normals(depth_map, *, relief=0.1):
    """Normals of a depth map whose whole range is ``relief`` times its longer side.

    A depth map has no pixel scale of its own; this one makes its slopes
    visible at any depth step.

    Parameters
    ----------
    depth_map : (H, W) float array
    relief : float, default 0.1

    Returns
    -------
    (H, W, 3) float64 array
        Unit normals ``(x right, y up, z toward the viewer)``.

    Examples
    --------
    >>> import numpy as np
    >>> depth_normals(np.zeros((4, 4)))[0, 0].tolist()
    [0.0, 0.0, 1.0]
    """
    d = np.asarray(depth_map, np.float64)
    span = float(d.max() - d.min())
    return height_normals(d * (relief * max(d.shape) / span) if span > 0 else np.zeros_like(d))


def shaded_preview(depth_map, drawing=None, *, light=(-1.0, 1.0, 1.5), ambient=0.15, relief=0.1):
    """Lambert-shaded preview of a depth map, with the drawing's ink on top.

    Parameters
    ----------
    depth_map : (H, W) float array
    drawing : Drawing or (H, W) / (H, W, 3) array, optional
        Multiplied onto the shading (ink stays dark).
    light : 3-tuple, default (-1, 1, 1.5)
        Direction toward the light (x right, y up, z toward the viewer).
    ambient : float, default 0.15
    relief : float, default 0.1
        See :func:`depth_normals`.

    Returns
    -------
    (H, W, 3) uint8 array

    Examples
    --------
    >>> import numpy as np
    >>> img = shaded_preview(np.zeros((2, 2)))
    >>> img.shape, bool((img == img[0, 0]).all())
    ((2, 2, 3), True)
    """
    shade = lambert(depth_normals(depth_map, relief=relief), light=light, ambient=ambient)
    img = np.repeat(shade[:, :, None], 3, axis=2)
    if drawing is not None:
        tex = np.asarray(getattr(drawing, "rgb", drawing), np.float64)
        tex = tex / 255.0 if tex.max(initial=0) > 1.0 else tex
        img = img * (tex[:, :, None] if tex.ndim == 2 else tex)
    return np.round(np.clip(img, 0, 1) * 255).astype(np.uint8)


def depth_files(output):
    """The depth PNG and its sidecar that :func:`write_depth_outputs` writes for ``output``.

    Examples
    --------
    >>> [p.name for p in depth_files("depth.png")]
    ['depth.png', 'depth.json']
    """
    output = Path(output)
    return [output, output.with_suffix(".json")]


def write_depth_outputs(result, output, *, npy=None, normals=None, shading=None, drawing=None,
                        outputs=None):
    """Write a depth map result: all files together or none.

    Parameters
    ----------
    result : inkray.depthmap.estimation.DepthResult
    output : str or pathlib.Path
        The 16-bit PNG; a sidecar ``<stem>.json`` beside it holds the range,
        the method and epsilon (and the KKT residuals for the exact method).
    npy, normals, shading : str or pathlib.Path, optional
        Float depth (``.npy``), normal map PNG, shaded preview PNG.
    drawing : Drawing, optional
        Ink for the shaded preview.
    outputs : optional
        An open :func:`inkray.formats.atomic.atomic_outputs` group to join.

    Returns
    -------
    list of pathlib.Path
        The files written.
    """
    from PIL import Image

    if outputs is None:
        with atomic_outputs() as group:
            return write_depth_outputs(result, output, npy=npy, normals=normals, shading=shading,
                                       drawing=drawing, outputs=group)
    output, sidecar = depth_files(output)
    png, meta = depth_png(result.depth)
    doc = {"depth_min": meta["depth_min"], "depth_max": meta["depth_max"],
           "scale": meta["scale"],
           "encoding": "16-bit: depth = depth_min + (value - 1) * scale; 0 = no surface",
           "method": result.method, "epsilon": result.epsilon}
    if result.method == "exact":
        doc["kkt"] = result.info.get("kkt", {})
        doc["objective"] = result.info.get("objective")
        doc["sigma"] = result.info.get("sigma")
    written = [output, sidecar]
    outputs.write_bytes(output, png)
    outputs.write_text(sidecar, json.dumps(doc, indent=2) + "\n")
    if npy is not None:
        outputs.write_with(npy, lambda f: np.save(f, result.depth))
        written.append(Path(npy))
    if normals is not None:
        image = Image.fromarray(encode_normals(depth_normals(result.depth)))
        outputs.write_with(normals, lambda f: image.save(f, format="PNG"))
        written.append(Path(normals))
    if shading is not None:
        preview = Image.fromarray(shaded_preview(result.depth, drawing))
        outputs.write_with(shading, lambda f: preview.save(f, format="PNG"))
        written.append(Path(shading))
    return written
