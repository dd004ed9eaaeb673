"""Benchmark of the ``--closed --union`` solid of every bundled drawing.

For each drawing, at its own size and upscaled to about ``--mpx``
megapixels (as ``bench_chain.py`` does), the stitched layers are built
once, then ``assemble(..., closed=True, union=True)`` is timed (the union
alone: wall clock and the process's CPU time, which shared cores inflate
less) and its solid measured with ``inkray.formats.mesh_report``: smallest
angle, shells, self-intersecting faces (exact in double precision, and
also once rounded to float32 as PLY and GLB store them:
``inkray.relief.patches.bad_faces``), watertight and manifold,
and ``top_distance`` (``relief_metrics.py`` beside this file): how far the
solid's top strays from the relief's visible fronts. Also the faces of the
solid against those of the closed parts it is made of (the ratio), and its
volume against the envelope's (the booleans' solid of the closed parts with
neither skirt nor snapping: the space between the highest front and the
lowest back, exactly), which the skirt, the snapping of outlines within a
pixel and the remeshing change, and a digest of the solid's bytes (the first
12 hex digits of the SHA-1 of its vertices' then its faces' bytes): which
solids a change of code leaves as they were.
Targets: <= 10 s at ~1 Mpx, >= 10 degrees, 1 shell, 0 self-intersecting
faces, watertight and manifold.

With ``--parts DIR`` the closed parts of each drawing and size are pickled
into ``DIR`` once (``<name>-<size>.pkl``) and read from there afterwards, and
``union_parts`` alone is timed on them: the same parts for code under
comparison (the chain's stages change parts as main moves), in a fraction of
the time.

Usage::

    python benchmarks/bench_union.py [--names turtle,frog] [--mpx 1.0] [--repeat 2] [--parts DIR]
"""

import argparse
import hashlib
import pickle
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
from inkray.relief.assembly import _envelope_solid, _volume, assemble, union_parts  # noqa: E402
from inkray.relief.patches import bad_faces  # noqa: E402

TARGET_S = 10.0  # at ~1 Mpx


def _closed_parts(name, megapixels, folder):
    """The drawing's size and closed parts, pickled in ``folder`` (when given) once."""
    size = "own" if not megapixels else f"{megapixels:g}mpx"
    path = folder / f"{name}-{size}.pkl" if folder else None
    if path is not None and path.is_file():
        with open(path, "rb") as handle:
            return pickle.load(handle)
    ann, drawing = _input(name, megapixels)
    layers = ReliefChain(ann, drawing).layers
    out = ann.size, assemble(layers, size=ann.size, closed=True).parts
    if path is not None:
        folder.mkdir(parents=True, exist_ok=True)
        with open(path, "wb") as handle:
            pickle.dump(out, handle)
    return out


def _row(name, megapixels, repeat, folder=None):
    size, parts = _closed_parts(name, megapixels, folder)
    walls, cpus, digests = [], [], set()
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        solid = union_parts(parts)
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
        digests.add(hashlib.sha1(np.ascontiguousarray(solid.vertices).tobytes()
                                 + np.ascontiguousarray(solid.faces).tobytes()).hexdigest()[:12])
    q = mesh_quality(solid.vertices, solid.faces)
    stored = int(bad_faces(solid.vertices, solid.faces, min_angle=0.0).sum())
    closed = q["watertight"] and q["edge_manifold"] and q["vertex_manifold"]
    same = "-" if repeat == 1 else ("yes" if len(digests) == 1 else "NO")
    faces = sum(len(p.faces) for p in parts)
    envelope = _volume(*_envelope_solid(parts, 0.0, 0.0))
    met = "yes" if not megapixels or np.median(cpus) <= TARGET_S else "NO"
    print(f"| {name} | {size[0]}x{size[1]} | {np.median(walls):.1f} | {np.median(cpus):.1f} "
          f"| {met} | {len(solid.faces)} | {faces} | {len(solid.faces) / faces:.2f} "
          f"| {'yes' if closed else 'NO'} | {q['shells']} | {q['min_angle_deg']:.1f} "
          f"| {q['self_intersecting_faces']} / {stored} | {top_distance(solid, parts):.2f} "
          f"| {_volume(solid.vertices, solid.faces) / envelope - 1:+.1e} | {same} "
          f"| {min(digests)} |", flush=True)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--names", help="comma-separated drawing names (default: all bundled)")
    parser.add_argument("--mpx", type=float, default=1.0,
                        help="also upscaled to this many Mpx (default 1; 0: own size only)")
    parser.add_argument("--repeat", type=int, default=1,
                        help="unions per drawing (medians); more than one also checks the bytes repeat")
    parser.add_argument("--parts", type=Path,
                        help="folder of pickled closed parts (made on the first run)")
    args = parser.parse_args(argv)
    names = args.names.split(",") if args.names else sorted(
        p.name for p in (ROOT / "examples").iterdir() if (p / "drawing.inkray.json").is_file())
    print(f"| drawing | size | union wall (s) | union CPU (s) | <= {TARGET_S:g} s | faces "
          "| parts' faces | ratio | watertight, manifold | shells | min angle (deg) "
          "| self-intersecting faces, double / float32 | top distance (px) | volume / envelope - 1 | same bytes "
          "| digest |")
    print("| --- " * 16 + "|")
    for megapixels in [0.0] + ([args.mpx] if args.mpx else []):
        for name in names:
            _row(name, megapixels, args.repeat, args.parts)


if __name__ == "__main__":
    main()
