"""The editor's HTTP API on a real server: every endpoint, bad documents, save, previews, concurrency."""

import dataclasses
import io
import json
import os
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest
from scipy import ndimage

pytest.importorskip("uvicorn")
pytest.importorskip("starlette")

from _editor import call, copy_example, running  # noqa: E402

from inkray.editor import session as session_module  # noqa: E402
from inkray.editor.session import EditSession, autosave_path, entry_paths  # noqa: E402
from inkray.errors import InkrayError, InputError  # noqa: E402
from inkray.formats.depth_png import depth_png, read_depth_png  # noqa: E402
from inkray.input.annotations import parse_annotations  # noqa: E402
from inkray.input.loading import load_input  # noqa: E402


@pytest.fixture
def turtle(tmp_path):
    return copy_example("turtle", tmp_path)


def _json(response):
    status, _, body = response
    return status, json.loads(body)


def _image(body):
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(body)))


def test_connections_send_answers_at_once():
    """asyncio turns Nagle's algorithm off only on connections whose socket names
    IPPROTO_TCP; on the others every answer's body waits for the client's delayed
    acknowledgement of its headers (40 ms a request on a kept-alive connection)."""
    import socket

    from inkray.editor.server import _listen

    listening = _listen("127.0.0.1", 0)
    with listening, socket.create_connection(listening.getsockname()):
        connection, _ = listening.accept()
        with connection:
            assert connection.proto == socket.IPPROTO_TCP


def test_get_annotations_is_the_file(turtle):
    with running(EditSession(turtle)) as url:
        status, doc = _json(call(url + "/api/annotations"))
        status_info, info = _json(call(url + "/api/info"))
        page = call(url + "/")
        three = call(url + "/static/vendor/three/build/three.module.js")
    assert status == 200 and doc == json.loads(turtle.read_text())
    assert status_info == 200 and info["size"] == [512, 512] and info["generation"] == 0
    assert info["palette"][0] == "#ffffff" and len(info["palette"]) == 1 + len(doc["regions"])
    assert page[0] == 200 and b"<html" in page[2].lower()
    assert three[0] == 200 and b"REVISION" in three[2]


@pytest.mark.parametrize("text, message", [
    ("{", "drawing.inkray.json: not valid JSON"),
    ('{"format": "inkray-annotations", "version": 1, "size": [512, 512], "size": [1, 1]}',
     "drawing.inkray.json: size: duplicate key"),
    ('{"format": "inkray-annotations", "version": 1, "size": [512, 512], "drawing": "drawing.png",'
     ' "order": [{"front": [10, 10], "back": [600, 10]}]}',
     "order[0].back: point (600, 10) lies outside the 512x512 drawing"),
    ('{"format": "inkray-annotations", "version": 1, "size": [512, 512], "drawing": "drawing.png",'
     ' "boundries": []}', "boundries: unknown key"),
    ('{"format": "inkray-annotations", "version": 1, "size": [256, 256], "drawing": "drawing.png"}',
     "size: the annotation is for a 256x256 drawing but the drawing is 512x512"),
    ('{"format": "inkray-annotations", "version": 1, "size": [512, 512], "drawing": "other.png"}',
     "drawing: this editor edits the annotation of \"drawing.png\""),
])
def test_bad_document_is_400_and_changes_nothing(turtle, text, message):
    session = EditSession(turtle)
    with running(session) as url:
        before = call(url + "/api/annotations")[2]
        status, answer = _json(call(url + "/api/annotations", "PUT", text))
        after = call(url + "/api/annotations")[2]
    assert status == 400 and answer["error"].startswith(message), answer
    assert "\n" not in answer["error"]
    assert after == before and session.generation == 0
    assert not autosave_path(turtle).exists()


