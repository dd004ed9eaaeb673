"""The editor's tools in a real Chromium with real mouse events: marks the same size at every
zoom, one's own entries hit before predictions, a region per part, the relief framed as it
grows, problems one click from their entries, two-click boundaries along the outline."""

import json

import numpy as np
import pytest
from scipy import ndimage

from _editor import (browser_or_skip, call, click_at, copy_example, drag, open_page, running,
                     screen_points, wait_previews)

sync_api = browser_or_skip()

from inkray.editor.session import EditSession  # noqa: E402
from inkray.formats.labels import label_palette  # noqa: E402


@pytest.fixture
def page():
    with open_page(sync_api) as page:
        yield page


def _selected(page):
    return page.evaluate("window.inkray.selection")


def test_marks_and_their_hit_areas_keep_their_screen_size(page, tmp_path):
    ann = copy_example("turtle", tmp_path)
    doc = json.loads(ann.read_text())
    with running(EditSession(ann)) as url:
        page.goto(url + "/")
        wait_previews(page, 0)
        # the arrow head over shell: its middle, and the unit normal of its line
        a, b = np.array(doc["order"][0]["front"], float), np.array(doc["order"][0]["back"], float)
        middle = (a + b) / 2
        u = (b - a) / np.linalg.norm(b - a)
        normal = np.array([-u[1], u[0]])
        fit = page.evaluate("window.inkray.fitScale")
        for scale in (fit, 4, 16):
            page.evaluate("([s, at]) => window.inkray.setZoom(s, at)", [scale, middle.tolist()])
            sizes = page.evaluate("""() => {
                const g = document.querySelector("#marks [data-key='order[0]']");
                const head = g.querySelector('polygon.head').getBoundingClientRect();
                return {line: getComputedStyle(g.querySelector('.line')).strokeWidth,
                        ctm: document.getElementById('marks').getScreenCTM().a,
                        head: Math.max(head.width, head.height)};
            }""")
            assert sizes["line"] == "3px" and sizes["ctm"] == 1, (scale, sizes)
            assert 11 <= sizes["head"] <= 15, (scale, sizes)  # a 13 px arrowhead
            centre = np.array(screen_points(page, [middle.tolist()])[0])
            for offset, hit in ((6.0, True), (12.0, False)):  # the hit radius is 8 screen px
                page.keyboard.press("Escape")
                page.mouse.click(*(centre + offset * normal))
                assert (_selected(page) == "order[0]") == hit, (scale, offset, _selected(page))


def test_ones_own_arrow_is_hit_before_a_prediction(page, tmp_path):
    ann = copy_example("cards", tmp_path)
    doc = json.loads(ann.read_text())
    doc["order"] = []  # the cards' order is all predicted
    ann.write_text(json.dumps(doc))
    session = EditSession(ann)
    with running(session) as url:
        page.goto(url + "/")
        wait_previews(page, 0)
        k, pred = page.evaluate("""() => { const r = window.inkray.relations;
            const k = r.findIndex((x) => x.source === 'predicted'); return [k, r[k]]; }""")
        assert pred is not None
        # one's own arrow from the prediction's tail, further into the same part
        a, b = np.array(pred["points"], float)
        tail = (a + (a - b) / np.linalg.norm(a - b) * 8).round(1)
        page.click("button[data-tool=order]")
        drag(page, [a.tolist(), tail.tolist()])
        wait_previews(page, 1)
        assert page.evaluate("window.inkray.relations.some((r) => r.source === 'predicted')")
        page.click("button[data-tool=select]")
        click_at(page, a.tolist())  # where the prediction's tail lies on one's own arrow
        assert _selected(page) == "order[0]"
        assert len(session.document["order"]) == 1 and session.generation == 1  # not accepted
        # the prediction is accepted by its own control only
        k = page.evaluate("window.inkray.relations.findIndex((r) => r.source === 'predicted')")
        page.click(f"#marks .chip.accept[data-relation='{k}']")
        wait_previews(page, 2)
        assert len(session.document["order"]) == 2


