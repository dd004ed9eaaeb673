"""How much of the front view lies on steep faces: the cost of giving them the paper colour.

    python benchmarks/steep_rims.py [DRAWING ...]      (default: turtle fish snowman cat)

The exporters give faces turned more than arccos(t) from the viewer the part's paper
colour (``inkray.formats.meshes._STEEP``, t = 0.1). For each bundled drawing and a few
thresholds t this prints the share of the relief's front-view pixels on such faces and
the share of the drawing's ink there (ink as the exporter and the renderer separate it):
what the front view would lose at that threshold.
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from inkray.chain import ReliefChain  # noqa: E402
from inkray.examples import example_path  # noqa: E402
from inkray.input.loading import load_input  # noqa: E402
from inkray.view.rasterization import rasterize  # noqa: E402

THRESHOLDS = (0.1, 0.15, 0.2, 0.25, 0.3)


def shares(relief, threshold):
    """``(pixels, ink)``: shares of the front view's pixels and ink pixels on faces steeper
    than ``arccos(threshold)``."""
    raster = rasterize(relief, size=relief.size, scale=1.0, offset=(0.0, 0.0))
    value = relief.texture.max(axis=2).astype(float)
    ink = value < 0.6 * np.percentile(value, 95)
    seen = raster.mask
    steep = np.zeros(seen.shape, bool)
    for i, part in enumerate(relief.parts):
        q = part.vertices[part.faces] * [1.0, -1.0, 1.0]
        n = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
        face = n[:, 2] < threshold * np.linalg.norm(n, axis=1)
        here = seen & (raster.part == i)
        steep[here] = face[raster.face[here]]
    return steep[seen].mean(), steep[seen & ink].sum() / max(int((seen & ink).sum()), 1)


def main(names):
    print("| drawing | " + " | ".join(f"t = {t}: pixels, ink" for t in THRESHOLDS) + " |")
    print("| --- " * (len(THRESHOLDS) + 1) + "|")
    for name in names:
        relief = ReliefChain(*load_input(example_path(name))).relief
        cells = [f"{100 * p:.2f} %, {100 * k:.1f} %"
                 for p, k in (shares(relief, t) for t in THRESHOLDS)]
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or ["turtle", "fish", "snowman", "cat"])
