"""Depth-buffer enhancement: darkening behind occluding edges by unsharp masking the depth.

Luft, Colditz and Deussen, "Image enhancement by unsharp masking the depth
buffer" (SIGGRAPH 2006): the high-pass of the depth buffer,
``dH = H - G_sigma * H`` (the depth minus its Gaussian blur), is negative on
the far side of every depth discontinuity, where a nearer surface occludes a
farther one, and fades away from it over the blur's radius. Adding its
negative part to the picture darkens the surfaces just behind occluding edges
(a soft, local ambient occlusion that separates overlapping parts), the
effect of Sýkora's habilitation Fig. 1.1d on an Ink-and-Ray relief.

Here ``H`` is the relief's height toward the viewer (drawing pixels), the
empty background lies at the drawing's plane, behind everything (so the
character's silhouette occludes it and is not darkened), and the darkening
multiplies the picture, so that hue is kept and nothing goes below black::

    picture * exp(strength * min(dH, 0) / radius)

A step as tall as the radius between two parts darkens the far side of the
edge by about ``exp(-strength / 2)``.
"""

import numpy as np
from scipy import ndimage

from inkray.errors import InputError

__all__ = ["STRENGTH", "RADIUS", "check_enhancement", "depth_highpass", "enhance"]

#: Default and extreme values of the two parameters: ``(default, low, high)``.
STRENGTH = (1.0, 0.0, 10.0)
RADIUS = (8.0, 0.5, 100.0)   # drawing pixels


def check_enhancement(strength, radius, *, prefix=""):
    """Validate the two parameters of :func:`enhance` up front.

    Parameters
    ----------
    strength, radius : float
    prefix : str, optional
        Put before the parameters' names in the message (a caller's own
        names for them, e.g. ``"enhance_"``).

    Raises
    ------
    InputError
        A value that is not a finite number within its range.

    Examples
    --------
    >>> check_enhancement(1.0, 8.0)
    >>> check_enhancement(1.0, 0.0)
    Traceback (most recent call last):
    ...
    inkray.errors.InputError: radius: expected a number in 0.5..100, got 0.0
    """
    for name, value, (_, low, high) in (("strength", strength, STRENGTH),
                                        ("radius", radius, RADIUS)):
        ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
        if not (ok and np.isfinite(value) and low <= value <= high):
            raise InputError(f"{prefix}{name}: expected a number in {low:g}..{high:g}, "
                             f"got {value!r}", option=prefix + name)


def depth_highpass(depth, *, radius, mask=None):
    """The depth minus its Gaussian blur: ``H - G_radius * H``.

    Parameters
    ----------
    depth : (H, W) float array
        Height toward the viewer; outside ``mask`` the lower of 0 (the
        drawing's plane) and the lowest height inside it is taken.
    radius : float
        Standard deviation of the Gaussian, in pixels of ``depth``.
    mask : (H, W) bool array, optional
        Where there is a surface; default everywhere.

    Returns
    -------
    (H, W) float array
        0 outside ``mask``; negative just behind occluding edges.

    Examples
    --------
    >>> step = np.zeros((1, 40)); step[0, 20:] = 10.0      # a part 10 px in front, at the right
    >>> h = depth_highpass(step, radius=3.0)
    >>> bool(h[0, 19] < -3 < 3 < h[0, 20]), abs(float(h[0, 0])) < 1e-6
    (True, True)
    """
    depth = np.asarray(depth, np.float64)
    mask = np.ones(depth.shape, bool) if mask is None else np.asarray(mask, bool)
    if depth.ndim != 2 or mask.shape != depth.shape:
        raise InputError(f"depth: expected an (H, W) image and a mask of its shape, got "
                         f"{depth.shape} and {mask.shape}")
    if not mask.any():
        return np.zeros(depth.shape)
    # The empty pixels lie behind everything (the drawing's plane, or the lowest surface):
    # a silhouette occludes them, not the other way round.
    floor = min(0.0, float(depth[mask].min()))
    smooth = ndimage.gaussian_filter(np.where(mask, depth, floor), radius, mode="nearest")
    return np.where(mask, depth - smooth, 0.0)


def enhance(rgb, depth, *, mask=None, strength=STRENGTH[0], radius=RADIUS[0], scale=1.0):
    """Darken a picture behind the occluding edges of its depth (Luft et al. 2006).

    Parameters
    ----------
    rgb : (H, W, 3) float array
        The picture, 0..1 (any encoding: the darkening is a factor).
    depth : (H, W) float array
        Height toward the viewer at each pixel, in drawing pixels.
    mask : (H, W) bool array, optional
        Where there is a surface; default everywhere.
    strength : float, default 1.0
        How dark: 0 leaves the picture as it is; at 10 a step of a tenth of
        the radius already darkens its far side to exp(-1/2), 0.6. Within
        0..10.
    radius : float, default 8.0
        Reach of the darkening behind an edge, in drawing pixels (the
        Gaussian's standard deviation). Within 0.5..100.
    scale : float, default 1.0
        Picture pixels per drawing pixel (a picture at twice the drawing's
        size darkens over twice the pixels).

    Returns
    -------
    (H, W, 3) float array

    Raises
    ------
    InputError
        A parameter out of its range, or images of different shapes.

    Examples
    --------
    >>> rgb = np.ones((1, 40, 3)); step = np.zeros((1, 40)); step[0, 20:] = 8.0
    >>> out = enhance(rgb, step, strength=1.0, radius=4.0)
    >>> bool(out[0, 19, 0] < 0.7), float(out[0, 0, 0]), float(out[0, 30, 0])
    (True, 1.0, 1.0)
    """
    check_enhancement(strength, radius)
    rgb = np.asarray(rgb, np.float64)
    if rgb.shape[:2] != np.shape(depth) or rgb.ndim != 3:
        raise InputError(f"rgb: expected an (H, W, 3) picture of the depth's size "
                         f"{np.shape(depth)}, got {rgb.shape}")
    if strength == 0:
        return rgb.copy()
    high = depth_highpass(depth, radius=radius * scale, mask=mask)
    return rgb * np.exp(strength * np.minimum(high, 0.0) / radius)[..., None]
