"""Stepping through a shot in the editor (inkray.editor.shot): a frame opens with the annotation
carried from its key, the entries to check are named, and a saved frame becomes a key.

The shot is synthetic and small: two overlapping boxes (a body and an arm in front of it) that
move 3 px to the right per frame; in the third frame the arm is lower, in the fourth it is gone,
so that the arm's entries have nowhere to go and must be named to check.
"""

import hashlib
import json
import re

import numpy as np
import pytest

from _editor import browser_or_skip, call, drag, open_page, running

from inkray.cli import main
from inkray.editor.shot import Shot, open_shot
from inkray.errors import InputError

FRAMES = ["0001", "0002", "0003", "0004"]


def _box(g, x0, y0, x1, y1):
    g[y0:y1 + 1, x0:x1 + 1] = 255
    g[y0:y1 + 1, [x0, x0 + 1, x1 - 1, x1]] = 0
    g[[y0, y0 + 1, y1 - 1, y1], x0:x1 + 1] = 0


def _frame(t):
    g = np.full((120, 160), 255, np.uint8)
    dx, dy = 3 * t, 14 if t == 2 else 0
    _box(g, 20 + dx, 20, 90 + dx, 100)
    if t != 3:
        _box(g, 60 + dx, 45 + dy, 135 + dx, 75 + dy)
    return g


@pytest.fixture
def shot(tmp_path):
    from PIL import Image

    for t, name in enumerate(FRAMES):
        Image.fromarray(_frame(t)).save(tmp_path / f"{name}.png")
    key = {"format": "inkray-annotations", "version": 1, "drawing": "0001.png", "size": [160, 120],
           "regions": [{"name": "body", "scribbles": [[[35, 40], [40, 85]]]},
                       {"name": "arm", "scribbles": [[[100, 60], [125, 60]]]}],
           "background": [[[5, 5], [150, 5], [150, 112]]],
           "order": [{"front": [80, 60], "back": [45, 60]}], "equal": [], "boundaries": []}
    (tmp_path / "0001.inkray.json").write_text(json.dumps(key))
    return tmp_path


def _get(base, what):
    status, _, body = call(base + what)
    assert status == 200, body
    return json.loads(body) if what.startswith("/api/shot") or what == "/api/annotations" else body


def _open(base, frame):
    status, _, body = call(base + "/api/shot/open", "POST", {"frame": frame})
    assert status == 200, body
    return json.loads(body)


def _named(doc, line):
    """The entry a check line names exists in the document."""
    kind, i = re.match(r"(regions|background|order|equal|boundaries)\[(\d+)\]", line).groups()
    return int(i) < len(doc[kind])


def test_a_frame_opens_carried_and_a_saved_frame_becomes_the_key(shot):
    session = open_shot(shot / "0002.png")
    assert not (shot / "0002.inkray.json").exists()  # carried, not written until saved
    with running(session) as base:
        info = _get(base, "/api/shot")
        assert info["frames"] == FRAMES and info["keys"] == ["0001"]
        assert (info["current"], info["key"], info["carried_from"]) == ("0002", "0001.inkray.json",
                                                                        "0001")
        assert info["check"] == []  # a shift of 3 px: nothing to check
        doc = _get(base, "/api/annotations")
        assert doc["drawing"] == "0002.png"
        assert [r["name"] for r in doc["regions"]] == ["body", "arm"]
        # The drawing moved 3 px to the right: so did the arm's scribble.
        assert np.allclose(doc["regions"][1]["scribbles"][0][0], [103, 60], atol=1.0)
        drawing = _get(base, "/api/drawing.png")

        # The arm is gone in the last frame: its entries are named to check.
        info = _open(base, "0004")
        assert info["current"] == "0004" and info["carried_from"] == "0003"
        doc = _get(base, "/api/annotations")
        flagged = {line.split(":")[0].split(" ")[0] for line in info["check"]}
        assert {"regions[1]", "order[0]"} <= flagged
        assert all(_named(doc, line) for line in info["check"])
        assert {e["key"] for e in info["entries"] if e["check"]} == flagged
        assert _get(base, "/api/drawing.png") != drawing

        # A correction on frame 3 (the arm renamed), saved: the frame is a key, and frame 4
        # is carried from it.
        _open(base, "0003")
        doc = _get(base, "/api/annotations")
        doc["regions"][1]["name"] = "forearm"
        assert call(base + "/api/annotations", "PUT", doc)[0] == 200
        assert call(base + "/api/save", "POST")[0] == 200  # the carried document validates
        assert (shot / "0003.inkray.json").is_file()
        assert _get(base, "/api/shot")["keys"] == ["0001", "0003"]
        info = _open(base, "0004")
        assert (info["key"], info["carried_from"]) == ("0003.inkray.json", "0003")
        assert [r["name"] for r in _get(base, "/api/annotations")["regions"]] == ["body", "forearm"]
        # Frame 2 is still carried from the first key.
        assert _open(base, "0002")["key"] == "0001.inkray.json"

        # A frame that is not in the shot: one line, and nothing changes.
        status, _, body = call(base + "/api/shot/open", "POST", {"frame": "0009"})
        assert status == 422 and "0009" in json.loads(body)["error"]
        assert call(base + "/api/shot/open", "POST", {"frames": 1})[0] == 400
        assert _get(base, "/api/shot")["current"] == "0002"


