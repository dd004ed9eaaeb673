"""Make the pictures of docs/pipelines.md: the turtle's layer stack and its sprite maps.

Run from the repository root::

    python docs/make_pipelines.py

One ReliefChain gives both (what ``inkray layers`` and ``inkray maps`` write);
the pictures go to docs/images/pipelines/.
"""

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from inkray.chain import ReliefChain
from inkray.examples import example_path
from inkray.formats.labels import label_palette
from inkray.formats.sprite_maps import sprite_maps
from inkray.input.loading import load_input
from inkray.relief.cutout import cut_out

OUT = Path(__file__).resolve().parent / "images" / "pipelines"
_TILE = 220
_CHECK = 8  # px squares of the transparency checkerboard


def _checker(w, h):
    y, x = np.mgrid[0:h, 0:w]
    grey = np.where(((x // _CHECK) + (y // _CHECK)) % 2, 235, 205).astype(np.uint8)
    return Image.fromarray(np.repeat(grey[..., None], 3, axis=2)).convert("RGBA")


def _tile(rgba, label, box=None):
    """An RGBA image over a checkerboard, fitted into a square tile, with a caption."""
    image = Image.fromarray(rgba, "RGBA")
    if box is not None:
        image = image.crop(box)
    scale = _TILE / max(image.size)
    image = image.resize((max(1, round(image.width * scale)), max(1, round(image.height * scale))),
                         Image.LANCZOS)
    tile = _checker(_TILE, _TILE + 22)
    tile.alpha_composite(image, ((_TILE - image.width) // 2, (_TILE - image.height) // 2))
    ImageDraw.Draw(tile).text((6, _TILE + 5), label, fill=(0, 0, 0, 255))
    return tile


def _row(tiles):
    out = Image.new("RGBA", (len(tiles) * (_TILE + 6) - 6, tiles[0].height), (255, 255, 255, 255))
    for k, t in enumerate(tiles):
        out.alpha_composite(t, (k * (_TILE + 6), 0))
    return out.convert("RGB")


def _box(mask, margin=6):
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    h, w = mask.shape
    return (max(cols[0] - margin, 0), max(rows[0] - margin, 0), min(cols[-1] + margin + 1, w),
            min(rows[-1] + margin + 1, h))


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    ann, drawing = load_input(example_path("turtle"))
    chain = ReliefChain(ann, drawing)
    character = chain.segmentation.labels >= 0
    box = _box(character)
    w, h = drawing.size

    stack = cut_out(chain.completion, chain.relations, drawing)
    tiles = []
    for layer in stack.layers:  # back to front, each on the full canvas, hidden part tinted
        canvas = np.zeros((h, w, 4), np.uint8)
        y0, y1, x0, x1 = layer.box
        rgba = layer.rgba.copy()
        tint = layer.hidden & (rgba[..., :3].mean(axis=2) > 96)
        rgba[tint, :3] = (rgba[tint, :3] * [0.75, 0.85, 1.0]).astype(np.uint8)
        canvas[y0:y1, x0:x1] = rgba
        tiles.append(_tile(canvas, f"{len(tiles)}: {layer.name}", box))
    tiles.append(_tile(stack.flatten(), "flattened", box))
    _row(tiles).save(OUT / "turtle-layers.png", optimize=True)

    seg = chain.segmentation
    maps = sprite_maps(chain.relief, seg.labels, seg.names)
    alpha = np.where(character, 255, 0).astype(np.uint8)

    def rgba_of(rgb):
        return np.dstack([np.where(character[..., None], rgb, 0).astype(np.uint8), alpha])

    normal = np.rint((maps.normal + 1) * 127.5)
    height = np.nan_to_num(maps.height)
    lo, hi = height[character].min(), height[character].max()
    grey = np.rint((height - lo) / max(hi - lo, 1e-9) * 255)
    ao = np.rint(maps.ao * 255)
    parts = label_palette(len(seg.names))[maps.parts + 1]
    tiles = [_tile(rgba_of(normal), "normal.png (OpenGL)", box),
             _tile(rgba_of(np.repeat(grey[..., None], 3, 2)), "height.png", box),
             _tile(rgba_of(np.repeat(ao[..., None], 3, 2)), "ao.png", box),
             _tile(rgba_of(parts), "parts.png", box)]
    _row(tiles).save(OUT / "turtle-maps.png", optimize=True)
    print(f"wrote {OUT / 'turtle-layers.png'} and {OUT / 'turtle-maps.png'}")


if __name__ == "__main__":
    main()
