"""Make the pictures of docs/pose.md.

docs/images/pose-man.png: the man at rest and with his arm raised by
examples/man/raise-arm.pose.json; docs/images/compose-men.png: the scene
docs/images/men.scene.json.

    python docs/make_pose_figure.py
"""

from pathlib import Path

import numpy as np
from PIL import Image

from inkray.artefacts import ARTEFACTS
from inkray.chain import ReliefChain
from inkray.composition import compose
from inkray.input.loading import load_input
from inkray.input.pose import load_pose
from inkray.input.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]


def main():
    ann, drawing = load_input(ROOT / "examples" / "man" / "drawing.inkray.json")
    chain = ReliefChain(ann, drawing)
    pose = load_pose(ROOT / "examples" / "man" / "raise-arm.pose.json", size=ann.size)
    pictures = [ARTEFACTS["posed"].make(chain, pose=pose, frame=f).image for f in (0, 6)]
    w, h = ann.size
    sheet = Image.new("RGBA", (2 * w, h), (255, 255, 255, 255))
    for k, rgba in enumerate(pictures):
        sheet.alpha_composite(Image.fromarray(np.asarray(rgba)), (k * w, 0))
    out = ROOT / "docs" / "images" / "pose-man.png"
    sheet.convert("RGB").save(out)
    print(out)
    scene = compose(load_scene(ROOT / "docs" / "images" / "men.scene.json"))
    rgba = Image.fromarray(scene.image())
    sheet = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
    sheet.alpha_composite(rgba)
    out = ROOT / "docs" / "images" / "compose-men.png"
    sheet.convert("RGB").save(out)
    print(out)


if __name__ == "__main__":
    main()
