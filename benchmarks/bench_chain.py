"""Benchmark of the resumable chain: what an edit costs against a cold relief.

For each bundled drawing with order entries, upscaled to about 1 Mpx (and at
its own size with ``--own-size``), in a fresh process:

- cold: a new chain's relief (every stage), its last ``order`` entry left out;
- +order: the chain after adding that entry back (target: no segmentation or
  completion re-run, <= 25 % of cold);
- inflation: after changing one region's ``inflation`` (<= 20 % of cold);
- undo: the chain of the annotations before that change (<= 5 % of cold).

Each edit is timed to its finished relief; the stages it ran are listed.

Usage::

    python benchmarks/bench_chain.py [--names turtle,frog] [--own-size] [--mpx 1.0]
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
TARGETS = {"+order": 0.25, "inflation": 0.20, "undo": 0.05}


def _drawings():
    return sorted(p.name for p in EXAMPLES.iterdir()
                  if (p / "drawing.inkray.json").is_file()
                  and json.loads((p / "drawing.inkray.json").read_text()).get("order"))


def _input(name, megapixels):
    from PIL import Image

    from inkray.input.loading import load_input

    ann_path = EXAMPLES / name / "drawing.inkray.json"
    drawing = None
    if megapixels:
        src = next(p for p in (EXAMPLES / name).iterdir()
                   if p.stem == "drawing" and p.suffix not in (".json", ".svg"))
        image = Image.open(src)
        scale = (megapixels * 1e6 / (image.width * image.height)) ** 0.5
        size = (round(image.width * scale), round(image.height * scale))
        drawing = Path(tempfile.mkdtemp()) / f"up{src.suffix}"
        image.resize(size, Image.LANCZOS).save(drawing)
    return load_input(ann_path, drawing=drawing, rescale=drawing is not None)


def _one(name, megapixels):
    from inkray.chain import ReliefChain

    ann, drawing = _input(name, megapixels)
    without = replace(ann, order=ann.order[:-1])
    rows = {}

    def timed(label, chain):
        start = time.perf_counter()
        chain.relief
        rows[label] = {"s": time.perf_counter() - start, "stages": list(chain.recomputed)}
        return chain

    cold = timed("cold", ReliefChain(without, drawing))
    full = timed("+order", cold.edit(annotations=ann))
    region = max(range(len(ann.regions)), key=lambda i: full.completion.completed(i).sum())
    regions = list(ann.regions)
    regions[region] = replace(regions[region], inflation=regions[region].inflation * 1.5)
    timed("inflation", full.edit(annotations=replace(ann, regions=regions)))
    timed("undo", full.edit(annotations=ann))
    print(json.dumps({"name": name, "size": list(ann.size), "regions": len(ann.regions),
                      "region": ann.regions[region].name, "rows": rows}))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--names", help="comma-separated bundled drawings (default: all with order)")
    parser.add_argument("--mpx", type=float, default=1.0, help="upscale to this many Mpx (default 1)")
    parser.add_argument("--own-size", action="store_true", help="the drawings at their own size")
    parser.add_argument("--one", nargs=2, metavar=("NAME", "MPX"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        _one(args.one[0], float(args.one[1]))
        return
    names = args.names.split(",") if args.names else _drawings()
    mpx = 0.0 if args.own_size else args.mpx
    print("| drawing | size | cold s | edit | s | / cold | target | stages run |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for name in names:
        run = subprocess.run([sys.executable, __file__, "--one", name, str(mpx)],
                             capture_output=True, text=True,
                             env={**os.environ, "PYTHONHASHSEED": "0"})
        if run.returncode != 0:
            print(f"| {name} | failed: {run.stderr.strip().splitlines()[-1]} |")
            continue
        r = json.loads(run.stdout.strip().splitlines()[-1])
        cold = r["rows"]["cold"]["s"]
        size = f"{r['size'][0]}x{r['size'][1]}"
        for label, target in TARGETS.items():
            row = r["rows"][label]
            ratio = row["s"] / cold
            edit = f"{label} ({r['region']})" if label == "inflation" else label
            ok = "ok" if ratio <= target else "MISSED"
            print(f"| {name} | {size} | {cold:.2f} | {edit} | {row['s']:.3f} | {ratio:.1%} | "
                  f"<= {target:.0%} {ok} | {', '.join(row['stages']) or 'none (cache)'} |")


if __name__ == "__main__":
    main()
