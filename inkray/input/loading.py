"""The input edge: an annotation file, its drawing and an optional scribble
layer, loaded and checked against each other."""

from dataclasses import replace
from pathlib import Path

import numpy as np

from inkray.input.annotations import load_annotations, rescale_annotations
from inkray.errors import InputError
from inkray.input.drawing import load_drawing
from inkray.input.limits import DEFAULT_LIMITS
from inkray.input.scribbles import load_scribble_layer

__all__ = ["load_input"]


def load_input(annotation, *, drawing=None, rescale=False, scribble_layer=None, legend=None,
               normalize=True, limits=DEFAULT_LIMITS):
    """Load an annotation file and the drawing it refers to.

    Parameters
    ----------
    annotation : str or pathlib.Path
        The ``.inkray.json`` file.
    drawing : str or pathlib.Path, optional
        Overrides the file's ``drawing`` key.
    rescale : bool, default False
        When the drawing's size differs from the annotation's ``size``, scale
        the annotation to it instead of failing.
    scribble_layer : str or pathlib.Path, optional
        A scribble PNG layer whose colours add regions (see
        :func:`inkray.input.scribbles.load_scribble_layer`).
    legend : dict or path, optional
        Colour-to-name legend for ``scribble_layer``.
    normalize : bool, default True
        Flatten uneven paper shading of the drawing.
    limits : inkray.input.limits.Limits, optional
        Bounds on pixels, points, entries and file sizes, checked before any
        heavy work.

    Returns
    -------
    annotations : Annotations
    drawing : Drawing

    Raises
    ------
    InputError
        Anything wrong with the files or their agreement.
    """
    ann = load_annotations(annotation, limits=limits)
    path = Path(drawing) if drawing is not None else ann.drawing
    if path is None:
        raise InputError(f"{annotation}: drawing: no drawing given",
                         fix=("add a \"drawing\" key or pass {}", "drawing"))
    image = load_drawing(path, normalize=normalize, limits=limits)
    if image.size != ann.size:
        if not rescale:
            raise InputError(
                f"size: the annotation is for a {ann.size[0]}x{ann.size[1]} drawing but {path} is "
                f"{image.size[0]}x{image.size[1]}", fix=("pass {} to scale the annotation", "rescale"))
        ann = rescale_annotations(ann, image.size)
    ann.drawing = path
    if scribble_layer is not None:
        regions, background = load_scribble_layer(scribble_layer, ann.size, legend=legend)
        names = {r.name for r in ann.regions}
        merged = list(ann.regions)
        for r in regions:
            if r.name in names:
                match = next(m for m in merged if m.name == r.name)
                extra = r.pixels if match.pixels is None else np.concatenate([match.pixels, r.pixels])
                merged[merged.index(match)] = replace(match, pixels=extra)
            else:
                merged.append(r)
                names.add(r.name)
        old = ann.background_pixels
        bg = background if old is None else np.concatenate([old, background])
        ann = replace(ann, regions=merged, background_pixels=bg)
    return ann, image
