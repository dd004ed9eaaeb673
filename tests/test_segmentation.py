import json
import re

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

from conftest import shared_drawing_names
from inkray.input.annotations import parse_annotations
from inkray.cli import main
from inkray.errors import InputError
from inkray.input.loading import load_input
from inkray.input.scribbles import seed_image
from inkray.segmentation import Segmentation, lazybrush, segment

UNSEEDED = -2


def _ring(shape, cx, cy, r, width=2.0):
    y, x = np.mgrid[:shape[0], :shape[1]]
    d = np.hypot(x - cx, y - cy)
    return np.abs(d - r) <= width / 2


def _disk(shape, cx, cy, r):
    y, x = np.mgrid[:shape[0], :shape[1]]
    return np.hypot(x - cx, y - cy) < r


def _seeds(shape, strokes):
    """strokes: {label: [(x0, y0, x1, y1), ...]} straight segments."""
    from skimage.draw import line

    s = np.full(shape, UNSEEDED, np.int32)
    for label, segs in strokes.items():
        for x0, y0, x1, y1 in segs:
            r, c = line(y0, x0, y1, x1)
            s[r, c] = label
    return s


def _ann(size, regions, background=()):
    return parse_annotations({
        "format": "inkray-annotations", "version": 1, "size": list(size),
        "regions": [{"name": n, "scribbles": s} for n, s in regions],
        "background": list(background)})


# -- lazybrush ---------------------------------------------------------------

def test_any_label_set_and_no_background_unless_asked():
    gray = np.ones((40, 60))
    gray[:, 30] = 0.0
    big = 2 ** 31 - 1
    seeds = _seeds(gray.shape, {3: [(10, 5, 10, 30)], big: [(50, 5, 50, 30)]})
    labels = lazybrush(gray, seeds)
    assert labels.dtype == np.int32 and labels.shape == gray.shape
    assert set(np.unique(labels)) == {3, big}
    assert (labels[:, :30] == 3).all() and (labels[:, 31:] == big).all()


def test_frame_background_makes_the_outside_background():
    shape = (80, 80)
    gray = np.where(_ring(shape, 40, 40, 25), 0.0, 1.0)
    seeds = _seeds(shape, {0: [(35, 40, 45, 40)]})
    inside = _disk(shape, 40, 40, 23)
    outside = ~_disk(shape, 40, 40, 27)
    framed = lazybrush(gray, seeds, frame_background=True)
    assert (framed[inside] == 0).all() and (framed[outside] == -1).all()
    assert (lazybrush(gray, seeds) == 0).all()  # no -1 seeds, no frame: no background


def test_part_cut_by_the_frame_stays_a_part():
    shape = (100, 120)
    ring = _ring(shape, 60, 99, 45, width=3)  # a half disk standing on the bottom edge
    gray = np.where(ring, 0.0, 1.0)
    seeds = _seeds(shape, {0: [(55, 80, 65, 80)]})
    labels = lazybrush(gray, seeds, frame_background=True)
    assert (labels[_disk(shape, 60, 99, 43)] == 0).mean() >= 0.98
    assert (labels[~_disk(shape, 60, 99, 47)] == -1).all()


def test_point_seeds_label_their_areas():
    # Depth-map mode: single labelled points, no background, one label twice.
    gray = np.ones((60, 60))
    gray[:, 20] = gray[:, 40] = gray[30, :20] = 0.0
    points = {(10, 10): 0, (10, 50): 1, (30, 30): 2, (50, 5): 3, (55, 55): 3}
    seeds = np.full(gray.shape, UNSEEDED, np.int32)
    for (x, y), label in points.items():
        seeds[y, x] = label
    labels = lazybrush(gray, seeds)
    assert (labels[:30, :20] == 0).all() and (labels[31:, :20] == 1).all()
    assert (labels[:, 21:40] == 2).all() and (labels[:, 41:] == 3).all()


