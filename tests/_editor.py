"""A real editor server (uvicorn on a free loopback port) in a thread, and HTTP calls to it."""

import json
import os
import shutil
import threading
import time
import urllib.error
import urllib.request
from contextlib import contextmanager
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def copy_example(name, folder):
    """Copy a bundled drawing and its annotation into ``folder``; the annotation's path."""
    for p in (EXAMPLES / name).iterdir():
        if p.name.startswith("drawing"):
            shutil.copy(p, folder / p.name)
    return folder / "drawing.inkray.json"


@contextmanager
def running(session):
    """Serve ``session`` on 127.0.0.1 (a free port) while the block runs; yields the base URL."""
    import uvicorn

    from inkray.editor.app import LOOPBACK_HOSTS, editor_app
    from inkray.editor.server import _listen

    sock = _listen("127.0.0.1", 0)  # as `inkray edit` listens
    server = uvicorn.Server(uvicorn.Config(editor_app(session, allowed_hosts=LOOPBACK_HOSTS),
                                           log_level="warning", lifespan="off"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    deadline = time.monotonic() + 20
    while not server.started:
        assert time.monotonic() < deadline, "the editor server did not start"
        time.sleep(0.01)
    try:
        yield f"http://127.0.0.1:{sock.getsockname()[1]}"
    finally:
        server.should_exit = True
        thread.join(10)
        sock.close()


def call(url, method="GET", body=None, headers=None):
    """``(status, headers, body bytes)`` of one request; ``body`` a dict is sent as JSON."""
    if isinstance(body, (dict, list)):
        body = json.dumps(body).encode()
    elif isinstance(body, str):
        body = body.encode()
    request = urllib.request.Request(url, data=body, method=method, headers=headers or {})
    try:
        with urllib.request.urlopen(request, timeout=120) as r:
            return r.status, r.headers, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.headers, e.read()


# -- the page in a real Chromium (Playwright) ------------------------------------------------

CHROMIUM = os.environ.get("INKRAY_CHROMIUM", "/usr/bin/chromium")
PREVIEWS = ("#labels", "#depth", "#relief", "#relations")


def browser_or_skip():
    """The Playwright sync API, or skip the module when it or Chromium is missing."""
    import pytest

    sync_api = pytest.importorskip("playwright.sync_api", reason="the playwright package is not "
                                   "installed (pip install '.[test]')")
    if not Path(CHROMIUM).is_file():
        pytest.skip(f"no Chromium at {CHROMIUM} (apt-get install chromium, or set "
                    f"INKRAY_CHROMIUM)", allow_module_level=True)
    return sync_api


@contextmanager
def open_page(sync_api):
    """A page of a headless Chromium (1440x1000, WebGL by SwiftShader); page errors fail."""
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        page = browser.new_page(viewport={"width": 1440, "height": 1000})
        page.set_default_timeout(120_000)  # a loaded two-core machine
        errors = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        yield page
        browser.close()
        assert not errors, errors


def wait_previews(page, generation, timeout=90_000):
    """Wait until the page shows every preview of ``generation`` and nothing is computing."""
    page.wait_for_function(
        "([ids, g]) => document.body.dataset.busy === 'false' && document.body.dataset.generation "
        "=== g && ids.every((id) => document.querySelector(id).dataset.generation === g)",
        arg=[list(PREVIEWS), str(generation)], timeout=timeout)


def screen_points(page, points):
    """Drawing pixels ``points`` as page coordinates of the current view."""
    return page.evaluate("""(pts) => {
        const vp = document.getElementById('viewport').getBoundingClientRect();
        const v = window.inkray.view;
        return pts.map(([x, y]) => [vp.left + v.tx + (x + 0.5) * v.s, vp.top + v.ty + (y + 0.5) * v.s]);
    }""", [list(map(float, p)) for p in points])


def drag(page, points, steps=6):
    """Drag the mouse through drawing pixels ``points`` on the canvas."""
    screen = screen_points(page, points)
    page.mouse.move(*screen[0])
    page.mouse.down()
    for a, b in zip(screen, screen[1:]):
        for k in range(1, steps + 1):
            t = k / steps
            page.mouse.move(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))
    page.mouse.up()


def click_at(page, point):
    """A click of the mouse on drawing pixel ``point``."""
    page.mouse.click(*screen_points(page, [point])[0])
