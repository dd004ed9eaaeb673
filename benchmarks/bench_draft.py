"""Benchmark of the depth draft: its time and its distance from the full fast depth map.

For each bundled drawing upscaled to about 1 Mpx (as ``bench_edit.py`` does),
one fast-method depth session is set up with every order and equal entry but
the last, solved in full and as a draft (both factorizations kept), then the
last entry is added back (the "+arrow" edit of ``bench_edit.py``) and the
depth map is solved again as a draft and in full. The re-solve times are
medians over ``--repeats`` add/remove rounds, in process (no HTTP, no PNG).
The distance is in depth levels (one ``order`` step is 1), over all pixels
and over paper only (grey >= 0.5).

Usage::

    python benchmarks/bench_draft.py [--names frog,donkey] [--mpx 1.0] [--repeats 5]
        [--figure docs/images/editor_depth_draft.png]
"""

import argparse
import shutil
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_edit import _drawings, _folder  # noqa: E402

from inkray.depthmap.estimation import DepthSession, depth_constraints  # noqa: E402
from inkray.input.loading import load_input  # noqa: E402
from inkray.input.scribbles import seed_image  # noqa: E402


def _one(name, megapixels, repeats):
    ann_path, _ = _folder(name, megapixels)
    try:
        ann, drawing = load_input(str(ann_path))[:2]
    finally:
        shutil.rmtree(ann_path.parent, ignore_errors=True)
    p, q, ineq, labels = depth_constraints(ann)
    if not len(p):
        return None
    s = DepthSession(drawing.gray, seeds=seed_image(ann))
    for i in range(len(p) - 1):
        s.add(int(p[i]), int(q[i]), inequality=bool(ineq[i]), label=labels[i])
    s.solve(draft=True)
    s.solve()
    times = {True: [], False: []}
    for _ in range(repeats):
        for draft in (True, False):
            k = s.add(int(p[-1]), int(q[-1]), inequality=bool(ineq[-1]), label=labels[-1])
            t = time.perf_counter()
            d = s.solve(draft=draft)
            times[draft].append(time.perf_counter() - t)
            if draft:
                rough = d
            else:
                full = d
            s.remove(k)
            s.solve(draft=draft)
    err = np.abs(rough - full)
    paper = drawing.gray >= 0.5
    return {"name": name, "size": drawing.gray.shape[::-1], "draft": np.median(times[True]),
            "full": np.median(times[False]), "mean": err.mean(), "paper_mean": err[paper].mean(),
            "paper_p99": np.percentile(err[paper], 99), "max": err.max(),
            "range": np.ptp(full), "maps": (full, rough)}


def _figure(maps, path):
    from PIL import Image

    full, rough = maps
    lo, hi = full.min(), full.max()
    gap = np.full((full.shape[0], 16), 255, np.uint8)
    row = [np.clip((m - lo) / (hi - lo) * 255, 0, 255).astype(np.uint8) for m in (full, rough)]
    image = Image.fromarray(np.concatenate([row[0], gap, row[1]], axis=1))
    image = image.resize((image.width // 2, image.height // 2), Image.LANCZOS)
    image.save(path, optimize=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--names", help="comma-separated bundled drawings (default: all)")
    parser.add_argument("--mpx", type=float, default=1.0, help="upscale to this many Mpx (default 1)")
    parser.add_argument("--repeats", type=int, default=5, help="add/remove rounds (default 5)")
    parser.add_argument("--figure", help="write the full map beside the draft of the first drawing")
    args = parser.parse_args()
    names = args.names.split(",") if args.names else _drawings()
    print("| drawing | size | draft s | full s | draft / full | levels | mean | paper mean "
          "| paper p99 | max |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for i, name in enumerate(names):
        r = _one(name, args.mpx, args.repeats)
        if r is None:
            print(f"| {name} | no order or equal entries |")
            continue
        if args.figure and i == 0:
            _figure(r["maps"], args.figure)
        print(f"| {name} | {r['size'][0]}x{r['size'][1]} | {r['draft']:.3f} | {r['full']:.3f} "
              f"| {r['draft'] / r['full']:.0%} | {r['range']:.0f} | {r['mean']:.3f} "
              f"| {r['paper_mean']:.3f} | {r['paper_p99']:.3f} | {r['max']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