def test_two_overlapping_circles_gap_in_one_outline_is_closed():
    shape = (160, 230)
    a, b = (85, 80, 50), (145, 80, 50)
    ring_b = _ring(shape, *b)
    # A 3 px gap in the arc of circle B that runs inside circle A (between A's
    # own part and the lens), far from every scribble.
    y, x = np.mgrid[:shape[0], :shape[1]]
    gap = ring_b & (np.abs(y - 80) <= 1) & (x < 115)
    gray = np.where(_ring(shape, *a) | (ring_b & ~gap), 0.0, 1.0)
    assert gap.sum() >= 3
    seeds = _seeds(shape, {0: [(50, 60, 50, 66)], 1: [(120, 60, 120, 64)],
                           2: [(180, 100, 180, 104)]})
    labels = lazybrush(gray, seeds, frame_background=True)
    in_a, in_b = _disk(shape, *a), _disk(shape, *b)
    paper = gray == 1.0
    for area, label in ((in_a & ~in_b, 0), (in_a & in_b, 1), (in_b & ~in_a, 2),
                        (~in_a & ~in_b, -1)):
        frac = (labels[area & paper & ~gap] == label).mean()
        assert frac >= 0.98, (label, frac)


def test_gap_to_the_background_is_closed():
    shape = (120, 120)
    ring = _ring(shape, 60, 60, 40)
    y, x = np.mgrid[:shape[0], :shape[1]]
    gap = ring & (x > 95) & (np.abs(y - 60) <= 2)  # a 5 px gap on the right
    gray = np.where(ring & ~gap, 0.0, 1.0)
    seeds = _seeds(shape, {0: [(40, 60, 44, 60)]})
    labels = lazybrush(gray, seeds, frame_background=True)
    inside = _disk(shape, 60, 60, 38)
    outside = ~_disk(shape, 60, 60, 42)
    assert (labels[inside] == 0).mean() >= 0.98
    assert (labels[outside] == -1).mean() >= 0.98


def test_scribble_overshooting_a_line_does_not_flip_the_other_side():
    gray = np.ones((100, 100))
    gray[:, 49:51] = 0.0
    # Region 0's stroke runs 6 px past the line into region 1's side.
    seeds = _seeds(gray.shape, {0: [(15, 50, 56, 50)], 1: [(85, 30, 85, 70)]})
    labels = lazybrush(gray, seeds)
    assert (labels[:, :49] == 0).all()
    assert (labels[:, 51:] == 1).all()  # overshoot pixels included: scribbles are soft
    hard = lazybrush(gray, seeds, seed_strength=50.0)
    assert (hard[50, 51:57] == 0).all()  # a hard stroke keeps its pixels


def test_a_stroke_across_a_decorative_line_marks_both_sides():
    shape = (100, 100)
    gray = np.ones(shape)
    gray[20, 20:81] = gray[80, 20:81] = gray[20:81, 20] = gray[20:81, 80] = 0.0
    gray[20:81, 60] = 0.0  # a stripe; the stroke overshoots it by 6 px
    seeds = _seeds(shape, {0: [(30, 50, 66, 50)]})
    labels = lazybrush(gray, seeds, frame_background=True)
    assert (labels[21:80, 21:80] == 0).all()
    assert (labels[:19] == -1).all()


def test_outline_ink_belongs_to_the_character_not_the_background():
    shape = (100, 100)
    ring = _ring(shape, 50, 50, 30, width=6)
    gray = np.where(ring, 0.0, 1.0)
    seeds = _seeds(shape, {0: [(45, 50, 55, 50)]})
    labels = lazybrush(gray, seeds, frame_background=True)
    assert (labels[ring] == 0).mean() >= 0.95


