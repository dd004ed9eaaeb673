"""Depth order (inkray.order): predictions, the user's local entries, cycles."""

import json
from dataclasses import replace

import numpy as np
import pytest
from PIL import Image

from inkray.input.annotations import Annotations, Boundary, Equal, Order, load_annotations
from inkray.cli import main
from inkray.relief.completion import complete_regions
from inkray.errors import InputError
from inkray.relief.ordering import depth_order, predict_place
from inkray.input.constraints import constraints

# Scenes are laid out on a 160 x 220 grid and drawn at SCALE, the size of the shared
# drawings' parts (the junction cue looks up to 40 px around a junction).
SCALE = 2
H, W = 160 * SCALE, 220 * SCALE
YY, XX = np.mgrid[:H, :W] / SCALE


def disk(cx, cy, r):
    return (XX - cx) ** 2 + (YY - cy) ** 2 <= r * r


def rect(x0, y0, x1, y1):
    return (XX >= x0) & (XX < x1) & (YY >= y0) & (YY < y1)


def P(x, y):
    """A layout point in drawing pixels."""
    return (float(x * SCALE), float(y * SCALE))


def ellipse(cx, cy, rx, ry, angle=0.0):
    c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
    u, v = (XX - cx) * c + (YY - cy) * s, (YY - cy) * c - (XX - cx) * s
    return (u / rx) ** 2 + (v / ry) ** 2 <= 1


def ring(cx, cy, r_out, r_in):
    return disk(cx, cy, r_out) & ~disk(cx, cy, r_in)


def paint(*shapes):
    """Painter's algorithm: later shapes are in front. Returns labels."""
    labels = np.full((H, W), -1, np.int32)
    for i, s in enumerate(shapes):
        labels[s] = i
    return labels


def predicted(labels):
    c = complete_regions(labels)
    relations, warnings = depth_order([], labels, c)
    return c, relations, warnings


SCENES = {
    "disk over disk": lambda: paint(disk(80, 80, 50), disk(140, 85, 40)),
    "small disk over big disk": lambda: paint(disk(90, 80, 60), disk(150, 60, 25)),
    "disk behind disk": lambda: paint(disk(140, 85, 40), disk(80, 80, 50)),
    "square over square": lambda: paint(rect(30, 30, 120, 120), rect(90, 70, 180, 150)),
    "disk over square": lambda: paint(rect(30, 30, 130, 130), disk(140, 80, 45)),
    "square over disk": lambda: paint(disk(90, 80, 55), rect(120, 20, 200, 140)),
    "band over square": lambda: paint(rect(40, 40, 180, 120), rect(95, 10, 125, 150)),
    "T-junction stack of 3": lambda: paint(rect(20, 20, 140, 100), rect(80, 50, 190, 130),
                                           rect(120, 10, 170, 150)),
    "stack of 3 disks": lambda: paint(disk(70, 80, 50), disk(120, 80, 45), disk(165, 80, 40)),
    "eye in head": lambda: paint(disk(110, 80, 70), disk(130, 60, 15)),
    # The cases the prediction most often misses on real drawings: parts over a body, parts behind.
    "arm drawn across a body": lambda: paint(ellipse(110, 80, 45, 65), ellipse(90, 85, 14, 50, 35)),
    "ears behind a head": lambda: paint(disk(75, 45, 18), disk(145, 45, 18), disk(110, 85, 50)),
    "legs behind a body": lambda: paint(ellipse(85, 130, 15, 35), ellipse(135, 130, 15, 35),
                                        ellipse(110, 75, 55, 65)),
}


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_known_order_is_predicted(scene):
    labels = SCENES[scene]()
    c, relations, warnings = predicted(labels)
    assert warnings == []
    assert c.places, "the scene has neighbouring regions"
    by_place = {r.place: r for r in relations}
    for p in c.places:
        r = by_place[p.index]                   # every overlap gets a prediction ...
        assert (r.front, r.back) == (max(p.a, p.b), min(p.a, p.b)), scene   # ... and it is right
        assert r.source == "predicted" and 0 < r.confidence <= 1 and r.entry is None
        assert r.kind == "order"
    pairs = {(p.a, p.b) for p in c.places}
    assert pairs == {(a, b) for a in range(c.count) for b in c.neighbours[a] if a < b}


