"""The picture of docs/export.md's *Backs*: the turtle's GLB in three.js, from the front, the side and behind.

    python docs/make_back_figure.py [--chromium /usr/bin/chromium]

The bundled turtle's relief is exported twice, as ``inkray relief`` writes it (every
part a sheet with a back of its own) and with ``back="none"`` shown by a material that
draws both sides (what a viewer that culls nothing, or Blender's Cycles, shows of a bare
surface). Each is loaded by the three.js GLTFLoader the editor vendors, in headless
Chromium, and drawn from the front, at three-quarters, from behind at three-quarters and
from behind.
Written to docs/images/backs.png.
"""

import argparse
import base64
import functools
import http.server
import io
import shutil
import sys
import tempfile
import threading
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from inkray.chain import ReliefChain  # noqa: E402
from inkray.examples import example_path  # noqa: E402
from inkray.formats.meshes import export_relief  # noqa: E402
from inkray.input.loading import load_input  # noqa: E402

VIEWS = (("front", 0), ("three-quarters", 45), ("behind, three-quarters", 135), ("behind", 180))
PAGE = """<!doctype html><html><body style="margin:0">
<script type="importmap">{"imports": {"three": "./vendor/three/build/three.module.js",
                                       "three/addons/": "./vendor/three/addons/"}}</script>
<script type="module">
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setSize(360, 360);
document.body.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x404048);
scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 1.2));
const sun = new THREE.DirectionalLight(0xffffff, 2.0);
scene.add(sun);
const camera = new THREE.OrthographicCamera(-0.3, 0.3, 0.3, -0.3, 0.001, 100);
window.shots = async (file, bothSides, yaws) => {
  const gltf = await new GLTFLoader().loadAsync(file);
  if (bothSides) gltf.scene.traverse((o) => { if (o.isMesh) o.material.side = THREE.DoubleSide; });
  scene.add(gltf.scene);
  const out = [];
  for (const yaw of yaws) {
    const a = yaw * Math.PI / 180;
    camera.position.set(-2 * Math.sin(a), 0.3, 2 * Math.cos(a));
    camera.lookAt(0, 0, 0);
    sun.position.copy(camera.position).add(new THREE.Vector3(-1, 1, 0));
    renderer.render(scene, camera);
    out.push(renderer.domElement.toDataURL("image/png"));
  }
  scene.remove(gltf.scene);
  return out;
};
window.ready = true;
</script></body></html>"""


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):  # the figure's requests are not news
        pass


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--chromium", default="/usr/bin/chromium")
    args = parser.parse_args()
    from PIL import Image, ImageDraw
    from playwright.sync_api import sync_playwright

    relief = ReliefChain(*load_input(example_path("turtle"))).relief
    with tempfile.TemporaryDirectory(prefix="inkray-backs-") as folder:
        folder = Path(folder)
        shutil.copytree(ROOT / "inkray" / "editor" / "static" / "vendor", folder / "vendor")
        (folder / "index.html").write_text(PAGE)
        export_relief(relief, folder / "sheet.glb")
        export_relief(relief, folder / "bare.glb", back="none")
        handler = functools.partial(_Quiet, directory=str(folder))
        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
        threading.Thread(target=server.serve_forever, daemon=True).start()
        rows = []
        try:
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=args.chromium, args=[
                    "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
                page = browser.new_page()
                page.goto(f"http://127.0.0.1:{server.server_address[1]}/index.html")
                page.wait_for_function("window.ready === true")
                for file, both in (("bare.glb", True), ("sheet.glb", False)):
                    urls = page.evaluate("([f, b, y]) => window.shots(f, b, y)",
                                         [file, both, [yaw for _, yaw in VIEWS]])
                    rows.append([Image.open(io.BytesIO(base64.b64decode(u.split(",")[1])))
                                 .convert("RGB") for u in urls])
                browser.close()
        finally:
            server.shutdown()
    labels = ("the bare surface, both sides drawn", "as exported: a back of its own")
    side, top, left = 360, 24, 0
    figure = Image.new("RGB", (left + side * len(VIEWS), top + (side + top) * len(rows)),
                       "white")
    draw = ImageDraw.Draw(figure)
    for i, (name, _) in enumerate(VIEWS):
        draw.text((left + i * side + 8, 6), name, fill="black")
    for r, (row, label) in enumerate(zip(rows, labels)):
        y = top + r * (side + top)
        draw.text((8, y + 6), label, fill="black")
        for i, image in enumerate(row):
            figure.paste(image, (left + i * side, y + top))
    out = ROOT / "docs" / "images" / "backs.png"
    figure.save(out, optimize=True)
    print(out)


if __name__ == "__main__":
    main()
