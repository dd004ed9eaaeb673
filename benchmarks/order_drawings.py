"""Line drawings with a known depth order, generated for learning the order prediction.

Usage::

    python benchmarks/order_drawings.py OUT_DIR [--count 8] [--seed 0] [--without gaps,paper]

writes ``OUT_DIR/gen_SEED/drawing.png`` and ``drawing.inkray.json`` per drawing: a drawing
and its annotation in the inkray format (regions with scribbles, background
scribbles, and one ``order`` entry per pair of parts that overlap), so the
segmentation and the ordering run on it as on a real annotation.

How a drawing is made (:func:`generate`, seeded: the same seed and styles give
the same drawing, byte for byte):

1. A scene of parts, each a filled shape with a depth rank. A *character*
   (probability 0.8): a body blob with spots and sometimes a belt on it; legs
   and arms as capsules attached to it, the far ones behind the body and the
   near ones over it; a head over a neck and over the body (behind it one time
   in eight); ears behind the head (over it one time in four), horns behind
   it or a tuft of hair over it, eyes (with pupils) and a muzzle on it; a tail
   behind the body; paws over the legs; a prop over or behind an arm. Around it scenery: a
   ground band behind everything, plants (bushes, grass tufts) behind the
   character or in front of its feet. Otherwise a *stack* of 3 to 7 random
   blobs painted in random order (cards, balls, pebbles).
2. Painted back to front with outlines only: every part first blanks its
   inside (so the lines of the parts behind it disappear under it), then
   draws its outline. The visible part of each shape is what the painter left
   of it: that is the true segmentation, and a part painted later that
   overlaps another is in front of it.
3. In the styles and with the shapes real drawings have, each switchable (:data:`STYLES`) and, when
   enabled, used in a drawing with probability one half:

   ``width``      stroke width varying along the stroke (smooth noise);
   ``taper``      an outline drawn as 1 to 4 strokes with tapered ends;
   ``gaps``       strokes broken where the pen lifted, and the lines of parts
                  behind stopping short of the outline in front;
   ``overshoot``  the lines of parts behind running on a little into the part
                  in front;
   ``sketchy``    every outline drawn twice, the second time wobbling off it;
   ``marker``     thick grey strokes;
   ``antialias``  ink rendered at twice the size and averaged down (else
                  thresholded, aliased);
   ``paper``      scanned paper: uneven shading, grain, slight blur;
   ``lobes``      the blobs (bodies, heads, paws, tufts, bushes, stacked pieces)
                  one time in two with 4 to 9 bumps round them: concave outlines,
                  so the contact does not always bend round the part in front;
   ``crowd``      each near leg beside a far one and over it (the pairs of legs
                  of a side view), and arms hanging down over the body and the
                  legs;
   ``fade``       the outline of a part in front fading out a little way into
                  the parts behind it, one part in two (a leg drawn into a
                  body without closing its top): no line between them there,
                  only the scribbles tell them apart;
   ``rest``       parts lying over the part below or beside them, each one time
                  in two (:meth:`_Scene.resting`): a forelock of scalloped locks
                  over the top of the head and the ears' bases, a collar or bib
                  under the head (the head over it, its chin line unbroken), an
                  arm resting over a leg, teeth over the head's lower outline.
                  Drawn from a stream of its own: a drawing that does not use
                  the style is the one drawn without it.
   ``onto``       parts lying on a surface drawn within its silhouette, each one
                  time in two (:meth:`_Scene.within`): a cap of hair over the top
                  of the head, a saddle or a patch over an edge of the body, and
                  the belt, the spots, the tuft and the muzzle cut at the outline
                  of what they lie on. Where such a part reaches the silhouette,
                  the surface's line is its outline, and a part behind the
                  surface (an ear, a far leg, the tail) meets it along that line:
                  the line runs on past the part in front into the surface's
                  outline, as the bar of a T does for a part in front of it. From
                  a stream of its own too.

The scribbles: one polyline along the middle of every visible piece of a part
larger than a few stroke widths, and background scribbles in the empty
corners. The ``order`` entries point from a pixel of the front part to one of
the back part, both near their contact.
"""

import argparse
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw
from scipy import ndimage
from skimage.measure import find_contours

#: The drawing styles :func:`generate` can use (all by default).
STYLES = ("width", "taper", "gaps", "overshoot", "sketchy", "marker", "antialias", "paper",
          "lobes", "crowd", "fade", "rest", "onto")
#: The styles added last, each drawn from a stream of its own (seeded ``(seed, k)``): a drawing
#: without them is the drawing the generator made before they were added.
_OWN = ("rest", "onto")
_SS = 2  # supersampling of the painted masks and strokes


@dataclass
class Part:
    """One shape of a scene: its name, its mask (supersampled) and its depth rank."""

    name: str
    mask: np.ndarray
    rank: float


