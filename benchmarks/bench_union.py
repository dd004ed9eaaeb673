"""Benchmark of the ``--closed --union`` solid of every bundled drawing.

For each drawing, the stitched layers are built once, then
``assemble(..., closed=True, union=True)`` is timed (the union alone) and
its solid measured with ``inkray.formats.mesh_report``: smallest angle,
largest aspect ratio, shells, self-intersecting faces (exact), watertight
and manifold, and ``top_distance`` (``relief_metrics.py`` beside this
file): how far the solid's top strays from the relief's visible fronts.
Also the faces of the solid and of the closed parts it is made of.
Targets: >= 10 degrees, 1 shell, 0 self-intersecting faces.

Usage::

    python benchmarks/bench_union.py [--names turtle,frog] [--repeat 2]
"""

import argparse
import hashlib
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from relief_metrics import top_distance  # noqa: E402

from inkray.chain import ReliefChain  # noqa: E402
from inkray.formats.mesh_report import mesh_quality  # noqa: E402
from inkray.input.loading import load_input  # noqa: E402
from inkray.relief.assembly import assemble  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--names", help="comma-separated drawing names (default: all bundled)")
    parser.add_argument("--repeat", type=int, default=1,
                        help="unions per drawing; more than one also checks the bytes repeat")
    args = parser.parse_args(argv)
    names = args.names.split(",") if args.names else sorted(
        p.name for p in (ROOT / "examples").iterdir() if (p / "drawing.inkray.json").is_file())
    print("| drawing | min angle (deg) | max aspect | shells | self-intersecting faces "
          "| top distance (px) | union (s) | same bytes | faces | parts' faces |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name in names:
        ann, drawing = load_input(ROOT / "examples" / name / "drawing.inkray.json")
        layers = ReliefChain(ann, drawing).layers
        times, digests = [], set()
        for _ in range(args.repeat):
            start = time.perf_counter()
            relief = assemble(layers, size=ann.size, closed=True, union=True)
            times.append(time.perf_counter() - start)
            solid = relief.parts[0]
            digests.add(hashlib.sha256(np.ascontiguousarray(solid.vertices).tobytes()
                                       + np.ascontiguousarray(solid.faces).tobytes()).hexdigest())
        parts = assemble(layers, size=ann.size, closed=True).parts
        q = mesh_quality(solid.vertices, solid.faces)
        ok = q["watertight"] and q["edge_manifold"] and q["vertex_manifold"]
        same = "yes" if len(digests) == 1 and args.repeat > 1 else ("-" if args.repeat == 1 else "NO")
        print(f"| {name} | {q['min_angle_deg']:.1f} | {q['max_aspect_ratio']:.1f} | {q['shells']}"
              f"{'' if ok else ' (not closed manifold)'} | {q['self_intersecting_faces']} "
              f"| {top_distance(solid, parts):.2f} | {min(times):.1f} | {same} | {len(solid.faces)} "
              f"| {sum(len(p.faces) for p in parts)} |", flush=True)


if __name__ == "__main__":
    main()
