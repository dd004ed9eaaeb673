"""Benchmark of the GI render's quality per sample: raw and denoised against a reference.

Run as ``python benchmarks/bench_gi.py [--examples turtle,figure,fox] [--size 512]
[--reference-spp 512] [--cache DIR] [--crops PNG]``.

For each bundled drawing the relief is built as ``inkray demo`` builds it and
rendered with ``render(mode="gi")`` at ``--size`` (square). The reference is
the raw render at ``--reference-spp`` with another seed, computed once and
cached in ``--cache`` (default: a folder in the system's temp dir; keyed by
the relief's geometry, so a changed relief gets a new reference). Each row
is the final 8-bit picture (ink on top) compared to the reference: PSNR (dB)
and SSIM (``skimage.metrics``), with the render's CPU time (all threads of
this process, steadier than wall time on a shared machine) and wall time,
and the CPU time as a ratio of the baseline: today's raw render at the
demo's former default of 32 samples per pixel.

The last table names, for each former default (``inkray demo``: 32 raw,
``inkray render --mode gi``: 64 raw), the fewest denoised samples per pixel
at least as close to the reference on every drawing (PSNR and SSIM).
"""

import argparse
import hashlib
import tempfile
import time
from pathlib import Path

import numpy as np
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

from inkray.chain import build_relief
from inkray.examples import example_path
from inkray.input.loading import load_input
from inkray.view.rendering import has_mitsuba, render

RAW = (8, 16, 32, 64)
DENOISED = (4, 8, 16)
BASELINE = ("raw", 32)
FORMER_DEFAULTS = {"inkray demo": 32, "inkray render --mode gi": 64}
_REFERENCE_SEED = 1000  # not the renders' seed: the reference's noise is its own


def example_relief(name):
    """A bundled example's relief, as ``inkray relief`` (and the demo) builds it."""
    ann, drawing = load_input(example_path(name))
    return build_relief(ann, drawing).relief


def _key(relief, size, spp):
    h = hashlib.sha256(f"{size} {spp}".encode())
    for p in relief.parts:
        h.update(np.ascontiguousarray(p.vertices, np.float64).tobytes())
        h.update(np.ascontiguousarray(p.faces, np.int64).tobytes())
    return h.hexdigest()[:16]


def reference(relief, name, size, spp, cache):
    """The raw render at ``spp``, from ``cache`` when it was rendered before."""
    path = cache / f"{name}-{size[0]}x{size[1]}-{spp}spp-{_key(relief, size, spp)}.npy"
    if path.exists():
        return np.load(path)
    print(f"  reference: {name} at {spp} spp (once; cached in {cache}/)", flush=True)
    img = render(relief, mode="gi", size=size, spp=spp, seed=_REFERENCE_SEED,
                 denoise=False).image
    cache.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npy")
    np.save(tmp, img)
    tmp.replace(path)
    return img


def _timed(fn):
    cpu, wall = time.process_time(), time.perf_counter()
    out = fn()
    return out, time.process_time() - cpu, time.perf_counter() - wall


def measure(relief, ref, size, kind, spp):
    """PSNR, SSIM, CPU and wall seconds of one render against the reference."""
    r, cpu, wall = _timed(lambda: render(relief, mode="gi", size=size, spp=spp,
                                         denoise=kind == "denoised"))
    a, b = r.image[..., :3], ref[..., :3]
    return {"psnr": peak_signal_noise_ratio(b, a, data_range=255),
            "ssim": structural_similarity(b, a, channel_axis=2, data_range=255),
            "cpu": cpu, "wall": wall, "image": r.image}


def _crops(results, refs, path, box=160):
    """Raw at the baseline spp | denoised at each spp | reference, a crop per drawing."""
    from PIL import Image, ImageDraw

    rows = []
    for name, ref in refs.items():
        h, w = ref.shape[:2]
        y0, x0 = (h - box) // 2, (w - box) // 2
        cells = [(f"raw {BASELINE[1]}", results[name][BASELINE]["image"])]
        cells += [(f"denoised {s}", results[name][("denoised", s)]["image"]) for s in DENOISED]
        cells += [("reference", ref)]
        row = np.concatenate([np.pad(img[y0:y0 + box, x0:x0 + box, :3],
                                     ((18, 2), (2, 2), (0, 0)), constant_values=255)
                              for _, img in cells], axis=1)
        pic = Image.fromarray(row)
        draw = ImageDraw.Draw(pic)
        for i, (label, _) in enumerate(cells):
            draw.text((i * (box + 4) + 4, 3), f"{name}: {label}", fill=(0, 0, 0))
        rows.append(np.asarray(pic))
    Image.fromarray(np.concatenate(rows, axis=0)).save(path, optimize=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", default="turtle,figure,fox",
                    help="bundled drawings, comma-separated (default: turtle,figure,fox)")
    ap.add_argument("--size", type=int, default=512, help="square image side (default: 512)")
    ap.add_argument("--reference-spp", type=int, default=512)
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "inkray-bench-gi")
    ap.add_argument("--crops", type=Path, help="write raw/denoised/reference crops (PNG)")
    args = ap.parse_args()
    if not has_mitsuba():
        raise SystemExit("bench_gi: Mitsuba 3 is not installed (pip install 'inkray[render]')")
    size = (args.size, args.size)
    runs = [("raw", s) for s in RAW] + [("denoised", s) for s in DENOISED]
    results, refs = {}, {}
    for name in args.examples.split(","):
        relief = example_relief(name)
        refs[name] = reference(relief, name, size, args.reference_spp, args.cache)
        results[name] = {run: measure(relief, refs[name], size, *run) for run in runs}

    print(f"\nGI {size[0]}x{size[1]} vs a {args.reference_spp}-spp reference; "
          f"x base = CPU time / CPU time of {BASELINE[0]} {BASELINE[1]} spp")
    print(f"{'drawing':<10}{'render':<10}{'spp':>5}{'PSNR dB':>9}{'SSIM':>8}{'CPU s':>8}"
          f"{'wall s':>8}{'x base':>8}")
    for name, rows in results.items():
        base = rows[BASELINE]["cpu"]
        for (kind, spp), m in rows.items():
            print(f"{name:<10}{kind:<10}{spp:>5}{m['psnr']:>9.2f}{m['ssim']:>8.4f}"
                  f"{m['cpu']:>8.2f}{m['wall']:>8.2f}{m['cpu'] / base:>8.2f}")

    print(f"\n{'former default':<26}{'raw spp':>8}{'denoised spp as close':>23}")
    for command, spp in FORMER_DEFAULTS.items():
        ok = [s for s in DENOISED
              if all(r[("denoised", s)]["psnr"] >= r[("raw", spp)]["psnr"]
                     and r[("denoised", s)]["ssim"] >= r[("raw", spp)]["ssim"]
                     for r in results.values())]
        print(f"{command:<26}{spp:>8}{(str(min(ok)) if ok else 'none'):>23}")
    if args.crops:
        _crops(results, refs, args.crops)
        print(f"\nwrote {args.crops}")


if __name__ == "__main__":
    main()