def test_a_folder_without_a_key_is_refused(shot):
    (shot / "0001.inkray.json").unlink()
    with pytest.raises(InputError, match="no key frame"):
        Shot(shot / "0002.png")
    with pytest.raises(InputError, match="no such drawing"):
        Shot(shot / "0042.png")


def test_the_command_line_refuses_a_frame_without_a_key(shot, capsys):
    (shot / "0001.inkray.json").unlink()
    assert main(["edit", str(shot / "0002.png"), "--no-browser", "--port", "0"]) == 2
    assert "no key frame" in capsys.readouterr().err
    assert main(["edit", str(shot / "0002.png"), "--drawing", str(shot / "0001.png"),
                 "--no-browser"]) == 2
    assert "--drawing" in capsys.readouterr().err
    assert sorted(p.name for p in shot.iterdir()) == [f"{n}.png" for n in FRAMES]


def _frame_shown(page, name):
    page.wait_for_function(f"document.body.dataset.frame === '{name}' && "
                           "document.getElementById('drawing').complete")


def test_the_page_steps_to_the_next_frame(shot):
    sync_api = browser_or_skip()
    session = open_shot(shot / "0003.png")
    with running(session) as base, open_page(sync_api) as page:
        page.goto(base + "/")
        _frame_shown(page, "0003")
        before = _drawing_digest(page)
        assert page.locator("#marks g.entry.warn").count() == 0
        assert page.locator("#shot-frame").text_content() == "frame 0003 (3/4)"
        page.click("#shot-next")
        _frame_shown(page, "0004")
        page.wait_for_selector("#marks g.entry.warn")
        warned = page.eval_on_selector_all("#marks g.entry.warn", "gs => gs.map((g) => g.dataset.key)")
        assert "order[0]" in warned and "regions[1].scribbles[0]" in warned
        assert "carried from 0001.inkray.json" in page.locator("#shot-source").text_content()
        assert page.locator("#warnings").text_content().count("check it") >= 2
        assert _drawing_digest(page) != before
        assert not (shot / "0003.inkray.json").exists()  # nothing edited: nothing saved

        # An edit (a background scribble), then the previous frame by its key: the edited
        # frame is saved first, and it is a key when the page comes back to it.
        page.keyboard.press("b")
        drag(page, [[8, 112], [60, 114]])
        page.wait_for_function("document.body.dataset.dirty === 'true'")
        page.keyboard.press(",")
        _frame_shown(page, "0003")
        saved = json.loads((shot / "0004.inkray.json").read_text())
        assert len(saved["background"]) == 2 and saved["drawing"] == "0004.png"
        page.click("#shot-next")
        _frame_shown(page, "0004")
        assert page.locator("#shot-source").text_content() == "key frame"


def _drawing_digest(page):
    pixels = page.evaluate("""() => {
        const img = document.getElementById('drawing');
        const c = document.createElement('canvas');
        c.width = img.naturalWidth; c.height = img.naturalHeight;
        const g = c.getContext('2d');
        g.drawImage(img, 0, 0);
        return Array.from(g.getImageData(0, 0, c.width, c.height).data.filter((_, i) => i % 4 === 0));
    }""")
    return hashlib.sha1(bytes(pixels)).hexdigest()
