"""Silhouettes that carry the whole outline: part labels grown over their contour ink.

In Sýkora et al., "Ink-and-Ray: Bas-Relief Meshes for Adding Global
Illumination Effects to Hand-Drawn Characters" (TOG 2014) the drawing is
mapped onto the relief by planar texture coordinates, so whatever of the
drawing lies outside the meshes is lost in any other viewer. The segmentation
splits a contour stroke somewhere inside it, so the outer part of the strokes
between a character and the paper would fall off the meshes. Here every
background ink pixel that a part reaches through ink within one stroke width
joins the nearest such part: the part's silhouette moves to the outer edge of
its contour stroke, while seams between parts (no background there) stay
where the segmentation puts them. The part then takes one pixel of paper
beyond its strokes: its smoothed outline, which cuts the stair-steps' corners
by a fraction of a pixel, still passes outside the centres of the outer ink
pixels, also where a crisp stroke has no soft edge.
"""

import math

import numpy as np
from scipy.ndimage import binary_dilation, distance_transform_edt, maximum_filter, minimum_filter

from inkray.errors import InputError

__all__ = ["INK_LEVEL", "ink_pixels", "stroke_width", "grow_over_ink", "pad_ink_edge"]

#: Grey level (paper 1, ink 0) below which a pixel is ink.
INK_LEVEL = 0.5
_GAP = 3  # px: paper this close to another part stays paper (pad_ink_edge)


def ink_pixels(gray, *, level=INK_LEVEL):
    """Ink pixels of a normalized grey drawing.

    Parameters
    ----------
    gray : (H, W) float array
        Paper 1, ink near 0.
    level : float, default 0.5
        Grey level below which a pixel is ink (higher takes in more of the
        strokes' soft edges).

    Returns
    -------
    (H, W) bool array

    Examples
    --------
    >>> ink_pixels(np.array([[1.0, 0.2, 0.6]])).tolist()
    [[False, True, False]]
    """
    return np.asarray(gray) < level


def stroke_width(ink):
    """Typical width of the strokes (px): four times the mean ink depth.

    A stroke of width ``w`` has depths (distance of a pixel's centre to the
    paper, less half a pixel) spread evenly over ``(0, w / 2)``, so their
    mean is ``w / 4``. The deepest tenth is left out: solid blobs of ink
    (eyes, shadows) would rule it.

    Parameters
    ----------
    ink : (H, W) bool array

    Returns
    -------
    float
        At least 1.

    Examples
    --------
    >>> ink = np.zeros((20, 20), bool); ink[:, 8:12] = True
    >>> stroke_width(ink)
    4.0
    """
    ink = np.asarray(ink, bool)
    if not ink.any():
        return 1.0
    depth = distance_transform_edt(ink)[ink] - 0.5
    return max(1.0, 4.0 * float(depth[depth <= np.percentile(depth, 90)].mean()))


def grow_over_ink(labels, ink, *, width=None):
    """Labels with every part grown over the background ink of its contour strokes.

    Parameters
    ----------
    labels : (H, W) int array
        ``-1`` background, ``0..R-1`` parts (the segmentation).
    ink : (H, W) bool array
        The drawing's ink (:func:`ink_pixels`).
    width : float, optional
        How far (px, through ink) a part reaches into background ink; default
        1.5 :func:`stroke_width` plus one pixel.

    Returns
    -------
    (H, W) int32 array
        ``labels`` with the reached background ink pixels set to the nearest
        part; every other pixel unchanged.

    Raises
    ------
    InputError
        Arrays of different shapes or a non-positive ``width``.

    Examples
    --------
    >>> labels = np.full((1, 8), -1); labels[0, :3] = 0
    >>> ink = np.zeros((1, 8), bool); ink[0, 2:5] = True
    >>> grow_over_ink(labels, ink, width=3).tolist()
    [[0, 0, 0, 0, 0, -1, -1, -1]]
    """
    labels = np.asarray(labels)
    ink = np.asarray(ink, bool)
    if labels.shape != ink.shape:
        raise InputError(f"ink: expected the labels' shape {labels.shape}, got {ink.shape}")
    if width is None:
        width = 1.5 * stroke_width(ink) + 1.0
    if not width > 0:
        raise InputError(f"width: expected a positive width in px, got {width!r}")
    parts = labels >= 0
    free = ink & ~parts
    out = labels.astype(np.int32)
    if not free.any() or not parts.any():
        return out
    # Reached through ink: a dilation that only walks on background ink.
    reached = binary_dilation(parts, structure=np.ones((3, 3), bool),
                              iterations=int(math.ceil(width)), mask=parts | free) & free
    if reached.any():
        _, (iy, ix) = distance_transform_edt(~parts, return_indices=True)
        out[reached] = labels[iy[reached], ix[reached]]
    return out


def pad_ink_edge(labels, ink):
    """Labels with the paper pixels beside a part's strokes given to that part.

    An outline smoothed over the pixel stair-steps of a stroke's outer edge
    passes through the centres of the stair-steps' outer pixels (on a crisp
    stroke with no soft edge, those are ink): they would fall off the mesh.
    With one pixel of paper beyond the stroke the outline passes outside
    them. 8-neighbours, so that a diagonal edge gets a rim as even as a
    straight one.

    Parameters
    ----------
    labels : (H, W) int array
        ``-1`` background, ``0..R-1`` parts (after :func:`grow_over_ink`).
    ink : (H, W) bool array
        The strokes with their soft edges (:func:`ink_pixels`).

    Returns
    -------
    (H, W) int32 array
        ``labels`` with every background pixel that 8-touches ink of a part set
        to the nearest such part, unless another part is within 3 px of it
        (a narrow gap between two parts stays paper); every other pixel
        unchanged.

    Raises
    ------
    InputError
        Arrays of different shapes.

    Examples
    --------
    >>> labels = np.full((1, 6), -1); labels[0, :3] = 0
    >>> ink = np.zeros((1, 6), bool); ink[0, 2] = True
    >>> pad_ink_edge(labels, ink).tolist()
    [[0, 0, 0, 0, -1, -1]]
    """
    labels = np.asarray(labels)
    ink = np.asarray(ink, bool)
    if labels.shape != ink.shape:
        raise InputError(f"ink: expected the labels' shape {labels.shape}, got {ink.shape}")
    out = labels.astype(np.int32)
    edge = ink & (labels >= 0)
    beside = binary_dilation(edge, structure=np.ones((3, 3), bool)) & (labels < 0)
    if beside.any():
        _, (iy, ix) = distance_transform_edt(~edge, return_indices=True)
        nearest = labels[iy, ix]
        # A narrow gap between two parts stays paper: two outlines brought within a
        # pixel of each other would make a sliver between them in a union solid.
        span = 2 * _GAP + 1
        top = maximum_filter(np.where(labels >= 0, labels, -1), size=span)
        low = minimum_filter(np.where(labels >= 0, labels, np.iinfo(np.int32).max), size=span)
        alone = (top == nearest) & (low == nearest)
        beside &= alone
        out[beside] = nearest[beside]
    return out
