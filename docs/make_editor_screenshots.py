"""The screenshots of docs/editor.md, made by driving the real page (Playwright, Chromium).

    python docs/make_editor_screenshots.py [--chromium /usr/bin/chromium]

Each picture is the editor served by ``inkray edit``'s own server on a copy of a bundled
drawing, driven with real mouse and keys as a user would: a guided start on the fish's
drawing alone, the fish after its first five minutes, the marks at 6x, a two-click
boundary, a contradiction in plain words beside the last good relief, the autosave
banner, and the Pose mode with a hand dragged up. Written to docs/images/editor*.png.
"""

import argparse
import io
import json
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"
EXAMPLES = ROOT / "examples"
sys.path.insert(0, str(ROOT))

from inkray.editor.server import serve  # noqa: E402
from inkray.editor.session import EditSession, autosave_path  # noqa: E402


def _serve(session):
    """Serve ``session`` on a free loopback port in a daemon thread; its address."""
    out = io.StringIO()
    threading.Thread(target=serve, args=(session,), daemon=True,
                     kwargs=dict(port=0, open_browser=False, stream=out)).start()
    while "serving" not in out.getvalue():
        time.sleep(0.05)
    return out.getvalue().split("serving ", 1)[1].strip()


class Page:
    """A Chromium page on an editor, with the moves of a user in drawing pixels."""

    def __init__(self, browser, url):
        self.page = browser.new_page(viewport={"width": 1440, "height": 900})
        self.page.set_default_timeout(180_000)
        self.page.goto(url)
        self.settle()

    def settle(self):
        self.page.wait_for_timeout(300)
        self.page.wait_for_function("document.body.dataset.busy === 'false'")
        self.page.wait_for_timeout(300)

    def screen(self, points):
        return self.page.evaluate("""(pts) => {
            const vp = document.getElementById('viewport').getBoundingClientRect();
            const v = window.inkray.view;
            return pts.map(([x, y]) => [vp.left + v.tx + (x + 0.5) * v.s, vp.top + v.ty + (y + 0.5) * v.s]);
        }""", points)

    def drag(self, points, steps=6):
        pts = self.screen(points)
        mouse = self.page.mouse
        mouse.move(*pts[0])
        mouse.down()
        for a, b in zip(pts, pts[1:]):
            for k in range(1, steps + 1):
                mouse.move(a[0] + k / steps * (b[0] - a[0]), a[1] + k / steps * (b[1] - a[1]))
        mouse.up()

    def click(self, point):
        self.page.mouse.click(*self.screen([point])[0])

    def name(self, text):
        self.page.wait_for_selector("#name-field:not([hidden])")
        self.page.keyboard.type(text)
        self.page.keyboard.press("Enter")

    def shot(self, name):
        self.page.evaluate("document.getElementById('side').scrollTop = 0")
        self.page.screenshot(path=str(IMAGES / name))
        print(f"wrote docs/images/{name}")


FISH_PARTS = [("body", [[150, 150], [200, 165]]), ("tail", [[55, 150], [70, 165]]),
              ("fin_top", [[235, 75], [260, 80]]), ("fin_bottom", [[250, 240], [265, 248]]),
              ("fin_side", [[255, 160], [275, 170]]), ("eye", [[368, 138], [372, 142]])]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--chromium", default="/usr/bin/chromium")
    args = parser.parse_args(argv)
    from playwright.sync_api import sync_playwright

    tmp = Path(tempfile.mkdtemp())
    shutil.copy(EXAMPLES / "fish" / "drawing.png", tmp / "fish.png")
    for p in (EXAMPLES / "turtle").iterdir():
        if p.name.startswith("drawing"):
            shutil.copy(p, tmp / p.name)
    turtle = tmp / "drawing.inkray.json"
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=args.chromium, args=[
            "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])

        # a new file: what to do first, and previews that say why they are empty
        fish = EditSession(tmp / "fish.inkray.json", drawing=tmp / "fish.png")
        page = Page(browser, _serve(fish))
        page.shot("editor-start.png")

        # its first five minutes: a scribble per part, each named at the scribble
        page.page.keyboard.press("r")
        for name, scribble in FISH_PARTS:
            page.drag(scribble)
            page.name(name)
            page.settle()
        page.drag([[320, 190], [340, 180]])  # in the body: extends it
        page.settle()
        page.page.keyboard.press("v")
        page.shot("editor.png")

        # zoomed in 6x: the marks and the predicted arrows' controls keep their size
        page.page.evaluate("window.inkray.setZoom(6, [215, 150])")
        page.page.wait_for_timeout(300)
        page.shot("editor-zoom.png")
        page.page.keyboard.press("f")

        # a two-click boundary: the path follows the fin's outline between the clicks
        page.page.keyboard.press("g")
        page.page.select_option("#boundary-type", "graft")
        page.click([232, 166])
        page.click([300, 186])
        page.page.wait_for_function("(window.inkray.doc.boundaries || []).length === 1")
        page.settle()
        page.page.keyboard.press("v")
        path = fish.document["boundaries"][-1]["path"]
        page.page.evaluate("([s, at]) => window.inkray.setZoom(s, at)",
                           [3.2, [(path[0][0] + path[-1][0]) / 2, (path[0][1] + path[-1][1]) / 2]])
        page.page.wait_for_timeout(300)
        page.shot("editor-boundary.png")
        page.page.keyboard.press("f")

        # a contradiction, in plain words above the drawing; the last good relief kept
        page.page.keyboard.press("o")
        page.drag([[265, 165], [230, 200]])
        page.settle()
        page.drag([[318, 198], [292, 183]])
        page.settle()
        page.page.keyboard.press("v")
        page.shot("editor-problems.png")
        page.page.close()

        # the autosave of an editor that was not saved: announced, with Discard
        doc = json.loads(turtle.read_text())
        autosave_path(turtle).write_text(json.dumps(dict(doc, order=doc["order"][:2])))
        page = Page(browser, _serve(EditSession(turtle)))
        page.shot("editor-autosave.png")
        page.page.close()

        # the Pose mode on the man: three handles clicked, the hand dragged up
        for p in (EXAMPLES / "man").iterdir():
            if p.name.startswith("drawing"):
                shutil.copy(p, tmp / f"man-{p.name}")
        man = tmp / "man-drawing.inkray.json"
        man.write_text(man.read_text().replace('"drawing.jpg"', '"man-drawing.jpg"'))
        page = Page(browser, _serve(EditSession(man)))
        page.page.click("#pose-mode")
        for point in ([150, 330], [150, 250], [265, 180]):
            page.click(point)
        page.page.wait_for_function("window.inkrayPose.updates >= 1 && !window.inkrayPose.busy")
        before = page.page.evaluate("window.inkrayPose.updates")
        page.drag([[265, 180], [233, 84]], steps=8)
        page.page.wait_for_function(f"window.inkrayPose.updates > {before} "
                                    f"&& !window.inkrayPose.busy")
        page.page.wait_for_timeout(500)
        page.shot("editor-pose.png")
        browser.close()


if __name__ == "__main__":
    main()
