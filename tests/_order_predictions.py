"""Per-place depth-order predictions of the bundled drawings, for the regression test
of tests/test_ordering.py and the fixture it compares against.

``python tests/_order_predictions.py`` writes ``tests/data/order_predictions.json``:
every place of every bundled drawing, at its size and upscaled to about 1 Mpx
(Lanczos, annotations rescaled), predicted with the weighted cues and with the
shipped learned model (the drawing's ink style, its graft and stitch seams, no
user entry, no consistency step).
"""

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FIXTURE = Path(__file__).resolve().parent / "data" / "order_predictions.json"
MEGAPIXELS = 1.0


def drawing_names():
    return sorted(p.parent.name for p in (ROOT / "examples").glob("*/drawing.inkray.json"))


def predictions(name, *, upscaled=False):
    """``{"size", "cues", "learned"}``: per place ``[a, b, front, confidence]`` (``null``
    where the place gives no prediction), at the drawing's size or about 1 Mpx."""
    from PIL import Image

    from inkray.chain import ChainOptions, ReliefChain
    from inkray.input.annotations import rescale_annotations
    from inkray.input.drawing import drawing_from_array
    from inkray.input.loading import load_input
    from inkray.relief.ink_style import ink_style
    from inkray.relief.order_model import load_order_model
    from inkray.relief.ordering import WEIGHTS, predict_place

    folder = ROOT / "examples" / name
    ann, drawing = load_input(folder / "drawing.inkray.json")
    if upscaled:
        image = Image.open(ann.drawing).convert("RGB")
        scale = (MEGAPIXELS * 1e6 / (image.width * image.height)) ** 0.5
        size = (round(image.width * scale), round(image.height * scale))
        drawing = drawing_from_array(np.asarray(image.resize(size, Image.LANCZOS)))
        ann = rescale_annotations(ann, size)
    ann = replace(ann, order=[])
    chain = ReliefChain(ann, drawing, options=ChainOptions(predict=False))
    completion = chain.candidates
    ink = ink_style(drawing.gray)
    seams = [b.path for b in ann.boundaries if b.type in ("graft", "stitch")]
    out = {"size": list(completion.labels.shape[::-1])}
    for key, given in (("cues", {"weights": WEIGHTS}), ("learned", {"model": load_order_model()})):
        rows = []
        for place in completion.places:
            r = predict_place(completion, place, seams=seams, ink=ink, **given)
            rows.append([place.a, place.b, None if r is None else r.front,
                         None if r is None else r.confidence])
        out[key] = rows
    return out


def main():
    import subprocess

    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip()
    data = {"made_by": "python tests/_order_predictions.py", "commit": commit,
            "megapixels": MEGAPIXELS, "drawings": {}}
    for name in drawing_names():
        data["drawings"][name] = {"native": predictions(name),
                                  "upscaled": predictions(name, upscaled=True)}
        print(name, file=sys.stderr)
    FIXTURE.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