def test_put_then_save_round_trip(turtle, tmp_path):
    session = EditSession(turtle)
    doc = json.loads(turtle.read_text())
    doc["order"] = doc["order"][:2]
    doc["regions"][0]["inflation"] = 3.5
    doc["_note"] = "comments are kept"
    original = turtle.read_bytes()
    with running(session) as url:
        status, answer = _json(call(url + "/api/annotations", "PUT", doc))
        assert status == 200 and answer["generation"] == 1 and len(answer["palette"]) == 5
        assert json.loads(autosave_path(turtle).read_text()) == doc
        assert turtle.read_bytes() == original  # nothing saved yet
        assert _json(call(url + "/api/annotations"))[1] == doc
        status, saved = _json(call(url + "/api/save", "POST"))
        info = _json(call(url + "/api/info"))[1]
    assert status == 200 and saved == {"path": str(turtle)}
    assert json.loads(turtle.read_text()) == doc
    assert not autosave_path(turtle).exists() and info["saved"] is True
    ann, drawing = load_input(turtle)
    assert len(ann.order) == 2 and ann.regions[0].inflation == 3.5
    from inkray.cli import main

    assert main(["validate", str(turtle)]) == 0


def test_saving_twice_gives_the_same_bytes(turtle):
    session = EditSession(turtle)
    session.save()
    first = turtle.read_bytes()
    session.save()
    assert turtle.read_bytes() == first


def test_previews_and_their_headers(turtle):
    with running(EditSession(turtle)) as url:
        labels = call(url + "/api/preview/labels.png")
        depth = call(url + "/api/preview/depth.png")
        relief = call(url + "/api/preview/relief.glb")
        missing = call(url + "/api/preview/normals.png")
    for status, headers, _ in (labels, depth, relief):
        assert status == 200
        assert float(headers["X-Inkray-Compute-Ms"]) >= 0
        assert headers["X-Inkray-Generation"] == "0"
    assert labels[1]["Content-Type"] == "image/png" and _image(labels[2]).shape == (512, 512)
    assert set(np.unique(_image(labels[2]))) == {0, 1, 2, 3, 4}
    assert _image(depth[2]).dtype == np.uint16
    assert relief[1]["Content-Type"] == "model/gltf-binary" and relief[2][:4] == b"glTF"
    assert missing[0] == 404


def test_previews_change_after_an_edit(turtle, tmp_path):
    doc = json.loads(turtle.read_text())
    session = EditSession(turtle)
    with running(session) as url:
        before = {n: call(url + f"/api/preview/{n}")[2] for n in ("labels.png", "depth.png")}
        # a new region scribbled on the shell's lower band and the head in front of the shell
        doc["regions"].append({"name": "band", "scribbles": [[[300, 362], [400, 366]]]})
        doc["order"].append({"front": [150, 285], "back": [300, 190]})
        assert call(url + "/api/annotations", "PUT", doc)[0] == 200
        after = {n: call(url + f"/api/preview/{n}") for n in ("labels.png", "depth.png")}
    assert all(h["X-Inkray-Generation"] == "1" for _, h, _ in after.values())
    old, new = _image(before["labels.png"]), _image(after["labels.png"][2])
    assert (new == 5).sum() > 100 and not (old == 5).any()
    (tmp_path / "a.png").write_bytes(before["depth.png"])
    (tmp_path / "b.png").write_bytes(after["depth.png"][2])
    d0, d1 = read_depth_png(tmp_path / "a.png")[0], read_depth_png(tmp_path / "b.png")[0]
    assert np.abs(d1 - d0).max() > 0.5


def test_undo_is_served_from_the_cache(turtle):
    doc = json.loads(turtle.read_text())
    session = EditSession(turtle)
    with running(session) as url:
        first = call(url + "/api/preview/relief.glb")
        edited = dict(doc, order=doc["order"][:-1])
        call(url + "/api/annotations", "PUT", edited)
        call(url + "/api/preview/relief.glb")
        call(url + "/api/annotations", "PUT", doc)
        undone = call(url + "/api/preview/relief.glb")
    assert undone[2] == first[2]
    assert float(undone[1]["X-Inkray-Compute-Ms"]) < float(first[1]["X-Inkray-Compute-Ms"]) / 5


