"""Benchmark of inkray.render: the GI render of the demo drawing at 512x512, 64 spp.

Run as ``python benchmarks/bench_render.py [--example NAME] [--spp N] [--size N]
[--out DIR]``.
The GI render is the one worth timing; the table also shows the cheap
modes and the rasterizer, with ratios against the ``shade`` render of the same
relief (the baseline: what a preview costs).

The relief is built by the pipeline exactly as ``inkray demo`` builds it.
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from inkray.examples import example_path
from inkray.input.loading import load_input
from inkray.chain import build_relief
from inkray.view.rasterization import rasterize
from inkray.formats.images import write_renderings
from inkray.view.rendering import has_mitsuba, render


def example_relief(name="turtle"):
    """A bundled example's relief, as ``inkray relief`` (and the demo) builds it."""
    ann, drawing = load_input(example_path(name))
    return build_relief(ann, drawing).relief


def _time(fn, repeat=1):
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--example", default="turtle", help="bundled example (default: turtle)")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--out", type=Path, help="also write the pictures here")
    args = ap.parse_args()
    size = (args.size, args.size)

    t_build, relief = _time(lambda: example_relief(args.example))
    tris = sum(len(p.faces) for p in relief.parts)
    print(f"relief: {args.example}, {len(relief.parts)} parts, {tris} triangles "
          f"(built in {t_build:.2f} s)")

    rows = []
    t_shade, shade = _time(lambda: render(relief, mode="shade", size=size), repeat=3)
    rows.append(("shade (baseline)", f"{size[0]}x{size[1]}", "-", t_shade))
    for mode in ("normals", "depth", "stereo"):
        t, _ = _time(lambda: render(relief, mode=mode, size=size), repeat=3)
        rows.append((mode, f"{size[0]}x{size[1]}", "-", t))
    t, _ = _time(lambda: rasterize(relief, scale=2), repeat=3)
    rows.append(("rasterize 2x", f"{2 * relief.size[0]}x{2 * relief.size[1]}", "-", t))
    pictures = {"shade": shade}
    if has_mitsuba():
        t, gi = _time(lambda: render(relief, mode="gi", size=size, spp=args.spp))
        rows.append(("gi (mitsuba scalar_rgb)", f"{size[0]}x{size[1]}", str(args.spp), t))
        pictures["gi"] = gi
    else:
        print("gi: skipped, Mitsuba 3 is not installed (pip install 'inkray[render]')")

    print(f"\n{'render':<26}{'size':>10}{'spp':>6}{'time s':>10}{'x shade':>10}"
          f"{'Msamples/s':>12}")
    for name, sz, spp, t in rows:
        rate = (f"{size[0] * size[1] * int(spp) / t / 1e6:.2f}" if spp != "-" else "")
        print(f"{name:<26}{sz:>10}{spp:>6}{t:>10.3f}{t / t_shade:>10.1f}{rate:>12}")
    if args.out:
        for name, r in pictures.items():
            write_renderings(r, args.out / f"{args.example}_{name}.png")
        print(f"\nwrote {', '.join(pictures)} to {args.out}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
