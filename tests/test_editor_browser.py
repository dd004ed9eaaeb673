"""The editor's page in a real headless Chromium: draw, see the previews update, accept, undo, save.

Needs the Playwright Python package and a system Chromium (``/usr/bin/chromium``, or
``INKRAY_CHROMIUM``); ``.ci/run`` installs both. The screenshot of the page is kept
as ``editor.png`` in the test's temporary folder (its path is printed), and also
written to ``$INKRAY_EDITOR_SCREENSHOT`` when that is set.
"""

import contextlib
import json
import os
import shutil

import pytest

from _editor import browser_or_skip, copy_example, open_page, running, wait_previews
from _editor import drag as _drag

sync_api = browser_or_skip()

from inkray.editor.session import EditSession  # noqa: E402
from inkray.input.loading import load_input  # noqa: E402

_wait_previews = wait_previews


@pytest.fixture
def page():
    with open_page(sync_api) as page:
        yield page


def _pixels_of(page, colour):
    """How many pixels of the segmentation overlay have ``colour`` (#rrggbb)."""
    return page.evaluate("""(colour) => {
        const img = document.getElementById('labels');
        const c = document.createElement('canvas');
        c.width = img.naturalWidth; c.height = img.naturalHeight;
        const g = c.getContext('2d');
        g.drawImage(img, 0, 0);
        const d = g.getImageData(0, 0, c.width, c.height).data;
        const want = [1, 3, 5].map((i) => parseInt(colour.slice(i, i + 2), 16));
        let n = 0;
        for (let i = 0; i < d.length; i += 4)
            if (d[i] === want[0] && d[i + 1] === want[1] && d[i + 2] === want[2]) n++;
        return n;
    }""", colour)


@contextlib.contextmanager
def _turtle_page(page, tmp_path):
    """The editor on a copy of the turtle, its page loaded with every preview shown."""
    ann = copy_example("turtle", tmp_path)
    doc = json.loads(ann.read_text())
    session = EditSession(ann)
    with running(session) as url:
        page.goto(url + "/")
        _wait_previews(page, 0)
        yield ann, doc, session, url


def test_draw_accept_undo_save(page, tmp_path):
    with _turtle_page(page, tmp_path) as (ann, doc, session, url):
        assert page.evaluate("window.inkray.doc") == doc
        assert int(page.get_attribute("#relief", "data-meshes")) == len(doc["regions"])

        # a scribble: a new region on the shell's lower band
        page.click("#add-region")
        _drag(page, [[300, 362], [350, 364], [400, 366]])
        _wait_previews(page, 1)
        shown = page.evaluate("window.inkray.doc")
        assert [r["name"] for r in shown["regions"]][-1] == "part1"
        colour = page.evaluate("window.inkray.palette[5]")
        assert _pixels_of(page, colour) > 200  # the overlay shows the new region
        assert int(page.get_attribute("#relief", "data-meshes")) == len(doc["regions"]) + 1

        # an order arrow: the head in front of the shell
        page.click("button[data-tool=order]")
        _drag(page, [[150, 285], [300, 190]])
        _wait_previews(page, 2)
        assert page.evaluate("window.inkray.doc.order.length") == len(doc["order"]) + 1
        relief_generation = page.get_attribute("#relief", "data-generation")
        assert relief_generation == "2"

        # a boundary far from any outline: the error names it and highlights the path
        page.click("button[data-tool=boundary]")
        _drag(page, [[40, 60], [80, 70], [120, 60]])
        _wait_previews(page, 3)
        k = len(doc["boundaries"])
        error = page.text_content("#error")
        assert page.is_visible("#error") and f"relief: boundaries[{k}]: no region outline" in error
        assert page.get_attribute(f"#marks [data-key='boundaries[{k}]']", "class").split().count("bad") == 1

        # undo: the path goes, and with it the error
        page.keyboard.press("Control+z")
        _wait_previews(page, 4)
        assert page.is_hidden("#error")
        assert len(page.evaluate("window.inkray.doc.boundaries")) == k

        # accept a predicted relation: it becomes an order entry
        page.wait_for_selector("#relations button.accept")
        before = page.evaluate("window.inkray.doc.order.length")
        predicted = page.evaluate("window.inkray.relations.find((r) => r.source === 'predicted')")
        page.click("#relations button.accept")
        _wait_previews(page, 5)
        order = page.evaluate("window.inkray.doc.order")
        assert len(order) == before + 1
        assert [order[-1]["front"], order[-1]["back"]] == predicted["points"]
        users = page.evaluate("window.inkray.relations.filter((r) => r.source === 'user')")
        assert any(u["entry"] == before and u["front"] == predicted["front"]
                   and u["back"] == predicted["back"] for u in users)

        # save: the file is the document the page shows, and it loads
        page.click("#save")
        page.wait_for_function("document.body.dataset.saved !== undefined")
        shown = page.evaluate("window.inkray.doc")
        shot = tmp_path / "editor.png"
        page.evaluate("document.getElementById('side').scrollTop = 0")
        page.screenshot(path=str(shot))
    print(f"editor screenshot: {shot}")
    if os.environ.get("INKRAY_EDITOR_SCREENSHOT"):
        shutil.copy(shot, os.environ["INKRAY_EDITOR_SCREENSHOT"])
    assert json.loads(ann.read_text()) == shown
    loaded, _ = load_input(ann)
    assert [r.name for r in loaded.regions][-1] == "part1"
    assert len(loaded.order) == len(doc["order"]) + 2
    assert len(loaded.boundaries) == len(doc["boundaries"])
    assert not (tmp_path / "drawing.inkray.json.autosave").exists()