def test_relations_and_accepting_a_prediction(turtle):
    doc = json.loads(turtle.read_text())
    doc["order"] = []
    turtle.write_text(json.dumps(doc))
    session = EditSession(turtle)
    with running(session) as url:
        status, rel = _json(call(url + "/api/relations"))
        labels = _image(call(url + "/api/preview/labels.png")[2]).astype(int) - 1
        predicted = [r for r in rel["relations"] if r["source"] == "predicted"]
        assert status == 200 and predicted and rel["error"] is None
        for r in predicted:
            assert 0 < r["confidence"] <= 1 and r["entry"] is None
            (fx, fy), (bx, by) = r["points"]
            assert labels[int(fy), int(fx)] == r["front_index"]
            assert labels[int(by), int(bx)] == r["back_index"]
            # each end well inside its part: a segmentation change of a few pixels keeps it there
            for (x, y), region in zip(r["points"], (r["front_index"], r["back_index"])):
                inside = ndimage.distance_transform_edt(np.pad(labels == region, 1))[1:-1, 1:-1]
                assert inside[int(y), int(x)] >= min(6, inside.max() / 3)
        pick = max(predicted, key=lambda r: r["confidence"])
        # flip it: the back point in front
        doc["order"] = [{"front": pick["points"][1], "back": pick["points"][0]}]
        assert call(url + "/api/annotations", "PUT", doc)[0] == 200
        status, rel = _json(call(url + "/api/relations"))
    users = [r for r in rel["relations"] if r["source"] == "user"]
    assert status == 200 and rel["generation"] == 1
    assert [(u["front"], u["back"], u["entry"], u["label"]) for u in users] == \
        [(pick["back"], pick["front"], 0, "order[0]")]


def test_contradiction_names_the_cycle(turtle):
    doc = json.loads(turtle.read_text())
    first = doc["order"][0]
    doc["order"].append({"front": first["back"], "back": first["front"]})
    session = EditSession(turtle)
    with running(session) as url:
        assert call(url + "/api/annotations", "PUT", doc)[0] == 200
        status, answer = _json(call(url + "/api/preview/relief.glb"))
        status_d, answer_d = _json(call(url + "/api/preview/depth.png"))
        _, rel = _json(call(url + "/api/relations"))
    last = f"order[{len(doc['order']) - 1}]"
    assert status == 422 and "contradict" in answer["error"]
    assert set(answer["paths"]) == {"order[0]", last}
    assert status_d == 422 and set(answer_d["paths"]) == {"order[0]", last}
    assert rel["error"] == answer["error"] and set(rel["paths"]) == {"order[0]", last}


def test_boundary_far_from_outlines_is_named(turtle):
    doc = json.loads(turtle.read_text())
    doc["boundaries"] = doc.get("boundaries", []) + [
        {"type": "graft", "path": [[40, 40], [60, 45]]}]
    k = len(doc["boundaries"]) - 1
    session = EditSession(turtle)
    with running(session) as url:
        call(url + "/api/annotations", "PUT", doc)
        status, answer = _json(call(url + "/api/preview/relief.glb"))
    assert status == 422 and answer["paths"] == [f"boundaries[{k}]"]
    assert answer["error"].startswith(f"boundaries[{k}]: no region outline within")


def test_new_annotation_for_a_drawing(tmp_path):
    copy_example("frog", tmp_path)
    (tmp_path / "drawing.inkray.json").unlink()
    target = tmp_path / "sub" / "frog.inkray.json"
    target.parent.mkdir()
    session = EditSession(target, drawing=tmp_path / "drawing.png")
    w, h = session.drawing.size
    with running(session) as url:
        _, doc = _json(call(url + "/api/annotations"))
        assert doc["drawing"] == "../drawing.png" and doc["size"] == [w, h]
        status, answer = _json(call(url + "/api/preview/relief.glb"))
        assert status == 422 and answer["error"].startswith("regions:")
        doc["regions"] = [{"name": "body", "scribbles": [[[w / 2, h / 2]]]}]
        call(url + "/api/annotations", "PUT", doc)
        call(url + "/api/save", "POST")
    ann, drawing = load_input(target)
    assert [r.name for r in ann.regions] == ["body"] and drawing.size == (w, h)


def test_a_missing_file_needs_a_drawing(tmp_path, capsys):
    from inkray.cli import main

    with pytest.raises(InputError, match="pass --drawing"):
        EditSession(tmp_path / "new.inkray.json")
    assert main(["edit", str(tmp_path / "new.inkray.json"), "--no-browser"]) == 2
    assert capsys.readouterr().err.startswith("inkray: error: ")
    assert not (tmp_path / "new.inkray.json").exists()


