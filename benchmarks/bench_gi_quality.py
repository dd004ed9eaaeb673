"""Benchmark of the GI quality presets: low-frequency noise (blotches) against a reference.

Run as ``python benchmarks/bench_gi_quality.py [--examples rings,turtle,figure]
[--size 400] [--reference-spp 256] [--spp 4,8,16,32,64] [--cache DIR]``.

Denoising a few samples per pixel removes the fine grain but leaves blotches:
the filter averages the noise into patches a few pixels wide, which PSNR
barely sees but a smooth surface shows. This measures them: the final 8-bit
picture (ink on top) and a raw reference at ``--reference-spp`` (another
seed, cached as in ``bench_gi.py``) are blurred with a Gaussian of
``sigma = 4`` px and the RMS of their difference (in 8-bit levels) is taken
over the relief's pixels (``blotch``); the fine-grain RMS (unblurred
difference minus the blurred one) is shown beside it, with the render's CPU
and wall time. ``rings`` is the drawing the presets were chosen on; the
others are held out. Quote medians: on a shared machine the times vary.
"""

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter

from bench_gi import example_relief, reference
from inkray.view.rendering import has_mitsuba, render

_SIGMA = 4.0
_LUMA = np.array([0.2126, 0.7152, 0.0722])


def noise(image, ref, mask):
    """(blotch, grain): RMS of the blurred and of the remaining difference, 8-bit levels."""
    d = (image[..., :3].astype(float) - ref[..., :3].astype(float)) @ _LUMA
    low = gaussian_filter(d, _SIGMA)
    m = mask.astype(bool)
    return float(np.sqrt(np.mean(low[m] ** 2))), float(np.sqrt(np.mean((d - low)[m] ** 2)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", default="rings,turtle,figure")
    ap.add_argument("--size", type=int, default=400)
    ap.add_argument("--reference-spp", type=int, default=256)
    ap.add_argument("--spp", default="4,8,16,32,64")
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "inkray-bench-gi")
    args = ap.parse_args()
    if not has_mitsuba():
        raise SystemExit("bench_gi_quality: Mitsuba 3 is not installed")
    size = (args.size, args.size)
    print(f"GI {size[0]}x{size[1]}, denoised, vs a raw {args.reference_spp}-spp reference; "
          f"blotch = RMS of the difference blurred by sigma {_SIGMA:g} px (8-bit levels)")
    print(f"{'drawing':<10}{'spp':>5}{'blotch':>9}{'grain':>8}{'CPU s':>8}{'wall s':>8}")
    for name in args.examples.split(","):
        relief = example_relief(name)
        ref = reference(relief, name, size, args.reference_spp, args.cache)
        for spp in (int(s) for s in args.spp.split(",")):
            cpu, wall = time.process_time(), time.perf_counter()
            r = render(relief, mode="gi", size=size, spp=spp)
            cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
            blotch, grain = noise(r.image, ref, r.mask)
            print(f"{name:<10}{spp:>5}{blotch:>9.3f}{grain:>8.3f}{cpu:>8.2f}{wall:>8.2f}",
                  flush=True)


if __name__ == "__main__":
    main()