@dataclass
class Generated:
    """One generated drawing.

    Attributes
    ----------
    gray : (H, W) uint8 array
        The drawing (255 paper).
    annotation : dict
        The inkray annotation (``"drawing": "drawing.png"``).
    labels : (H, W) int32 array
        The true visible part of every region (``-1`` where no part is).
    names : list of str
    relations : list of (str, str)
        ``(front, back)`` for every pair of parts that overlap.
    styles : tuple of str
        The styles this drawing was drawn in.
    """

    gray: np.ndarray
    annotation: dict
    labels: np.ndarray
    names: list
    relations: list
    styles: tuple


def generate(seed, *, styles=STYLES, size=None):
    """Generate one drawing with a known depth order.

    Parameters
    ----------
    seed : int
    styles : sequence of str, default :data:`STYLES`
        The styles that may be used (each with probability 1/2).
    size : (int, int), optional
        ``(width, height)``; default random between 300 and 460 pixels a side.

    Returns
    -------
    Generated

    Examples
    --------
    >>> g = generate(3, size=(200, 200))
    >>> g.gray.shape, len(g.names) == len(g.annotation["regions"])
    ((200, 200), True)
    """
    unknown = sorted(set(styles) - set(STYLES))
    if unknown:
        raise ValueError(f"styles: unknown style {unknown[0]!r} (expected {', '.join(STYLES)})")
    rng = np.random.default_rng(seed)
    if size is None:
        size = (int(rng.integers(300, 461)), int(rng.integers(300, 461)))
    w, h = size
    used = tuple(s for s in STYLES if s not in _OWN and s in styles and rng.random() < 0.5)
    streams = {s: np.random.default_rng((seed, k)) for k, s in enumerate(_OWN, 1)}
    used += tuple(s for s in _OWN if s in styles and streams[s].random() < 0.5)
    scene = _Scene(rng, w * _SS, h * _SS, used, extra=streams["rest"])
    if rng.random() < 0.8:
        scene.character()
        if "onto" in used:
            scene.within(streams["onto"])
    else:
        scene.stack()
    parts = sorted(scene.parts, key=lambda p: p.rank)
    width = float(rng.uniform(1.2, 3.5))
    if "marker" in used:
        width = float(rng.uniform(3.0, 6.5))
    width *= min(w, h) / 420.0
    ink = _paint(parts, rng, used, width * _SS)
    gray = _finish(ink, rng, used)
    labels = _visible(parts, h, w)
    names = [p.name for p in parts]
    relations = _relations(parts)
    annotation = _annotation(labels, names, relations, (w, h), width, rng)
    return Generated(gray=gray, annotation=annotation, labels=labels, names=names,
                     relations=[(names[f], names[b]) for f, b in relations], styles=used)


