"""The picture of a shot in the editor (docs/editor.md, Shots), made by driving the real page.

    python docs/make_editor_shot_screenshot.py [--chromium /usr/bin/chromium]

The Krita walk cycle (examples/shots/krita_walkcycle, GFDL 1.3) copied to a temporary
folder with its key, frame 1; the editor opens frame 3 with the annotation carried to it and
steps to frame 4 with the ▶ button. Written to docs/images/editor-shot.png.
"""

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from make_editor_screenshots import EXAMPLES, Page, _serve  # noqa: E402

from inkray.editor.shot import open_shot  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--chromium", default="/usr/bin/chromium")
    args = parser.parse_args(argv)
    from playwright.sync_api import sync_playwright

    tmp = Path(tempfile.mkdtemp())
    for p in (EXAMPLES / "shots" / "krita_walkcycle").glob("000[1-5]*"):
        shutil.copy(p, tmp / p.name)
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=args.chromium, args=[
            "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        page = Page(browser, _serve(open_shot(tmp / "0003.png")))
        page.page.click("#shot-next")
        page.page.wait_for_function("document.body.dataset.frame === '0004'")
        page.settle()
        page.shot("editor-shot.png")
        browser.close()


if __name__ == "__main__":
    main()
