"""The close-ups of docs/relief.md: shaded reliefs of the donkey's hip, the fox's outline and open joins.

Usage::

    python docs/make_relief_figures.py --suffix after

Each picture is the ``shade`` rendering (``inkray render --mode shade``) of
the bundled drawing's relief, cropped and enlarged 2x without smoothing so
that facets and steps stay visible. Run on an earlier version of inkray with
``--suffix before`` for the comparison pictures. The open-join pictures are
of the frog and the turtle annotated without their ``graft`` entries (their
legs' open tops found from the drawing).
"""

import argparse
import dataclasses
from pathlib import Path

import numpy as np
from PIL import Image

from inkray.chain import ReliefChain
from inkray.input.loading import load_input
from inkray.view.rendering import render
from inkray.view.shading import over_white

ROOT = Path(__file__).resolve().parents[1]
OUT = Path(__file__).resolve().parent / "images" / "relief"
# (drawing, picture name, crop box (x0, y0, x1, y1) in drawing pixels, keep the boundaries)
CROPS = (("donkey", "donkey-hip", (720, 580, 1020, 820), True),
         ("fox", "fox-outline", (40, 20, 290, 270), True),
         ("frog", "frog-open-join", (100, 540, 460, 760), False),
         ("turtle", "turtle-open-join", (150, 280, 270, 390), False))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suffix", default="after", help="picture name suffix (before, after)")
    parser.add_argument("--names", help="comma-separated picture names (default: all)")
    args = parser.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    for name, picture, box, boundaries in CROPS:
        if args.names and picture not in args.names.split(","):
            continue
        ann, drawing = load_input(ROOT / "examples" / name / "drawing.inkray.json")
        if not boundaries:
            ann = dataclasses.replace(ann, boundaries=[])
        shaded = np.rint(255 * over_white(render(ReliefChain(ann, drawing).relief,
                                                  mode="shade").image)).astype(np.uint8)
        x0, y0, x1, y1 = box
        crop = Image.fromarray(shaded[y0:y1, x0:x1])
        scale = 2 if (x1 - x0) > 200 else 4
        crop = crop.resize((scale * (x1 - x0), scale * (y1 - y0)), Image.NEAREST)
        crop.save(OUT / f"{picture}-{args.suffix}.png", optimize=True)


if __name__ == "__main__":
    main()
