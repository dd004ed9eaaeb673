"""Cues of depth order at one place (inkray.relief.order_cues)."""

import numpy as np
import pytest
from scipy import ndimage

from inkray.errors import InputError
from inkray.relief.completion import complete_regions
from inkray.relief.ink_style import InkStyle
from inkray.relief.order_cues import (CUES, FEATURES, contact_continuation, contact_runon,
                                      contact_spur, order_cues, outline_lengths, place_features,
                                      region_stats)
from inkray.relief.ordering import WEIGHTS, predict_place

H, W = 200, 260
YY, XX = np.mgrid[:H, :W]


def _disk(cx, cy, r):
    return (XX - cx) ** 2 + (YY - cy) ** 2 <= r * r


def _paint(*shapes):
    """Later shapes in front; returns labels."""
    labels = np.full((H, W), -1, np.int32)
    for i, s in enumerate(shapes):
        labels[s] = i
    return labels


def _place(c, a, b):
    (place,) = [p for p in c.places if (p.a, p.b) == (min(a, b), max(a, b))]
    return place


def test_outline_lengths_count_edge_pixels_and_holes():
    labels = np.full((12, 12), -1, np.int32)
    labels[2:10, 2:10] = 0
    labels[5:7, 5:7] = 1                        # a 2x2 hole of another region
    assert outline_lengths(labels).tolist() == [28 + 4 * 2, 4]
    labels[:, :] = 0                            # the whole image: its frame is its outline
    assert outline_lengths(labels).tolist() == [44]
    assert outline_lengths(np.full((3, 3), -1)).size == 0


def test_an_enclosed_part_has_its_whole_outline_on_the_contact():
    labels = _paint(_disk(130, 100, 80), _disk(150, 80, 15))     # an eye on a head
    c = complete_regions(labels)
    cues = order_cues(c, c.places[0])
    assert set(cues) == set(CUES)
    assert cues["junction"] == 0.0                              # a closed contact: no junction
    assert cues["surround"] < -0.9                              # the eye (b) is bounded by the head


def test_ears_behind_a_head_read_from_the_junctions():
    labels = _paint(_disk(85, 50, 22), _disk(175, 50, 22), _disk(130, 110, 65))
    c = complete_regions(labels)
    for ear in (0, 1):
        cues = order_cues(c, _place(c, ear, 2))
        assert cues["junction"] < 0                             # the head (b) is the bar: in front
        assert abs(cues["surround"]) < 0.2                      # an ear meets the head only briefly


def test_junctions_on_a_seam_give_no_cue():
    labels = _paint(_disk(85, 50, 22), _disk(130, 110, 65))
    c = complete_regions(labels)
    place = c.places[0]
    seam = np.array([[x, y] for x, y in place.junctions], float)
    assert order_cues(c, place, seams=[seam]) is None
    assert predict_place(c, place, seams=[seam]) is None


def test_confidence_is_the_logistic_margin_of_the_weighted_cues():
    labels = _paint(_disk(85, 50, 22), _disk(130, 110, 65))
    c = complete_regions(labels)
    place = c.places[0]
    cues = order_cues(c, place)
    score = sum(WEIGHTS[k] * cues[k] for k in CUES)
    r = predict_place(c, place, weights=WEIGHTS)
    assert r.front == (place.a if score > 0 else place.b)
    assert r.confidence == pytest.approx(2.0 / (1.0 + np.exp(-abs(score))) - 1.0)
    doubled = predict_place(c, place, weights={k: 2 * v for k, v in WEIGHTS.items()})
    assert doubled.front == r.front and doubled.confidence > r.confidence
    with pytest.raises(InputError, match="^weights: unknown cue 'size'"):
        predict_place(c, place, weights={"size": 1.0})
    with pytest.raises(InputError, match="^junction_radius:"):
        predict_place(c, place, junction_radius=0)


# -- the learned model's features -------------------------------------------------

def test_region_stats_are_areas_and_centres():
    labels = np.full((10, 12), -1, np.int32)
    labels[2:4, 3:9] = 0                        # 2 x 6: centre (5.5, 2.5)
    labels[6:9, 0:3] = 2                        # region 1 is empty
    areas, centres = region_stats(labels)
    assert areas.tolist() == [12.0, 0.0, 9.0]
    assert centres.tolist() == [[5.5, 2.5], [0.0, 0.0], [1.0, 7.0]]


def test_feature_rows_are_the_two_orientations_of_one_place():
    labels = _paint(_disk(85, 50, 22), _disk(130, 110, 65), _disk(150, 120, 12))
    c = complete_regions(labels)
    for place in c.places:
        f = place_features(c, place, ink=CLEAN)
        assert f.shape == (2, len(FEATURES))
        swapped = place_features(c, place, ink=CLEAN)[::-1]
        odd = ("junction", "area", "surround", "continuation", "continuation_raw", "log_area",
               "log_thickness", "inside", "rise", "ink_spur", "runon")
        for k, name in enumerate(FEATURES):
            if name in odd:
                assert f[0, k] == pytest.approx(-f[1, k])
        pairs = (("share_x", "share_y"), ("near_x", "near_y"), ("hidden_y", "hidden_x"))
        for u, v in pairs:
            assert f[0, FEATURES.index(u)] == f[1, FEATURES.index(v)]
        assert np.array_equal(f, swapped[::-1])     # deterministic