def test_areas_split_by_decoration_merge_into_one_region():
    shape = (100, 100)
    gray = np.ones(shape)
    gray[20, 20:81] = gray[80, 20:81] = gray[20:81, 20] = gray[20:81, 80] = 0.0  # a square
    for x in (40, 60):
        gray[20:81, x] = 0.0  # two stripes across it
    seeds = _seeds(shape, {0: [(30, 50, 30, 55), (50, 50, 50, 55), (70, 50, 70, 55)]})
    labels = lazybrush(gray, seeds, frame_background=True)
    body = labels == 0
    assert ndimage.label(body)[1] == 1
    assert body[21:80, 21:80].all()  # stripes included


def test_coarse_to_fine_agrees_with_full_resolution(shared_drawings):
    ann, d = load_input(shared_drawings / "frog" / "drawing.inkray.json")
    seeds = seed_image(ann)
    fine = lazybrush(d.gray, seeds, frame_background=not ann.background, coarse_to_fine=False)
    fast = lazybrush(d.gray, seeds, frame_background=not ann.background, coarse_to_fine=True)
    paper = d.gray >= 0.5
    assert (fine[paper] == fast[paper]).mean() >= 0.999
    assert (fine == fast).mean() >= 0.995  # the rest is which side of a line gets the ink


def test_deterministic():
    rng = np.random.default_rng(0)
    gray = np.clip(rng.random((60, 60)) * 0.3 + 0.7, 0, 1)
    gray[:, 30] = 0.1
    seeds = _seeds(gray.shape, {0: [(5, 5, 5, 50)], 1: [(55, 5, 55, 50)], -1: [(30, 0, 30, 3)]})
    first = lazybrush(gray, seeds)
    assert (first == lazybrush(gray, seeds)).all()


@pytest.mark.parametrize("gray, seeds, match", [
    (np.ones((5, 5)), np.zeros((5, 6), int), "shape"),
    (np.ones((5, 5)), np.full((5, 5), -2), "no seed"),
    (np.full((5, 5), np.nan), np.zeros((5, 5), int), "finite"),
    (np.ones((5, 5)), np.full((5, 5), -3), "label -3"),
    (np.ones((5, 5)), np.zeros((5, 5)), "integer"),
    (np.ones((5, 5)), np.full((5, 5), 2 ** 40), "beyond int32"),
])
def test_lazybrush_rejects_bad_input(gray, seeds, match):
    with pytest.raises(InputError, match=match):
        lazybrush(gray, seeds)


# -- segment -----------------------------------------------------------------

def _square_with_hole():
    gray = np.ones((60, 60))
    gray[10, 10:51] = gray[50, 10:51] = gray[10:51, 10] = gray[10:51, 50] = 0.0
    gray[np.where(_ring(gray.shape, 38, 38, 6, width=1.5))] = 0.0
    return gray


def test_segment_frame_is_background_and_unscribbled_area_is_reported():
    gray = _square_with_hole()
    ann = _ann((60, 60), [("box", [[[15, 20], [25, 20]]])])
    seg = segment(ann, gray)
    assert isinstance(seg, Segmentation) and seg.names == ["box"]
    assert seg.labels[2, 2] == -1 and seg.labels[30, 20] == 0
    hole = _disk(gray.shape, 38, 38, 5)
    assert (seg.labels[hole] == 0).all()  # given to the region around it
    assert len(seg.warnings) == 1
    x, y = map(int, re.search(r"at \((\d+), (\d+)\)", seg.warnings[0]).groups())
    assert hole[y, x] and "'box'" in seg.warnings[0]


def test_segment_labels_follow_annotation_order():
    gray = np.ones((40, 60))
    gray[5, 5:56] = gray[35, 5:56] = 0.0
    gray[5:36, 5] = gray[5:36, 30] = gray[5:36, 55] = 0.0  # two boxes side by side
    ann = _ann((60, 40), [("right", [[[45, 20]]]), ("left", [[[15, 20]]])],
               background=[[[0, 0], [59, 0]]])
    seg = segment(ann, gray)
    assert seg.names == ["right", "left"]
    assert (seg.labels[6:35, 31:55] == 0).all() and (seg.labels[6:35, 6:30] == 1).all()
    assert (seg.labels[:5] == -1).all() and (seg.labels[36:] == -1).all()


