"""Hand-built reliefs for the export and check tests (stitching does not exist yet).

Parts are disks inflated to spherical caps (a disk of radius R with height R is
a hemisphere), triangulated with ``triangle``, in the convention of
inkray.relief: drawing pixels (centres at integers, the drawing spanning
[-0.5, W - 0.5] x [-0.5, H - 0.5]), y down, front faces clockwise in (x, y).
"""

import numpy as np
import triangle

from inkray.relief.model import Part, Relief

SIZE = (160, 120)  # (W, H): not square, so swapped axes show
# (name, centre x, centre y, radius, base height): "head" overlaps "body" and stands on it.
DISKS = (("body", 70.0, 64.0, 40.0, 0.0), ("head", 116.0, 46.0, 26.0, 12.0))


def disk_part(name, cx, cy, radius, *, base=0.0, height=None, closed=False, max_area=6.0):
    """A disk inflated to a spherical cap of ``height`` (default: hemisphere) above ``base``.

    Open: the front surface only, its rim at ``z = base``. Closed: the front
    mirrored below ``base`` and joined at the rim (shared rim vertices).
    """
    height = radius if height is None else height
    n = max(24, int(round(2 * np.pi * radius / 2.0)))
    t = 2 * np.pi * np.arange(n) / n
    rim = np.stack([cx + radius * np.cos(t), cy + radius * np.sin(t)], axis=1)
    seg = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    tri = triangle.triangulate({"vertices": rim, "segments": seg}, f"pq30a{max_area}Q")
    xy, faces = tri["vertices"], tri["triangles"]
    on_rim = tri["vertex_markers"].reshape(-1) == 1
    r = np.hypot(xy[:, 0] - cx, xy[:, 1] - cy) / radius
    h = height * np.sqrt(np.clip(1.0 - r ** 2, 0.0, None))
    h[on_rim] = 0.0
    # triangle's output is counter-clockwise in (x, y); the relief wants clockwise.
    front = faces[:, ::-1]
    vertices = np.column_stack([xy, base + h])
    if not closed:
        return Part(name, vertices, front.copy(), closed=False)
    inner = np.flatnonzero(~on_rim)
    back_index = np.arange(len(xy))
    back_index[inner] = len(xy) + np.arange(len(inner))
    back_vertices = np.column_stack([xy[inner], base - h[inner]])
    back = back_index[faces]  # counter-clockwise in (x, y): facing away from the viewer
    return Part(name, np.vstack([vertices, back_vertices]), np.vstack([front, back]), closed=True)


def grid_part(name, xs, ys, z=0.0):
    """A flat grid over pixel positions ``xs`` x ``ys``, front faces toward the viewer."""
    gx, gy = np.meshgrid(np.asarray(xs, float), np.asarray(ys, float))
    vertices = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, float(z))])
    nx = len(xs)
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(len(ys) - 1))
    a = (j * nx + i).ravel()
    b, c = a + 1, a + nx
    d = c + 1
    faces = np.concatenate([np.stack([a, c, b], 1), np.stack([b, c, d], 1)])
    return Part(name, vertices, faces)


def drawing(size=SIZE, disks=DISKS, seed=0):
    """A colourful drawing with fine detail: gradients, noise, ink outlines of the disks."""
    w, h = size
    y, x = np.mgrid[0:h, 0:w].astype(float)
    rng = np.random.default_rng(seed)
    img = np.stack([40 + 180 * x / w, 40 + 180 * y / h, 120 + 60 * np.sin(x / 5.0)], axis=2)
    img += rng.normal(0.0, 25.0, img.shape)
    for _, cx, cy, radius, _ in disks:
        ink = np.abs(np.hypot(x - cx, y - cy) - (radius - 2.0)) < 1.0
        img[ink] = 10.0
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def disk_relief(closed=False):
    """The two-disk relief with its drawing: open (front only) or closed."""
    parts = [disk_part(name, cx, cy, r, base=base, closed=closed)
             for name, cx, cy, r, base in DISKS]
    return Relief(parts=parts, size=SIZE, texture=drawing())


def disk_mask(size=SIZE, disks=DISKS, inset=1.0):
    """Pixels whose centre lies inside a disk by at least ``inset`` pixels (the character)."""
    w, h = size
    y, x = np.mgrid[0:h, 0:w].astype(float)
    mask = np.zeros((h, w), bool)
    for _, cx, cy, radius, _ in disks:
        mask |= np.hypot(x - cx, y - cy) < radius - inset
    return mask
