"""Make docs/images/frog-shared-outline.png (docs/regions.md, docs/pose.md).

The frog's body completed under its hind leg: by the diffusion alone (left),
with the silhouette shared at the graft's end (middle), and the frog posed
with that completion, its hind leg swung 20 degrees about the graft (right).

    python docs/make_shared_outline_figure.py
"""

from pathlib import Path

import numpy as np
from PIL import Image

from inkray.chain import ReliefChain
from inkray.input.loading import load_input
from inkray.relief.completion import complete_regions
from inkray.view.posed import PosedDrawing

ROOT = Path(__file__).resolve().parents[1]
WIDTH = 400  # px per panel
# The hind leg's swing: two pins on the body and the leg's toe, turned about the graft.
PINS = np.array([[802.0, 35.0], [439.0, 1068.0]])
TOE, GRAFT = np.array([632.0, 1192.0]), np.array([269.6, 631.2])


def _overlay(drawing, completion, body):
    """The drawing with the body's hidden area tinted blue."""
    rgb = np.asarray(drawing.rgb, float).copy()
    hidden = completion.completed(body) & (completion.labels != body)
    rgb[hidden] = 0.55 * rgb[hidden] + 0.45 * np.array([60.0, 90.0, 255.0])
    return Image.fromarray(rgb.astype(np.uint8))


def main():
    ann, drawing = load_input(ROOT / "examples" / "frog" / "drawing.inkray.json")
    chain = ReliefChain(ann, drawing)
    shared = chain.completion
    body = shared.names.index("body")
    alone = complete_regions(shared.labels, names=shared.names).ordered(chain.relations)
    a = np.radians(20.0)
    turn = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    handles = np.vstack([PINS, TOE])
    posed = PosedDrawing(chain.relief, shared, chain.relations, drawing, handles,
                         boundaries=ann.boundaries)
    x = posed.positions(np.vstack([PINS, GRAFT + turn @ (TOE - GRAFT)]), iterations=8)
    rgba = Image.fromarray(posed.image(x))
    swung = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
    swung.alpha_composite(rgba)
    panels = [_overlay(drawing, alone, body), _overlay(drawing, shared, body),
              swung.convert("RGB")]
    w, h = panels[0].size
    size = (WIDTH, round(h * WIDTH / w))
    sheet = Image.new("RGB", (3 * WIDTH, size[1]), (255, 255, 255))
    for k, panel in enumerate(panels):
        sheet.paste(panel.resize(size, Image.LANCZOS), (k * WIDTH, 0))
    out = ROOT / "docs" / "images" / "frog-shared-outline.png"
    sheet.save(out)
    print(out)


if __name__ == "__main__":
    main()