@pytest.mark.parametrize("case, match", [
    ("no regions", "no region scribbles"),
    ("on ink", r"regions\[0\]\.scribbles\[1\]: the scribble lies entirely on ink"),
    ("blank", "blank"),
    ("black", "all ink"),
    ("size", "size"),
])
def test_segment_rejects_bad_input(case, match):
    gray = _square_with_hole()
    regions = [("box", [[[15, 20], [25, 20]]])]
    size = (60, 60)
    if case == "no regions":
        regions = []
    elif case == "on ink":
        regions = [("box", [[[15, 20]], [[12, 10], [40, 10]]])]
    elif case == "blank":
        gray = np.ones_like(gray)
    elif case == "black":
        gray = np.zeros_like(gray)
    elif case == "size":
        size = (61, 60)
    with pytest.raises(InputError, match=match):
        segment(_ann(size, regions), gray)


def test_segment_rejects_a_scribble_layer_region_on_ink():
    from inkray.input.annotations import Region

    gray = _square_with_hole()
    ann = _ann((60, 60), [("box", [[[15, 20], [25, 20]]])])
    ann.regions.append(Region(name="lid", scribbles=[],
                              pixels=np.array([[20, 10], [21, 10], [22, 10]])))
    with pytest.raises(InputError, match=r"regions\[1\] \(lid\) layer: .* entirely on ink"):
        segment(ann, gray)


# -- the shared drawings -----------------------------------------------------

@pytest.mark.parametrize("name", shared_drawing_names())
def test_shared_drawing_scribbles_and_closed_areas(shared_drawings, name):
    ann, d = load_input(shared_drawings / name / "drawing.inkray.json")
    seg = segment(ann, d)
    seeds = seed_image(ann)
    seeded = seeds != UNSEEDED
    # Every scribble pixel carries its own region's (or the background's) label.
    wrong = seeded & (seg.labels != seeds)
    assert not wrong.any(), f"{wrong.sum()} seed pixels relabelled, e.g. {np.argwhere(wrong)[0]}"
    # Closed white areas touched by exactly one region's scribbles: >= 98 % that label.
    comp, n = ndimage.label(d.gray >= 0.5)
    if not ann.background:  # the frame is background
        seeds = seeds.copy()
        for edge in (seeds[0], seeds[-1], seeds[:, 0], seeds[:, -1]):
            edge[edge == UNSEEDED] = -1
        seeded = seeds != UNSEEDED
    pairs = np.unique(np.stack([comp[seeded], seeds[seeded]]), axis=1)
    touched = np.bincount(pairs[0], minlength=n + 1)
    checked = 0
    for k, label in pairs.T:
        if k == 0 or touched[k] != 1 or label < 0:
            continue
        area = comp == k
        frac = (seg.labels[area] == label).mean()
        assert frac >= 0.98, f"area {k} ({area.sum()} px) of {seg.names[label]}: {frac:.3f}"
        checked += 1
    assert checked >= min(3, len(ann.regions))  # rings: two regions, one area each
    assert seg.labels.min() >= -1 and seg.labels.max() < len(ann.regions)


# -- command line ------------------------------------------------------------

def test_cli_writes_png_legend_and_npy(shared_drawings, tmp_path, capsys):
    ann = shared_drawings / "turtle" / "drawing.inkray.json"
    png, npy = tmp_path / "out" / "labels.png", tmp_path / "out" / "labels.npy"
    assert main(["--quiet", "segment", str(ann), "-o", str(png), "--npy", str(npy)]) == 0
    labels = np.load(npy)
    assert labels.dtype == np.int32
    image = Image.open(png)
    assert image.mode == "P"
    assert (np.asarray(image).astype(int) - 1 == labels).all()
    legend = json.loads((tmp_path / "out" / "labels.json").read_text())
    names = list(legend["regions"])
    assert names == ["head", "leg_front", "shell", "foot_hind"]
    palette = np.array(image.getpalette()[:3 * (len(names) + 1)]).reshape(-1, 3)
    for name, entry in legend["regions"].items():
        assert entry["colour"] == "#%02x%02x%02x" % tuple(palette[entry["index"]])
        assert entry["pixels"] == int((labels == entry["label"]).sum())
    assert legend["background"]["pixels"] == int((labels == -1).sum())
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["labels.json", "labels.npy",
                                                                   "labels.png"]


