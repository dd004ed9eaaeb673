"""Label images: the segmentation as an indexed PNG with a JSON legend.

``inkray segment`` writes ``NAME.png``, an 8-bit palette ("P") PNG when there
are at most 255 regions (RGB otherwise), whose index 0 is the background and
index ``i + 1`` region ``i``, and ``NAME.json``, the legend::

    {"format": "inkray-labels", "version": 1, "image": "NAME.png",
     "size": [W, H],
     "background": {"label": -1, "index": 0, "colour": "#ffffff", "pixels": N},
     "regions": {"head": {"label": 0, "index": 1, "colour": "#e6194b", "pixels": N}, ...},
     "warnings": [...]}

Labels are those of LazyBrush (Sýkora, Dingliana, Collins, CGF 2009): ``-1``
background, ``i`` the annotation's ``regions[i]``.
"""

import io
import json
from pathlib import Path

import numpy as np

from inkray.errors import InputError
from inkray.formats.atomic import atomic_outputs

__all__ = ["label_palette", "label_image", "labels_png", "labels_legend", "write_labels", "label_files",
           "read_labels"]


def label_palette(n):
    """Colours of a label image: white background, then ``n`` distinct regions.

    Parameters
    ----------
    n : int
        Number of regions.

    Returns
    -------
    (n + 1, 3) uint8 array
        Row 0 is the background (white), row ``i + 1`` region ``i``: 20 hand
        picked distinguishable colours, then golden-angle hues.

    Examples
    --------
    >>> label_palette(2).tolist()
    [[255, 255, 255], [230, 25, 75], [60, 180, 75]]
    """
    out = np.zeros((n + 1, 3), np.uint8)
    out[0] = 255
    for i in range(n):
        if i < len(_COLOURS):
            out[i + 1] = [int(_COLOURS[i][k:k + 2], 16) for k in (1, 3, 5)]
        else:
            import colorsys

            hue = (i * 0.618033988749895) % 1.0
            light = 0.45 + 0.15 * ((i // 7) % 2)
            out[i + 1] = np.round(np.array(colorsys.hls_to_rgb(hue, light, 0.75)) * 255)
    return out


# Sasha Trubetskoy's 20 distinct colours (white omitted: it is the background).
_COLOURS = ("#e6194b", "#3cb44b", "#4363d8", "#f58231", "#911eb4", "#42d4f4", "#f032e6",
            "#bfef45", "#fabed4", "#469990", "#dcbeff", "#9a6324", "#fffac8", "#800000",
            "#aaffc3", "#808000", "#ffd8b1", "#000075", "#a9a9a9", "#000000")


def label_image(labels, n):
    """The label image as a PIL image: indexed when the palette fits 256 entries.

    Parameters
    ----------
    labels : (H, W) int array
        ``-1`` background, ``0..n-1`` regions.
    n : int
        Number of regions.

    Returns
    -------
    PIL.Image.Image

    Examples
    --------
    >>> import numpy as np
    >>> im = label_image(np.array([[-1, 0, 1]]), 2)
    >>> im.mode, np.asarray(im).tolist()
    ('P', [[0, 1, 2]])
    """
    from PIL import Image

    palette = label_palette(n)
    index = np.asarray(labels) + 1
    if len(palette) <= 256:
        image = Image.fromarray(index.astype(np.uint8))
        image.putpalette(palette.ravel().tolist())
        return image
    return Image.fromarray(palette[index])


def labels_png(segmentation):
    """The label PNG of a segmentation, as bytes.

    Parameters
    ----------
    segmentation : inkray.segmentation.Segmentation

    Returns
    -------
    bytes
    """
    buf = io.BytesIO()
    label_image(segmentation.labels, len(segmentation.names)).save(buf, format="PNG")
    return buf.getvalue()


def labels_legend(segmentation, image_name):
    """The legend (a JSON-ready dict) of a label PNG called ``image_name``.

    Parameters
    ----------
    segmentation : inkray.segmentation.Segmentation
    image_name : str

    Returns
    -------
    dict
    """
    labels, names = segmentation.labels, segmentation.names
    palette = label_palette(len(names))
    hexes = [f"#{r:02x}{g:02x}{b:02x}" for r, g, b in palette.tolist()]
    counts = np.bincount((labels + 1).ravel(), minlength=len(palette))
    return {
        "format": "inkray-labels", "version": 1, "image": image_name,
        "size": [int(labels.shape[1]), int(labels.shape[0])],
        "background": {"label": -1, "index": 0, "colour": hexes[0], "pixels": int(counts[0])},
        "regions": {name: {"label": i, "index": i + 1, "colour": hexes[i + 1],
                           "pixels": int(counts[i + 1])} for i, name in enumerate(names)},
        "warnings": list(segmentation.warnings),
    }


def label_files(path):
    """The label PNG and its legend that :func:`write_labels` writes for ``path``.

    Examples
    --------
    >>> [p.name for p in label_files("labels.png")]
    ['labels.png', 'labels.json']
    """
    png = Path(path)
    return [png, png.with_suffix(".json")]


def write_labels(segmentation, path, *, npy=None, outputs=None):
    """Write ``path`` (the label PNG), its legend ``path.with_suffix('.json')`` and an optional ``.npy``.

    Parameters
    ----------
    segmentation : inkray.segmentation.Segmentation
    path : str or pathlib.Path
    npy : str or pathlib.Path, optional
        The labels as an int32 array (-1 background).
    outputs : optional
        An open :func:`inkray.formats.atomic.atomic_outputs` group to join.

    Returns
    -------
    list of pathlib.Path
    """
    if outputs is None:
        with atomic_outputs() as group:
            return write_labels(segmentation, path, npy=npy, outputs=group)
    png, legend = label_files(path)
    outputs.write_bytes(png, labels_png(segmentation))
    outputs.write_text(legend, json.dumps(labels_legend(segmentation, png.name), indent=2,
                                          ensure_ascii=False) + "\n")
    written = [png, legend]
    if npy is not None:
        outputs.write_with(npy, lambda f: np.save(f, segmentation.labels.astype(np.int32)))
        written.append(Path(npy))
    return written


def read_labels(path):
    """Read a label PNG and its legend back.

    Parameters
    ----------
    path : str or pathlib.Path
        The PNG; its legend is beside it (``.json``).

    Returns
    -------
    labels : (H, W) int32 array
        ``-1`` background, ``i`` region ``i``.
    names : list of str

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from inkray.segmentation import Segmentation
    >>> seg = Segmentation(labels=np.array([[-1, 0, 1]], np.int32), names=["a", "b"], warnings=[])
    >>> p = write_labels(seg, pathlib.Path(tempfile.mkdtemp()) / "l.png")[0]
    >>> labels, names = read_labels(p)
    >>> labels.tolist(), names
    ([[-1, 0, 1]], ['a', 'b'])
    """
    from PIL import Image

    png = Path(path)
    try:
        legend = json.loads(png.with_suffix(".json").read_text(encoding="utf-8"))
        names = sorted(legend["regions"], key=lambda n: legend["regions"][n]["index"])
        with Image.open(png) as im:
            if im.mode == "P":
                labels = np.asarray(im).astype(np.int32) - 1
            else:
                rgb = np.asarray(im.convert("RGB")).astype(np.int64)
                code = (rgb[..., 0] << 16) | (rgb[..., 1] << 8) | rgb[..., 2]
                palette = label_palette(len(names)).astype(np.int64)
                keys = (palette[:, 0] << 16) | (palette[:, 1] << 8) | palette[:, 2]
                lookup = {int(k): i - 1 for i, k in enumerate(keys)}
                labels = np.vectorize(lookup.get, otypes=[np.int32])(code)
    except (OSError, KeyError, ValueError, TypeError) as e:
        raise InputError(f"{png}: not an inkray label image ({type(e).__name__}: {e})") from None
    return labels, names
