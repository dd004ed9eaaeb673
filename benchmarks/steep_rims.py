"""Steep faces: what the front view loses to the paper colour, what a three-quarter view smears.

    python benchmarks/steep_rims.py [DRAWING ...]      (default: turtle fish snowman cat,
                                                        then the held-out frog fox dragon)

The exporters give faces turned more than arccos(t) from the viewer the part's paper
colour (``inkray.formats.meshes._STEEP``, t = 0.1). For each bundled drawing this prints
two tables:

- per threshold t, the share of the relief's front-view pixels on faces steeper than
  arccos(t) and the share of the drawing's ink there (ink as the exporter and the
  renderer separate it): what the front view would lose at that threshold;
- the three-quarter views from either side (yaw -45 and 45 degrees, pitch 30
  degrees, one output pixel per drawing pixel, orthographic), summed: the visible
  pixels, the *streaked* pixels (on a face that keeps the drawing, whose texture is
  magnified more than 3 times along some direction of the view, and that show ink
  there) and the 99th percentile of the magnification over the visible pixels that
  keep the drawing (the larger side's); then the front view's ink on faces that keep
  the drawing (*ink kept*, of the ink the front view covers) and their count.
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from inkray.chain import ReliefChain  # noqa: E402
from inkray.examples import example_path  # noqa: E402
from inkray.formats.meshes import _FRONT, _face_kinds  # noqa: E402
from inkray.input.loading import load_input  # noqa: E402
from inkray.view.rasterization import rasterize  # noqa: E402

THRESHOLDS = (0.1, 0.15, 0.2, 0.25, 0.3)
TUNED = ("turtle", "fish", "snowman", "cat")
HELD_OUT = ("frog", "fox", "dragon")
YAW, PITCH = 45.0, 30.0  # degrees: the three-quarter view
STREAK = 3.0  # texture magnification along the view beyond which the drawing smears


def _ink(relief):
    """Per drawing pixel: ink, as the exporter and the renderer separate it."""
    value = relief.texture.max(axis=2).astype(float)
    return value < 0.6 * np.percentile(value, 95)


def view_matrix(yaw=YAW, pitch=PITCH):
    """Rotation of the relief's frame (x right, y down, z toward the viewer): turned by
    ``yaw`` about the vertical, then tilted by ``pitch`` to look down on it."""
    a, b = np.radians(yaw), np.radians(pitch)
    turn = np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(b), np.sin(b)], [0.0, -np.sin(b), np.cos(b)]])
    return tilt @ turn


def magnification(part, rotation):
    """Per face: the largest stretch of the drawing (texture pixels) on the view's screen."""
    v = np.asarray(part.vertices, float)
    tex = v[:, :2] if part.texcoords is None else np.asarray(part.texcoords, float)[:, :2]
    f = np.asarray(part.faces, np.int64)
    screen = (v @ rotation.T)[:, :2]
    t = np.stack([tex[f[:, 1]] - tex[f[:, 0]], tex[f[:, 2]] - tex[f[:, 0]]], axis=2)
    s = np.stack([screen[f[:, 1]] - screen[f[:, 0]], screen[f[:, 2]] - screen[f[:, 0]]], axis=2)
    ok = np.abs(np.linalg.det(t)) > 1e-12
    out = np.full(len(f), np.inf)  # a face without texture area smears whatever it shows
    jac = s[ok] @ np.linalg.inv(t[ok])
    out[ok] = np.linalg.svd(jac, compute_uv=False)[:, 0]
    return out


