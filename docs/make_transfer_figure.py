"""Make docs/images/transfer/walkcycle.png: a shot's frames with their carried annotations and reliefs.

Run from the repository root::

    python docs/make_transfer_figure.py [--frames 4]

The key annotation of the Krita walk cycle (``examples/shots/krita_walkcycle``)
is carried frame to frame as ``inkray batch --key`` does. Top row: each frame
segmented with its annotation (regions coloured, times the ink) with the
scribbles and order entries drawn over it; bottom row: its relief
(``inkray render --mode shade``). Frame 1 is the key.
"""

import argparse
import io
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from inkray.chain import ReliefChain
from inkray.formats.labels import label_image
from inkray.input.loading import load_input
from inkray.transfer import transfer_annotations
from inkray.view.rendering import render
from inkray.view.shading import over_white

DOCS = Path(__file__).resolve().parent
SHOT = DOCS.parent / "examples" / "shots" / "krita_walkcycle"
OUT = DOCS / "images" / "transfer"
CROP = (200, 80, 540, 540)  # the character in every frame (x0, y0, x1, y1)


def _annotated(ann, drawing, chain):
    seg = chain.segmentation
    ink = np.asarray(drawing.rgb, float) / 255.0
    rgb = np.asarray(label_image(seg.labels, len(seg.names)).convert("RGB"), float)
    image = Image.fromarray(np.uint8(rgb * ink))
    draw = ImageDraw.Draw(image)
    for r in ann.regions:
        for s in r.scribbles:
            pts = [tuple(map(float, p)) for p in s]
            if len(pts) > 1:
                draw.line(pts, fill=(0, 0, 0), width=3)
            else:
                x, y = pts[0]
                draw.ellipse([x - 3, y - 3, x + 3, y + 3], fill=(0, 0, 0))
    for o in ann.order:
        draw.line([tuple(o.back), tuple(o.front)], fill=(0, 160, 0), width=3)
        x, y = o.front
        draw.ellipse([x - 4, y - 4, x + 4, y + 4], fill=(0, 160, 0))
    return image.crop(CROP)


def _relief(chain, size):
    shaded = render(chain.relief, mode="shade", size=size)
    return Image.fromarray(np.uint8(np.rint(over_white(shaded.image) * 255))).crop(CROP)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=4)
    args = parser.parse_args()
    ann, drawing = load_input(SHOT / "0001.inkray.json")
    labels, prev, prior = None, drawing, None
    top, bottom = [], []
    for n in range(1, args.frames + 1):
        if n > 1:
            _, frame = load_input(SHOT / "0001.inkray.json", drawing=SHOT / f"{n:04d}.png")
            t = transfer_annotations(ann, prev, frame, key_labels=labels, prior=prior)
            ann, labels, prev = t.annotations, t.labels, frame
            prior = {e.key: e.match for e in t.entries}
            print(f"frame {n}: match {t.confidence:.2f}, {len(t.warnings)} entries to check")
        chain = ReliefChain(ann, prev)
        top.append(_annotated(ann, prev, chain))
        bottom.append(_relief(chain, ann.size))
    w, h = top[0].size
    sheet = Image.new("RGB", (w * len(top), 2 * h), "white")
    for i, (a, b) in enumerate(zip(top, bottom)):
        sheet.paste(a, (i * w, 0))
        sheet.paste(b, (i * w, h))
    sheet = sheet.resize((sheet.width // 2, sheet.height // 2), Image.LANCZOS)
    OUT.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    sheet.quantize(64).save(buf, format="PNG", optimize=True)
    (OUT / "walkcycle.png").write_bytes(buf.getvalue())
    print(f"wrote {OUT / 'walkcycle.png'} ({len(buf.getvalue()) // 1024} KB)")


if __name__ == "__main__":
    main()
