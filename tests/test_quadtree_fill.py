"""The quadtree fill: closed forms its blocks hold exactly, areas closed by ink, and its
distance from the exact harmonic fill on a drawing with gappy outlines."""

import numpy as np
import pytest
from scipy import ndimage

from inkray.errors import InputError
from inkray.numerics.grid import edge_weights
from inkray.numerics.harmonic_fill import HarmonicFill, settle
from inkray.numerics.quadtree_fill import quadtree_blocks, quadtree_fill


def _uniform(h, w):
    return np.ones((h, w - 1)), np.ones((h - 1, w))


def _unknowns(wx, wy, known):
    """How many pixels the blocks cover (the reduction is real)."""
    _, _, s = quadtree_blocks(wx, wy, known)
    return int((s ** 2).sum())


def test_a_ramp_between_two_fixed_columns_is_exact():
    h, w = 150, 260
    wx, wy = _uniform(h, w)
    known = np.zeros((h, w), bool)
    known[:, [0, -1]] = True
    ramp = np.tile(np.linspace(-3.0, 5.0, w), (h, 1))
    d = quadtree_fill(wx, wy, known, np.where(known, ramp, 0.0))
    assert np.abs(d - ramp).max() < 1e-9
    assert _unknowns(wx, wy, known) > 0.8 * h * w


def test_a_bilinear_field_on_a_frame_is_exact():
    # x * y is discretely harmonic, and bilinear in every block.
    h, w = 131, 170
    wx, wy = _uniform(h, w)
    yy, xx = np.mgrid[0:h, 0:w]
    field = (xx - 40.0) * (yy - 70.0) / 1000.0
    known = np.ones((h, w), bool)
    known[1:-1, 1:-1] = False
    d = quadtree_fill(wx, wy, known, np.where(known, field, 0.0))
    assert np.abs(d - field).max() < 1e-9


def _drawing(h=256, w=320, gap=0):
    """Paper with an ink box (a gap of ``gap`` px in its left side) and an ink line;
    one pixel fixed inside the box at 3, the right column at 0, the left at 1."""
    gray = np.ones((h, w))
    gray[60:200, 80:84] = gray[60:200, 220:224] = 0.0
    gray[60:64, 80:224] = gray[196:200, 80:224] = 0.0
    gray[20:240, 270:272] = 0.05
    if gap:
        gray[120:120 + gap, 80:84] = 1.0
    rng = np.random.default_rng(7)
    gray = np.clip(gray + rng.normal(0.0, 0.02, gray.shape), 0.0, 1.0)  # paper texture
    fixed = np.zeros((h, w), bool)
    values = np.zeros((h, w))
    fixed[130, 150] = True
    values[130, 150] = 3.0
    fixed[:, -1] = fixed[:, 0] = True
    values[:, 0] = 1.0
    return gray, fixed, values


@pytest.mark.parametrize("gap", [0, 3])
def test_an_area_closed_by_ink_keeps_its_level(gap):
    gray, fixed, values = _drawing(gap=gap)
    wx, wy, _ = edge_weights(gray)
    exact = HarmonicFill(wx, wy, incremental=False).solve(fixed, values)
    out, free = settle(fixed, values)
    d = quadtree_fill(wx, wy, ~free, out)
    # The fixed values are 1 apart at least: a small fraction of that step.
    err = np.abs(d - exact)
    assert err.max() < 0.02 and err[free].mean() < 2e-3
    inside = np.zeros(gray.shape, bool)
    inside[70:190, 90:214] = True
    if not gap:  # the box's inside hangs on couplings of 1e-5 and stays near 3
        assert np.abs(d[inside] - 3.0).max() < 0.05
    assert _unknowns(wx, wy, ~free) > 0.5 * gray.size
    assert np.array_equal(d[fixed], values[fixed])


def test_blocks_keep_away_from_ink_and_known_pixels_and_do_not_overlap():
    gray, fixed, _ = _drawing(gap=3)
    wx, wy, _ = edge_weights(gray)
    band = 2
    r0, c0, s = quadtree_blocks(wx, wy, fixed, band=band, max_block=32)
    assert s.max() == 32 and s.min() >= 2
    cover = np.zeros(gray.shape, int)
    for r, c, k in zip(r0, c0, s):
        cover[r:r + k, c:c + k] += 1
    assert cover.max() == 1
    detail = fixed | (ndimage.minimum_filter(gray, 3) < 0.5)
    near = ndimage.binary_dilation(detail, np.ones((3, 3), bool), iterations=band)
    assert not (near & (cover > 0)).any()
    # Larger blocks lie farther from the details.
    dist = ndimage.distance_transform_cdt(~detail, metric="chessboard")
    for r, c, k in zip(r0, c0, s):
        assert dist[r:r + k, c:c + k].min() > band + k // 2 - 1


def test_bad_input_is_refused():
    wx, wy = _uniform(8, 9)
    known = np.zeros((8, 9), bool)
    with pytest.raises(InputError, match="at least one known pixel"):
        quadtree_fill(wx, wy, known, np.zeros((8, 9)))
    known[0, 0] = True
    with pytest.raises(InputError, match="expected shape"):
        quadtree_fill(wx, wy, known[:, :-1], np.zeros((8, 8)))
    with pytest.raises(InputError, match="power of two"):
        quadtree_fill(wx, wy, known, np.zeros((8, 9)), max_block=48)
    with pytest.raises(InputError, match="positive"):
        quadtree_fill(-wx, wy, known, np.zeros((8, 9)))