def test_features_of_an_enclosed_part_and_of_a_bar_over_a_box():
    labels = _paint(_disk(130, 100, 80), _disk(140, 90, 20))          # an eye in a head
    c = complete_regions(labels)
    f = place_features(c, c.places[0], ink=CLEAN)
    assert f[0, FEATURES.index("enclosed_y")] == 1.0 and f[0, FEATURES.index("enclosed_x")] == 0.0
    assert f[0, FEATURES.index("log_area")] == pytest.approx(np.log((labels == 0).sum() + 1.0)
                                                             - np.log((labels == 1).sum() + 1.0))
    assert -0.3 < f[0, FEATURES.index("rise")] < 0        # the head's centre lies below the eye
    bar = (YY >= 90) & (YY < 110) & (XX >= 20) & (XX < 240)
    box = (XX >= 60) & (XX < 200) & (YY >= 40) & (YY < 160)
    c = complete_regions(_paint(box, bar))
    f = place_features(c, c.places[0], ink=CLEAN)
    # The bar (b) is thinner; its T-junctions: it covers half of a small disk there.
    assert f[0, FEATURES.index("log_thickness")] > 0
    assert f[0, FEATURES.index("near_y")] == pytest.approx(0.5, abs=0.1)
    assert f[0, FEATURES.index("junctions")] == 4


# -- contact continuation: which part's outline runs on along the contact --------

CLEAN = InkStyle(width=2.0, stroke_ends=0.0)


def _box_over_leg():
    leg = (XX >= 110) & (XX < 150) & (YY >= 100)
    box = (XX >= 40) & (XX < 220) & (YY >= 40) & (YY < 140)
    return leg, box


def test_the_part_whose_outline_continues_the_contact_is_in_front():
    leg, box = _box_over_leg()
    for front in (0, 1):                       # the box as region a, then as region b
        labels = np.full((H, W), -1, np.int32)
        labels[leg] = 1 - front
        labels[box] = front
        c = complete_regions(labels)
        owns = contact_continuation(labels, c.places[0], ink=CLEAN)
        assert owns > 0.8 if front == 0 else owns < -0.8


def test_the_far_side_of_a_thin_front_part_is_not_on_its_continuation():
    # A brim 10 px high over a head: within 6 stroke widths (12 px) of a junction
    # the brim's top side is near in the plane but over 40 px away along its outline.
    head = _disk(130, 115, 60)
    brim = (XX >= 70) & (XX < 190) & (YY >= 50) & (YY < 60)
    c = complete_regions(_paint(head, brim))
    assert len(c.places[0].junctions) == 2
    assert contact_continuation(c.labels, c.places[0], ink=CLEAN) < -0.5     # the brim (b)


def test_the_continuation_cue_is_weighted_by_the_ink_clarity():
    leg, box = _box_over_leg()
    c = complete_regions(_paint(leg, box))
    place = c.places[0]
    owns = contact_continuation(c.labels, place, ink=CLEAN)
    assert order_cues(c, place)["continuation"] == 0.0                   # no ink, no cue
    assert order_cues(c, place, ink=CLEAN)["continuation"] == pytest.approx(owns)
    gappy = InkStyle(width=2.0, stroke_ends=2.0)
    assert order_cues(c, place, ink=gappy, stroke_end_scale=1.0)["continuation"] == \
        pytest.approx(owns * np.exp(-2.0))
    assert predict_place(c, place, ink=CLEAN).front == 1                  # the box
    assert contact_continuation(c.labels, place, ink=InkStyle(width=0.0, stroke_ends=0.0)) == 0.0


# -- contact spur: a line running on into the part in front ------------------------


@pytest.mark.parametrize("start", [132, 139, 146])
def test_a_line_running_on_into_the_box_says_it_is_in_front_under_either_naming(start):
    from inkray.relief.ink_style import ink_style

    leg, box = _box_over_leg()
    gray = np.ones((H, W))
    # 3 px lines on the label outlines: the box's all round, the leg's two sides below it
    gray[box & ~ndimage.binary_erosion(box, iterations=2)] = 0.0
    gray[ndimage.binary_dilation(box, iterations=1) & ~box] = 0.0
    for x in (110, 149):              # 7 px on into the box, ending at its line, 6 px short
        gray[start:, x - 1:x + 2] = 0.0
    ink = ink_style(gray)
    for front in (0, 1):
        labels = np.full((H, W), -1, np.int32)
        labels[leg] = 1 - front
        labels[box] = front
        c = complete_regions(labels)
        spur = contact_spur(labels, c.places[0], ink=ink)
        if start < 139:
            assert (spur if front == 0 else -spur) > 0.05
        else:
            assert spur == 0.0        # no ink inside either part
        f = place_features(c, c.places[0], ink=ink)
        column = FEATURES.index("ink_spur")
        assert f[0, column] == pytest.approx(spur) and f[1, column] == pytest.approx(-spur)