class _Scene:
    """Parts of one scene, in supersampled pixels."""

    def __init__(self, rng, w, h, used=(), extra=None):
        self.rng, self.w, self.h = rng, w, h
        self.extra = extra if "rest" in used else None
        self.legs = []
        self.lobed = "lobes" in used
        self.crowded = "crowd" in used
        self.parts = []
        self.yy, self.xx = np.mgrid[:h, :w].astype(np.float32)

    def add(self, name, mask, rank):
        if mask.sum() > 40 * _SS * _SS:
            self.parts.append(Part(name, mask, rank))

    def _box(self, x0, x1, y0, y1):
        """The grid's crop over a box (clipped to the image), and the full-size mask to fill."""
        x0, y0 = max(int(x0) - 2, 0), max(int(y0) - 2, 0)
        x1, y1 = min(int(x1) + 3, self.w), min(int(y1) + 3, self.h)
        return (slice(y0, max(y1, y0)), slice(x0, max(x1, x0))), np.zeros((self.h, self.w), bool)

    def blob(self, cx, cy, rx, ry, *, angle=0.0, wobble=0.12, lobes=0.0, scallops=False, rng=None):
        """A star-shaped blob: an ellipse with a random smooth radius, and ``lobes`` the
        amplitude of 4 to 9 bumps round it (a cloud of hair, a fist: a concave outline),
        ``scallops``: the bumps meet in sharp inward corners (a forelock's locks); ``rng``
        the stream it draws from (default the scene's)."""
        rng = self.rng if rng is None else rng
        reach = max(rx, ry) * (1.0 + wobble + lobes)
        box, mask = self._box(cx - reach, cx + reach, cy - reach, cy + reach)
        dx, dy = self.xx[box] - cx, self.yy[box] - cy
        t = np.arctan2(dy, dx) - angle
        c, s = np.cos(angle), np.sin(angle)
        u, v = dx * c + dy * s, -dx * s + dy * c
        r = np.hypot(u / rx, v / ry)
        bump = np.ones_like(r)
        for k in (2, 3, 5):
            bump += wobble / k * rng.uniform(-1, 1) * np.cos(k * t + rng.uniform(0, 2 * np.pi))
        if lobes > 0:
            k, phase = int(rng.integers(4, 10)), rng.uniform(0, 2 * np.pi)
            bump += (lobes * (2.0 * np.abs(np.sin(0.5 * k * t + phase)) - 1.0) if scallops
                     else lobes * np.cos(k * t + phase))
        mask[box] = r <= bump
        return mask

    def capsule(self, p, q, r0, r1):
        """A limb: the segment ``p``-``q`` thickened from radius ``r0`` to ``r1``."""
        p, q = np.asarray(p, np.float32), np.asarray(q, np.float32)
        r = max(r0, r1)
        box, mask = self._box(min(p[0], q[0]) - r, max(p[0], q[0]) + r,
                              min(p[1], q[1]) - r, max(p[1], q[1]) + r)
        xx, yy = self.xx[box], self.yy[box]
        d = q - p
        length2 = max(float(d @ d), 1e-6)
        t = np.clip(((xx - p[0]) * d[0] + (yy - p[1]) * d[1]) / length2, 0, 1)
        dist = np.hypot(xx - p[0] - t * d[0], yy - p[1] - t * d[1])
        mask[box] = dist <= r0 + (r1 - r0) * t
        return mask

    def lobes(self):
        """Amplitude of the bumps round a blob: none, or one time in two some with ``lobes``."""
        return float(self.rng.uniform(0.04, 0.16)) if self.lobed and self.rng.random() < 0.5 else 0.0

    def bent(self, p, q, r0, r1, bend):
        """A limb with a knee: two capsules bent by ``bend`` times its length."""
        p, q = np.asarray(p, float), np.asarray(q, float)
        d = q - p
        knee = (p + q) / 2 + bend * np.array([-d[1], d[0]])
        rk = (r0 + r1) / 2
        return self.capsule(p, knee, r0, rk) | self.capsule(knee, q, rk, r1)

    def character(self):
        rng, w, h = self.rng, self.w, self.h
        s = min(w, h)
        ground_y = h * rng.uniform(0.78, 0.92)
        if rng.random() < 0.5:
            wave = ground_y + s * 0.02 * np.sin(self.xx / w * rng.uniform(3, 9) + rng.uniform(0, 6))
            self.add("ground", self.yy >= wave, 0.0)
        cx, cy = w * rng.uniform(0.4, 0.6), h * rng.uniform(0.42, 0.55)
        rx, ry = s * rng.uniform(0.14, 0.24), s * rng.uniform(0.1, 0.2)
        upright = rng.random() < 0.4
        if upright:
            rx, ry = ry * 0.8, rx * 1.1
        self.add("body", self.blob(cx, cy, rx, ry, angle=rng.uniform(-0.3, 0.3),
                                   lobes=self.lobes()), 10.0)
        self.frame = dict(body=(cx, cy, rx, ry))
        # Legs: down from the body's lower half; far ones behind, near ones over it. Crowded:
        # each near leg beside a far one, over it (a side view's pairs of legs).
        n_legs = int(rng.choice([2, 2, 4]))
        fx = cx
        for i in range(n_legs):
            near = i % 2 == 1 if n_legs == 4 else i == 1 and rng.random() < 0.7
            r0 = s * rng.uniform(0.03, 0.06)
            if self.crowded and i % 2 == 1:
                fx = fx + rng.choice([-1, 1]) * r0 * rng.uniform(1.1, 2.0)
                near = True
            else:
                fx = cx + rx * (rng.uniform(-0.7, -0.2) if i < max(n_legs // 2, 1)
                                else rng.uniform(0.2, 0.7))
            top = (fx, cy + ry * rng.uniform(0.1, 0.6))
            foot = (fx + s * rng.uniform(-0.06, 0.06), min(cy + ry + s * rng.uniform(0.12, 0.28), h - 8))
            mask = (self.bent(top, foot, r0, r0 * rng.uniform(0.6, 1.0), rng.uniform(-0.15, 0.15))
                    if rng.random() < 0.5 else self.capsule(top, foot, r0, r0 * rng.uniform(0.6, 1.0)))
            rank = 12.0 + i if near else 5.0 + i
            self.add(f"leg{i}_{'near' if near else 'far'}", mask, rank)
            self.legs.append((np.asarray(top), np.asarray(foot), r0, rank))
            if rng.random() < 0.5:
                paw = self.blob(foot[0] + r0 * 0.5, foot[1], r0 * 1.4, r0 * 0.9, lobes=self.lobes())
                self.add(f"paw{i}", paw, rank + 0.5)
        # Arms (upright characters) or a tail.
        if upright or rng.random() < 0.3:
            for i, side in enumerate((-1, 1)):
                near = rng.random() < 0.5
                sh = (cx + side * rx * rng.uniform(0.3, 0.8), cy - ry * rng.uniform(0.3, 0.7))
                hand = (sh[0] + side * s * rng.uniform(-0.05, 0.2), sh[1] + s * rng.uniform(-0.15, 0.25))
                if self.crowded and rng.random() < 0.6:
                    # Hanging down over the body and the legs.
                    hand = (sh[0] + side * s * rng.uniform(-0.08, 0.06), cy + ry * rng.uniform(0.6, 1.4))
                r0 = s * rng.uniform(0.025, 0.05)
                rank = 14.0 + i if near else 4.0 + i
                self.add(f"arm{i}_{'near' if near else 'far'}",
                         self.bent(sh, hand, r0, r0 * 0.8, rng.uniform(-0.2, 0.2)), rank)
                if i == 1 and rng.random() < 0.4:
                    prop = (self.blob(hand[0], hand[1] - s * 0.05, s * 0.06, s * 0.09, wobble=0.05)
                            if rng.random() < 0.5 else
                            (np.abs(self.xx - hand[0]) < s * 0.04) & (np.abs(self.yy - hand[1] + s * 0.06) < s * 0.1))
                    self.add("prop", prop, rank + (0.5 if rng.random() < 0.6 else -0.5))
        if rng.random() < 0.6:
            side = rng.choice([-1, 1])
            base = (cx + side * rx * 0.8, cy - ry * rng.uniform(-0.2, 0.4))
            tip = (base[0] + side * s * rng.uniform(0.12, 0.25), base[1] - s * rng.uniform(-0.1, 0.2))
            r0 = s * rng.uniform(0.02, 0.045)
            self.add("tail", self.bent(base, tip, r0, r0 * rng.uniform(0.3, 1.2), rng.uniform(-0.3, 0.3)), 3.0)
        # Neck and head.
        hx = cx + rx * rng.uniform(-0.6, 0.6)
        hr = s * rng.uniform(0.07, 0.13)
        hy = cy - ry - hr * rng.uniform(-0.3, 0.6)
        behind = rng.random() < 0.125
        head_rank = 9.0 if behind else 20.0
        if rng.random() < 0.5:
            self.add("neck", self.capsule((hx, cy - ry * 0.5), (hx, hy), hr * 0.45, hr * 0.35),
                     head_rank - 0.5)
        hrx, hry = hr * rng.uniform(0.9, 1.3), hr * rng.uniform(0.8, 1.1)
        self.add("head", self.blob(hx, hy, hrx, hry, lobes=self.lobes()), head_rank)
        self.frame["head"] = (hx, hy, hrx, hry)
        if rng.random() < 0.85:
            over = rng.random() < 0.25
            for i, side in enumerate((-1, 1)):
                ex, ey = hx + side * hrx * rng.uniform(0.3, 0.8), hy - hry * rng.uniform(0.6, 1.0)
                ear = (self.blob(ex, ey, hr * rng.uniform(0.2, 0.4), hr * rng.uniform(0.35, 0.6),
                                 angle=side * rng.uniform(0, 0.6))
                       if rng.random() < 0.6 else
                       self.capsule((ex, ey + hr * 0.3), (ex + side * hr * 0.3, ey - hr * 0.4),
                                    hr * 0.25, hr * 0.08))
                self.add(f"ear{i}", ear, head_rank + (0.5 if over else -0.6))
        for i, side in enumerate((-1, 1)):
            if rng.random() < 0.8:
                er = hr * rng.uniform(0.14, 0.3)
                ex, ey = hx + side * hrx * rng.uniform(0.25, 0.5), hy - hry * rng.uniform(-0.1, 0.3)
                self.add(f"eye{i}", self.blob(ex, ey, er, er * rng.uniform(1.0, 1.4), wobble=0.03),
                         head_rank + 1.0)
                if rng.random() < 0.4:
                    self.add(f"pupil{i}", self.blob(ex, ey + er * 0.3, er * 0.45, er * 0.5,
                                                    wobble=0.02), head_rank + 1.2)
        if rng.random() < 0.5:
            side = rng.choice([-1, 1])
            self.add("muzzle", self.blob(hx + side * hrx * 0.7, hy + hry * 0.35, hr * 0.45,
                                         hr * 0.3), head_rank + 0.8)
        if rng.random() < 0.3:
            # Horns behind the head, or a tuft of hair over it.
            if rng.random() < 0.5:
                for i, side in enumerate((-1, 1)):
                    base = (hx + side * hrx * 0.4, hy - hry * 0.6)
                    self.add(f"horn{i}", self.capsule(base, (base[0] + side * hr * 0.5, base[1] - hr * 0.9),
                                                      hr * 0.18, hr * 0.05), head_rank - 0.7)
            else:
                self.add("tuft", self.blob(hx, hy - hry * 0.9, hrx * 0.5, hry * 0.35, wobble=0.3,
                                           lobes=self.lobes()),
                         head_rank + 0.9)
        for i in range(int(rng.integers(0, 4))):
            self.add(f"spot{i}", self.blob(cx + rx * rng.uniform(-0.5, 0.5), cy + ry * rng.uniform(-0.5, 0.5),
                                           rx * rng.uniform(0.1, 0.3), ry * rng.uniform(0.1, 0.3)), 10.5 + i / 10)
        if rng.random() < 0.25:
            # A belt or a strap across the body, over it.
            y = cy + ry * rng.uniform(-0.4, 0.4)
            tilt = s * rng.uniform(-0.08, 0.08)
            self.add("belt", self.capsule((cx - rx * 1.1, y - tilt), (cx + rx * 1.1, y + tilt),
                                          s * rng.uniform(0.02, 0.04), s * rng.uniform(0.02, 0.04)), 10.8)
        if self.extra is not None:
            self.resting(cx, cy, rx, ry, (hx, hy, hrx, hry, hr, head_rank))
        # Plants behind the character or in front of its feet.
        for i in range(int(rng.integers(0, 3))):
            front = rng.random() < 0.5
            px = w * rng.uniform(0.1, 0.9)
            py = ground_y + s * rng.uniform(-0.02, 0.06)
            if rng.random() < 0.5:
                plant = self.blob(px, py, s * rng.uniform(0.06, 0.14), s * rng.uniform(0.05, 0.1),
                                  wobble=0.3, lobes=self.lobes())
            else:
                plant = np.zeros((h, w), bool)
                for k in range(int(rng.integers(3, 6))):
                    tip = (px + s * rng.uniform(-0.08, 0.08), py - s * rng.uniform(0.06, 0.16))
                    plant |= self.capsule((px + s * rng.uniform(-0.03, 0.03), py), tip, s * 0.018, 2.0)
            self.add(f"plant{i}", plant, 30.0 + i if front else 1.0 + i)

    def resting(self, cx, cy, rx, ry, head):
        """The ``rest`` style: parts lying over the part below or beside them, each one time
        in two, drawn from the style's own stream: a forelock over the top of the head and
        the ears' bases, a collar or bib under the head (the head over it, its chin line
        unbroken), an arm resting over a leg, teeth over the head's lower outline."""
        rng, s = self.extra, min(self.w, self.h)
        hx, hy, hrx, hry, hr, head_rank = head
        if rng.random() < 0.5:
            self.add("forelock", self.blob(hx + hrx * rng.uniform(-0.2, 0.2), hy - hry * rng.uniform(0.7, 1.0),
                                           hrx * rng.uniform(0.55, 0.95), hry * rng.uniform(0.35, 0.7),
                                           wobble=0.2, lobes=rng.uniform(0.1, 0.25), scallops=True, rng=rng),
                     head_rank + 0.95)
        if rng.random() < 0.5:
            collar = (self.blob(hx, hy + hry * rng.uniform(0.7, 1.1), hrx * rng.uniform(1.0, 1.8),
                                hry * rng.uniform(0.35, 0.8), wobble=0.1, lobes=rng.uniform(0.0, 0.1), rng=rng)
                      if rng.random() < 0.5 else
                      self.capsule((hx - hrx * rng.uniform(0.9, 1.6), hy + hry * rng.uniform(0.7, 1.0)),
                                   (hx + hrx * rng.uniform(0.9, 1.6), hy + hry * rng.uniform(0.7, 1.0)),
                                   hry * rng.uniform(0.2, 0.45), hry * rng.uniform(0.2, 0.45)))
            self.add("collar", collar, head_rank - 0.3 if head_rank > 10.0 else 10.7)
        if self.legs and rng.random() < 0.5:
            top, foot, r0, rank = self.legs[int(rng.integers(len(self.legs)))]
            side = rng.choice([-1, 1])
            shoulder = (cx + side * rx * rng.uniform(0.3, 0.9), cy - ry * rng.uniform(0.0, 0.6))
            hand = top + (foot - top) * rng.uniform(0.3, 0.7) + side * r0 * rng.uniform(-1.0, 1.0)
            r = s * rng.uniform(0.025, 0.05)
            self.add("arm_rest", self.bent(shoulder, hand, r, r * 0.8, rng.uniform(-0.15, 0.15)),
                     max(rank, 10.0) + 1.7)
        if rng.random() < 0.5:
            for i in range(int(rng.integers(1, 4))):
                x = hx + hrx * rng.uniform(-0.6, 0.6)
                y = hy + hry * rng.uniform(0.75, 0.95)
                length = hr * rng.uniform(0.25, 0.5)
                self.add(f"tooth{i}", self.capsule((x, y - length * 0.4), (x + hr * rng.uniform(-0.1, 0.1), y + length),
                                                   hr * rng.uniform(0.1, 0.18), hr * rng.uniform(0.02, 0.06)),
                         head_rank + 1.1 + i / 10)

    def within(self, rng):
        """The ``onto`` style, drawn from ``rng``: parts lying on the head or the body drawn
        within its silhouette, each one time in two: a cap of hair over the top of the head
        (the ears' and horns' bases under its edge), a saddle or patch over an edge of the
        body (where legs, arms and the tail leave it), and the belt, spots, tuft, muzzle and
        eyes cut at the outline of what they lie on."""
        surfaces = {p.name: p for p in self.parts if p.name in ("head", "body")}
        if "head" in surfaces and rng.random() < 0.5:
            hx, hy, hrx, hry = self.frame["head"]
            head = surfaces["head"]
            cap = self.blob(hx + hrx * rng.uniform(-0.3, 0.3), hy - hry * rng.uniform(0.5, 1.0),
                            hrx * rng.uniform(0.7, 1.3), hry * rng.uniform(0.4, 0.8),
                            wobble=0.2, lobes=rng.uniform(0.0, 0.25), scallops=rng.random() < 0.5,
                            rng=rng)
            self.add("cap", cap & head.mask, head.rank + 0.95)
        if "body" in surfaces and rng.random() < 0.5:
            cx, cy, rx, ry = self.frame["body"]
            body = surfaces["body"]
            t = rng.uniform(0, 2 * np.pi)
            patch = self.blob(cx + rx * np.cos(t) * rng.uniform(0.5, 1.0),
                              cy + ry * np.sin(t) * rng.uniform(0.5, 1.0),
                              rx * rng.uniform(0.3, 0.7), ry * rng.uniform(0.3, 0.7),
                              wobble=0.2, lobes=rng.uniform(0.0, 0.2), rng=rng)
            self.add("patch", patch & body.mask, body.rank + 0.6)
        on = {"belt": "body", "tuft": "head", "muzzle": "head", "eye0": "head", "eye1": "head"}
        on.update({p.name: "body" for p in self.parts if p.name.startswith("spot")})
        for p in self.parts:
            if p.name in on and on[p.name] in surfaces and rng.random() < 0.5:
                p.mask = p.mask & surfaces[on[p.name]].mask

    def stack(self):
        rng, w, h = self.rng, self.w, self.h
        s = min(w, h)
        for i in range(int(rng.integers(3, 8))):
            cx, cy = w * rng.uniform(0.25, 0.75), h * rng.uniform(0.25, 0.75)
            rx, ry = s * rng.uniform(0.08, 0.22), s * rng.uniform(0.08, 0.22)
            if rng.random() < 0.3:
                mask = (np.abs(self.xx - cx) < rx) & (np.abs(self.yy - cy) < ry)
            else:
                mask = self.blob(cx, cy, rx, ry, angle=rng.uniform(0, np.pi), wobble=rng.uniform(0, 0.3),
                                 lobes=self.lobes())
            self.add(f"piece{i}", mask, float(i))


def _smooth_noise(rng, n, scale):
    """Smooth noise in [-1, 1] along ``n`` samples, varying over about ``scale`` samples."""
    knots = max(int(n / max(scale, 1.0)) + 2, 2)
    values = rng.uniform(-1, 1, knots)
    return np.interp(np.linspace(0, knots - 1, n), np.arange(knots), values)


def _outlines(mask):
    """Closed outline polylines ``[x, y]`` of a mask (supersampled pixels), one per piece."""
    padded = np.pad(mask.astype(np.float32), 1)
    return [c[:, ::-1] - 1.0 for c in find_contours(padded, 0.5) if len(c) > 8]


def _resample(line, step):
    seg = np.hypot(*np.diff(line, axis=0).T)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    n = max(int(arc[-1] / step), 2)
    t = np.linspace(0, arc[-1], n)
    return np.stack([np.interp(t, arc, line[:, 0]), np.interp(t, arc, line[:, 1])], 1)


def _strokes(outline, rng, used, width):
    """The strokes that draw one closed outline: ``[(points, radii)]``."""
    pts = _resample(outline, 1.0)
    n = len(pts)
    if "taper" in used:
        k = int(rng.integers(1, 5))
        cuts = np.sort(rng.choice(n, k, replace=False)) if n > 4 * k else np.array([0])
        pieces = []
        for i, c in enumerate(cuts):
            end = cuts[(i + 1) % len(cuts)] + (n if i + 1 == len(cuts) else 0)
            over = int(rng.integers(0, int(2 * width) + 2))
            idx = np.arange(c - over, end + over) % n
            pieces.append(pts[idx])
    else:
        pieces = [np.concatenate([pts, pts[:1]])]
    out = []
    for p in pieces:
        m = len(p)
        r = np.full(m, width / 2.0)
        if "width" in used:
            r *= 1.0 + 0.45 * _smooth_noise(rng, m, rng.uniform(20, 80) * _SS)
        if "taper" in used:
            t = np.minimum(np.arange(m), np.arange(m)[::-1]) / max(rng.uniform(6, 20) * width, 1.0)
            r *= np.clip(0.2 + t, 0.2, 1.0)
        if "gaps" in used and rng.random() < 0.5:
            keep = np.ones(m, bool)
            for _ in range(int(rng.integers(1, 3))):
                at, length = int(rng.integers(0, m)), int(rng.uniform(1.0, 3.5) * width)
                keep[at:at + length] = False
            out += [(p[s], r[s]) for s in ndimage.find_objects(ndimage.label(keep)[0])]
            continue
        out.append((p, r))
    if "sketchy" in used:
        again = []
        for p, r in out:
            m = len(p)
            wob = width * rng.uniform(0.6, 1.5)
            off = np.stack([_smooth_noise(rng, m, 60 * _SS), _smooth_noise(rng, m, 60 * _SS)], 1) * wob
            again.append((p + off, r * rng.uniform(0.6, 1.0)))
        out += again
    return out


def _paint(parts, rng, used, width):
    """Ink coverage (supersampled, float in [0, 1]) of the parts painted back to front."""
    h, w = parts[0].mask.shape
    ink = np.zeros((h, w), np.float32)
    shade = 0.75 + 0.2 * rng.random() if "marker" in used else 1.0
    under = np.zeros((h, w), bool)  # the parts painted so far, the ground excepted
    for part in parts:
        fade = _fading(part, under, rng, width) if "fade" in used else None
        if part.name != "ground":
            under |= part.mask
        blank = part.mask
        if "gaps" in used and rng.random() < 0.6:
            blank = ndimage.binary_dilation(blank, iterations=max(int(rng.uniform(0.5, 2.0) * width), 1))
        elif "overshoot" in used and rng.random() < 0.6:
            blank = ndimage.binary_erosion(blank, iterations=max(int(rng.uniform(0.5, 2.0) * width), 1))
        ink[blank] = 0.0
        layer = Image.new("L", (w, h), 0)
        draw = ImageDraw.Draw(layer)
        for outline in _outlines(part.mask):
            for pts, radii in _strokes(outline, rng, used, width):
                if fade is not None:
                    radii = radii * _faded(fade, pts)
                for (x, y), r in zip(pts, radii):
                    if r <= 0.0:
                        continue
                    r = max(float(r), 0.5)
                    draw.ellipse((x - r, y - r, x + r, y + r), fill=255)
        ink = np.maximum(ink, np.asarray(layer, np.float32) / 255.0 * shade)
    return ink


def _fading(part, under, rng, width):
    """For a part whose outline is to fade where it runs over the parts painted before it
    (one time in two): the depth into those parts, and how deep the strokes reach; None
    when it keeps its outline."""
    if rng.random() >= 0.5 or not (part.mask & under).any():
        return None
    depth = ndimage.distance_transform_edt(under)
    reach = float(rng.uniform(0.5, 4.0)) * width
    outline = part.mask & ~ndimage.binary_erosion(part.mask)
    # Only a part reaching out of the parts behind (a limb, a head): the scribbles tell it
    # from them. An ear or an eye lying on a head keeps its line.
    if (depth[outline] > 0).mean() > 0.6:
        return None
    return depth, reach


def _faded(fade, pts):
    """Radius factor of stroke points ``[x, y]`` tapering to 0 over the last half of the
    reach into the parts behind (0 beyond it)."""
    depth, reach = fade
    h, w = depth.shape
    d = depth[np.clip(np.round(pts[:, 1]).astype(int), 0, h - 1),
              np.clip(np.round(pts[:, 0]).astype(int), 0, w - 1)]
    return np.clip((reach - d) / (0.5 * reach), 0.0, 1.0)


def _finish(ink, rng, used):
    """The grey drawing (uint8, 255 paper) from the supersampled ink."""
    h, w = ink.shape[0] // _SS, ink.shape[1] // _SS
    blocks = ink[:h * _SS, :w * _SS].reshape(h, _SS, w, _SS)
    cover = blocks.mean((1, 3)) if "antialias" in used else (blocks.mean((1, 3)) >= 0.5) * blocks.max((1, 3))
    gray = 1.0 - cover
    if "paper" in used:
        yy, xx = np.mgrid[:h, :w] / max(h, w)
        shading = 1.0 - rng.uniform(0.05, 0.25) * (0.5 + 0.5 * np.sin(rng.uniform(1, 4) * xx
                                                                      + rng.uniform(1, 4) * yy + rng.uniform(0, 6)))
        ink_level = rng.uniform(0.05, 0.3)
        gray = shading * (1.0 - cover * (1.0 - ink_level))
        gray = ndimage.gaussian_filter(gray, rng.uniform(0.4, 1.0))
        gray = gray + rng.normal(0, rng.uniform(0.01, 0.04), gray.shape)
    return np.clip(np.round(gray * 255), 0, 255).astype(np.uint8)


def _visible(parts, h, w):
    """The true segmentation: for every pixel, the part painted last there (at pixel centres)."""
    labels = np.full((h, w), -1, np.int32)
    off = _SS // 2
    for i, p in enumerate(parts):
        labels[p.mask[off::_SS, off::_SS][:h, :w]] = i
    return labels


def _relations(parts):
    """``(front, back)`` indices of every pair of parts whose shapes overlap and both show."""
    out = []
    for i in range(len(parts)):
        for j in range(i):
            both = parts[i].mask & parts[j].mask
            if both.sum() >= 20 * _SS * _SS:
                out.append((i, j))
    return out


def _annotation(labels, names, relations, size, width, rng):
    """The inkray annotation of a generated drawing: scribbles and order entries."""
    h, w = labels.shape
    margin = width + 3.0
    # Depth of every pixel in its own part (or the paper): distance to another label.
    padded = np.pad(labels, 1, constant_values=-2)
    core = padded[1:-1, 1:-1]
    edge = ((padded[:-2, 1:-1] != core) | (padded[2:, 1:-1] != core)
            | (padded[1:-1, :-2] != core) | (padded[1:-1, 2:] != core))
    depth = ndimage.distance_transform_edt(~edge)
    regions, shown = [], set()
    for i in rng.permutation(len(names)):  # annotations list their regions in any order
        lines = []
        pieces, n = ndimage.label(labels == i)
        for k, box in enumerate(ndimage.find_objects(pieces), 1):
            # Off the ink: at a margin from the outline, or for a thin piece just off it.
            lines += (_scribbles(pieces[box] == k, depth[box], margin, box)
                      or _scribbles(pieces[box] == k, depth[box], 0.5 * width, box))
        if lines:
            regions.append({"name": names[i], "scribbles": lines})
            shown.add(int(i))
    background = []
    # The paper apart where a narrow neck joins it, so that every pocket of it has a scribble.
    pieces, n = ndimage.label((labels < 0) & (depth > 0.5 * width + 2.0))
    for k, box in enumerate(ndimage.find_objects(pieces), 1):
        background += _scribbles(pieces[box] == k, depth[box], 0.0, box)
    order = []
    for f, b in relations:
        if f in shown and b in shown:
            entry = _entry(labels, depth, f, b, margin)
            if entry is not None:
                order.append(entry)
    return {"format": "inkray-annotations", "version": 1, "drawing": "drawing.png",
            "size": [int(w), int(h)], "regions": regions, "background": background,
            "order": order}


def _scribbles(piece, dist, margin, box):
    """Polylines along the middle of one visible piece (a crop at ``box``): through the
    deepest pixel of every part of a slice across its main axis (five slices, more for a
    piece longer than 200 pixels), a point joined to a line where the straight step to it
    stays in the piece (a bent piece, the paper round a character: several lines); none
    when the piece is too thin."""
    inner = piece & (dist > margin + 1.5)
    if inner.sum() < 6:
        return []
    ys, xs = np.nonzero(inner)
    pts = np.stack([xs, ys], 1).astype(float)
    centre = pts.mean(0)
    axis = np.linalg.svd(pts - centre, full_matrices=False)[2][0]
    t = (pts - centre) @ axis
    cuts = np.linspace(t.min(), t.max(), max(5, int((t.max() - t.min()) / 40.0)) + 1)
    runs = []
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        sel = np.zeros_like(inner)
        sel[ys[(t >= lo) & (t <= hi)], xs[(t >= lo) & (t <= hi)]] = True
        parts, n = ndimage.label(sel, structure=np.ones((3, 3)))
        if not n:
            continue
        # The deepest pixel of each part of the slice: a scribble along the medial line.
        deepest = ndimage.maximum_position(np.where(sel, dist, -1.0), parts, range(1, n + 1))
        sizes = ndimage.sum(sel, parts, range(1, n + 1))
        for (y, x), size in zip(deepest, sizes):
            if size < 6:
                continue
            p = np.array([x, y], float)
            for run in runs:
                q = run[-1]
                k = int(np.ceil(np.hypot(*(p - q)))) + 1
                line_x, line_y = np.linspace(q[0], p[0], k), np.linspace(q[1], p[1], k)
                if inner[np.round(line_y).astype(int), np.round(line_x).astype(int)].all():
                    run.append(p)
                    break
            else:
                runs.append([p])
    y0, x0 = box[0].start, box[1].start
    return [[[float(x + x0), float(y + y0)] for x, y in run] for run in runs]


def _entry(labels, depth, f, b, margin):
    """An order entry: a deep pixel of the front part and one of the back part, near their contact."""
    near_b = ndimage.binary_dilation(labels == b, iterations=2)
    contact = np.argwhere((labels == f) & near_b)
    if not len(contact):
        return None
    mid = contact[len(contact) // 2]
    points = []
    for x in (f, b):
        cand = np.argwhere((labels == x) & (depth > margin + 1.0))
        if not len(cand):
            return None
        y, xx = cand[np.argmin(np.hypot(*(cand - mid).T))]
        points.append([float(xx), float(y)])
    return {"front": points[0], "back": points[1]}


def write(g, folder):
    """Write ``drawing.png`` and ``drawing.inkray.json`` of a :class:`Generated` into ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    Image.fromarray(g.gray).save(folder / "drawing.png")
    (folder / "drawing.inkray.json").write_text(json.dumps(g.annotation, indent=1) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--count", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--without", default="", help="comma-separated styles never used")
    args = ap.parse_args(argv)
    without = [s for s in args.without.split(",") if s]
    styles = [s for s in STYLES if s not in without]
    for seed in range(args.seed, args.seed + args.count):
        g = generate(seed, styles=styles)
        write(g, args.out / f"gen_{seed}")
        print(f"gen_{seed}: {len(g.names)} parts, {len(g.relations)} relations, styles {','.join(g.styles)}")


if __name__ == "__main__":
    main()
