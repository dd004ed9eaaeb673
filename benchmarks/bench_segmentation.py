"""Benchmark: the segmentation as the editor's open calls it, cold, per drawing.

Times :func:`inkray.segmentation.segment` on each bundled drawing at its own
size and upscaled to about ``--mpx`` (the upscaling of ``bench_edit.py``),
called as the editor's labels stage calls it on opening: the annotation and
the drawing loaded from the file, an empty memo. Each run is a fresh
subprocess (the first call's page faults and imports are its own); the
figure is the call's CPU seconds (user + system of the process, every
thread), the median of ``--repeats``. Each row also gives the first 16 hex
digits of the SHA-256 of the labels PNG (:func:`inkray.formats.labels.labels_png`).

``--against SRC`` runs the same calls on another version of the package (the
directory holding its ``inkray``, e.g. ``git archive main | tar -x -C SRC``),
alternating with this one run by run, and adds its CPU, the ratio this /
baseline and whether the labels PNG is the same byte for byte
(``--digest-only``: one run each, the labels alone).

Usage::

    python benchmarks/bench_segmentation.py [--names fox,man] [--mpx 1.0] [--repeats 3]
        [--own-size-only | --upscaled-only] [--against SRC] [--digest-only] [--profile fox]
"""

import argparse
import hashlib
import json
import os
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


def _run(name, megapixels, profile=False, source=None):
    cmd = [sys.executable, __file__, "--worker", name, str(megapixels)]
    if profile:
        cmd.append("--profile-worker")
    env = dict(os.environ, PYTHONPATH=str(source)) if source else None
    out = subprocess.run(cmd, check=True, capture_output=not profile, text=True, env=env)
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
    parser.add_argument("--against", metavar="SRC", help="another version's source directory")
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
    versions = [None] + ([args.against] if args.against else [])
    head = "| drawing | size | segmentation CPU s (median) | runs | labels |"
    if args.against:
        head += " baseline CPU s (median) | baseline runs | this / baseline | same labels |"
    print(head)
    print("|" + " --- |" * head.count(" |"))
    for mpx in sizes:
        for name in names:
            runs = {v: [] for v in versions}
            for _ in range(repeats):
                for v in versions:  # alternating, so that both see the same load
                    runs[v].append(_run(name, mpx, source=v))
            cells = []
            for v in versions:
                cpus = [r["cpu"] for r in runs[v]]
                digests = sorted({r["labels"] for r in runs[v]})
                cells.append((float(np.median(cpus)), " ".join(f"{c:.3f}" for c in cpus),
                              digests[0] if len(digests) == 1 else "differ: " + ",".join(digests)))
            row = (f"| {name} | {runs[None][0]['size']} | {cells[0][0]:.3f} | {cells[0][1]} | "
                   f"{cells[0][2]} |")
            if args.against:
                same = "yes" if cells[0][2] == cells[1][2] else f"**no** ({cells[1][2]})"
                row += (f" {cells[1][0]:.3f} | {cells[1][1]} | {cells[0][0] / cells[1][0]:.2f} | "
                        f"{same} |")
            print(row, flush=True)

if __name__ == "__main__":
    main()
