"""The editor's Pose mode: the HTTP route, and in a real headless Chromium: place handles, drag one
with the mouse, the posed picture changes, the pose file saves."""

import base64
import io
import json
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from _editor import call, copy_example, running
from inkray.editor.session import EditSession
from inkray.input.pose import load_pose
from inkray.view.posed import PosedDrawing

CHROMIUM = os.environ.get("INKRAY_CHROMIUM", "/usr/bin/chromium")


def _png(body):
    import io

    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(body)))


def _pose_mode(playwright, url):
    """The editor at ``url`` in Chromium, in Pose mode: the browser, the page and the list its
    errors go to."""
    browser = playwright.chromium.launch(executable_path=CHROMIUM, args=[
        "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
    page = browser.new_page(viewport={"width": 1440, "height": 1000})
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url + "/")
    page.wait_for_function("window.inkrayPose && window.inkray.size[0] > 1", timeout=60_000)
    page.click("#pose-mode")
    return browser, page, errors


def test_pose_route_answers_a_drag_and_saves(tmp_path):
    ann = copy_example("man", tmp_path)
    session = EditSession(ann)
    with running(session) as url:
        handles = [[150, 330], [150, 250], [265, 180]]
        status, headers, body = call(url + "/api/pose", "POST", {"handles": handles, "to": handles})
        assert status == 200 and headers["Content-Type"] == "image/png"
        rest = _png(body)
        raised = [[150, 330], [150, 250], [250, 110]]
        status, headers, body = call(url + "/api/pose", "POST", {"handles": handles, "to": raised})
        assert status == 200 and float(headers["X-Inkray-Compute-Ms"]) > 0
        assert rest.shape == (540, 304, 4) and (_png(body) != rest).any()
        status, _, body = call(url + "/api/pose", "POST", {"handles": handles, "to": raised,
                                                          "scale": 0.5})
        assert status == 200 and _png(body).shape == (270, 152, 4)
        status, _, body = call(url + "/api/pose", "POST", {"handles": [[2, 2]], "to": [[3, 3]]})
        assert status == 422 and "handles[0]" in json.loads(body)["error"]
        doc = {"format": "inkray-pose", "version": 1, "handles": handles,
               "keys": [{"frame": 0, "to": raised}]}
        status, _, body = call(url + "/api/pose/save", "POST", doc)
        assert status == 200
        assert load_pose(tmp_path / "drawing.pose.json").keys[0].to.tolist() == raised
        status, _, body = call(url + "/api/pose/save", "POST", dict(doc, version=3))
        assert status == 400 and json.loads(body)["error"].startswith("version:")


def test_pose_meshes_and_their_posed_vertices(tmp_path):
    ann = copy_example("man", tmp_path)
    session = EditSession(ann)
    with running(session) as url:
        status, headers, body = call(url + "/api/pose/meshes")
        assert status == 200
        meshes = json.loads(body)
        generation = headers["X-Inkray-Generation"]
        assert meshes["size"] == [304, 540] and meshes["height"][0] < meshes["height"][1]
        parts = meshes["parts"]
        assert len(parts) == 7
        for part in parts:
            faces = np.array(part["faces"])
            assert faces.size % 3 == 0 and 0 < part["inner"] < faces.size // 3
            assert faces.max() < part["vertices"] == len(part["texcoords"]) // 2
            w, h = part["texture"]["size"]
            assert _png(base64.b64decode(part["texture"]["png"])).shape == (h, w, 4)
        handles = [[150, 330], [150, 250], [265, 180]]
        counts = [p["vertices"] for p in parts]

        def posed(to):
            status, headers, body = call(url + "/api/pose/vertices", "POST",
                                         {"handles": handles, "to": to})
            assert status == 200 and headers["Content-Type"] == "application/octet-stream"
            assert headers["X-Inkray-Generation"] == generation
            v = np.frombuffer(body, "<f4").reshape(-1, 3)
            assert len(v) == sum(counts)
            return np.split(v, np.cumsum(counts)[:-1])

        # at rest every vertex is drawn where its colour is taken from
        for part, v in zip(parts, posed(handles)):
            uv = np.array(part["texcoords"]).reshape(-1, 2) + part["texture"]["origin"]
            assert np.abs(v[:, :2] - uv).max() < 1e-3
        raised = posed([[150, 330], [150, 250], [250, 110]])
        arm = next(k for k, p in enumerate(parts) if p["name"] == "arm_right")
        assert raised[arm][:, 1].min() < 130
        status, _, body = call(url + "/api/pose/vertices", "POST", {"handles": handles})
        assert status == 400
        status, _, body = call(url + "/api/pose/vertices", "POST",
                               {"handles": [[2, 2]], "to": [[3, 3]]})
        assert status == 422 and "handles[0]" in json.loads(body)["error"]


@pytest.mark.skipif(not Path(CHROMIUM).is_file(), reason=f"no Chromium at {CHROMIUM}")
def test_the_page_draws_a_pose_as_the_server_pictures_it(tmp_path):
    """The page's WebGL drawing of the posed meshes against the server's picture of the
    same rig positions."""
    sync_api = pytest.importorskip("playwright.sync_api")
    session = EditSession(copy_example("man", tmp_path))
    handles = [[150, 330], [150, 250], [265, 180]]

    def pose(chain, digest):
        posed = PosedDrawing(chain.relief, chain.completion, chain.relations, chain.drawing,
                             handles, boundaries=chain.annotations.boundaries)
        x = posed.positions([[150, 330], [150, 250], [250, 110]], iterations=8)
        v = np.concatenate([d.ravel() for d in posed.drawn_vertices(x)]).astype("<f4")
        return {"vertices": v, "picture": posed.image(x)}

    with running(session) as url, sync_api.sync_playwright() as p:
        browser, page, errors = _pose_mode(p, url)
        page.wait_for_function("window.inkrayPose.gl && window.inkrayPose.gl.generation >= 0",
                               timeout=120_000)
        got = session.newest(pose, lock="relief", wrap=False)
        page.evaluate("""(b64) => {
            const s = atob(b64), u = new Uint8Array(s.length);
            for (let i = 0; i < s.length; i++) u[i] = s.charCodeAt(i);
            window.inkrayPose.gl.draw(new Float32Array(u.buffer));
        }""", base64.b64encode(got["vertices"].tobytes()).decode())
        drawn = _png(base64.b64decode(page.evaluate(
            "document.getElementById('posed-gl').toDataURL('image/png')").split(",")[1]))
        browser.close()
    assert not errors, errors

    def over_white(a):
        a = a.astype(float)
        return a[..., :3] * a[..., 3:] / 255 + 255 * (1 - a[..., 3:] / 255)

    picture = got["picture"]
    assert drawn.shape == picture.shape
    seen = (drawn[..., 3] > 0) | (picture[..., 3] > 0)
    off = np.abs(over_white(drawn) - over_white(picture)).max(axis=-1) > 16
    # the same pixels within a few levels, but where soft edges of two parts overlap
    assert seen.sum() > 40_000 and off.sum() <= 0.001 * seen.sum(), off.sum()


@pytest.mark.skipif(not Path(CHROMIUM).is_file(), reason=f"no Chromium at {CHROMIUM}")
def test_drag_a_handle_with_the_mouse_and_save_the_pose(tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api")
    ann = copy_example("man", tmp_path)
    session = EditSession(ann)
    with running(session) as url, sync_api.sync_playwright() as p:
        browser, page, errors = _pose_mode(p, url)

        def screen(x, y):
            return page.evaluate("""([x, y]) => {
                const vp = document.getElementById('viewport').getBoundingClientRect();
                const v = window.inkray.view;
                return [vp.left + v.tx + (x + 0.5) * v.s, vp.top + v.ty + (y + 0.5) * v.s];
            }""", [x, y])

        for x, y in ((150, 330), (150, 250), (265, 180)):
            page.mouse.click(*screen(x, y))
        page.wait_for_function("window.inkrayPose.updates >= 1 && !window.inkrayPose.busy",
                               timeout=120_000)
        before = page.evaluate("window.inkrayPose.updates")
        shot_before = page.locator("#posed").screenshot()
        page.mouse.move(*screen(265, 180))
        page.mouse.down()
        for k in range(1, 7):
            page.mouse.move(*screen(265 - 2.5 * k, 180 - 12 * k))
        # while the handle moves the page draws the posed meshes itself
        page.wait_for_function("window.inkrayPose.drawn >= 1", timeout=120_000)
        assert page.evaluate("!document.getElementById('posed-gl').hidden")
        page.mouse.up()
        page.wait_for_function(f"window.inkrayPose.updates > {before} && !window.inkrayPose.busy",
                               timeout=120_000)
        page.wait_for_timeout(300)
        # where it stops, the server's picture
        assert page.evaluate("document.getElementById('posed-gl').hidden")
        assert page.locator("#posed").screenshot() != shot_before
        # every handle is seen over the posed picture, in its colour (#1e88e5)
        for k in range(3):
            box = page.locator("#pose-handles circle").nth(k).bounding_box()
            dot = np.asarray(Image.open(io.BytesIO(page.screenshot(clip=box))).convert("RGB"), int)
            blue = (abs(dot - [0x1e, 0x88, 0xe5]).max(axis=-1) < 40).sum()
            assert blue >= 10, (k, blue)
        moved = page.evaluate("window.inkrayPose.to[2]")
        assert abs(moved[1] - 108) < 3
        page.click("#pose-key")
        page.click("#pose-save")
        page.wait_for_function("document.getElementById('pose-saved').dataset.ok === 'true'",
                               timeout=30_000)
        pose = load_pose(tmp_path / "drawing.pose.json", size=(304, 540))
        assert len(pose.handles) == 3 and abs(pose.keys[0].to[2][1] - 108) < 3
        browser.close()
        assert not errors, errors
