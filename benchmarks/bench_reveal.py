"""Whether the completed hidden parts of the cut-out layers take the part's paper tone.

Posing shows a part's completed hidden area (the layer ``inkray layers``
writes) where a part in front moves away: it should look like the part's
drawn interior, not like the ink around it. For every layer of ``cut_out``
with a hidden part, from the layer's pixels and the drawing only (so two
versions of inkray are measured alike):

- the part's *paper*: its visible pixels (its label) that are not ink (the
  drawing's ink coverage, 0 paper .. 1 the strokes' core, below 0.25 and no
  pixel of coverage 0.5 or more within 2 px); its floor is their 2nd
  percentile of luminance (Rec. 601, 0..255);
- the layer's *continued outline*: ``cut_out`` draws it along the edge of
  the part's completed shape (its label and its hidden pixels), inside it,
  as wide as the part's drawn strokes (see ``bench_layers.py``). Its width
  is measured on the layer: the depth (px from that edge, in whole pixels)
  at which fewer than half of the layer's hidden pixels are darker than the
  floor; ``outline`` is the widest over the layers with a fill;
- the *fill*: the layer's hidden pixels, opaque, deeper than its continued
  outline and one soft pixel;
- ``dark %``: the share of the fill darker than the floor (pooled over the
  layers), ``worst``: the largest share of one layer (its name), ``min``:
  the darkest fill pixel below its layer's floor (levels, 0 when none).

A fill dark all through would read as a continued outline as deep as the
hidden part: its fill px then falls to nothing, which the table shows.

Each bundled drawing at its own size and upscaled to about 1 Mpx (as
``bench_pose.py`` does). Target: 0 %.

Usage::

    python benchmarks/bench_reveal.py [--names fox,man] [--no-upscale] [--save after.json]
    python benchmarks/bench_reveal.py --compare before.json after.json

Run it with the interpreter of another checkout (its ``inkray`` importable) to
measure that version.
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy import ndimage
from skimage.morphology import skeletonize

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_pose import _load  # noqa: E402

NAMES = "fox,man,donkey,frog,dragon,turtle,cat,gingerbread"
SOFT = 1  # px: the continued outline's soft inner edge, beyond its measured width
LUMA = np.array([0.299, 0.587, 0.114])


def measure(name, megapixels):
    from inkray.chain import ReliefChain
    from inkray.relief.cutout import cut_out

    ann, drawing = _load(name, megapixels)
    chain = ReliefChain(ann, drawing)
    labels = chain.completion.labels
    stack = cut_out(chain.completion, chain.relations, drawing)
    luma = np.asarray(drawing.rgb, np.float64) @ LUMA
    paper = float(np.median(luma[ndimage.binary_erosion(labels < 0, iterations=10)]))
    inked = luma < (paper + float(np.percentile(luma, 0.5))) / 2
    core = float(np.median(luma[skeletonize(inked)])) if inked.any() else 0.0
    cover = np.clip((paper - luma) / max(paper - core, 1.0), 0, 1)
    non_ink = (cover < 0.25) & ~ndimage.binary_dilation(cover >= 0.5, iterations=2)
    total = dark = 0
    worst, worst_name, darkest, widest = 0.0, "-", 0.0, 0
    for layer in stack.layers:
        if layer.region < 0 or not layer.hidden.any():
            continue
        y0, y1, x0, x1 = layer.box
        own = (labels[y0:y1, x0:x1] == layer.region) & non_ink[y0:y1, x0:x1]
        if own.sum() < 20:
            continue
        floor = float(np.percentile(luma[y0:y1, x0:x1][own], 2))
        alpha = layer.rgba[..., 3]
        shape = layer.hidden | (labels[y0:y1, x0:x1] == layer.region)
        depth = ndimage.distance_transform_edt(np.pad(shape, 1))[1:-1, 1:-1]
        luma_layer = layer.rgba[..., :3].astype(np.float64) @ LUMA
        outline = _outline_width(depth, layer.hidden & (alpha > 0), luma_layer < floor)
        fill = layer.hidden & (alpha == 255) & (depth > outline + SOFT)
        if not fill.any():
            continue
        widest = max(widest, outline)
        value = luma_layer[fill]
        below = value < floor
        total += int(fill.sum())
        dark += int(below.sum())
        share = float(below.mean())
        if share > worst:
            worst, worst_name = share, layer.name
        if below.any():
            darkest = max(darkest, floor - float(value.min()))
    h, w = labels.shape
    return {"name": name, "size": f"{w}x{h}", "fill_px": total, "dark_px": dark,
            "dark": dark / total if total else 0.0, "worst": worst, "worst_layer": worst_name,
            "darkest": darkest, "outline": widest}


def _outline_width(depth, hidden, dark):
    """The continued outline's width (px): the whole depths from the completed shape's edge
    at which at least half of the ``hidden`` pixels are ``dark``, up to the first at which
    fewer are (a hidden part deep inside the shape, no outline at its edge: 0)."""
    rings = np.ceil(depth[hidden]).astype(int)
    shade = dark[hidden]
    width = 0
    for k in np.unique(rings):
        if shade[rings == k].mean() < 0.5:
            break
        width = int(k)
    return width


def _cells(r):
    return (f"{r.get('outline', '-')}", f"{100 * r['dark']:.2f} %",
            f"{100 * r['worst']:.1f} % ({r['worst_layer']})", f"{r['darkest']:.0f}")


HEADER = ("| drawing | size | fill px | outline px | dark % | worst layer | levels below floor |\n"
          "|---|---|---|---|---|---|---|")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--names", default=NAMES, help="comma-separated drawing names")
    parser.add_argument("--no-upscale", action="store_true", help="own size only")
    parser.add_argument("--save", help="write the results as JSON")
    parser.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"),
                        help="print two saved results side by side")
    args = parser.parse_args(argv)
    print(HEADER)
    if args.compare:
        before, after = (json.loads(Path(p).read_text()) for p in args.compare)
        old = {(r["name"], r["size"]): r for r in before}
        for r in after:
            b = old.get((r["name"], r["size"]))
            if b is not None:
                cells = " | ".join(f"{x} -> {y}" for x, y in zip(_cells(b), _cells(r)))
                print(f"| {r['name']} | {r['size']} | {b['fill_px']} -> {r['fill_px']} | {cells} |")
        return 0
    results = []
    for name in args.names.split(","):
        for mp in ([0.0] if args.no_upscale else [0.0, 1.0]):
            r = measure(name, mp)
            results.append(r)
            print(f"| {r['name']} | {r['size']} | {r['fill_px']} | " + " | ".join(_cells(r)) + " |",
                  flush=True)
    if args.save:
        Path(args.save).write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