def rings():
    """Two interlocking rings: A over B at the upper crossing, B over A at the lower one."""
    a = ring(85, 80, 55, 40)
    b = ring(135, 80, 55, 40)
    labels = paint(a, b)
    labels[a & b & (YY < 80)] = 0
    return labels, a & b


def _near(labels, region, where):
    """The pixel of ``region`` nearest to ``where`` (x, y in pixels)."""
    pts = np.argwhere(labels == region)
    y, x = pts[np.argmin(np.hypot(pts[:, 1] - where[0], pts[:, 0] - where[1]))]
    return (float(x), float(y))


def test_interlocking_rings_two_local_entries():
    labels, both = rings()
    entries = []
    for i, (upper, front, back) in enumerate([(True, 0, 1), (False, 1, 0)]):
        ys, xs = np.nonzero(both & ((YY < 80) == upper))
        centre = (xs.mean(), ys.mean())
        entries.append(Order(front=_near(labels, front, centre), back=_near(labels, back, centre),
                             index=i))
    ann = Annotations(size=(W, H), order=entries)
    c = complete_regions(labels, names=["A", "B"])
    assert len(c.places) == 2
    relations, warnings = depth_order(constraints(ann), labels, c, seams=ann.boundaries)
    users = [r for r in relations if r.source == "user"]
    assert [(r.front_name, r.back_name) for r in users] == [("A", "B"), ("B", "A")]
    assert users[0].place != users[1].place
    assert relations == users                   # both places spoken for: nothing predicted
    assert warnings == []
    final = c.ordered(relations)
    # B is completed under A only at the upper crossing, A under B only at the lower one.
    assert (final.owner == 1).any() and (YY[final.owner == 1] < 80).all()
    assert (final.owner == 0).any() and (YY[final.owner == 0] > 80).all()
    # The completed rings cover their crossings.
    assert (final.completed(1) & both & (YY < 80)).sum() > 0.8 * (both & (YY < 80)).sum()


def two_squares():
    return paint(rect(30, 30, 120, 120), rect(90, 70, 180, 150))


def test_user_entry_wins_over_prediction():
    labels = two_squares()
    c = complete_regions(labels)
    wrong = Annotations(size=(W, H), order=[Order(front=P(60, 60), back=P(150, 120), index=0)])
    relations, _ = depth_order(constraints(wrong), labels, c, seams=wrong.boundaries)
    assert [(r.front, r.back, r.source, r.entry) for r in relations] == [(0, 1, "user", 0)]
    assert relations[0].where == P(105, 90)
    only_user, _ = depth_order([], labels, c, predict=False)
    assert only_user == []


def test_contradicting_entries_name_the_cycle():
    labels = two_squares()
    c = complete_regions(labels)
    ann = Annotations(size=(W, H), order=[
        Order(front=P(60, 60), back=P(150, 120), index=0),
        Order(front=P(61, 61), back=P(150, 121), index=1),   # the same again: fine
        Order(front=P(150, 120), back=P(60, 60), index=2),   # the opposite: not fine
    ])
    with pytest.raises(InputError, match=r"order\[0\] -> order\[2\] -> order\[0\]"):
        depth_order(constraints(ann), labels, c, seams=ann.boundaries)


def test_three_entry_cycle_at_one_site():
    labels = SCENES["T-junction stack of 3"]()
    c = complete_regions(labels, names=["back", "middle", "front"])
    pts = {i: tuple(float(v) for v in np.argwhere(labels == i)[0][::-1]) for i in range(3)}
    ann = Annotations(size=(W, H), order=[
        Order(front=pts[2], back=pts[1], index=0),
        Order(front=pts[1], back=pts[0], index=1),
        Order(front=pts[0], back=pts[2], index=2),
    ])
    with pytest.raises(InputError, match=r"order\[0\] -> order\[1\] -> order\[2\] -> order\[0\]"):
        depth_order(constraints(ann), labels, c, seams=ann.boundaries)