@pytest.mark.parametrize("case", ["on ink", "blank", "no regions"])
def test_cli_bad_input_exits_2_and_writes_nothing(tmp_path, capsys, case):
    gray = _square_with_hole()
    if case == "blank":
        gray = np.ones_like(gray)
    Image.fromarray((gray * 255).astype(np.uint8)).save(tmp_path / "d.png")
    scribbles = [[[15, 20], [25, 20]]] if case != "on ink" else [[[12, 10], [40, 10]]]
    doc = {"format": "inkray-annotations", "version": 1, "drawing": "d.png", "size": [60, 60],
           "regions": [] if case == "no regions" else [{"name": "box", "scribbles": scribbles}]}
    (tmp_path / "a.inkray.json").write_text(json.dumps(doc))
    out = tmp_path / "out"
    code = main(["--quiet", "segment", str(tmp_path / "a.inkray.json"), "-o", str(out / "l.png"),
                 "--npy", str(out / "l.npy")])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("inkray: error:") and len(err.strip().splitlines()) == 1
    assert not out.exists() or not any(out.iterdir())


def test_cli_reports_warnings_and_keeps_them_in_the_legend(tmp_path, capsys):
    Image.fromarray((_square_with_hole() * 255).astype(np.uint8)).save(tmp_path / "d.png")
    doc = {"format": "inkray-annotations", "version": 1, "drawing": "d.png", "size": [60, 60],
           "regions": [{"name": "box", "scribbles": [[[15, 20], [25, 20]]]}]}
    (tmp_path / "a.inkray.json").write_text(json.dumps(doc))
    assert main(["--quiet", "segment", str(tmp_path / "a.inkray.json"),
                 "-o", str(tmp_path / "seg.png")]) == 0
    err = capsys.readouterr().err
    assert "inkray: warning: unscribbled area" in err
    legend = json.loads((tmp_path / "seg.json").read_text())
    assert len(legend["warnings"]) == 1 and legend["warnings"][0] in err


def test_cli_rejects_wrong_npy_suffix(tmp_path, shared_drawings):
    ann = shared_drawings / "turtle" / "drawing.inkray.json"
    assert main(["--quiet", "segment", str(ann), "-o", str(tmp_path / "l.png"),
                 "--npy", str(tmp_path / "l.txt")]) == 2
    assert not any(tmp_path.iterdir())


def test_package_exports():
    import inkray
    import inkray.segmentation

    assert inkray.segment is segment and inkray.Segmentation is Segmentation
    assert inkray.segmentation.segment is segment  # the module is not hidden by a function


def test_graft_and_stitch_paths_guide_the_cut():
    """A limb open at the top into a body: the cut follows the annotated graft path."""
    from inkray.input.annotations import parse_annotations
    from inkray.segmentation import segment

    gray = np.ones((120, 160))
    gray[10, 10:150] = gray[110, 10:150] = 0  # the body's outline
    gray[10:111, 10] = gray[10:111, 150] = 0
    gray[60:111, 60] = gray[60:111, 100] = 0  # the limb: two open strokes up from the bottom
    doc = {"format": "inkray-annotations", "version": 1, "size": [160, 120],
           "regions": [{"name": "body", "scribbles": [[[30, 30], [130, 30]]]},
                       {"name": "limb", "scribbles": [[[80, 100]]]}],
           "background": [[[2, 2], [157, 2]]]}
    plain = segment(parse_annotations(doc), gray).labels
    doc["boundaries"] = [{"type": "graft", "path": [[60, 80], [100, 80]]}]
    cut = segment(parse_annotations(doc), gray).labels
    # with the path the limb ends exactly at y = 80; without it the cheapest
    # cut wraps tightly around the limb's dot
    assert (cut[81:109, 61:100] == 1).all() and (cut[60:79, 61:100] == 0).all()
    assert (plain == 1).sum() < 0.5 * (cut == 1).sum()


