"""Benchmark of ``inkray batch``: frames per minute with 1 and 2 Dask workers.

The frames are the bundled drawings (``examples/*/drawing.inkray.json``, at
their own sizes), repeated ``--repeat`` times as copies so that a run has
enough frames to keep every worker busy. Each row starts a local cluster of
that many worker processes (one thread each, as ``inkray batch`` does) and
times ``run_batch`` on a fresh output folder (nothing skipped), the cluster's
start included; "frame s" sums the frames' own times as the workers measured
them, "CPU s" the CPU time they used (when frame s grows and CPU s does not,
the workers waited for a core). The baseline is one worker; a row without Dask runs ``run_frame`` on
every frame in this process, the cost of the work alone.

Usage::

    python benchmarks/bench_batch.py [--jobs relief,render,layers,maps] [--repeat 2] [--workers 1,2]
"""

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def _frames(folder, repeat):
    """Copies of every bundled drawing's folder, ``repeat`` times; the glob pattern."""
    for k in range(repeat):
        for src in sorted(EXAMPLES.iterdir()):
            if (src / "drawing.inkray.json").is_file():
                shutil.copytree(src, folder / f"{src.name}-{k}")
    return str(folder / "*" / "drawing.inkray.json")


def _in_process(pattern, jobs):
    from inkray.batch import find_frames, run_frame

    frames = find_frames(pattern)
    start, cpu = time.perf_counter(), 0.0
    for f in frames:
        result = run_frame(f.annotation, jobs)
        if result["status"] != "done":
            raise SystemExit(f"{f.annotation}: {result['error']}")
        cpu += result["cpu_time"]
    wall = time.perf_counter() - start
    return len(frames), wall, wall, cpu


def _on_dask(pattern, jobs, workers, out):
    from inkray.batch import run_batch

    start = time.perf_counter()
    report = run_batch(pattern, out, jobs=jobs, workers=workers)
    wall = time.perf_counter() - start
    if report["counts"]["failed"]:
        raise SystemExit(f"{report['counts']['failed']} frames failed")
    frames = report["frames"].values()
    busy, cpu = sum(r["time"] for r in frames), sum(r["cpu_time"] for r in frames)
    return report["counts"]["done"], wall, busy, cpu


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", default="relief,render,layers,maps")
    parser.add_argument("--repeat", type=int, default=2, help="copies of every drawing")
    parser.add_argument("--workers", default="1,2", help="comma-separated worker counts")
    args = parser.parse_args()
    jobs = tuple(args.jobs.split(","))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        pattern = _frames(tmp / "shots", args.repeat)
        rows = []
        rows.append(("in process, no Dask",) + _in_process(pattern, jobs))
        for workers in (int(w) for w in args.workers.split(",")):
            rows.append((f"{workers} worker{'s' if workers > 1 else ''}",)
                         + _on_dask(pattern, jobs, workers, tmp / f"out-{workers}"))
    base = next(r for r in rows if r[0].startswith("1 worker"))
    print(f"jobs {','.join(jobs)}; {os.cpu_count()} cores; frames: the bundled drawings x "
          f"{args.repeat}")
    print("| run | frames | wall s | frames/min | vs 1 worker | frame s (sum) | CPU s (sum) |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, n, wall, busy, cpu in rows:
        fpm = 60.0 * n / wall
        ratio = fpm / (60.0 * base[1] / base[2])
        print(f"| {name} | {n} | {wall:.1f} | {fpm:.1f} | {ratio:.2f}x | {busy:.1f} | {cpu:.1f} |")


if __name__ == "__main__":
    main()
