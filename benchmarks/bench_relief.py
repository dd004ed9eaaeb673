"""Benchmark of the whole relief chain: per-stage times, peak memory and surface quality.

Runs ``inkray.chain.build_relief`` on the shared drawings at their own size
and upscaled to about 1 Mpx, each case in a fresh process (so peak RSS is that
case's own, measured before the quality figures), and prints a table against
the targets: 5 s and 2 GB for a 1 Mpx drawing on a 2-core machine. The
quality columns (``relief_metrics.py`` beside this file says how each is
measured) with their targets:

- ``jump90``: normal jump at ink-free seams, 90th percentile (deg), <= 5;
  ``all90`` the same over every ink-free part change, occlusion steps
  through gaps in the ink included (the first definition, no target);
- ``open90``: normal jump across open joins (a part's stroke stopping short
  inside the part behind it), steps included, 90th percentile (deg), <= 5;
- ``order``: order held along the segments between entries' points (%), 100;
- ``turn``: silhouette turning over that of the 3 px smoothed outline, <= 1.25;
- ``ink%``: outline ink on the mesh (%), >= 97;
- ``minang``, ``shells``: smallest angle (deg) and shell count of the
  ``--closed --union`` solid, >= 10 and 1.

With ``--cpu`` the stage columns are the process's CPU seconds (all its
threads) spent in each stage instead of wall seconds: on a shared machine
the wall times stretch with the load, the CPU times much less (a stage that
runs on two threads shows their sum). With ``--repeats N`` each case runs
in N fresh processes and every time and memory column is their median (the
quality columns are the first run's: the same input gives the same relief).

Usage::

    python benchmarks/bench_relief.py [--names turtle,frog] [--no-upscale | --upscale-only]
                                      [--no-quality] [--cpu] [--repeats 1]
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT / "examples"  # the bundled drawings
TARGET_S, TARGET_MB = 5.0, 2048.0
STAGES = ("segment", "complete", "order", "inflate", "stitch", "assemble")


def _cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _progress():
    """A quiet Progress that also sums the process's CPU seconds per stage (``.cpu``)."""
    from inkray.progress import Progress

    class CpuProgress(Progress):
        def __init__(self):
            super().__init__(quiet=True)
            self.cpu = {}

        @contextmanager
        def stage(self, name):
            start = _cpu()
            try:
                with super().stage(name) as inner:
                    yield inner
            finally:
                self.cpu[name] = self.cpu.get(name, 0.0) + _cpu() - start

    return CpuProgress()


