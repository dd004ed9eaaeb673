"""Make docs/images/order-drawings.png: generated drawings with a known depth order.

Run from the repository root::

    python docs/make_order_drawings.py

Six drawings of ``benchmarks/order_drawings.py`` (seeds 1 to 6, every style
allowed), each above its true parts coloured back (dark) to front (light),
with the styles it was drawn in. The learned order model is trained on
drawings like these (``benchmarks/train_order.py``).
"""

import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS.parent / "benchmarks"))

from order_drawings import generate  # noqa: E402

OUT = DOCS / "images" / "order-drawings.png"
SIDE = 220


def main():
    tiles = []
    for seed in range(1, 7):
        g = generate(seed, size=(360, 360))
        drawing = Image.fromarray(g.gray).convert("RGB").resize((SIDE, SIDE), Image.LANCZOS)
        depth = np.full(g.labels.shape + (3,), 255, np.uint8)
        # Painted back to front, so the label index is the depth rank.
        for i in range(len(g.names)):
            shade = int(60 + 170 * i / max(len(g.names) - 1, 1))
            depth[g.labels == i] = (shade, int(shade * 0.8), 255 - shade // 2)
        depth[g.gray < 128] = 0
        parts = Image.fromarray(depth).resize((SIDE, SIDE), Image.NEAREST)
        tile = Image.new("RGB", (SIDE, 2 * SIDE + 16), "white")
        tile.paste(drawing, (0, 0))
        tile.paste(parts, (0, SIDE))
        ImageDraw.Draw(tile).text((4, 2 * SIDE + 2), ", ".join(g.styles) or "plain", fill="black")
        tiles.append(tile)
    sheet = Image.new("RGB", (len(tiles) * (SIDE + 6), 2 * SIDE + 16), "white")
    for k, tile in enumerate(tiles):
        sheet.paste(tile, (k * (SIDE + 6), 0))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    sheet.save(OUT, optimize=True)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
