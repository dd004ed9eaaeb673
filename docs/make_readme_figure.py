"""Make the README's picture: the bundled turtle's relief rendered with global illumination.

Run from the repository root (needs Mitsuba 3: ``pip install -e ".[render]"``)::

    python docs/make_readme_figure.py

The demo's relief (``inkray demo``'s ``relief.glb``) rendered as ``inkray
render relief.glb --mode gi --quality final`` does; written to
docs/images/turtle-gi.png.
"""

from pathlib import Path

from inkray.chain import build_relief
from inkray.examples import example_path
from inkray.formats.images import write_renderings
from inkray.input.loading import load_input
from inkray.view.rendering import GI_MAX_SIDE, GI_QUALITY, output_size, render

OUT = Path(__file__).resolve().parent / "images" / "turtle-gi.png"


def main():
    ann, drawing = load_input(example_path("turtle"))
    relief = build_relief(ann, drawing).relief
    size = output_size(relief.size, max_side=GI_MAX_SIDE)
    image = render(relief, mode="gi", size=size, spp=GI_QUALITY["final"])
    write_renderings(image, OUT)
    print(f"wrote {OUT.relative_to(Path.cwd()) if OUT.is_relative_to(Path.cwd()) else OUT}")


if __name__ == "__main__":
    main()
