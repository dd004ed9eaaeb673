"""Benchmark of the ``--closed --union`` solid of every bundled drawing.

For each drawing, at its own size and upscaled to about ``--mpx``
megapixels (as ``bench_chain.py`` does), the stitched layers are built
once, then ``assemble(..., closed=True, union=True)`` is timed (the union
alone: wall clock and the process's CPU time, which shared cores inflate
less) and its solid measured with ``inkray.formats.mesh_report``: smallest
angle, shells, self-intersecting faces (exact), watertight and manifold,
and ``top_distance`` (``relief_metrics.py`` beside this file): how far the
solid's top strays from the relief's visible fronts. Also the faces of the
solid against those of the closed parts it is made of (the ratio), and its
volume against the envelope's (the booleans' solid of the closed parts with
neither skirt nor snapping: the space between the highest front and the
lowest back, exactly), which the skirt, the snapping of outlines within a
pixel and the remeshing change.
Targets: <= 10 s at ~1 Mpx, >= 10 degrees, 1 shell, 0 self-intersecting
faces, watertight and manifold.

Usage::

    python benchmarks/bench_union.py [--names turtle,frog] [--mpx 1.0] [--repeat 2]
"""

import argparse
import hashlib
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_chain import _input  # noqa: E402
from relief_metrics import top_distance  # noqa: E402

from inkray.chain import ReliefChain  # noqa: E402
from inkray.formats.mesh_report import mesh_quality  # noqa: E402
from inkray.relief.assembly import _envelope_solid, _volume, assemble  # noqa: E402

TARGET_S = 10.0  # at ~1 Mpx


def _row(name, megapixels, repeat):
    ann, drawing = _input(name, megapixels)
    layers = ReliefChain(ann, drawing).layers
    walls, cpus, digests = [], [], set()
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        relief = assemble(layers, size=ann.size, closed=True, union=True)
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
        solid = relief.parts[0]
        digests.add(hashlib.sha256(np.ascontiguousarray(solid.vertices).tobytes()
                                   + np.ascontiguousarray(solid.faces).tobytes()).hexdigest())
    parts = assemble(layers, size=ann.size, closed=True).parts
    q = mesh_quality(solid.vertices, solid.faces)
    closed = q["watertight"] and q["edge_manifold"] and q["vertex_manifold"]
    same = "-" if repeat == 1 else ("yes" if len(digests) == 1 else "NO")
    faces = sum(len(p.faces) for p in parts)
    envelope = _volume(*_envelope_solid(parts, 0.0, 0.0))
    met = "yes" if not megapixels or np.median(cpus) <= TARGET_S else "NO"
    print(f"| {name} | {ann.size[0]}x{ann.size[1]} | {np.median(walls):.1f} | {np.median(cpus):.1f} "
          f"| {met} | {len(solid.faces)} | {faces} | {len(solid.faces) / faces:.2f} "
          f"| {'yes' if closed else 'NO'} | {q['shells']} | {q['min_angle_deg']:.1f} "
          f"| {q['self_intersecting_faces']} | {top_distance(solid, parts):.2f} "
          f"| {_volume(solid.vertices, solid.faces) / envelope - 1:+.1e} | {same} |", flush=True)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--names", help="comma-separated drawing names (default: all bundled)")
    parser.add_argument("--mpx", type=float, default=1.0,
                        help="also upscaled to this many Mpx (default 1; 0: own size only)")
    parser.add_argument("--repeat", type=int, default=1,
                        help="unions per drawing (medians); more than one also checks the bytes repeat")
    args = parser.parse_args(argv)
    names = args.names.split(",") if args.names else sorted(
        p.name for p in (ROOT / "examples").iterdir() if (p / "drawing.inkray.json").is_file())
    print(f"| drawing | size | union wall (s) | union CPU (s) | <= {TARGET_S:g} s | faces "
          "| parts' faces | ratio | watertight, manifold | shells | min angle (deg) "
          "| self-intersecting faces | top distance (px) | volume / envelope - 1 | same bytes |")
    print("| --- " * 15 + "|")
    for megapixels in [0.0] + ([args.mpx] if args.mpx else []):
        for name in names:
            _row(name, megapixels, args.repeat)


if __name__ == "__main__":
    main()