# -- kept between edits (memo) -------------------------------------------------

def _edits(ann):
    """A sequence of annotations as an editor makes them: scribbles added back one at a
    time, a scribble given to another region, a background scribble, a seam removed,
    and back to the start (undo)."""
    from dataclasses import replace

    regions = ann.regions
    fewer = [replace(r, scribbles=r.scribbles[:1]) for r in regions]
    out = [replace(ann, regions=fewer)]
    for i, r in enumerate(regions):
        if len(r.scribbles) > 1:
            fewer = fewer[:i] + [replace(fewer[i], scribbles=r.scribbles)] + fewer[i + 1:]
            out.append(replace(ann, regions=fewer))
    moved = list(fewer)
    moved[1] = replace(moved[1], scribbles=moved[1].scribbles + [regions[0].scribbles[-1]])
    out.append(replace(ann, regions=moved))
    out.append(replace(ann, background=list(ann.background) + [regions[-1].scribbles[0]]))
    out.append(replace(ann, boundaries=[]))
    out.append(ann)
    return out


@pytest.mark.parametrize("name", ["turtle", "fox"])
def test_kept_memo_gives_what_a_fresh_segmentation_gives(shared_drawings, name):
    ann, d = load_input(shared_drawings / name / "drawing.inkray.json")
    memo = {}
    for edit in _edits(ann):
        kept = segment(edit, d, coarse_to_fine=True, memo=memo)
        fresh = segment(edit, d, coarse_to_fine=True)
        np.testing.assert_array_equal(kept.labels, fresh.labels)
        assert kept.warnings == fresh.warnings


@pytest.mark.slow
@pytest.mark.parametrize("name", ["turtle", "fox", "dragon", "donkey", "frog", "man"])
def test_kept_memo_gives_what_a_fresh_segmentation_gives_at_1_mpx(shared_drawings, name):
    from inkray.input.annotations import rescale_annotations
    from skimage.transform import resize

    ann, d = load_input(shared_drawings / name / "drawing.inkray.json")
    h, w = d.gray.shape
    s = (1e6 / (h * w)) ** 0.5
    size = (int(round(w * s)), int(round(h * s)))
    gray = resize(d.gray, (size[1], size[0]), order=1)
    memo = {}
    for edit in _edits(rescale_annotations(ann, size)):
        kept = segment(edit, gray, memo=memo)
        fresh = segment(edit, gray)
        np.testing.assert_array_equal(kept.labels, fresh.labels)
        assert kept.warnings == fresh.warnings


def test_kept_memo_solves_only_the_cuts_a_scribble_changes(shared_drawings, monkeypatch):
    from dataclasses import replace

    from inkray import segmentation

    ann, d = load_input(shared_drawings / "turtle" / "drawing.inkray.json")
    solved = []
    cut = segmentation._binary_cut
    monkeypatch.setattr(segmentation, "_binary_cut", lambda *a: solved.append(1) or cut(*a))
    memo = {}
    labels = segment(ann, d, coarse_to_fine=True, memo=memo).labels
    first = len(solved)
    # a dot deep inside the area its region already has: every cut stays
    shell = [r.name for r in ann.regions].index("shell")
    inside = ndimage.distance_transform_edt(labels == shell)
    y, x = np.unravel_index(np.argmax(inside), inside.shape)
    again = [replace(r, scribbles=r.scribbles + [[[float(x), float(y)]]]) if i == shell else r
             for i, r in enumerate(ann.regions)]
    dotted = segment(replace(ann, regions=again), d, coarse_to_fine=True, memo=memo)
    assert first > 0 and len(solved) == first
    np.testing.assert_array_equal(dotted.labels, labels)
    # the same with another drawing: the memo is emptied and everything solved again
    other = np.where(d.gray > 0.99, 1.0, d.gray * 0.5)
    np.testing.assert_array_equal(segment(ann, other, coarse_to_fine=True, memo=memo).labels,
                                  segment(ann, other, coarse_to_fine=True).labels)
    assert len(solved) >= 3 * first


