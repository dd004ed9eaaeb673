"""The editor as a new user meets it, in a real Chromium with real mouse and keys: a guided
start on a drawing nobody annotated, the first five minutes up to a saved file that
``inkray validate`` passes and a relief; an autosave announced with Discard; undo kept
across a reload."""

import json
import shutil
import subprocess
import sys

import pytest

from _editor import (EXAMPLES, browser_or_skip, copy_example, drag, open_page, running,
                     wait_previews)

sync_api = browser_or_skip()

from inkray.editor.session import EditSession, autosave_path  # noqa: E402


@pytest.fixture
def page():
    with open_page(sync_api) as page:
        yield page


def _name_new_region(page, name):
    page.wait_for_selector("#name-field:not([hidden])")
    page.keyboard.type(name)
    page.keyboard.press("Enter")


def test_the_first_five_minutes_on_a_new_drawing(page, tmp_path):
    # the fish's drawing alone, as an illustrator would bring it
    shutil.copy(EXAMPLES / "fish" / "drawing.png", tmp_path / "fish.png")
    ann = tmp_path / "fish.inkray.json"
    session = EditSession(ann, drawing=tmp_path / "fish.png")
    with running(session) as url:
        page.goto(url + "/")
        wait_previews(page, 0)
        # what to do first, no error, nothing "unsaved", previews that say why they are empty
        assert page.is_visible("#guide") and "scribble inside each part" in page.text_content("#guide")
        assert page.is_hidden("#error")
        assert "unsaved" not in page.text_content("#status")
        assert "needs at least one region" in page.text_content("#relief-note")
        assert "No depth map yet" in page.text_content("#depth-note")

        # a region scribble on the paper around the fish: said to be background, not kept
        page.keyboard.press("r")
        drag(page, [[20, 20], [40, 30]])
        page.wait_for_selector("#error:not([hidden])")
        assert "Background (B)" in page.text_content("#error")
        assert page.evaluate("window.inkray.doc.regions.length") == 0 and session.generation == 0

        # a scribble per part, each named at once
        parts = [("body", [[150, 150], [200, 165]]), ("tail", [[55, 150], [70, 165]]),
                 ("fin_top", [[235, 75], [260, 80]]), ("fin_bottom", [[250, 240], [265, 248]]),
                 ("fin_side", [[255, 160], [275, 170]]), ("eye", [[368, 138], [372, 142]])]
        for g, (name, scribble) in enumerate(parts):
            drag(page, scribble)
            _name_new_region(page, name)
            wait_previews(page, 2 * g + 2)  # the scribble, then the name
        assert "unsaved" in page.text_content("#status") and page.is_hidden("#error")
        # a second scribble in the body extends it
        drag(page, [[320, 190], [340, 180]])
        wait_previews(page, 13)
        regions = page.evaluate("window.inkray.doc.regions")
        assert [r["name"] for r in regions] == [n for n, _ in parts]
        assert len(regions[0]["scribbles"]) == 2
        assert page.is_hidden("#relief-note") or not page.text_content("#relief-note")
        assert int(page.get_attribute("#relief", "data-meshes")) == len(parts)

        # the order: the side fin in front of the body, by an arrow
        page.keyboard.press("o")
        drag(page, [[265, 165], [230, 200]])
        wait_previews(page, 14)
        assert page.is_hidden("#error")

        page.keyboard.press("Control+s")
        page.wait_for_function("document.body.dataset.saved !== undefined")
        assert "saved" in page.text_content("#status") and "unsaved" not in page.text_content("#status")
        assert int(page.get_attribute("#relief", "data-meshes")) == len(parts)
    saved = json.loads(ann.read_text())
    assert [r["name"] for r in saved["regions"]] == [n for n, _ in parts]
    check = subprocess.run([sys.executable, "-m", "inkray", "validate", str(ann)],
                           capture_output=True, text=True)
    assert check.returncode == 0, check.stdout + check.stderr


def test_an_autosave_is_announced_with_discard_and_undo_survives_a_reload(page, tmp_path):
    ann = copy_example("turtle", tmp_path)
    original = ann.read_bytes()
    doc = json.loads(original)
    kept = dict(doc, order=doc["order"][:2])
    autosave_path(ann).write_text(json.dumps(kept))
    session = EditSession(ann)
    with running(session) as url:
        page.goto(url + "/")
        wait_previews(page, 0)
        assert page.is_visible("#autosave-banner")
        assert "unsaved changes" in page.text_content("#autosave-banner")
        assert page.evaluate("window.inkray.doc") == kept
        page.click("#autosave-discard")
        page.wait_for_selector("#autosave-banner", state="hidden")
        wait_previews(page, 1)
        assert page.evaluate("window.inkray.doc") == doc == session.document
        assert not autosave_path(ann).exists() and ann.read_bytes() == original
        assert "unsaved" not in page.text_content("#status")

        # an edit, a reload, and undo still takes it back
        page.click("button[data-tool=order]")
        drag(page, [[150, 285], [300, 190]])
        wait_previews(page, 2)
        page.reload()
        wait_previews(page, 2)
        assert page.evaluate("window.inkray.doc.order.length") == len(doc["order"]) + 1
        assert page.is_visible("#autosave-banner") is False  # the same server: nothing restored
        page.keyboard.press("Control+z")
        wait_previews(page, 3)
        assert session.document == doc