def three_quarter(relief, yaw=YAW, pitch=PITCH):
    """``(visible, streaked, p99)``: pixels of the three-quarter view, those on drawing faces
    magnified more than ``STREAK`` times that show ink, and the 99th percentile of the
    magnification over the visible drawing pixels."""
    rotation = view_matrix(yaw, pitch)
    corners = np.concatenate([np.asarray(p.vertices, float) for p in relief.parts]) @ rotation.T
    low, high = corners.min(axis=0), corners.max(axis=0)
    view = np.column_stack([rotation, -low])
    size = tuple(int(np.ceil(x)) + 2 for x in (high - low)[:2])
    raster = rasterize(relief, size=size, scale=1.0, offset=(0.5, 0.5), view=view)
    seen = raster.mask
    mag = np.zeros(seen.shape)
    textured = np.zeros(seen.shape, bool)
    for i, part in enumerate(relief.parts):
        here = seen & (raster.part == i)
        face = raster.face[here]
        mag[here] = magnification(part, rotation)[face]
        textured[here] = (_face_kinds(part.vertices, part.faces) == _FRONT)[face]
    w, h = relief.size
    xy = raster.position[..., :2]
    col = np.clip(np.rint(xy[..., 0]), 0, w - 1).astype(np.intp)
    row = np.clip(np.rint(xy[..., 1]), 0, h - 1).astype(np.intp)
    ink = _ink(relief)[row, col]
    streaked = seen & textured & (mag > STREAK) & ink
    shown = mag[seen & textured]
    return int(seen.sum()), int(streaked.sum()), float(np.percentile(shown, 99)) if len(shown) else 0.0


def ink_kept(relief):
    """``(share, count)``: front-view ink pixels on faces that keep the drawing, of the ink the
    front view covers, and their number."""
    raster = rasterize(relief, size=relief.size, scale=1.0, offset=(0.0, 0.0))
    seen = raster.mask & _ink(relief)
    kept = np.zeros(seen.shape, bool)
    for i, part in enumerate(relief.parts):
        here = seen & (raster.part == i)
        kept[here] = (_face_kinds(part.vertices, part.faces) == _FRONT)[raster.face[here]]
    return kept.sum() / max(int(seen.sum()), 1), int(kept.sum())


def shares(relief, threshold):
    """``(pixels, ink)``: shares of the front view's pixels and ink pixels on faces steeper
    than ``arccos(threshold)``."""
    raster = rasterize(relief, size=relief.size, scale=1.0, offset=(0.0, 0.0))
    ink = _ink(relief)
    seen = raster.mask
    steep = np.zeros(seen.shape, bool)
    for i, part in enumerate(relief.parts):
        q = part.vertices[part.faces] * [1.0, -1.0, 1.0]
        n = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
        face = n[:, 2] < threshold * np.linalg.norm(n, axis=1)
        here = seen & (raster.part == i)
        steep[here] = face[raster.face[here]]
    return steep[seen].mean(), steep[seen & ink].sum() / max(int((seen & ink).sum()), 1)


def main(names):
    reliefs = {}
    for group in ([n for n in names if n not in HELD_OUT], [n for n in names if n in HELD_OUT]):
        if not group:
            continue
        print("\n| drawing | " + " | ".join(f"t = {t}: pixels, ink" for t in THRESHOLDS) + " |")
        print("| --- " * (len(THRESHOLDS) + 1) + "|")
        for name in group:
            relief = reliefs[name] = ReliefChain(*load_input(example_path(name))).relief
            cells = [f"{100 * p:.2f} %, {100 * k:.1f} %"
                     for p, k in (shares(relief, t) for t in THRESHOLDS)]
            print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
        print(f"\n| drawing | 3/4 pixels | streaked (> {STREAK:g}x, ink) | magnification p99 "
              "| front ink kept | ink pixels kept |")
        print("| --- | --- | --- | --- | --- | --- |")
        for name in group:
            sides = [three_quarter(reliefs[name], yaw=yaw) for yaw in (-YAW, YAW)]
            seen, streaked = (sum(side[j] for side in sides) for j in (0, 1))
            p99 = max(side[2] for side in sides)
            share, count = ink_kept(reliefs[name])
            print(f"| {name} | {seen} | {streaked} | {p99:.2f} | {100 * share:.2f} % | {count} |",
                  flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or [*TUNED, *HELD_OUT])
