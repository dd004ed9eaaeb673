"""Regenerate the reference meshes of the bundled examples.

    python meshes/regenerate.py

writes ``meshes/<example>.ply`` (binary PLY, inkray's default frame: 0.001
units per pixel, centred; the relief's surface alone, without the back an
export adds) for the examples in ``REFERENCES``. ``tests/test_regression.py``
rebuilds each relief and compares it with these files, so a change that moves
the output shows up as a failing test; regenerate (and review the difference)
when the change is intended.
"""

from pathlib import Path

from inkray.examples import example_path
from inkray.formats.meshes import export_relief
from inkray.input.loading import load_input
from inkray.chain import build_relief

HERE = Path(__file__).resolve().parent
#: The examples with a reference mesh: small, large, and one of every kind of entry.
REFERENCES = ("turtle", "balls", "frog")


def main():
    for name in REFERENCES:
        ann, drawing = load_input(example_path(name))
        result = build_relief(ann, drawing)
        written = export_relief(result.relief, HERE / f"{name}.ply", back="none")
        parts = result.relief.parts
        print(f"{written[0]}: {len(parts)} parts, {sum(len(p.vertices) for p in parts)} vertices")


if __name__ == "__main__":
    main()
