"""How drawn the cut-out layers' completed hidden parts look, per bundled drawing.

For every layer of ``cut_out`` (what ``inkray layers`` writes) with a hidden
part, measured from the layer's pixels and the drawing only (so two versions
of inkray are measured alike):

- ``cut px``: how much longer the longest horizontal or vertical run of the
  continued outline's edge (the hidden part's pixels beside a transparent
  one; not one continuing a straight drawn edge) is than the longest such
  run of the part's drawn edge: a straight cut the drawing does not have
  (largest over the layers; 0 when the continued outline is no straighter
  than the drawn one);
- ``width`` and ``tone``: the continued outline's stroke against the part's
  own drawn strokes near the hidden part, both measured the same way: the
  coverage (0 paper, 1 the drawing's ink core) summed over the stroke, over
  the length of its skeleton, and the median grey (0..255) along the
  skeleton; reported as continued / drawn (medians over the layers). A
  drawn stroke counts whole within the part (its skeleton 8-32 px from the
  layer's pixels on other parts' labels: its hidden part and any stubs of
  its strokes it draws there), strokes up to 32 px wide;
- ``soft``: the share of the layers' edge pixels (opaque at all, beside a
  transparent one) that are partly transparent, against the share of the
  drawing's ink edge pixels (beside a stroke, not ink) that are partly
  covered: anti-aliased as the drawing is when both are alike.

Each drawing at its own size and, with ``--upscale``, also upscaled to about
1 Mpx (as ``bench_pose.py`` does; the drawings' strokes get wider with it).

Usage::

    python benchmarks/bench_layers.py [--names cat,turtle] [--upscale] [--save after.json]
    python benchmarks/bench_layers.py --compare before.json after.json

Run it with the interpreter of another checkout (its ``inkray`` importable)
to measure that version: ``/path/to/other/.venv/bin/python
benchmarks/bench_layers.py --save before.json``.
"""

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy import ndimage
from skimage.morphology import skeletonize

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
HALF = 16  # px: half the widest stroke measured (the frog's strokes are 20 px wide)
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_pose import _load  # noqa: E402


def _edge(alpha):
    clear = np.pad(alpha == 0, 1, constant_values=True)
    beside = clear[:-2, 1:-1] | clear[2:, 1:-1] | clear[1:-1, :-2] | clear[1:-1, 2:]
    return (alpha > 0) & beside


def _runs(mask):
    """(length, axis, line, start, stop) of every horizontal (axis 0) and vertical run."""
    out = []
    for axis, m in ((0, mask), (1, mask.T)):
        d = np.diff(np.pad(m, ((0, 0), (1, 1))).astype(np.int8), axis=1)
        for line, start in zip(*np.nonzero(d == 1)):
            stop = start + np.argmax(d[line, start:] == -1)
            out.append((int(stop - start), axis, int(line), int(start), int(stop)))
    return out


def _straight_cut(edge, drawn_edge):
    """How much longer the longest run of ``edge`` (not continuing a straight run of 5 px or
    more of ``drawn_edge``) is than the longest run of ``drawn_edge``: a curve as flat as
    the drawn ones has runs as long, a straight cut longer ones."""
    best = 0
    for length, axis, line, start, stop in _runs(edge):
        if length <= best:
            continue
        drawn = drawn_edge if axis == 0 else drawn_edge.T
        row = drawn[line]
        before = row[max(start - 5, 0):start]
        after = row[stop:stop + 5]
        if (before.size == 5 and before.all()) or (after.size == 5 and after.all()):
            continue
        best = length
    drawn = max((r[0] for r in _runs(drawn_edge)), default=0)
    return max(best - drawn, 0)


def _length(skeleton):
    """Length of a thin 8-connected curve: its steps, sqrt(2) for a diagonal one that does
    not cut the corner of a row step and a column step."""
    ys, xs = np.nonzero(skeleton)
    on = set(zip(ys.tolist(), xs.tolist()))
    total = 0.0
    for y, x in on:
        total += ((y, x + 1) in on) + ((y + 1, x) in on)
        for dx in (1, -1):
            if (y + 1, x + dx) in on and (y, x + dx) not in on and (y + 1, x) not in on:
                total += np.sqrt(2.0)
    return total


def _stroke(cover, zone, inside=None):
    """(coverage-width, skeleton) of the strokes in ``inside`` (coverage >= 0.5 is ink;
    ``zone`` when None) whose skeleton lies in ``zone``: the coverage of the pixels nearest
    to that skeleton, away from its ends, over its length. A stroke running along the edge
    of ``zone`` counts whole (within ``inside``), not cut to the zone."""
    inside = zone if inside is None else inside
    ink = (cover >= 0.5) & inside
    skeleton = skeletonize(ink)
    count = ndimage.convolve(skeleton.astype(int), np.ones((3, 3), int), mode="constant")
    ends = skeleton & (count <= 2)
    inner = skeleton & (ndimage.distance_transform_edt(~ends) > 3) & zone
    length = _length(inner)
    if length < 5:
        return None, inner
    dist, (iy, ix) = ndimage.distance_transform_edt(~skeleton, return_indices=True)
    near = inner[iy, ix] & (dist <= HALF) & ndimage.binary_dilation(ink, iterations=2) & inside
    return float(cover[near].sum() / length), inner


def measure(name, megapixels=0.0):
    from inkray.chain import ReliefChain
    from inkray.relief.cutout import cut_out

    ann, drawing = _load(name, megapixels)
    chain = ReliefChain(ann, drawing)
    t0 = time.perf_counter()
    stack = cut_out(chain.completion, chain.relations, drawing)
    seconds = time.perf_counter() - t0
    return {"name": name, **measure_stack(stack, chain.completion.labels, drawing),
            "seconds": seconds}