def test_equal_entries():
    labels = two_squares()
    c = complete_regions(labels)
    ann = Annotations(size=(W, H), equal=[Equal(a=P(60, 60), b=P(150, 120), index=0)])
    relations, _ = depth_order(constraints(ann), labels, c, seams=ann.boundaries)
    assert [(r.kind, r.source, r.entry) for r in relations] == [("equal", "user", 0)]
    assert (c.ordered(relations).owner == -1).all()   # they meet: nothing is hidden
    ann.order = [Order(front=P(150, 120), back=P(60, 60), index=0)]
    with pytest.raises(InputError, match=r"equal\[0\] -> order\[0\] -> equal\[0\]|"
                                         r"order\[0\] -> equal\[0\] -> order\[0\]"):
        depth_order(constraints(ann), labels, c, seams=ann.boundaries)


def test_weakest_prediction_in_a_cycle_is_dropped():
    labels = SCENES["T-junction stack of 3"]()
    c = complete_regions(labels, names=["back", "middle", "front"])
    pts = {i: tuple(float(v) for v in np.argwhere(labels == i)[-1][::-1]) for i in range(3)}
    # The user puts the back region over the front one; the predictions front > middle > back
    # then close a cycle with it, and one of them must go.
    ann = Annotations(size=(W, H), order=[Order(front=pts[0], back=pts[2], index=0)])
    place = next(p for p in c.places if (p.a, p.b) == (0, 2))
    ann.order = [Order(front=_near(labels, 0, place.where), back=_near(labels, 2, place.where),
                       index=0)]
    relations, warnings = depth_order(constraints(ann), labels, c, seams=ann.boundaries)
    dropped = [w for w in warnings if "dropped" in w]
    assert len(dropped) == 1 and "closes the cycle" in dropped[0]
    kept = [r for r in relations if r.source == "predicted"]
    assert len(kept) == 1
    weakest = min((predict_place(c, p) for p in c.places if (p.a, p.b) != (0, 2)),
                  key=lambda r: r.confidence)
    assert f"{weakest.front_name} over {weakest.back_name}" in dropped[0]


def test_predictions_kept_in_a_memo_are_reused_across_entries(monkeypatch):
    import inkray.relief.ordering as ordering

    labels = SCENES["T-junction stack of 3"]()
    c = complete_regions(labels, names=["back", "middle", "front"])
    place = next(p for p in c.places if (p.a, p.b) == (0, 2))
    entry = Annotations(size=(W, H), order=[Order(front=_near(labels, 0, place.where),
                                                  back=_near(labels, 2, place.where), index=0)])
    memo = {}
    first = depth_order([], labels, c, memo=memo)
    assert first == depth_order([], labels, c)
    assert len(memo) == len(c.places)
    calls = []
    real = ordering.predict_place
    monkeypatch.setattr(ordering, "predict_place", lambda *a, **k: calls.append(1) or real(*a, **k))
    # an arrow changes which predictions are kept, not what the cues say: nothing is measured again
    again, warnings = depth_order(constraints(entry), labels, c, memo=memo)
    assert calls == []
    assert again == depth_order(constraints(entry), labels, c)[0]
    assert any("dropped" in w for w in warnings)


def test_entries_that_name_no_pair_warn():
    labels = paint(disk(50, 80, 30), disk(170, 80, 30))          # two regions apart
    c = complete_regions(labels, names=["left", "right"])
    ann = Annotations(size=(W, H), order=[
        Order(front=P(50, 80), back=P(5, 5), index=0),        # background
        Order(front=P(45, 80), back=P(55, 80), index=1),      # one region
        Order(front=P(50, 80), back=P(170, 80), index=2),     # regions that do not touch
    ])
    relations, warnings = depth_order(constraints(ann), labels, c, seams=ann.boundaries)
    assert [(r.entry, r.place) for r in relations] == [(2, None)]
    assert warnings[0].startswith(f"order[0].back: point ({5 * SCALE}, {5 * SCALE}) lies in "
                                  f"the background")
    assert warnings[1].startswith("order[1]: both points lie in region 'left'")
    assert warnings[2].startswith("order[2]: regions 'left' and 'right' do not touch")