def test_without_the_ink_mask_the_spur_is_zero_and_a_wrong_size_is_an_input_error():
    leg, box = _box_over_leg()
    c = complete_regions(_paint(leg, box))
    assert contact_spur(c.labels, c.places[0], ink=CLEAN) == 0.0
    assert place_features(c, c.places[0], ink=CLEAN)[0, FEATURES.index("ink_spur")] == 0.0
    wrong = InkStyle(width=2.0, stroke_ends=0.0, mask=np.zeros((H + 1, W), bool))
    with pytest.raises(InputError, match="ink mask"):
        contact_spur(c.labels, c.places[0], ink=wrong)


# -- run-on: the line running on at the contact is a third part's silhouette -------------


def _ear_head_cap(names, ear_in_front=False):
    """An ear behind a head (over it with ``ear_in_front``) and a cap on the head drawn up to
    its outline, labelled ``names`` (ear, head, cap); the completion and the place of the
    ear and the cap."""
    ear = (XX >= 100) & (XX < 180) & (YY >= 20) & (YY < 110)
    head = (XX >= 60) & (XX < 220) & (YY >= 70) & (YY < 190)
    cap = head & (XX < 140) & (YY < 110)
    labels = np.full((H, W), -1, np.int32)
    for k in ((1, 2, 0) if ear_in_front else (0, 1, 2)):
        labels[(ear, head, cap)[k]] = names[k]
    c = complete_regions(labels)
    return c, _place(c, names[0], names[2])


@pytest.mark.parametrize("names", [(0, 1, 2), (2, 1, 0), (1, 0, 2)])
def test_a_part_ending_on_the_silhouette_of_a_part_in_front_is_over_what_lies_behind(names):
    # The ear's line runs on past the cap as the head's silhouette (the bar of a T: the
    # ear read in front), which the head owns at its other junction with the ear: the cap
    # lies on the head, over the ear, under any naming.
    c, place = _ear_head_cap(names)
    cap_is_a = names[2] == place.a
    runon = contact_runon(c, place, ink=CLEAN)
    assert (runon if cap_is_a else -runon) > 0.25
    f = place_features(c, place, ink=CLEAN)
    assert f[0, FEATURES.index("runon")] == pytest.approx(runon)
    assert f[1, FEATURES.index("runon")] == pytest.approx(-runon)


def test_a_bar_whose_part_owns_its_line_everywhere_gives_no_run_on():
    # The ear in front of the head: its line is its own, and the T reads as it is drawn.
    c, place = _ear_head_cap((0, 1, 2), ear_in_front=True)
    assert contact_runon(c, place, ink=CLEAN) == 0.0
    c, place = _ear_head_cap((0, 1, 2))
    assert contact_runon(c, place, ink=InkStyle(width=0.0, stroke_ends=0.0)) == 0.0


def test_walk_reaches_the_chessboard_ball_on_open_paper_and_follows_a_bent_line():
    from inkray.relief.order_cues import _walk

    open_paper = np.ones((41, 41), bool)
    start = np.zeros_like(open_paper)
    start[20, 20] = True
    yy, xx = np.mgrid[:41, :41]
    for steps in (0, 1, 7, 25):
        ball = np.maximum(abs(yy - 20), abs(xx - 20)) <= steps
        (got,) = _walk([open_paper], open_paper, start, steps)
        np.testing.assert_array_equal(got, np.flatnonzero(ball))
    # an L-shaped one-pixel line: 30 steps from its end reach its first 31 pixels and,
    # cutting the corner diagonally, the first pixel past the corner
    line = np.zeros((41, 41), bool)
    line[5, 5:36] = True
    line[5:36, 35] = True
    start = np.zeros_like(line)
    start[5, 5] = True
    (reached,) = _walk([line], open_paper, start, 30)
    reached = np.isin(np.arange(line.size), reached).reshape(line.shape)
    assert reached.sum() == 32 and reached[5, 35] and reached[6, 35] and not reached[7, 35]
    assert not len(_walk([line], open_paper, ~line, 30)[0])  # no start on the line: nothing
    # the masks are walked apart: the line's row does not lead into the square beside it,
    # and ``within`` cuts the walk short
    square = np.zeros_like(line)
    square[6:20, 5:20] = True
    along, inside = _walk([line, square], open_paper, start | square, 30)
    assert len(along) == 32 and len(inside) == square.sum()
    half = xx < 20
    (cut,) = _walk([line], half, start, 30)
    np.testing.assert_array_equal(cut, np.flatnonzero(line & half))
