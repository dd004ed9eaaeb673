"""Benchmark: LazyBrush segmentation against skimage's random walker.

Times :func:`inkray.segmentation.lazybrush` and
``skimage.segmentation.random_walker(mode='cg_mg')`` (Grady, PAMI 2006, with
an algebraic-multigrid preconditioner; needs ``pyamg``) on the same drawing
and seeds, upscaled to 0.25 and 1 Mpx. Each run happens in a fresh
subprocess so its peak resident memory (``ru_maxrss``, interpreter and
imports included) is its own.

Usage::

    python benchmarks/bench_segment.py [--drawing fox] [--sizes 0.25,1] [--repeat 1]

Prints one row per size and method: seconds (best of ``--repeat``), peak RSS,
the speed-up over the random walker, and the share of pixels on which the
two labellings agree.
"""

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SHARED = Path(__file__).resolve().parents[1] / "examples"  # the bundled drawings
METHODS = ("random_walker", "lazybrush", "lazybrush_c2f", "lazybrush_full_res")


def _problem(drawing, mpx):
    """Grey image and seeds of a shared drawing scaled to about ``mpx`` megapixels."""
    from skimage.transform import resize

    from inkray.input.annotations import rescale_annotations
    from inkray.input.loading import load_input
    from inkray.input.scribbles import seed_image

    ann, d = load_input(SHARED / drawing / "drawing.inkray.json")
    h, w = d.gray.shape
    s = (mpx * 1e6 / (h * w)) ** 0.5
    size = (int(round(w * s)), int(round(h * s)))
    gray = resize(d.gray, (size[1], size[0]), order=1, anti_aliasing=s < 1).astype(np.float32)
    ann = rescale_annotations(ann, size)
    frame = not ann.background
    return gray, seed_image(ann), frame


def _worker(method, drawing, mpx, repeat, out):
    gray, seeds, frame = _problem(drawing, mpx)
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        if method == "random_walker":
            from skimage.segmentation import random_walker

            if frame:
                seeds = seeds.copy()
                border = np.zeros(seeds.shape, bool)
                border[[0, -1], :] = border[:, [0, -1]] = True
                seeds[border & (seeds == -2)] = -1
            # random_walker: 0 unseeded, 1.. labels; ours -2 unseeded, -1 background.
            markers = np.where(seeds == -2, 0, seeds + 2)
            labels = random_walker(gray, markers, mode="cg_mg") - 2
        else:
            from inkray.segmentation import lazybrush

            # lazybrush: the default (coarse-to-fine above 0.5 Mpx); the other
            # two force one way.
            c2f = {"lazybrush": None, "lazybrush_c2f": True, "lazybrush_full_res": False}[method]
            labels = lazybrush(gray, seeds, frame_background=frame, coarse_to_fine=c2f)
        best = min(best, time.perf_counter() - t)
    np.save(out, labels.astype(np.int32))
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # kB on Linux
    n_labels = len(np.unique(seeds[seeds != -2])) + (1 if frame and not (seeds == -1).any() else 0)
    print(json.dumps({"seconds": best, "rss_mb": rss, "pixels": int(gray.size),
                      "labels": n_labels}))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drawing", default="fox", help="shared drawing (default: fox, 10 regions)")
    ap.add_argument("--sizes", default="0.25,1", help="megapixels, comma separated")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--worker", nargs=2, metavar=("METHOD", "MPX"), help=argparse.SUPPRESS)
    ap.add_argument("--out", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        _worker(args.worker[0], args.drawing, float(args.worker[1]), args.repeat, args.out)
        return 0
    import importlib.util

    if importlib.util.find_spec("pyamg") is None:
        print("note: pyamg is missing, so random_walker falls back from cg_mg to cg_j")
    print(f"drawing {args.drawing}, best of {args.repeat}, each run in its own process\n")
    header = (f"{'Mpx':>5} {'labels':>6} {'method':<20} {'time s':>8} {'peak RSS MB':>11} "
              f"{'speed-up':>8} {'agree RW':>8}")
    print(header)
    print("-" * len(header))
    with tempfile.TemporaryDirectory() as tmp:
        for mpx in (float(v) for v in args.sizes.split(",")):
            rows = {}
            for method in METHODS:
                out = Path(tmp) / f"{method}_{mpx}.npy"
                res = subprocess.run(
                    [sys.executable, __file__, "--worker", method, str(mpx), "--drawing",
                     args.drawing, "--repeat", str(args.repeat), "--out", str(out)],
                    check=True, capture_output=True, text=True)
                rows[method] = json.loads(res.stdout.strip().splitlines()[-1])
                rows[method]["labels_arr"] = np.load(out)
            base = rows["random_walker"]
            for method in METHODS:
                r = rows[method]
                agree = float((r["labels_arr"] == base["labels_arr"]).mean())
                print(f"{r['pixels'] / 1e6:5.2f} {r['labels']:6d} {method:<20} "
                      f"{r['seconds']:8.2f} {r['rss_mb']:11.0f} "
                      f"{base['seconds'] / r['seconds']:7.1f}x {agree:8.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
