"""Ambient occlusion baked from a height field, by horizon search.

Horizon-based ambient occlusion (Bavoil, Sainz and Dimitrov, "Image-space
horizon-based ambient occlusion", SIGGRAPH 2008 talks) measures, in a number
of directions around each pixel, how high the surrounding surface rises above
the pixel's tangent plane: the sine of the horizon's elevation minus the
sine of the tangent's is the fraction of that direction's slice of the
hemisphere hidden from the sky. Averaged over the directions and
attenuated with distance, it is the ambient light a pixel does *not* get.

Here the height field is the front view of an Ink-and-Ray relief (Sýkora et
al., TOG 2014, section 6): heights and distances are both in drawing pixels,
so the angles are the relief's own. A part lying behind another one is dark
along the front part's edge (the crease between them), an open bulge is
lit. Samples are taken at whole-pixel offsets, so the result is exact
arithmetic on shifted copies of the image: fast and deterministic.
"""

import numpy as np

from inkray.errors import InputError

__all__ = ["MAX_RADIUS", "ambient_occlusion"]

#: Largest occlusion radius in pixels (the work does not grow with it: beyond
#: the image every sample sees the ground).
MAX_RADIUS = 1e6


def ambient_occlusion(height, *, mask=None, radius=16.0, directions=16, steps=8):
    """Ambient light per pixel of a height field, 1 open sky, 0 fully occluded.

    Parameters
    ----------
    height : (H, W) float array
        Heights toward the viewer, in the same units as the pixel spacing.
    mask : (H, W) bool array, optional
        Where there is a surface. Elsewhere the ground lies at the lowest
        masked height (it occludes nothing), and the result is 1.
    radius : float, default 16
        Farthest distance (pixels) a neighbour can occlude from; occlusion
        fades as ``1 - (r / radius)^2``.
    directions : int, default 16
        Horizon directions, evenly spaced around the circle.
    steps : int, default 8
        Samples per direction, spaced evenly out to ``radius``.

    Returns
    -------
    (H, W) float64 array in [0, 1]

    Examples
    --------
    >>> import numpy as np
    >>> h = np.zeros((9, 9)); h[:, 5:] = 4.0          # a step up to the right
    >>> ao = ambient_occlusion(h, radius=4, directions=8, steps=4)
    >>> float(ao[4, 0]), bool(ao[4, 4] < ao[4, 1])   # open floor; dark at the step's foot
    (1.0, True)
    """
    h = np.asarray(height, np.float64)
    if h.ndim != 2 or min(h.shape) < 1:
        raise InputError(f"height: expected an (H, W) array, got shape {h.shape}")
    if mask is None:
        mask = np.ones(h.shape, bool)
    mask = np.asarray(mask, bool)
    if mask.shape != h.shape:
        raise InputError(f"mask: shape {mask.shape} differs from the height's {h.shape}")
    if not np.isfinite(h[mask]).all():
        raise InputError("height: not finite inside the mask")
    if not (np.isfinite(radius) and 1 <= radius <= MAX_RADIUS):
        raise InputError(f"radius: expected 1..{MAX_RADIUS:g} pixels, got {radius!r}",
                         option="radius")
    if int(directions) < 1 or int(steps) < 1:
        raise InputError(f"directions, steps: expected at least 1, got {directions}, {steps}")
    if not mask.any():
        return np.ones(h.shape)
    ground = float(h[mask].min())
    # Single precision: half the memory traffic of the 128 passes; angles need no more.
    field = np.where(mask, h, ground).astype(np.float32)
    # Samples farther than the image all see the ground: the padding need not be wider.
    pad = min(int(np.ceil(radius)), max(h.shape)) + 1
    padded = np.pad(field, pad, mode="constant", constant_values=ground)
    rows, cols = h.shape
    gx, gy = _slope(field, axis=1), _slope(field, axis=0)
    occlusion = np.zeros(h.shape, np.float32)
    for k in range(int(directions)):
        angle = 2 * np.pi * k / int(directions)
        dx, dy = np.cos(angle), np.sin(angle)
        best = np.zeros(h.shape, np.float32)
        seen = set()
        for s in range(1, int(steps) + 1):
            r = radius * s / int(steps)
            ox, oy = int(round(r * dx)), int(round(r * dy))
            if (ox, oy) in seen or (ox, oy) == (0, 0):
                continue
            seen.add((ox, oy))
            dist = float(np.hypot(ox, oy))
            if dist > radius:
                continue
            d2, fade = np.float32(dist * dist), np.float32(1.0 - (dist / radius) ** 2)
            sx, sy = (min(max(o, -pad), pad) for o in (ox, oy))  # the same ground beyond
            rise = padded[pad + sy:pad + sy + rows, pad + sx:pad + sx + cols] - field
            # The surface's own tangent plane occludes nothing: the sine of the
            # sample's elevation counts above the tangent's, faded with distance.
            tangent = gx * np.float32(ox) + gy * np.float32(oy)
            base = tangent / np.sqrt(tangent * tangent + d2)
            sine = rise / np.sqrt(rise * rise + d2)
            np.maximum(best, (sine - base) * fade, out=best)
        occlusion += best
    ao = np.clip(1.0 - occlusion.astype(np.float64) / int(directions), 0.0, 1.0)
    return np.where(mask, ao, 1.0)


def _slope(field, *, axis):
    """Height change per pixel along ``axis``: the smaller of the one-sided differences.

    Across a step (a part in front of another) one side is the step and the
    other the surface itself; the smaller one keeps the surface's slope, so
    the foot of the step stays a crease (minmod limiter).
    """
    d = np.diff(field, axis=axis)
    zero = np.zeros_like(np.take(d, [0], axis=axis))
    back, ahead = np.concatenate([zero, d], axis=axis), np.concatenate([d, zero], axis=axis)
    return np.where(back * ahead > 0, np.sign(back) * np.minimum(abs(back), abs(ahead)), 0.0)
