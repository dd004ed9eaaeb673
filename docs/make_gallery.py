"""Make docs/gallery.md: every bundled drawing's overlay, labels, depth map and relief.

Run from the repository root::

    python docs/make_gallery.py [--width 320]

Each drawing goes through one ReliefChain (segmented once); the pictures are
written to docs/images/gallery/ as small PNGs, the page to docs/gallery.md.
"""

import argparse
import io
from pathlib import Path

import numpy as np
from PIL import Image

from inkray.chain import ReliefChain
from inkray.errors import InkrayError
from inkray.examples import EXAMPLES, example_path
from inkray.formats.labels import label_image
from inkray.input.loading import load_input
from inkray.view.rendering import output_size, render
from inkray.view.shading import over_white

DOCS = Path(__file__).resolve().parent
OUT = DOCS / "images" / "gallery"


def _thumbnail(image, width):
    image = image.convert("RGB")
    height = max(1, round(image.height * width / image.width))
    return image.resize((width, height), Image.LANCZOS)


def _save(image, name, width):
    buf = io.BytesIO()
    # 32 colours are plenty for line art and keep the page light (a few
    # hundred KB for all drawings; the photographed paper costs the most).
    _thumbnail(image, width).quantize(32).save(buf, format="PNG", optimize=True)
    (OUT / name).write_bytes(buf.getvalue())
    return f"images/gallery/{name}"


def _depth_grey(depth, ink):
    """Depth as grey (near bright), the ink multiplied on top."""
    lo, hi = float(depth.min()), float(depth.max())
    grey = (depth - lo) / (hi - lo) if hi > lo else np.ones_like(depth)
    return np.uint8(np.rint(255 * (0.15 + 0.85 * grey)[..., None] * ink))


def _pictures(name, width):
    """The four pictures of one drawing, and a note per stage that failed."""
    ann, drawing = load_input(example_path(name))
    chain = ReliefChain(ann, drawing)
    ink = np.asarray(drawing.rgb, float) / 255.0
    overlay = Image.open(example_path(name).parent / "overlay.png")
    cells, notes = {"annotations": _save(overlay, f"{name}-overlay.png", width)}, []

    def labels():
        seg = chain.segmentation
        rgb = np.asarray(label_image(seg.labels, len(seg.names)).convert("RGB"), float)
        return Image.fromarray(np.uint8(rgb * ink))

    def depth_map():
        return Image.fromarray(_depth_grey(chain.depth_map.depth, ink))

    def relief():
        size = output_size(ann.size, width=min(2 * width, ann.size[0]))
        shaded = render(chain.relief, mode="shade", size=size)
        return Image.fromarray(np.uint8(np.rint(over_white(shaded.image) * 255)))

    # A stage that fails keeps the pictures of the stages that worked.
    for key, make in (("labels", labels), ("depth map", depth_map), ("relief", relief)):
        try:
            cells[key] = _save(make(), f"{name}-{key.split()[0]}.png", width)
        except InkrayError as e:
            cells[key] = None
            notes.append(f"{key}: {e}")
    return cells, notes, ann, chain


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=320, help="thumbnail width (default 320)")
    args = parser.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    lines = ["# Gallery", "",
             "Every bundled drawing (`examples/`, attribution in `examples/SOURCES.md`) "
             "through the whole method: the annotations drawn over the drawing, the "
             "segmentation (labels times the ink), the exact depth map of the `order`/`equal` "
             "entries (grey, near bright, ink on top) and the relief (`inkray render --mode "
             "shade`).", "",
             "Made by `python docs/make_gallery.py`.", ""]
    for name in EXAMPLES:
        cells, notes, ann, chain = _pictures(name, args.width)
        w, h = ann.size
        predicted = ("" if cells["relief"] is None else
                     f"; {sum(r.source == 'predicted' for r in chain.relations)} depth relations "
                     "predicted beyond the file's")
        lines += [f"## {name}", "",
                  f"{w}x{h}, {len(ann.regions)} regions, {len(ann.order)} order and "
                  f"{len(ann.equal)} equal entries, {len(ann.boundaries)} boundaries{predicted}.", "",
                  "| " + " | ".join(cells) + " |",
                  "| " + " | ".join("---" for _ in cells) + " |",
                  "| " + " | ".join("(failed)" if v is None else f"![{name} {k}]({v})"
                                    for k, v in cells.items()) + " |",
                  ""]
        lines += [f"Failed: {note}" for note in notes] + ([""] if notes else [])
        print(f"{name}: {'done' if not notes else '; '.join(notes)}")
    (DOCS / "gallery.md").write_text("\n".join(lines), encoding="utf-8")


if __name__ == "__main__":
    main()
