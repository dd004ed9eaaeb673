import numpy as np
import pytest
from skimage.measure import points_in_poly

from inkray.errors import InputError
from inkray.relief.outline import region_outline
from inkray.relief.silhouette import grow_over_ink, ink_pixels, pad_ink_edge, stroke_width


def _ring_drawing(size=80, radius=25, width=4):
    """A disk part whose contour stroke is split in the middle by the segmentation."""
    yy, xx = np.mgrid[:size, :size]
    r = np.hypot(xx - size / 2, yy - size / 2)
    ink = np.abs(r - radius) < width / 2
    labels = np.where(r < radius, 0, -1)
    return labels, ink, r


def test_part_grows_to_the_outer_edge_of_its_stroke():
    labels, ink, r = _ring_drawing()
    grown = grow_over_ink(labels, ink)
    assert (grown[ink] == 0).all()  # the whole stroke is on the part
    assert (grown[(r >= 27.5) & ~ink] == -1).all()  # the paper is not


def test_seams_between_parts_stay():
    labels, ink, _ = _ring_drawing()
    labels[:, :40] = np.where(labels[:, :40] == 0, 1, -1)  # two parts meeting at x = 40
    ink[:, 39:41] |= labels[:, 39:41] >= 0  # a line between them
    grown = grow_over_ink(labels, ink)
    inside = labels >= 0
    assert np.array_equal(grown[inside], labels[inside])


def test_background_ink_out_of_reach_stays_background():
    labels = np.full((20, 40), -1)
    labels[:, :10] = 0
    ink = np.zeros((20, 40), bool)
    ink[:, 10:30] = True  # a 20 px blob beside the part
    grown = grow_over_ink(labels, ink, width=3)
    assert (grown[:, 10:13] == 0).all() and (grown[:, 14:] == -1).all()


def test_nearest_part_takes_a_pixel():
    labels = np.full((5, 11), -1)
    labels[:, :3], labels[:, 8:] = 0, 1
    ink = np.zeros((5, 11), bool)
    ink[:, 3:8] = True
    grown = grow_over_ink(labels, ink, width=5)
    assert grown[2].tolist() == [0, 0, 0, 0, 0, grown[2, 5], 1, 1, 1, 1, 1]


def _ink_off_outline(mask, ink):
    """Ink pixels of the mask whose centres the smoothed outer outline leaves out."""
    out = region_outline(mask)
    loop = out.points[out.loop == int(np.flatnonzero(~out.hole)[0])]
    ys, xs = np.nonzero(ink & mask)
    return int((~points_in_poly(np.column_stack([xs, ys]).astype(float), loop)).sum())


def test_paper_beside_a_crisp_stroke_keeps_its_ink_inside_the_outline():
    # a crisp (binary) stroke: the smoothed outline cuts its stair-steps' corners
    labels, ink, r = _ring_drawing(size=120, radius=41.3, width=3)
    grown = grow_over_ink(labels, ink)
    assert _ink_off_outline(grown == 0, ink) > 0
    padded = pad_ink_edge(grown, ink)
    assert _ink_off_outline(padded == 0, ink) == 0
    added = padded != grown
    assert (grown[added] == -1).all() and (padded[added] == 0).all()
    assert r[added].min() >= r[ink].max()  # one pixel of paper beyond the stroke
    assert r[added].max() <= r[ink].max() + 1.5


def test_padding_gives_no_part_pixel_to_another_and_keeps_narrow_gaps():
    labels = np.full((9, 16), -1)
    labels[:, :5], labels[:, 7:10] = 0, 1
    ink = np.zeros((9, 16), bool)
    ink[:, 4] = ink[:, 7] = ink[:, 9] = True
    padded = pad_ink_edge(labels, ink)
    inside = labels >= 0
    assert np.array_equal(padded[inside], labels[inside])
    # the 2 px gap between the parts stays paper; the open side of part 1 gets its pixel
    assert padded[4].tolist() == [0] * 5 + [-1, -1] + [1] * 4 + [-1] * 5
    with pytest.raises(InputError, match="shape"):
        pad_ink_edge(labels, ink[:3])


def test_stroke_width_ignores_blobs():
    ink = np.zeros((100, 100), bool)
    ink[:, 10:14] = ink[:, 30:34] = ink[:, 50:54] = True
    ink[80:90, 80:90] = True  # a small filled eye
    assert stroke_width(ink) == pytest.approx(4.0, abs=0.5)


def test_ink_threshold_and_bad_input():
    assert ink_pixels(np.array([0.49, 0.51])).tolist() == [True, False]
    with pytest.raises(InputError, match="shape"):
        grow_over_ink(np.zeros((3, 3), int), np.zeros((2, 3), bool))
    with pytest.raises(InputError, match="width"):
        grow_over_ink(np.zeros((3, 3), int), np.zeros((3, 3), bool), width=0)