def test_an_autosave_is_restored(turtle):
    doc = json.loads(turtle.read_text())
    doc["order"] = doc["order"][:1]
    autosave_path(turtle).write_text(json.dumps(doc))
    session = EditSession(turtle)
    assert session.restored and session.document == doc and not session.saved
    assert json.loads(turtle.read_text())["order"] != doc["order"]


def test_an_edit_during_a_preview_supersedes_it(turtle, monkeypatch):
    """The preview answered is of the newest document, computed again after the edit."""
    session = EditSession(turtle)
    doc = json.loads(turtle.read_text())
    edited = dict(doc, order=doc["order"][:-1])
    depth = session_module._PREVIEW["depth.png"]
    seen = []

    def depth_with_an_edit(chain, **params):
        seen.append(len(chain.annotations.order))
        if len(seen) == 1:  # an edit arrives while the first preview is computing
            threading.Thread(target=session.replace, args=(json.dumps(edited),)).start()
            while session.generation == 0:
                pass
        return depth.compute(chain, **params)

    monkeypatch.setitem(session_module._PREVIEW, "depth.png",
                        dataclasses.replace(depth, compute=depth_with_an_edit))
    preview = session.preview("depth.png")
    assert preview.generation == 1 == session.generation
    assert seen == [len(doc["order"]), len(doc["order"]) - 1]
    fresh = EditSession(turtle)
    fresh.replace(json.dumps(edited))
    assert preview.body == fresh.preview("depth.png").body


def test_entry_paths():
    assert entry_paths("boundaries[2]: no region outline; regions[0] and order[11]") == \
        ["boundaries[2]", "regions[0]", "order[11]"]
    assert entry_paths("size: the annotation is for a 3x3 drawing") == []