def _random_grid(rng):
    """A small grid's shape and random ink costs."""
    h, w = rng.integers(3, 14, size=2)
    return h, w, rng.random((h, w)) ** 3


def _grid_edges(h, w, cost, flat, pull=None):
    """The edges of a binary cut on the pixels ``flat`` of the grid (the others
    fixed), floor 0.01; ``pull`` an (H, W) array or None."""
    from inkray.segmentation import _cut_edges, _level

    fixed = np.zeros((h, w), np.int32)
    fixed.ravel()[flat] = -2
    return _cut_edges(_level(cost, fixed, 0.01), np.arange(len(flat)),
                      None if pull is None else (lambda p: pull.ravel()[p]))


def test_cut_edges_are_the_grid_edges_among_the_pixels():
    from inkray.segmentation import _cut_edges, _level, _quantized

    rng = np.random.default_rng(4)
    for _ in range(100):
        h, w, cost = _random_grid(rng)
        pull = _quantized(0.04 * rng.random((h, w)))
        free = rng.random((h, w)) < rng.choice([0.5, 0.9, 1.0])
        fixed = np.where(free, -2, 0).astype(np.int32)
        level = _level(cost, fixed, 0.01)
        idx = np.flatnonzero(free)
        on = np.flatnonzero(rng.random(len(idx)) < 0.8)
        flat = idx[on]
        node = {p: k for k, p in enumerate(flat)}
        expected = []  # right edges, then down edges, in raster order of the first end
        for step, ok in ((1, lambda p: p % w < w - 1), (w, lambda p: p < (h - 1) * w)):
            for p in flat:
                if ok(p) and p + step in node:
                    cap = _quantized(min(cost.flat[p], cost.flat[p + step]) + 0.01)
                    expected.append((node[p], node[p + step], cap + pull.flat[p],
                                     cap + pull.flat[p + step]))
        got = [e for a, b, fwd, rev in _cut_edges(level, on, lambda p: pull.ravel()[p])
               for e in zip(a, b, fwd, rev)]
        assert [(int(a), int(b)) for a, b, _, _ in got] == [(a, b) for a, b, _, _ in expected]
        np.testing.assert_array_equal(np.array([g[2:] for g in got]).reshape(-1, 2),
                                      np.array([e[2:] for e in expected]).reshape(-1, 2))


def _random_terminals(rng, n):
    """Quantized source and sink capacities, each on about a fifth of ``n`` pixels."""
    from inkray.segmentation import _quantized

    return tuple(_quantized(np.where(rng.random(n) < 0.2, rng.random(n) * 3, 0.0))
                 for _ in range(2))


def test_unchanged_cut_is_the_fresh_cut_on_random_graphs():
    from inkray.segmentation import _binary_cut, _quantized, _unchanged_cut

    rng = np.random.default_rng(1)
    reused = 0
    for _ in range(200):
        h, w, cost = _random_grid(rng)
        flat = np.flatnonzero(rng.random(h * w) < 0.9)
        n = len(flat)
        edges = _grid_edges(h, w, cost, flat)
        src, snk = _random_terminals(rng, n)
        won = _binary_cut(n, edges, src, snk)[1]
        more = _quantized(np.where(rng.random(n) < 0.2, rng.random(n), 0.0))
        # more capacity toward the side each pixel took, and now and then against it
        src2 = src + np.where(won | (rng.random(n) < 0.05), more, 0.0)
        snk2 = snk + np.where(~won | (rng.random(n) < 0.05), more[::-1], 0.0)
        fresh = _binary_cut(n, edges, src2, snk2)[1]
        if _unchanged_cut((flat, src, snk, won), src2, snk2):
            reused += 1
            np.testing.assert_array_equal(fresh, won)
    assert 20 < reused < 200