def test_a_scribble_per_part_makes_a_region_per_part(page, tmp_path):
    ann = tmp_path / "cards.inkray.json"
    src = copy_example("cards", tmp_path)
    with running(EditSession(ann, drawing=src.parent / "drawing.png")) as url:
        page.goto(url + "/")
        wait_previews(page, 0)
        page.keyboard.press("r")
        cards = [[[85, 160], [100, 175]], [[160, 130], [170, 160]], [[240, 125], [235, 160]],
                 [[320, 175], [300, 210]]]
        for g, scribble in enumerate(cards, start=1):
            drag(page, scribble)
            page.wait_for_selector("#name-field:not([hidden])")
            assert page.evaluate("document.activeElement.id") == "name-field"
            page.keyboard.press("Escape")  # keeps the default name
            wait_previews(page, g)
        # a second scribble in the second card extends its region
        drag(page, [[165, 180], [175, 200]])
        wait_previews(page, 5)
        regions = page.evaluate("window.inkray.doc.regions")
        assert [r["name"] for r in regions] == ["part1", "part2", "part3", "part4"]
        assert [len(r["scribbles"]) for r in regions] == [1, 2, 1, 1]
        assert page.evaluate("window.inkray.region") == 1  # the current region, shown
        assert "part2" in page.text_content("#current-region")
        # a name typed into the field at the scribble renames the new region
        drag(page, [[215, 255], [225, 265]])
        page.wait_for_selector("#name-field:not([hidden])")
        page.keyboard.type("coin")
        page.keyboard.press("Enter")
        wait_previews(page, 7)
        assert page.evaluate("window.inkray.doc.regions.map((r) => r.name)")[-1] == "coin"


def test_the_relief_view_frames_the_relief_as_it_grows(page, tmp_path):
    ann = copy_example("turtle", tmp_path)
    doc = json.loads(ann.read_text())
    doc["regions"] = [r for r in doc["regions"] if r["name"] == "head"]
    doc["order"], doc["boundaries"] = [], []
    ann.write_text(json.dumps(doc))
    with running(EditSession(ann)) as url:
        page.goto(url + "/")
        wait_previews(page, 0)
        assert page.evaluate("window.inkray.reliefView.contains()")
        before = page.evaluate("window.inkray.reliefView.box.max.x - window.inkray.reliefView.box.min.x")
        page.keyboard.press("r")
        drag(page, [[230, 200], [300, 190], [400, 250], [370, 305]])  # the shell: a new part
        page.keyboard.press("Escape")
        wait_previews(page, 1)
        after = page.evaluate("window.inkray.reliefView.box.max.x - window.inkray.reliefView.box.min.x")
        assert after > 1.5 * before
        assert page.evaluate("window.inkray.reliefView.contains()")
        # a view the user moved is kept; Reset view frames the whole relief again
        box = page.locator("#relief canvas").bounding_box()
        page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        page.mouse.wheel(0, -900)
        page.wait_for_timeout(200)
        assert not page.evaluate("window.inkray.reliefView.contains()")
        page.click("#relief-reset")
        assert page.evaluate("window.inkray.reliefView.contains()")
        page.click("#relief-enlarge")
        big = page.locator("#relief canvas").bounding_box()
        assert big["width"] > 1000 and big["height"] > 700
        assert page.evaluate("window.inkray.reliefView.contains()")
        page.keyboard.press("Escape")
        assert page.locator("#relief canvas").bounding_box()["width"] < 500