def test_cli_serves_warns_off_loopback_and_stops_on_ctrl_c(turtle):
    code = "import sys; from inkray.cli import main; sys.exit(main())"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.Popen([sys.executable, "-c", code, "edit", str(turtle), "--no-browser",
                             "--host", "0.0.0.0", "--port", "0"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    try:
        line = proc.stdout.readline().strip()
        assert line.startswith("inkray edit: serving http://0.0.0.0:") and line.endswith("/")
        port = int(line.rsplit(":", 1)[1].strip("/"))
        status, info = _json(call(f"http://127.0.0.1:{port}/api/info"))
        assert status == 200 and info["size"] == [512, 512]
    finally:
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert "warning: serving on 0.0.0.0, not loopback" in err
    assert "Traceback" not in err


def test_exact_depth_on_request(turtle, tmp_path):
    with running(EditSession(turtle)) as url:
        fast = call(url + "/api/preview/depth.png")
        exact = call(url + "/api/preview/depth.png?method=exact")
        bad = _json(call(url + "/api/preview/depth.png?method=slow"))
    assert fast[0] == exact[0] == 200 and fast[2] != exact[2]
    (tmp_path / "fast.png").write_bytes(fast[2])
    (tmp_path / "exact.png").write_bytes(exact[2])
    d_fast, d_exact = (read_depth_png(tmp_path / n)[0] for n in ("fast.png", "exact.png"))
    # the same ordering: both put the head (front) above the shell (back) at order[0]
    for d in (d_fast, d_exact):
        assert d[273, 168] > d[265, 180]
    assert bad[0] == 400 and bad[1]["error"].startswith("method: unknown depth method 'slow'")


def test_a_failing_stage_is_one_line(turtle, monkeypatch, capsys):
    def broken(chain):
        raise RuntimeError("boom\nsecond line")

    relief = session_module._PREVIEW["relief.glb"]
    monkeypatch.setitem(session_module._PREVIEW, "relief.glb",
                        dataclasses.replace(relief, compute=broken))
    with running(EditSession(turtle)) as url:
        status, answer = _json(call(url + "/api/preview/relief.glb"))
    assert status == 500 and answer["error"] == "internal error: RuntimeError: boom second line"
    assert "inkray edit: error: internal error: RuntimeError" in capsys.readouterr().err


def test_an_edit_stops_the_work_of_the_document_it_replaces(turtle):
    """A relief under way stops at its next stage once a newer document arrives."""
    doc = json.loads(turtle.read_text())
    session = EditSession(turtle)
    old = session._chain
    answer = {}
    worker = threading.Thread(target=lambda: answer.update(p=session.preview("relief.glb")))
    worker.start()
    while not old.recomputed:  # the segmentation is done: the rest takes a second or more
        pass
    session.replace(json.dumps(dict(doc, order=doc["order"][:-1])))
    worker.join()
    assert answer["p"].generation == 1
    assert "assemble" not in old.recomputed and "assemble" in session._chain.recomputed
    assert "segment" not in session._chain.recomputed  # the stopped chain's stage was kept


def test_only_requests_naming_this_machine(turtle):
    session = EditSession(turtle)
    doc = json.loads(turtle.read_text())
    with running(session) as url:
        port = url.rsplit(":", 1)[1]
        rebound = call(url + "/api/annotations", "PUT", dict(doc, order=[]),
                       headers={"Host": f"attacker.example:{port}"})
        local = call(url + "/api/info", headers={"Host": f"localhost:{port}"})
    assert rebound[0] == 400 and session.generation == 0
    assert local[0] == 200


def test_closing_stops_the_work_under_way(turtle):
    session = EditSession(turtle)
    chain = session._chain
    failed = []

    def work():
        try:
            session.preview("relief.glb")
        except InkrayError as e:
            failed.append(str(e))

    worker = threading.Thread(target=work)
    worker.start()
    while not chain.recomputed:
        pass
    session.close()
    worker.join()
    assert failed == ["the editor is closing"] and "assemble" not in chain.recomputed


def test_the_page_needs_nothing_from_elsewhere(turtle):
    """Every script, style and module the page loads is served by the editor itself."""
    import re

    with running(EditSession(turtle)) as url:
        page = call(url + "/")[2].decode()
        refs = re.findall(r'(?:src|href)="([^"]+)"', page)
        imports = json.loads(re.search(r'<script type="importmap">(.*?)</script>', page,
                                       re.S).group(1))["imports"]
        modules = ["/static/editor.js", "/static/relief.js",
                   imports["three"], imports["three/addons/"] + "controls/OrbitControls.js",
                   imports["three/addons/"] + "loaders/GLTFLoader.js"]
        served = {ref: call(url + ref)[0] for ref in refs + modules}
        scripts = {ref: call(url + ref)[2].decode() for ref in modules}
    assert refs and all(ref.startswith("/static/") for ref in refs)
    assert all(status == 200 for status in served.values()), served
    for ref, text in scripts.items():
        for target in re.findall(r'^\s*(?:import|export)[^;]*?from\s+["\']([^"\']+)["\']', text, re.M):
            assert target.startswith((".", "/", "three")), (ref, target)


def test_the_depth_map_starts_after_the_segmentation(turtle, monkeypatch):
    """The page asks for both after a scribble: the segmentation is computed first, alone."""
    session = EditSession(turtle)
    depth = session_module._PREVIEW["depth.png"]
    segmented = []

    def depth_after(chain, **params):
        segmented.append(chain.segmented)
        return depth.compute(chain, **params)

    monkeypatch.setitem(session_module._PREVIEW, "depth.png",
                        dataclasses.replace(depth, compute=depth_after))
    assert not session._chain.segmented
    session.preview("depth.png")
    assert segmented == [True]
    doc = json.loads(turtle.read_text())
    session.replace(json.dumps(dict(doc, regions=doc["regions"][1:])))
    assert not session._chain.segmented
    session.preview("depth.png")
    assert segmented == [True, True]


def test_the_depth_preview_is_the_depth_file_compressed_less(turtle, tmp_path):
    """The preview's zlib level differs from `inkray depth`'s files, not its values."""
    session = EditSession(turtle)
    body = session.preview("depth.png").body
    file_bytes = depth_png(session._chain.depth_map.depth)[0]
    (tmp_path / "preview.png").write_bytes(body)
    (tmp_path / "file.png").write_bytes(file_bytes)
    assert body != file_bytes
    assert np.array_equal(_image(body), _image(file_bytes))
    preview, meta = read_depth_png(tmp_path / "preview.png")
    assert np.array_equal(preview, read_depth_png(tmp_path / "file.png")[0])
    assert meta == read_depth_png(tmp_path / "file.png")[1]


def test_depth_draft_first(turtle, tmp_path, monkeypatch):
    """The draft (the page's first answer) is the fast depth map with its fill at half
    resolution; below the draft size it is the full map itself."""
    from inkray.depthmap import estimation

    with running(EditSession(turtle)) as url:
        small = call(url + "/api/preview/depth.png?quality=draft")
        full = call(url + "/api/preview/depth.png")
        bad = _json(call(url + "/api/preview/depth.png?quality=best"))
        exact = _json(call(url + "/api/preview/depth.png?quality=draft&method=exact"))
    assert small[0] == full[0] == 200
    assert small[1]["X-Inkray-Quality"] == full[1]["X-Inkray-Quality"] == "full"
    (tmp_path / "small.png").write_bytes(small[2])
    (tmp_path / "full.png").write_bytes(full[2])
    d_full = read_depth_png(tmp_path / "full.png")[0]
    assert np.array_equal(read_depth_png(tmp_path / "small.png")[0], d_full)
    assert bad[0] == 400 and bad[1]["error"].startswith("quality: unknown quality 'best'")
    assert exact[0] == 400 and exact[1]["error"].startswith("quality: a draft is of the fast")

    monkeypatch.setattr(estimation, "DRAFT_ABOVE", 1000)
    with running(EditSession(turtle)) as url:
        draft = call(url + "/api/preview/depth.png?quality=draft")
    assert draft[0] == 200 and draft[1]["X-Inkray-Compute-Ms"]
    assert draft[1]["X-Inkray-Quality"] == "draft"
    (tmp_path / "draft.png").write_bytes(draft[2])
    d_draft = read_depth_png(tmp_path / "draft.png")[0]
    assert d_draft.shape == d_full.shape and not np.array_equal(d_draft, d_full)
    assert np.abs(d_draft - d_full).mean() < 0.05 * np.ptp(d_full)
    assert d_draft[273, 168] > d_draft[265, 180]  # order[0]: the head over the shell


def test_the_open_answers_the_draft_with_the_reduced_full_map(turtle, tmp_path, monkeypatch):
    """On opening, a fill over more than REDUCED_ABOVE pixels with nothing factored is
    solved on the reduced system: the draft request gets the full map, says so and is
    encoded as it, the full request the same bytes, and after the relief the session
    readies the exact and the draft fill."""
    from inkray.depthmap import estimation

    monkeypatch.setattr(estimation, "DRAFT_ABOVE", 1000)
    monkeypatch.setattr(estimation, "REDUCED_ABOVE", 1000)
    edit = EditSession(turtle)
    with running(edit) as url:
        draft = call(url + "/api/preview/depth.png?quality=draft")
        full = call(url + "/api/preview/depth.png")
        session = edit._chain._cache.session[1]
        reduced = session._fills[False].reduced
        relief = call(url + "/api/preview/relief.glb")
        warming = session._warming
        if warming is not None:
            warming.join()
    assert draft[0] == full[0] == relief[0] == 200 and reduced
    assert draft[1]["X-Inkray-Quality"] == full[1]["X-Inkray-Quality"] == "full"
    assert draft[2] == full[2]
    (tmp_path / "draft.png").write_bytes(draft[2])
    (tmp_path / "full.png").write_bytes(full[2])
    d_full = read_depth_png(tmp_path / "full.png")[0]
    assert np.array_equal(read_depth_png(tmp_path / "draft.png")[0], d_full)
    assert set(session._fills) == {False, True}       # the draft's fill, ready for an edit
    assert d_full[273, 168] > d_full[265, 180]        # order[0]: the head over the shell


def test_a_saved_file_is_compact_and_v1(turtle):
    doc = json.loads(turtle.read_text())
    doc["order"].append({"front": [265.8333, 190.04], "back": [300.25, 188]})
    session = EditSession(turtle)
    session.replace(json.dumps(doc))
    session.save()
    text = turtle.read_text()
    lines = text.splitlines()
    # a line per key, region and entry: each polyline and each arrow on one line
    polylines = sum(len(r["scribbles"]) for r in doc["regions"]) + len(doc["background"])
    entries = len(doc["order"]) + len(doc["boundaries"])
    structure = 2 + 4 + 5 * len(doc["regions"]) + 2 * 4  # braces, scalar keys, regions, lists
    assert len(lines) == structure + polylines + entries, text
    assert '{"front": [265.8, 190], "back": [300.2, 188]}' in text
    saved = json.loads(text)
    assert saved["format"] == "inkray-annotations" and saved["version"] == 1
    from inkray.cli import main

    assert main(["validate", str(turtle)]) == 0


def test_an_autosave_equal_to_the_file_is_removed(turtle):
    autosave_path(turtle).write_text(turtle.read_text())
    session = EditSession(turtle)
    assert not session.restored and session.saved and not autosave_path(turtle).exists()


def test_discarding_the_autosave_goes_back_to_the_file(turtle):
    doc = json.loads(turtle.read_text())
    kept = dict(doc, order=doc["order"][:1])
    autosave_path(turtle).write_text(json.dumps(kept))
    session = EditSession(turtle)
    with running(session) as url:
        assert _json(call(url + "/api/info"))[1]["restored"] is True
        status, answer = _json(call(url + "/api/discard-autosave", "POST"))
        info = _json(call(url + "/api/info"))[1]
        shown = _json(call(url + "/api/annotations"))[1]
    assert status == 200 and answer["generation"] == 1
    assert shown == doc and info["restored"] is False and info["saved"] is True
    assert not autosave_path(turtle).exists()


def test_saving_refuses_what_validate_refuses(turtle):
    from inkray.chain import ReliefChain
    from inkray.validation import validate

    doc = json.loads(turtle.read_text())
    first = doc["order"][0]
    doc["order"].append({"front": first["back"], "back": first["front"]})  # a cycle
    original = turtle.read_bytes()
    session = EditSession(turtle)
    with running(session) as url:
        assert call(url + "/api/annotations", "PUT", doc)[0] == 200
        status, answer = _json(call(url + "/api/save", "POST"))
    ann, drawing = load_input(turtle)
    ann.order = parse_annotations(doc).order
    expected = [p.message for p in validate(ReliefChain(ann, drawing)) if p.severity == "error"]
    assert status == 422 and answer["error"] == expected[0] and "\n" not in answer["error"]
    assert answer["plain"].startswith("the arrow at (174, 269) says head is in front of shell, "
                                      "but the arrow at (174, 269) says shell is in front of head")
    assert turtle.read_bytes() == original


def test_a_chunked_put_stops_at_the_limit(turtle, monkeypatch):
    """The body is read as it streams in, and refused as soon as it passes the limit."""
    import socket
    import select

    from inkray.editor import app

    limit = 1 << 20
    monkeypatch.setattr(app, "_MAX_BODY", limit)
    with running(EditSession(turtle)) as url:
        port = int(url.rsplit(":", 1)[1])
        sock = socket.create_connection(("127.0.0.1", port))
        sock.sendall(b"PUT /api/annotations HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                     b"Transfer-Encoding: chunked\r\n\r\n")
        chunk = b"%x\r\n" % 65536 + b" " * 65536 + b"\r\n"
        sent, answer = 0, b""
        while sent < 200 * limit:  # far more than the limit, unless the answer comes first
            if select.select([sock], [], [], 0)[0]:
                answer = sock.recv(4096)
                break
            try:
                sock.sendall(chunk)
            except (BrokenPipeError, ConnectionResetError):
                answer = sock.recv(4096)
                break
            sent += 65536
        sock.close()
        # A declared length over the limit is refused before any of the body is sent
        # (a client still sending when the server closes would see a reset instead).
        sock = socket.create_connection(("127.0.0.1", port))
        sock.sendall(b"PUT /api/annotations HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                     b"Content-Length: %d\r\n\r\n" % (limit + 1))
        sock.settimeout(30)
        length = sock.recv(4096)
        sock.close()
    assert answer.startswith(b"HTTP/1.1 413"), answer[:100]
    assert sent < 40 * limit  # the limit and what the sockets' buffers hold
    assert length.startswith(b"HTTP/1.1 413"), length[:100]


def test_scribble_region_is_the_part_under_the_scribble(turtle):
    doc = json.loads(turtle.read_text())
    names = [r["name"] for r in doc["regions"]]
    with running(EditSession(turtle)) as url:
        def region(points, current=None):
            return _json(call(url + "/api/scribble-region", "POST",
                              {"points": points, "current": current}))[1]["region"]

        edge = _json(call(url + "/api/scribble-region", "POST",
                          {"points": [[30, 30], [40, 40]]}))[1]["edge"]
        inner = _json(call(url + "/api/scribble-region", "POST",
                           {"points": [[300, 250], [320, 260]]}))[1]["edge"]
        shell = region([[300, 250], [320, 260]])
        head = region([[110, 265], [120, 270]])
        paper = region([[30, 30], [40, 40]])
        bad = call(url + "/api/scribble-region", "POST", {"points": "here"})
    assert names[shell] == "shell" and names[head] == "head" and paper is None
    assert edge and not inner
    assert bad[0] == 422 and b"[x, y] points" in bad[2]


@pytest.mark.slow
def test_the_first_scribble_after_opening_updates_the_depth_fill(tmp_path):
    from inkray.depthmap.estimation import depth

    fox = copy_example("fox", tmp_path)            # gappy ink: the fill spans the whole grid
    doc = json.loads(fox.read_text())
    opened = json.loads(fox.read_text())
    body = next(r for r in opened["regions"] if r["name"] == "body")
    body["scribbles"] = body["scribbles"][:-1]
    fox.write_text(json.dumps(opened))
    session = EditSession(fox)
    with running(session) as url:
        for name in ("depth.png", "relief.glb"):
            assert call(url + f"/api/preview/{name}")[0] == 200
        # After the relief the depth session's fill is factored again, in the background,
        # keeping what an update reuses (the cold open's factorization keeps none).
        fill = session._chain._cache.session[1]._fills[False]
        fill._adopt(wait=True)
        assert fill._chol.updatable
        assert call(url + "/api/annotations", "PUT", doc)[0] == 200   # the scribble back
        assert call(url + "/api/preview/depth.png")[0] == 200
        chain = session._chain
        assert 0 < chain._cache.session[1].refactored_fronts < fill.fronts / 10
        fresh = depth(parse_annotations(doc), load_input(fox)[1], method="fast",
                      segmentation=chain.segmentation.labels)
        assert np.abs(chain.depth_map.depth - fresh.depth).max() < 1e-9


def test_a_depth_map_computing_keeps_a_core_from_the_relief_maps(turtle, monkeypatch):
    """On two cores a map of independent solves (the relief's) runs one call at a time
    while a depth map computes, and two at a time otherwise."""
    import time

    from inkray.numerics.threads import thread_map

    if (os.cpu_count() or 1) != 2:
        pytest.skip("the reservation leaves maps one call at a time on two cores")
    session = EditSession(turtle)
    lock = threading.Lock()

    def most_at_once():
        now, most = [0], [0]

        def call(_):
            with lock:
                now[0] += 1
                most[0] = max(most[0], now[0])
            time.sleep(0.05)
            with lock:
                now[0] -= 1

        thread_map(call, range(4))
        return most[0]

    seen = {}
    for name in ("depth.png", "labels.png"):
        preview = session_module._PREVIEW[name]

        def compute(chain, _name=name, _preview=preview, **params):
            seen[_name] = most_at_once()  # as the relief's thread would, meanwhile
            return _preview.compute(chain, **params)

        monkeypatch.setitem(session_module._PREVIEW, name,
                            dataclasses.replace(preview, compute=compute))
    session.preview("labels.png")
    session.preview("depth.png", draft=True)
    assert seen == {"labels.png": 2, "depth.png": 1}
    assert most_at_once() == 2  # kept only while the depth map computed
