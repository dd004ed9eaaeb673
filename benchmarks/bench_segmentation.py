"""Benchmark: the segmentation as the editor's open calls it, cold, per drawing.

Times :func:`inkray.segmentation.segment` on each bundled drawing at its own
size and upscaled to about ``--mpx`` (the upscaling of ``bench_edit.py``),
called as the editor's labels stage calls it on opening: the annotation and
the drawing loaded from the file, an empty memo. Each run is a fresh
subprocess (the first call's page faults and imports are its own); the
figure is the call's CPU seconds (user + system of the process, every
thread), the median of ``--repeats``. Each row also gives the first 16 hex
digits of the SHA-256 of the labels PNG (:func:`inkray.formats.labels.labels_png`),
so two versions of the code can be checked for the same labels: run it under
each and compare the ``labels`` columns (``--digest-only`` skips the timing).

Usage::

    python benchmarks/bench_segmentation.py [--names fox,man] [--mpx 1.0] [--repeats 3]
        [--own-size-only | --upscaled-only] [--digest-only] [--profile fox]
"""

import argparse
import hashlib
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_edit import _drawings, _folder  # noqa: E402  (the same upscaled copies)


def _worker(name, megapixels, profile=False):
    from inkray.formats.labels import labels_png
    from inkray.input.annotations import parse_annotations
    from inkray.input.drawing import load_drawing
    from inkray.segmentation import segment

    ann_path, doc = _folder(name, megapixels)
    try:
        ann = parse_annotations(json.loads(ann_path.read_text()))
        drawing = load_drawing(ann_path.parent / ann.drawing)
        if profile:
            import cProfile
            import pstats

            prof = cProfile.Profile(time.process_time)
            prof.enable()
        start = time.process_time()
        seg = segment(ann, drawing, memo={})
        cpu = time.process_time() - start
        if profile:
            prof.disable()
            pstats.Stats(prof, stream=sys.stderr).sort_stats("cumulative").print_stats(40)
    finally:
        shutil.rmtree(ann_path.parent, ignore_errors=True)
    digest = hashlib.sha256(labels_png(seg)).hexdigest()[:16]
    return {"size": f"{doc['size'][0]}x{doc['size'][1]}", "cpu": cpu, "labels": digest}


def _run(name, megapixels, profile=False):
    cmd = [sys.executable, __file__, "--worker", name, str(megapixels)]
    if profile:
        cmd.append("--profile-worker")
    out = subprocess.run(cmd, check=True, capture_output=not profile, text=True)
    if profile:
        return None
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--names", help="comma-separated drawings (default: all bundled)")
    parser.add_argument("--mpx", type=float, default=1.0, help="upscale to this many Mpx (default 1)")
    parser.add_argument("--own-size-only", action="store_true", help="skip the upscaled run")
    parser.add_argument("--upscaled-only", action="store_true", help="skip the own-size run")
    parser.add_argument("--repeats", type=int, default=3, help="fresh processes per row (default 3)")
    parser.add_argument("--digest-only", action="store_true", help="one run per row, for the labels")
    parser.add_argument("--profile", metavar="NAME", help="cProfile (CPU) of one upscaled run")
    parser.add_argument("--worker", nargs=2, help=argparse.SUPPRESS)
    parser.add_argument("--profile-worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        row = _worker(args.worker[0], float(args.worker[1]), args.profile_worker)
        print(json.dumps(row), flush=True)
        return
    if args.profile:
        _run(args.profile, args.mpx, profile=True)
        return
    names = args.names.split(",") if args.names else _drawings()
    sizes = ([] if args.upscaled_only else [0.0]) + ([] if args.own_size_only else [args.mpx])
    repeats = 1 if args.digest_only else args.repeats
    print("| drawing | size | segmentation CPU s (median) | runs | labels |")
    print("| --- | --- | --- | --- | --- |")
    for mpx in sizes:
        for name in names:
            runs = [_run(name, mpx) for _ in range(repeats)]
            cpus = [r["cpu"] for r in runs]
            digests = {r["labels"] for r in runs}
            labels = digests.pop() if len(digests) == 1 else "differ: " + ",".join(sorted(digests))
            print(f"| {name} | {runs[0]['size']} | {np.median(cpus):.3f} | "
                  f"{' '.join(f'{c:.3f}' for c in cpus)} | {labels} |", flush=True)


if __name__ == "__main__":
    main()
