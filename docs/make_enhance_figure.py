"""Make the picture of docs/render.md's depth-buffer enhancement section.

Run from the repository root::

    python docs/make_enhance_figure.py

Two bundled drawings' reliefs in ``render --mode enhance``: strength 0 (the
plain drawing on the relief), the defaults (strength 1, radius 8) and a
strong setting (strength 3, radius 16), side by side over white; written to
docs/images/render-enhance.png.
"""

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from inkray.chain import build_relief
from inkray.examples import example_path
from inkray.input.loading import load_input
from inkray.view.rendering import render

OUT = Path(__file__).resolve().parent / "images" / "render-enhance.png"
SETTINGS = ((0.0, 8.0), (1.0, 8.0), (3.0, 16.0))
_TILE = 300


def _tile(rgba, label):
    a = rgba[..., 3:4] / 255.0
    rgb = np.rint(rgba[..., :3] * a + 255 * (1 - a)).astype(np.uint8)
    rows, cols = np.flatnonzero(a[..., 0].any(axis=1)), np.flatnonzero(a[..., 0].any(axis=0))
    image = Image.fromarray(rgb[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1])
    image.thumbnail((_TILE - 10, _TILE - 10), Image.LANCZOS)
    tile = Image.new("RGB", (_TILE, _TILE + 20), (255, 255, 255))
    tile.paste(image, ((_TILE - image.width) // 2, (_TILE - image.height) // 2))
    ImageDraw.Draw(tile).text((6, _TILE + 4), label, fill=(0, 0, 0))
    return tile


def main():
    rows = []
    for name in ("turtle", "cat"):
        relief = build_relief(*load_input(example_path(name))).relief
        rows.append([_tile(render(relief, mode="enhance", enhance_strength=s,
                                  enhance_radius=r).image,
                           f"{name}: strength {s:g}, radius {r:g}") for s, r in SETTINGS])
    out = Image.new("RGB", (len(SETTINGS) * _TILE, len(rows) * (_TILE + 20)), (255, 255, 255))
    for i, row in enumerate(rows):
        for j, tile in enumerate(row):
            out.paste(tile, (j * _TILE, i * (_TILE + 20)))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    out.save(OUT, optimize=True)
    print(OUT)


if __name__ == "__main__":
    main()
