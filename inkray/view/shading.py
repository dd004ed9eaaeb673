"""Normals and Lambert shading of height fields: one encoding for every normal map.

A height field ``h`` (rows growing downward, heights toward the viewer) has
the unit normal ``n = (-dh/dx, dh/dy, 1) / |...|`` in the frame *x right, y up,
z toward the viewer* (OpenGL's tangent-space convention, "+Y"). A normal map
stores it as ``rgb = round((n + 1) * 127.5)``. The relief's raster normals
(:mod:`inkray.view.rasterization`) are encoded by the same function, so the
2010 depth maps (Sýkora et al., CGF 2010) and the 2014 reliefs (Ink-and-Ray,
TOG 2014) write normal maps that agree.
"""

import numpy as np

__all__ = ["height_normals", "encode_normals", "lambert", "over_white"]


def height_normals(height):
    """Unit normals of a height field, ``(x right, y up, z toward the viewer)``.

    Parameters
    ----------
    height : (H, W) float array
        Heights in pixels, rows growing downward.

    Returns
    -------
    (H, W, 3) float64 array

    Examples
    --------
    >>> import numpy as np
    >>> height_normals(np.zeros((3, 3)))[1, 1].tolist()
    [0.0, 0.0, 1.0]
    """
    h = np.asarray(height, np.float64)
    if min(h.shape) > 1:
        gy, gx = np.gradient(h)
    else:
        gy = gx = np.zeros_like(h)
    # Image rows grow downward; the normal's y points up.
    n = np.stack([0.0 - gx, gy, np.ones_like(h)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def encode_normals(normals, mask=None):
    """Unit normals as 8-bit RGB(A): ``round((n + 1) * 127.5)``.

    Parameters
    ----------
    normals : (H, W, 3) float array
        ``(x right, y up, z toward the viewer)``.
    mask : (H, W) bool array, optional
        Where there is a surface; with it the result is RGBA, transparent
        black elsewhere.

    Returns
    -------
    (H, W, 3) or (H, W, 4) uint8 array

    Examples
    --------
    >>> import numpy as np
    >>> encode_normals(np.array([[[0.0, 0.0, 1.0]]]))[0, 0].tolist()
    [128, 128, 255]
    """
    rgb = np.rint((np.clip(np.asarray(normals, np.float64), -1, 1) + 1.0) * 127.5).astype(np.uint8)
    if mask is None:
        return rgb
    mask = np.asarray(mask, bool)
    rgba = np.zeros(mask.shape + (4,), np.uint8)
    rgba[..., :3] = np.where(mask[..., None], rgb, 0)
    rgba[..., 3] = np.where(mask, 255, 0)
    return rgba


def lambert(normals, *, light=(-1.0, 1.0, 1.5), ambient=0.15):
    """Lambert shading ``ambient + (1 - ambient) max(0, n . l)``.

    Parameters
    ----------
    normals : (..., 3) float array
        Unit normals, ``(x right, y up, z toward the viewer)``.
    light : 3-tuple, default (-1, 1, 1.5)
        Direction toward the light in the same frame (upper left).
    ambient : float, default 0.15

    Returns
    -------
    (...) float array in [ambient, 1]

    Examples
    --------
    >>> import numpy as np
    >>> float(lambert(np.array([0.0, 0.0, 1.0]), light=(0, 0, 1), ambient=0.0))
    1.0
    """
    l = np.asarray(light, np.float64)
    l = l / np.linalg.norm(l)
    return ambient + (1.0 - ambient) * np.clip(np.asarray(normals) @ l, 0.0, 1.0)


def over_white(rgba):
    """Composite 8-bit RGBA over white; returns RGB in [0, 1].

    Parameters
    ----------
    rgba : (..., 4) uint8 array

    Returns
    -------
    (..., 3) float array

    Examples
    --------
    >>> import numpy as np
    >>> over_white(np.array([[0, 0, 0, 0], [0, 0, 0, 255]], np.uint8)).tolist()
    [[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]
    """
    a = rgba[..., 3:4] / 255.0
    return rgba[..., :3] / 255.0 * a + (1 - a)