def test_junctions_on_a_graft_are_no_cue():
    labels = paint(rect(20, 20, 200, 100), rect(90, 60, 130, 150))  # a leg under a body
    c = complete_regions(labels)
    place = c.places[0]
    seams = [np.array([P(85, 100), P(135, 100)])]                   # graft along the cut
    assert predict_place(c, place) is not None
    assert predict_place(c, place, seams=seams) is None
    ann = Annotations(size=(W, H), boundaries=[Boundary(type="graft", path=seams[0], index=0)])
    relations, _ = depth_order(constraints(ann), labels, c, seams=ann.boundaries)
    assert relations == []


def test_labels_must_match():
    labels = two_squares()
    c = complete_regions(labels)
    with pytest.raises(InputError, match="not the one the completion"):
        depth_order([], labels[:, ::-1], c)


# -- command line --------------------------------------------------------------

def _drawing(tmp_path):
    """A disk drawn behind a band, as ink outlines, with scribbles."""
    gray = np.full((H, W), 255, np.uint8)
    d = disk(100, 80, 50)
    band = rect(85, 5, 125, 155)
    def edge(m):
        return m & ~(np.roll(m, 1, 0) & np.roll(m, -1, 0) & np.roll(m, 1, 1) & np.roll(m, -1, 1))

    gray[edge(d) & ~band] = 0
    gray[edge(band)] = 0
    Image.fromarray(gray).save(tmp_path / "d.png")
    doc = {"format": "inkray-annotations", "version": 1, "drawing": "d.png", "size": [W, H],
           "regions": [{"name": "disk",
                        "scribbles": [[P(70, 80), P(75, 90)], [P(135, 80), P(140, 70)]]},
                       {"name": "band", "scribbles": [[P(105, 20), P(105, 140)]]}],
           "background": [[P(5, 5), P(215, 5), P(215, 155), P(5, 155), P(5, 5)]]}
    path = tmp_path / "d.inkray.json"
    path.write_text(json.dumps(doc))
    return path, doc


def test_cli_regions(tmp_path, capsys):
    ann, _ = _drawing(tmp_path)
    out = tmp_path / "out" / "report.json"
    masks = tmp_path / "masks"
    assert main(["--quiet", "regions", str(ann), "-o", str(out), "--masks", str(masks)]) == 0
    report = json.loads(out.read_text())
    regions = {r["name"]: r for r in report["regions"]}
    assert regions["disk"]["neighbours"] == ["band"]
    assert regions["disk"]["completed_area"] > regions["disk"]["visible_area"]
    assert regions["band"]["completed_area"] == regions["band"]["visible_area"]
    rel = report["relations"]
    assert [(r["front"], r["back"], r["source"]) for r in rel] == [("band", "disk", "predicted")]
    assert set(rel[0]) >= {"front", "back", "where", "source", "confidence"}
    mask = np.asarray(Image.open(masks / "disk.png")) > 0
    assert mask.sum() == regions["disk"]["completed_area"]
    # The completed disk is round again.
    assert (mask & disk(100, 80, 50)).sum() / (mask | disk(100, 80, 50)).sum() > 0.95


def test_cli_regions_no_predict_and_user_entries(tmp_path):
    ann, doc = _drawing(tmp_path)
    doc["order"] = [{"front": P(70, 80), "back": P(105, 60)}]
    ann.write_text(json.dumps(doc))
    out = tmp_path / "r.json"
    assert main(["--quiet", "regions", str(ann), "-o", str(out), "--no-predict"]) == 0
    report = json.loads(out.read_text())
    assert [(r["front"], r["back"], r["source"], r["entry"]) for r in report["relations"]] == \
        [("disk", "band", "user", "order[0]")]
    regions = {r["name"]: r for r in report["regions"]}
    assert regions["disk"]["completed_area"] == regions["disk"]["visible_area"]


