"""Synthetic shots made from a bundled drawing, with the truth of every frame.

Frame ``t`` of a shot is the key drawing under a known smooth warp that grows
with ``t`` (a drift plus a slow wave), one limb turned by ``angle * t``
degrees about the point where it meets the rest of the character (away
from it), a short
stroke added inside the body and a gap cut into an outline (both moving from
frame to frame). The truth of frame ``t`` is the key's annotation moved by the
same map: a point of the limb is turned with it, every point is warped.
"""

from dataclasses import dataclass, replace

import numpy as np
from scipy import ndimage

from inkray.input.drawing import drawing_from_array
from inkray.input.loading import load_input
from inkray.examples import example_path
from inkray.segmentation import segment

#: The limb turned in each drawing's shot.
#: Parts behind the body, so that the outlines they leave stay closed.
LIMBS = {"figure": "arm_far", "cat": "tail", "bird": "tail"}


@dataclass
class Shot:
    """A synthetic shot: ``frames[0]`` is the key, ``truths[t]`` frame t's annotation."""

    name: str
    frames: list
    truths: list
    limb: str


def _wave(x, y, t, w, h):
    """The backward warp of frame t: the key point shown at frame pixel (x, y) is (x, y) + b."""
    return (-2.0 * t + 1.5 * t * np.sin(2 * np.pi * y / h),
            -1.0 * t + 1.2 * t * np.cos(2 * np.pi * x / w))


def make_shot(name, frames=4, *, angle=12.0, size=None):
    """The synthetic shot of the bundled drawing ``name`` (see the module docstring).

    ``size`` ``(w, h)`` resamples the key first (for timings at another size).
    """
    ann, key = load_input(example_path(name))
    if size is not None:
        from inkray.input.annotations import rescale_annotations
        from PIL import Image

        rgb = np.asarray(Image.fromarray(key.rgb).resize(size, Image.LANCZOS))
        key = drawing_from_array(rgb, normalize=False)
        ann = rescale_annotations(ann, size)
    limb = LIMBS[name]
    labels = segment(ann, key).labels
    li = ann.region_index(limb)
    limb_mask = ndimage.binary_dilation(labels == li, iterations=2)
    rest = (labels >= 0) & ~limb_mask
    ry, rx = np.nonzero(rest)
    ly, lx = np.nonzero(limb_mask)
    k = np.argmin((lx - rx.mean()) ** 2 + (ly - ry.mean()) ** 2)
    pivot = np.array([lx[k], ly[k]], float)
    near_rest = ndimage.binary_dilation(rest, iterations=3)
    # Turn the limb the way that takes it away from the rest of the character.
    rad = np.deg2rad(angle)
    overlap = []
    for sign in (1, -1):
        c, s_ = np.cos(sign * rad), np.sin(sign * rad)
        dx, dy = lx - pivot[0], ly - pivot[1]
        tx = np.rint(c * dx - s_ * dy + pivot[0]).astype(int)
        ty = np.rint(s_ * dx + c * dy + pivot[1]).astype(int)
        ok = (tx >= 0) & (ty >= 0) & (tx < rest.shape[1]) & (ty < rest.shape[0])
        overlap.append(np.count_nonzero(rest[ty[ok], tx[ok]]))
    angle = angle if overlap[0] <= overlap[1] else -angle
    body = ann.region_index("body")
    by, bx = np.nonzero(labels == body)
    gray = np.asarray(key.gray, float)
    h, w = gray.shape
    ys, xs = np.mgrid[:h, :w].astype(float)
    images, truths = [key], [ann]
    for t in range(1, frames):
        theta = np.deg2rad(angle * t)
        c, s = np.cos(theta), np.sin(theta)
        bxq, byq = _wave(xs, ys, t, w, h)
        y = np.stack([xs + bxq, ys + byq], axis=-1)  # key-space point before the limb turn
        # Inside the turned limb, the key point is the limb point turned back.
        d = y - pivot
        back = np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], -1) + pivot
        in_turned = ndimage.map_coordinates(limb_mask.astype(float), [back[..., 1], back[..., 0]],
                                            order=0) > 0.5
        # The limb's old place is cleared, but not the outlines of the parts it met.
        in_old = ndimage.map_coordinates((limb_mask & ~near_rest).astype(float),
                                         [y[..., 1], y[..., 0]], order=0) > 0.5
        src = np.where(in_turned[..., None], back, y)
        frame = ndimage.map_coordinates(gray, [src[..., 1], src[..., 0]], order=1, cval=1.0)
        frame[in_old & ~in_turned] = 1.0
        _strokes(frame, bx, by, t, rest)
        images.append(drawing_from_array(np.clip(frame, 0, 1), normalize=False))
        truths.append(_moved(ann, labels, li, pivot, (c, s), t, (w, h)))
    return Shot(name=name, frames=images, truths=truths, limb=limb)


def _strokes(frame, bx, by, t, rest):
    """A short stroke added inside the body and a gap cut into the outline, both moving."""
    h, w = frame.shape
    cx, cy = int(np.median(bx)), int(np.median(by))
    # Below the middle, clear of the body's scribble (often a dot at its centre).
    x0 = int(np.clip(cx - 8 + 2 * t, 1, w - 20))
    frame[min(cy + int(0.45 * (by.max() - cy)) + t, h - 2), x0:x0 + 14] = 0.0
    # The gap: three pixels of ink erased on the body's outline, to its left.
    row = min(max(cy - 10 + 2 * t, 0), h - 1)
    ink = np.nonzero(frame[row, :cx] < 0.5)[0]
    if len(ink):
        x = ink.max()
        frame[max(row - 2, 0):row + 3, max(x - 1, 0):x + 2] = 1.0


def _moved(ann, labels, limb, pivot, cs, t, size):
    """The annotation moved by frame t's map."""
    w, h = size
    c, s = cs

    def forward(p, turned):
        p = np.asarray(p, float).reshape(-1, 2)
        if turned:
            d = p - pivot
            p = np.stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]], -1) + pivot
        q = p.copy()
        for _ in range(50):  # q + b(q) = p
            bx, by = _wave(q[:, 0], q[:, 1], t, w, h)
            q = p - np.stack([bx, by], -1)
        return np.clip(q, 0, [w - 1, h - 1])

    def on_limb(p):
        x, y = int(round(p[0])), int(round(p[1]))
        return labels[min(max(y, 0), h - 1), min(max(x, 0), w - 1)] == limb

    regions = [replace(r, scribbles=[forward(sc, i == limb) for sc in r.scribbles])
               for i, r in enumerate(ann.regions)]
    order = [replace(o, front=tuple(forward(o.front, on_limb(o.front))[0]),
                     back=tuple(forward(o.back, on_limb(o.back))[0])) for o in ann.order]
    equal = [replace(e, a=tuple(forward(e.a, on_limb(e.a))[0]),
                     b=tuple(forward(e.b, on_limb(e.b))[0])) for e in ann.equal]
    return replace(ann, regions=regions, background=[forward(b, False) for b in ann.background],
                   order=order, equal=equal,
                   boundaries=[replace(b, path=forward(b.path, False)) for b in ann.boundaries],
                   drawing=None, source=None)