def test_a_problem_row_selects_its_entry_and_repeats_are_folded(page, tmp_path):
    ann = copy_example("cards", tmp_path)
    doc = json.loads(ann.read_text())
    doc["regions"] = doc["regions"][:2]  # the other cards and the coin are left unscribbled
    doc["order"] = [{"front": [90, 150], "back": [100, 170]}]  # both ends in card_1
    ann.write_text(json.dumps(doc))
    with running(EditSession(ann)) as url:
        page.goto(url + "/")
        wait_previews(page, 0)
        warnings = page.evaluate("window.inkray.warnings")
        unscribbled = [w for w in warnings if w.startswith("unscribbled area")]
        assert len(unscribbled) >= 2
        # the toolbar says how many, one click from the list
        assert page.text_content("#problems-button").startswith(f"⚠ {len(warnings)} problem")
        page.click("#problems-button")
        assert page.locator("#warnings").is_visible()
        # one row for them all, which opens to each
        assert page.locator("#warnings > li > details").count() == 1
        assert page.locator("#warnings details li").count() == len(unscribbled)
        # the arrow the warning names is marked on the drawing
        assert "warn" in page.get_attribute("#marks [data-key='order[0]']", "class").split()
        fit = page.evaluate("window.inkray.view.s")
        page.click("#warnings button.goto:has-text('order[0]')")
        assert _selected(page) == "order[0]"
        assert page.evaluate("window.inkray.view.s") > fit  # zoomed to it
        assert "selected" in page.get_attribute("#marks [data-key='order[0]']", "class").split()
        # a folded row shows its place
        page.click("#warnings details summary")
        page.click("#warnings details li button.goto >> nth=0")
        x, y = map(float, unscribbled[0].split(" at (")[1].split(")")[0].split(", "))
        assert page.evaluate("window.inkray.spot") == [x, y]
        assert page.locator("#marks .spot").count() == 1
        # a relation row shows its arrow on the drawing
        page.keyboard.press("Escape")
        k = int(page.get_attribute("#relations li.predicted >> nth=0", "data-relation"))
        page.click("#relations li.predicted button.goto >> nth=0")
        assert page.evaluate("window.inkray.selectedRelation") == k
        assert "selected" in page.get_attribute(f"#marks .pred[data-relation='{k}']", "class")


def test_a_two_click_boundary_follows_the_outline(page, tmp_path):
    ann = copy_example("turtle", tmp_path)
    doc = json.loads(ann.read_text())
    doc["boundaries"] = []
    ann.write_text(json.dumps(doc))
    session = EditSession(ann)
    with running(session) as url:
        page.goto(url + "/")
        wait_previews(page, 0)
        page.keyboard.press("g")
        click_at(page, [170, 330])  # near the front leg's outline, 2-5 px off
        assert page.locator("#marks .pending").count() == 1
        click_at(page, [243, 384])
        wait_previews(page, 1)
        path = np.array(session.document["boundaries"][0]["path"])
        labels = session._chain.segmentation.labels
        # every vertex on the front leg's outline, and the path longer than the straight line
        leg = labels == [r["name"] for r in doc["regions"]].index("leg_front")
        outline = leg & ~ndimage.binary_erosion(leg)
        distance = ndimage.distance_transform_edt(~outline)
        assert len(path) > 3
        assert distance[path[:, 1].astype(int), path[:, 0].astype(int)].max() <= 1.0
        length = np.linalg.norm(np.diff(path, axis=0), axis=1).sum()
        assert length > 1.1 * np.linalg.norm(path[-1] - path[0])
        # boundary colours: dark casing and light dashes, none of the region palette
        colours = page.evaluate("""() => [...document.querySelectorAll(
            "#marks .boundary .line, #marks .boundary .casing")].map((e) => getComputedStyle(e).stroke)""")
        palette = {f"rgb({r}, {g}, {b})" for r, g, b in label_palette(20)[1:].tolist()}
        assert colours and not set(colours) & palette


def test_outline_path_endpoint_refuses_points_far_from_outlines(tmp_path):
    ann = copy_example("turtle", tmp_path)
    with running(EditSession(ann)) as url:
        status, _, body = call(url + "/api/outline-path", "POST", {"from": [5, 5], "to": [6, 500]})
    assert status == 422 and json.loads(body)["error"].startswith("boundary: no region outline")
