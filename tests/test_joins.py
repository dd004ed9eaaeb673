"""Open joins: ink-free cuts between two regions, where a part's stroke stops short."""

import numpy as np
import pytest

from inkray.errors import InputError
from inkray.input.annotations import Boundary
from inkray.numerics.polyline import arc_length
from inkray.relief.joins import OPEN_MIN, open_joins


def _leg(gap_top=38):
    """A body (0) and a leg (1) below it, the leg drawn with two 3 px strokes whose
    tips stop at row ``gap_top``: the leg is open at the top into the body."""
    gray = np.ones((120, 120))
    gray[gap_top:118, 30:33] = 0.0
    gray[gap_top:118, 87:90] = 0.0
    labels = np.zeros((120, 120), int)
    labels[38:, 30:90] = 1
    return labels, gray


def test_a_leg_open_at_the_top_joins_the_body_between_its_stroke_tips():
    labels, gray = _leg()
    (join,) = open_joins(labels, gray, names=["body", "leg"])
    assert join.type == "graft" and join.regions == (0, 1) and join.index == 0
    assert join.label == "the open join of 'body' and 'leg' at (60, 38)"
    p = join.path
    # from the edge of one stroke to the edge of the other, along the cut (y = 37.5)
    assert sorted([p[0, 0], p[-1, 0]]) == pytest.approx([33.0, 86.0], abs=0.01)
    assert np.abs(p[:, 1] - 37.5).max() < 1e-9
    assert np.all(np.diff(np.linalg.norm(p - p[0], axis=1)) > 0)  # monotone, no doubling back


def test_the_path_is_smooth_where_the_cut_has_pixel_steps():
    # a cut along a staircase (one pixel down every 4 px): the path keeps its
    # slope and smooths the steps away
    gray = np.ones((100, 140))
    labels = np.zeros((100, 140), int)
    yy, xx = np.mgrid[:100, :140]
    labels[yy >= 30 + xx // 4] = 1
    (join,) = open_joins(labels, gray)
    p = join.path[10:-10]
    e = np.diff(p, axis=0)
    heading = np.degrees(np.arctan2(e[:, 1], e[:, 0])) % 180.0  # either way along
    assert np.ptp(heading) < 6.0  # a staircase turns by 90 degrees at each step
    assert np.median(heading) == pytest.approx(np.degrees(np.arctan(0.25)), abs=1.0)


def test_a_gap_in_a_line_is_no_join():
    # the leg's outline drawn all round but for a gap of a stroke width and a half
    labels, gray = _leg()
    gray[36:39, 30:90] = 0.0
    gray[36:39, 55:60] = 1.0
    assert open_joins(labels, gray) == []
    assert arc_length(open_joins(*_leg())[0].path)[-1] >= OPEN_MIN


def test_a_cut_a_boundaries_entry_marks_is_that_entry_s():
    labels, gray = _leg()
    graft = Boundary(type="graft", path=np.array([[33.0, 37.5], [86.0, 37.5]]), index=0)
    assert open_joins(labels, gray, boundaries=[graft]) == []
    # an entry elsewhere leaves the join, numbered after the entries
    far = Boundary(type="flat", path=np.array([[5.0, 5.0], [20.0, 5.0]]), index=0)
    (join,) = open_joins(labels, gray, boundaries=[far])
    assert join.index == 1


def test_the_background_and_ink_make_no_join():
    labels, gray = _leg()
    labels[:38] = -1  # the leg alone on the paper
    assert open_joins(labels, gray) == []
    assert open_joins(np.zeros((50, 50), int), np.ones((50, 50))) == []


def test_arrays_of_different_shapes_are_refused():
    with pytest.raises(InputError, match="gray: expected the labels' shape"):
        open_joins(np.zeros((10, 10), int), np.ones((10, 11)))