def _one(name, megapixels, quality):
    from PIL import Image

    from inkray.input.loading import load_input
    from inkray.chain import build_relief

    ann_path = SHARED / name / "drawing.inkray.json"
    drawing = None
    if megapixels:
        src = next(p for p in (SHARED / name).iterdir() if p.stem == "drawing" and p.suffix != ".json")
        image = Image.open(src)
        scale = (megapixels * 1e6 / (image.width * image.height)) ** 0.5
        size = (round(image.width * scale), round(image.height * scale))
        drawing = Path(tempfile.mkdtemp()) / f"up{src.suffix}"
        image.resize(size, Image.LANCZOS).save(drawing)
    ann, d = load_input(ann_path, drawing=drawing, rescale=drawing is not None)
    progress = _progress()
    start = time.perf_counter()
    result = build_relief(ann, d, progress=progress)
    total = time.perf_counter() - start
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    figures = {}
    if quality:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from relief_metrics import relief_figures, solid_figures

        from inkray.chain import ReliefChain
        figures = relief_figures(result, d.gray)
        try:
            union = ReliefChain(ann, d).edit(closed=True, union=True).relief
            figures.update(solid_figures(union))
        except Exception as e:  # reported in the table, not fatal to the other columns
            figures["solid_error"] = str(e).splitlines()[0]
    print(json.dumps({"name": name, "size": list(ann.size), "regions": len(ann.regions),
                      "stages": dict(progress.timings), "cpu": progress.cpu, "total": total, "rss_mb": rss,
                      "vertices": sum(len(p.vertices) for p in result.relief.parts),
                      "figures": figures}))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--names", help="comma-separated shared drawings (default: all)")
    parser.add_argument("--no-upscale", action="store_true", help="only the drawings' own size")
    parser.add_argument("--upscale-only", action="store_true", help="only the 1 Mpx cases")
    parser.add_argument("--no-quality", action="store_true",
                        help="times and memory only (no quality columns)")
    parser.add_argument("--cpu", action="store_true",
                        help="stage columns in CPU seconds of the process instead of wall seconds")
    parser.add_argument("--repeats", type=int, default=1,
                        help="fresh processes per case; the times are their medians")
    parser.add_argument("--one", nargs=3, metavar=("NAME", "MPX", "QUALITY"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        _one(args.one[0], float(args.one[1]), args.one[2] == "1")
        return
    names = args.names.split(",") if args.names else sorted(
        p.name for p in SHARED.iterdir() if (p / "drawing.inkray.json").is_file())
    cases = (([] if args.upscale_only else [(n, 0.0) for n in names])
             + ([] if args.no_upscale else [(n, 1.0) for n in names]))
    head = (f"{'drawing':<12} {'size':>10} {'reg':>3} " + " ".join(f"{s:>8}" for s in STAGES)
            + f" {'total s':>8} {'x 5 s':>6} {'RSS MB':>7} {'x 2 GB':>6} {'verts':>7}"
            + ("" if args.no_quality else f" {'jump90':>6} {'all90':>6} {'open90':>6} {'order':>6}"
                                          f" {'turn':>5}"
                                          f" {'ink%':>5} {'minang':>6} {'shells':>6}"))
    print(f"stage columns: {'CPU' if args.cpu else 'wall'} seconds; total s: wall seconds")
    print(head)
    print("-" * len(head))
    for name, mpx in cases:
        runs, failed = [], None
        for k in range(max(args.repeats, 1)):
            run = subprocess.run([sys.executable, __file__, "--one", name, str(mpx),
                                  "0" if args.no_quality or k > 0 else "1"],
                                 capture_output=True, text=True,
                                 env={**os.environ, "PYTHONHASHSEED": "0"})
            if run.returncode != 0:
                failed = run.stderr.strip().splitlines()[-1]
                break
            runs.append(json.loads(run.stdout.strip().splitlines()[-1]))
        if failed is not None:
            print(f"{name:<12} failed: {failed}")
            continue
        r = _median(runs)
        size = f"{r['size'][0]}x{r['size'][1]}"
        print(f"{name:<12} {size:>10} {r['regions']:>3} "
              + " ".join(f"{r['cpu' if args.cpu else 'stages'].get(s, 0):8.2f}" for s in STAGES)
              + f" {r['total']:8.2f} {r['total'] / TARGET_S:6.2f} {r['rss_mb']:7.0f}"
              f" {r['rss_mb'] / TARGET_MB:6.2f} {r['vertices']:>7}" + _quality(r["figures"]))


def _median(runs):
    """The first run with every time and memory figure replaced by the runs' median."""
    r = dict(runs[0])
    for key in ("stages", "cpu"):
        r[key] = {s: float(np.median([x[key].get(s, 0.0) for x in runs])) for s in runs[0][key]}
    for key in ("total", "rss_mb"):
        r[key] = float(np.median([x[key] for x in runs]))
    return r


def _quality(f):
    """The quality columns of one case (empty without figures)."""
    if not f:
        return ""
    solid = (f" {f['min_angle']:6.1f} {f['shells']:>6}" if "min_angle" in f
             else f" {'failed':>13}")
    return (f" {f['jump_p90']:6.1f} {f['jump_p90_all']:6.1f} {f['open_p90']:6.1f}"
            f" {100 * f['order_held']:6.1f}"
            f" {f['turning']:5.2f} {100 * f['ink_on_mesh']:5.1f}" + solid)


if __name__ == "__main__":
    main()
