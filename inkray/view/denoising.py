"""Edge-avoiding a-trous filtering of a noisy render, guided by its scene buffers.

A path-traced picture at a few samples per pixel is noisy, but the scene that
made it is known exactly: its surface normals and which object every
pixel sees. The edge-avoiding a-trous wavelet transform (Dammertz, Sewtz,
Hanika and Lensch, "Edge-Avoiding A-Trous Wavelet Transform for fast Global
Illumination Filtering", HPG 2010) smooths the picture with a sparse kernel
whose holes double at every level, so a few levels reach far at little cost,
and stops at the edges of those buffers (here: creases of the normals and
changes of object; on a relief, a height field whose parts are objects of
their own, a depth stop adds nothing). Spatiotemporal variance-guided
filtering (Schied et al., "Spatiotemporal Variance-Guided Filtering", HPG 2017)
adds the stop on luminance scaled by the noise each pixel is known to have, so
real changes of light (shadows) stay while the noise goes; the variance is
filtered along with the picture.

This filters whatever it is given; the caller divides the colour of the
surfaces out first (it is sharp where lighting is smooth) and multiplies it
back afterwards.
"""

import numpy as np

__all__ = ["atrous_denoise"]

_TAPS = (0.25, 0.5, 0.25)  # the linear B-spline: a 3x3 kernel per level
_LUMA = np.array([0.2126, 0.7152, 0.0722])
_EPS = 1e-10


def atrous_denoise(image, *, normals=None, labels=None, variance=None, levels=5,
                   sigma_normal=64.0, sigma_luminance=4.0):
    """Smooth ``image`` within the regions its guide buffers agree on.

    Level ``i`` (``i = 0 .. levels - 1``) averages each pixel with its eight
    neighbours ``2**i`` pixels away, weighted by a 3x3 linear B-spline times
    the edge-stopping weights

    - normals: ``max(0, n_p . n_q) ** sigma_normal``;
    - labels: 1 when ``l_p == l_q``, else 0;
    - luminance (with ``variance``): ``exp(-|L_p - L_q| / (sigma_luminance *
      sqrt(var_p) + eps))``, ``var`` the variance of the luminance of the
      mean, blurred 3x3 and carried through the levels.

    Parameters
    ----------
    image : (h, w) or (h, w, c) float array
        The noisy picture (linear values).
    normals : (h, w, 3) float array, optional
        Unit normals.
    labels : (h, w) int array, optional
        Object id per pixel; nothing is averaged across ids.
    variance : (h, w) float array, optional
        Variance of each pixel's luminance (of the channel mean weighted
        0.2126, 0.7152, 0.0722 for three channels, the value for one).
    levels : int, optional
        Number of levels; the kernel reaches ``2 ** levels - 1`` pixels.
    sigma_normal, sigma_luminance : float, optional
        Edge-stopping strengths (a larger normal exponent is stricter, a
        larger luminance sigma more lenient).

    Returns
    -------
    (h, w) or (h, w, c) float array
        The filtered picture, ``float64``, shaped like ``image``.

    Raises
    ------
    ValueError
        A guide's shape does not match the image, or a parameter is out of range.

    Examples
    --------
    A noisy constant field becomes (nearly) constant; an edge in the labels is kept.

    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> labels = np.zeros((32, 32), int); labels[:, 16:] = 1
    >>> noisy = np.where(labels == 1, 1.0, 0.2) + rng.normal(0, 0.05, (32, 32))
    >>> out = atrous_denoise(noisy, labels=labels)
    >>> bool(out[:, :16].std() < 0.01 and out[:, 16:].std() < 0.01)
    True
    >>> round(float(out[:, 15].mean()), 1), round(float(out[:, 16].mean()), 1)
    (0.2, 1.0)
    """
    image = np.asarray(image, float)
    flat = image.ndim == 2
    if flat:
        image = image[..., None]
    if image.ndim != 3 or image.shape[0] < 1 or image.shape[1] < 1:
        raise ValueError(f"atrous_denoise: image must be (h, w) or (h, w, c), got {image.shape}")
    h, w = image.shape[:2]
    guides = {"normals": (normals, (h, w, 3)), "labels": (labels, (h, w)),
              "variance": (variance, (h, w))}
    for name, (g, shape) in guides.items():
        if g is not None and np.shape(g) != shape:
            raise ValueError(f"atrous_denoise: {name} must be {shape}, got {np.shape(g)}")
    if not (isinstance(levels, (int, np.integer)) and 0 <= levels <= 16):
        raise ValueError(f"atrous_denoise: levels must be an integer in 0..16, got {levels!r}")
    for name, s in (("sigma_normal", sigma_normal), ("sigma_luminance", sigma_luminance)):
        if not (np.isfinite(s) and s > 0):
            raise ValueError(f"atrous_denoise: {name} must be positive, got {s!r}")

    # float32 halves the memory traffic; the sums are short.
    out = image.astype(np.float32)
    n = None if normals is None else np.asarray(normals, np.float32)
    lab = None if labels is None else np.asarray(labels)
    var = None if variance is None else np.asarray(variance, np.float32)
    for level in range(levels):
        out, var = _level(out, 1 << level, n, lab, var, float(sigma_normal),
                          float(sigma_luminance))
    out = out.astype(float)
    return out[..., 0] if flat else out


def _luminance(image):
    return image[..., 0] if image.shape[2] != 3 else image @ _LUMA.astype(np.float32)


def _blur3(a):
    """3x3 binomial blur (edges repeated): a steadier variance to stop on."""
    p = np.pad(a, 1, mode="edge")
    rows = 0.25 * p[:-2] + 0.5 * p[1:-1] + 0.25 * p[2:]
    return 0.25 * rows[:, :-2] + 0.5 * rows[:, 1:-1] + 0.25 * rows[:, 2:]


def _level(image, step, n, lab, var, sigma_n, sigma_l):
    h, w = image.shape[:2]
    total = image * (_TAPS[1] * _TAPS[1])  # the centre tap: every weight 1
    weight = np.full((h, w), _TAPS[1] * _TAPS[1], np.float32)
    if var is not None:
        lum = _luminance(image)
        # the luminance stop scales with the noise the pixel still has
        scale = 1.0 / (sigma_l * np.sqrt(np.maximum(_blur3(var), 0.0)) + _EPS)
        var_total = var * (_TAPS[1] * _TAPS[1]) ** 2
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dy == 0 and dx == 0:
                continue
            oy, ox = dy * step, dx * step
            if abs(oy) >= h or abs(ox) >= w:
                continue
            # p runs over the pixels whose neighbour q = p + (oy, ox) is inside
            p = (slice(max(0, -oy), h - max(0, oy)), slice(max(0, -ox), w - max(0, ox)))
            q = (slice(max(0, oy), h - max(0, -oy)), slice(max(0, ox), w - max(0, -ox)))
            wq = np.float32(_TAPS[dy + 1] * _TAPS[dx + 1])
            if lab is not None:
                wq = wq * (lab[p] == lab[q])
            if n is not None:
                dot = np.einsum("ijk,ijk->ij", n[p], n[q])
                wq = wq * np.maximum(dot, 0.0) ** sigma_n
            if var is not None:
                wq = wq * np.exp(-np.abs(lum[p] - lum[q]) * scale[p])
                var_total[p] += wq * wq * var[q]
            total[p] += wq[..., None] * image[q]
            weight[p] += wq
    out = total / weight[..., None]
    if var is not None:
        var = var_total / (weight * weight)
    return out, var