def test_resumed_background_cut_is_the_fresh_cut_on_random_graphs():
    from inkray.segmentation import BACKGROUND, _binary_cut, _min_cut, _quantized

    rng = np.random.default_rng(2)
    for _ in range(100):
        h, w, cost = _random_grid(rng)
        pull = _quantized(0.04 * rng.random((h, w)))
        flat = np.flatnonzero(rng.random(h * w) < 0.9)
        edges = _grid_edges(h, w, cost, flat, pull)
        memo = {}
        for _ in range(3):  # any change of the terminals, more or less capacity
            src, snk = _random_terminals(rng, len(flat))
            won = _min_cut(flat, (h, w), BACKGROUND, lambda: edges, src, snk, memo)
            fresh = _binary_cut(len(flat), edges, src, snk)[1]
            np.testing.assert_array_equal(won, fresh)
        assert memo[("cut", (h, w), BACKGROUND)][4] is not None


def test_grown_cut_is_the_fresh_cut_on_random_graphs():
    from inkray.segmentation import _binary_cut, _grown_cut

    rng = np.random.default_rng(3)
    grown = 0
    for _ in range(300):
        h, w, cost = _random_grid(rng)
        # some pixels join the cut: a block of the grid, without source capacity, now
        # and then walled off from the rest (then it costs nothing on either side)
        y, x, r = rng.integers(0, h), rng.integers(0, w), rng.integers(0, 3)
        rows, cols = np.divmod(np.arange(h * w), w)
        ring = np.maximum(abs(rows - y), abs(cols - x))
        keep = (rng.random(h * w) < 0.9) | (ring <= r)
        if rng.random() < 0.3:
            keep &= ring != r + 1
        flat = np.flatnonzero(keep)
        src, snk = _random_terminals(rng, len(flat))
        new = ring[flat] <= r
        if new.all():
            continue
        src[new] = 0.0
        snk[new] *= rng.random() < 0.5
        old = ~new
        won0 = _binary_cut(int(old.sum()), _grid_edges(h, w, cost, flat[old]), src[old],
                           snk[old])[1]
        won = _grown_cut((flat[old], src[old], snk[old], won0), flat, (h, w), src, snk)
        if won is not None:
            grown += 1
            fresh = _binary_cut(len(flat), _grid_edges(h, w, cost, flat), src, snk)[1]
            np.testing.assert_array_equal(won, fresh)
    assert 20 < grown < 300


def test_pooling_without_a_padded_copy_is_pooling_the_padded_image():
    from inkray.segmentation import _pool, _pool_max, _pool_min

    rng = np.random.default_rng(5)
    for h, w in ((6, 8), (7, 8), (6, 9), (7, 9), (1, 1), (1, 4), (5, 1)):
        a = rng.random((h, w))
        padded = np.pad(a, ((0, h % 2), (0, w % 2)), mode="edge")
        np.testing.assert_array_equal(_pool_min(a), _pool(padded, np.minimum))
        # a few seeds on an unseeded image, their strengths on zeros; and values
        # below the fill, where only the padded pooling is right
        for fill, values in ((-2, rng.integers(-1, 5, (h, w)).astype(np.int32)),
                             (0.0, rng.random((h, w))), (0.0, -rng.random((h, w)))):
            sparse = np.where(rng.random((h, w)) < 0.3, values, fill).astype(values.dtype)
            padded = np.pad(sparse, ((0, h % 2), (0, w % 2)), constant_values=fill)
            pooled = _pool_max(sparse, fill)
            assert pooled.dtype == sparse.dtype
            np.testing.assert_array_equal(pooled, _pool(padded, np.maximum))