def test_cli_regions_writes_nothing_on_contradiction(tmp_path, capsys):
    ann, doc = _drawing(tmp_path)
    doc["order"] = [{"front": P(70, 80), "back": P(105, 60)},
                    {"front": P(105, 60), "back": P(70, 80)}]
    ann.write_text(json.dumps(doc))
    out = tmp_path / "r.json"
    masks = tmp_path / "m"
    assert main(["--quiet", "regions", str(ann), "-o", str(out), "--masks", str(masks)]) == 2
    assert "order[0] -> order[1] -> order[0]" in capsys.readouterr().err
    assert not out.exists()
    assert not masks.exists() or not any(masks.iterdir())


# -- shared drawings -------------------------------------------------------------

@pytest.mark.slow
def test_prediction_agrees_with_shared_drawings(shared_drawings, capsys):
    """With the order entries removed, the prediction agrees with them on >= 89 %
    of the entries whose two regions touch (the figure per drawing is printed;
    it read 111 of 124, 89.5 %, when the continuation cue was added, up from
    104). In-sample: the weights were fitted on these drawings (by log-loss, so
    not to the most entries right); the leave-one-out figure (112 of 124) is
    benchmarks/bench_order.py's."""
    from inkray.input.loading import load_input
    from inkray.relief.ink_style import ink_style
    from inkray.segmentation import segment

    agree = counted = total = 0
    lines = []
    folders = sorted(p for p in shared_drawings.iterdir() if (p / "drawing.inkray.json").is_file())
    for folder in folders:
        ann, drawing = load_input(folder / "drawing.inkray.json")
        seg = segment(ann, drawing)
        c = complete_regions(seg.labels, names=seg.names)
        users, _ = depth_order(constraints(ann), seg.labels, c, seams=ann.boundaries, predict=False)
        guesses, _ = depth_order(constraints(replace(ann, order=[])), seg.labels, c,
                                 seams=ann.boundaries, ink=ink_style(drawing.gray))
        by_place = {r.place: r for r in guesses}
        orders = [u for u in users if u.kind == "order"]
        placed = [u for u in orders if u.place is not None]
        good = sum(1 for u in placed if by_place.get(u.place) is not None
                   and by_place[u.place].front == u.front)
        agree += good
        counted += len(placed)
        total += len(load_annotations(folder / "drawing.inkray.json").order)
        lines.append(f"{folder.name}: {good}/{len(placed)} of the entries between touching "
                     f"regions ({len(orders)} entries between regions)")
    with capsys.disabled():
        print("\n" + "\n".join(lines) + f"\nall: {agree}/{counted} = {agree / counted:.1%} "
              f"({total} entries, {total - counted} between regions that do not touch)")
    assert agree / counted >= 0.89


# -- the predictions stay what they were --------------------------------------------

#: Drawings compared at their size in the default suite; the others, and every drawing
#: upscaled to about 1 Mpx, are slow.
_QUICK = ("fox", "man", "turtle")


def _stored():
    from _order_predictions import FIXTURE

    return json.loads(FIXTURE.read_text(encoding="utf-8"))


@pytest.mark.parametrize("name, upscaled", [
    pytest.param(n, up, id=f"{n}-{'1mpx' if up else 'native'}",
                 marks=() if n in _QUICK and not up else pytest.mark.slow)
    for n in sorted(_stored()["drawings"]) for up in (False, True)])
def test_predictions_match_the_stored_ones(name, upscaled):
    """Every place's prediction (weighted cues and learned model) equals the one stored
    in tests/data/order_predictions.json (``python tests/_order_predictions.py``): the
    same front, the confidence to 1e-6. Making the cues faster must not change them."""
    from _order_predictions import predictions

    want = _stored()["drawings"][name]["upscaled" if upscaled else "native"]
    got = predictions(name, upscaled=upscaled)
    assert got["size"] == want["size"]
    for key in ("cues", "learned"):
        assert len(got[key]) == len(want[key])
        for place, (g, e) in enumerate(zip(got[key], want[key])):
            assert g[:3] == e[:3], f"{name} {key} place {place}: {g} != {e}"
            if e[3] is not None:
                assert abs(g[3] - e[3]) <= 1e-6, f"{name} {key} place {place}: {g} != {e}"