def measure_stack(stack, labels, drawing, *, layers=None):
    """The measures of one layer stack of ``drawing`` segmented as ``labels``; with a list
    ``layers``, also each layer's (name, continued width, drawn width) appended to it."""
    gray = np.asarray(drawing.gray, np.float64) * 255
    paper = float(np.median(gray[ndimage.binary_erosion(labels < 0, iterations=10)]))
    inked = gray < (paper + float(np.percentile(gray, 0.5))) / 2
    core = float(np.median(gray[skeletonize(inked)])) if inked.any() else 0.0
    cover = np.clip((paper - gray) / max(paper - core, 1.0), 0, 1)
    cuts, widths, tones, soft = [], [], [], []
    for layer in stack.layers:
        y0, y1, x0, x1 = layer.box
        alpha = layer.rgba[..., 3]
        edge = _edge(alpha)
        soft.append(((alpha[edge] < 255).sum(), edge.sum()))
        if layer.hidden is None or not layer.hidden.any():
            continue
        hidden = layer.hidden
        continued = edge & ndimage.binary_dilation(hidden, iterations=1) & ~(
            labels[y0:y1, x0:x1] == layer.region)
        drawn = edge & ~continued
        cuts.append(_straight_cut(continued, drawn))
        # The continued outline: the layer over the paper, in the hidden part near its edge.
        a = alpha / 255.0
        value = layer.rgba[..., :3].mean(axis=2) * a + paper * (1 - a)
        layer_cover = np.clip((paper - value) / max(paper - core, 1.0), 0, 1)
        outside = ndimage.distance_transform_edt(alpha > 0)
        zone = hidden & (outside <= 2 * HALF) & ~ndimage.binary_dilation(
            labels[y0:y1, x0:x1] == layer.region, iterations=8)
        w_cont, sk_cont = _stroke(layer_cover, zone | (edge & ndimage.binary_dilation(zone)))
        # The part's own drawn strokes near the hidden part (not at the junctions).
        own = labels[y0:y1, x0:x1] == layer.region
        # Measured from the layer's pixels on the other parts' labels: its hidden part and
        # any drawn stubs of its strokes there, up to the occluder's outline.
        on_others = hidden | ((alpha > 0) & (labels[y0:y1, x0:x1] >= 0) & ~own)
        drawn_zone = own & ndimage.binary_dilation(on_others, iterations=32) & \
            ~ndimage.binary_dilation(on_others, iterations=8)
        w_draw, sk_draw = _stroke(cover[y0:y1, x0:x1], drawn_zone, own)
        if w_cont is None or w_draw is None:
            continue
        if layers is not None:
            layers.append((layer.name, w_cont, w_draw))
        widths.append(w_cont / w_draw)
        tones.append(float(np.median(value[sk_cont])) - float(np.median(gray[y0:y1, x0:x1][sk_draw])))
    # The drawing's own soft edge: beside ink (4-neighbours), not ink, partly covered.
    ink_edge = ndimage.binary_dilation(cover >= 0.5) & (cover < 0.5) & (labels < 0)
    soft_drawing = float(np.mean((cover[ink_edge] > 0.05))) if ink_edge.any() else 0.0
    partly, total = (sum(v) for v in zip(*soft))
    h, w = labels.shape
    return {"size": f"{w}x{h}", "layers": len(stack.layers),
            "cut_px": max(cuts, default=0),
            "width_ratio": float(np.median(widths)) if widths else None,
            "tone_diff": float(np.median(tones)) if tones else None,
            "soft_layers": float(partly / total) if total else 0.0,
            "soft_drawing": soft_drawing}


def _row(r):
    def f(v, fmt):
        return "-" if v is None else format(v, fmt)
    return (f"| {r['name']} | {r.get('size', '-')} | {f(r['cut_px'], 'd')} | {f(r['width_ratio'], '.2f')} | "
            f"{f(r['tone_diff'], '+.0f')} | {r['soft_layers']:.2f} | {r['soft_drawing']:.2f} |")


HEADER = ("| drawing | size | cut px | width cont/drawn | tone cont-drawn | soft edges layers | "
          "soft edges drawing |\n|---|---|---|---|---|---|---|")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--names", help="comma-separated drawing names (default: all bundled)")
    parser.add_argument("--upscale", action="store_true",
                        help="each drawing also upscaled to about 1 Mpx")
    parser.add_argument("--save", help="write the results as JSON")
    parser.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"),
                        help="print two saved results side by side")
    args = parser.parse_args(argv)
    if args.compare:
        before, after = (json.loads(Path(p).read_text()) for p in args.compare)
        old = {(r["name"], r.get("size")): r for r in before}
        print(HEADER)
        for r in after:
            b = old.get((r["name"], r.get("size")))
            if b is None:
                continue
            cells = []
            for key, fmt in (("cut_px", "d"), ("width_ratio", ".2f"), ("tone_diff", "+.0f"),
                             ("soft_layers", ".2f")):
                fb = "-" if b[key] is None else format(b[key], fmt)
                fa = "-" if r[key] is None else format(r[key], fmt)
                cells.append(f"{fb} -> {fa}")
            print(f"| {r['name']} | {r.get('size', '-')} | " + " | ".join(cells) +
                  f" | {r['soft_drawing']:.2f} |")
        return 0
    names = (args.names.split(",") if args.names else
             sorted(p.name for p in EXAMPLES.iterdir() if (p / "drawing.inkray.json").is_file()))
    print(HEADER)
    results = []
    for name in names:
        for mp in ([0.0, 1.0] if args.upscale else [0.0]):
            r = measure(name, mp)
            results.append(r)
            print(_row(r), flush=True)
    if args.save:
        Path(args.save).write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