def test_fields_refused_edit_move_delete_and_a_contradiction(page, tmp_path):
    with _turtle_page(page, tmp_path) as (ann, doc, session, url):
        page.fill("#regions .region[data-index='0'] .inflation", "5")
        page.press("#regions .region[data-index='0'] .inflation", "Enter")
        _wait_previews(page, 1)
        assert session.document["regions"][0]["inflation"] == 5

        # a name the format refuses: the server keeps its document, the page takes it back
        page.fill("#regions .region[data-index='1'] .name", "leg front")
        page.press("#regions .region[data-index='1'] .name", "Enter")
        page.wait_for_selector("#error:not([hidden])")
        assert page.text_content("#error").startswith("regions[1].name: 'leg front' may only")
        assert page.input_value("#regions .region[data-index='1'] .name") == "leg_front"
        assert "bad" in page.get_attribute("#regions .region[data-index='1']", "class")
        assert session.generation == 1 and session.document["regions"][1]["name"] == "leg_front"
        assert page.evaluate("window.inkray.doc") == session.document

        # select an arrow, move it, delete it
        front, back = doc["order"][1]["front"], doc["order"][1]["back"]
        middle = [(front[0] + back[0]) / 2, (front[1] + back[1]) / 2]
        page.click("button[data-tool=select]")
        _drag(page, [middle, [middle[0] + 10, middle[1] + 6]])
        _wait_previews(page, 2)
        moved = session.document["order"][1]
        assert abs(moved["front"][0] - front[0] - 10) < 1 and abs(moved["back"][1] - back[1] - 6) < 1
        assert "selected" in page.get_attribute("#marks [data-key='order[1]']", "class").split()
        page.keyboard.press("Delete")
        _wait_previews(page, 3)
        assert session.document["order"] == doc["order"][:1] + doc["order"][2:]

        # the first arrow reversed: both arrows of the cycle are highlighted
        first = doc["order"][0]
        page.click("button[data-tool=order]")
        _drag(page, [first["back"], first["front"]])
        _wait_previews(page, 4)
        assert "contradict" in page.text_content("#error")
        assert page.get_attribute("#relief", "data-last-good") == "true"  # the last good relief
        assert "last good relief" in page.text_content("#relief-badge")
        bad = page.eval_on_selector_all("#marks .entry.bad", "els => els.map((e) => e.dataset.key)")
    assert set(bad) == {"order[0]", f"order[{len(doc['order']) - 1}]"}


def test_the_depth_draft_comes_first_then_the_full_map(page, tmp_path, monkeypatch):
    from inkray.depthmap import estimation

    monkeypatch.setattr(estimation, "DRAFT_ABOVE", 1000)  # the turtle drafts too
    with _turtle_page(page, tmp_path) as (ann, doc, session, url):
        warming = session._chain._cache.session[1]._warming
        if warming is not None:
            warming.join()  # the draft's own fill ready: the arrow's draft is a draft
        page.evaluate("""() => {
            window.depthShown = [];
            new MutationObserver(() => window.depthShown.push(
                document.getElementById('depth').dataset.quality))
                .observe(document.getElementById('depth'), {attributes: true,
                                                            attributeFilter: ['data-quality']});
        }""")
        page.click("button[data-tool=order]")
        _drag(page, [[150, 285], [300, 190]])
        _wait_previews(page, 1)
        assert page.evaluate("window.depthShown") == ["draft", "full"]
        assert page.get_attribute("#depth", "data-quality") == "full"


def test_an_open_whose_draft_is_the_full_map_asks_for_the_depth_map_once(page, tmp_path,
                                                                          monkeypatch):
    """Opening a drawing whose depth draft the server answers with the full map (the
    reduced system's fill, as at 1 Mpx): the page shows it as the full map and makes no
    second depth request."""
    from inkray.depthmap import estimation

    monkeypatch.setattr(estimation, "DRAFT_ABOVE", 1000)    # the turtle drafts ...
    monkeypatch.setattr(estimation, "REDUCED_ABOVE", 1000)  # ... but opens on the reduced fill
    asked = []
    page.on("request", lambda r: asked.append(r.url) if "/depth.png" in r.url else None)
    with _turtle_page(page, tmp_path) as (ann, doc, session, url):
        assert session._chain._cache.session[1]._fills[False].reduced
        assert [a.split("/api/preview/")[1] for a in asked] == ["depth.png?quality=draft"]
        assert page.get_attribute("#depth", "data-quality") == "full"
        assert page.evaluate("document.getElementById('depth').naturalWidth") == \
            session.drawing.gray.shape[1]
