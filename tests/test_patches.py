"""Patches of a mesh re-triangulated: thin strips cut into ladders, the last slivers polished."""

import numpy as np

from inkray.numerics.tri_intersection import self_intersecting_faces
from inkray.relief.assembly import _closed_manifold, _SliverFix, _volume
from inkray.relief.patches import _simple, ladders, min_angles


def _column(width, height):
    """A closed box ``width`` x ``width`` x ``height``, two triangles a side (walls of
    needles, as the booleans leave a column where outlines nearly meet)."""
    v = np.array([[0, 0, 0], [width, 0, 0], [width, width, 0], [0, width, 0]], float)
    v = np.concatenate([v, v + [0.0, 0.0, height]])
    f = [[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7]]
    for a in range(4):
        b = (a + 1) % 4
        f += [[a, b, b + 4], [a, b + 4, a + 4]]
    return v, np.array(f, np.int64)


def test_a_column_under_a_pixel_across_is_cut_into_ladders():
    v, f = _column(0.5, 12.0)
    bad = min_angles(v, f) < 10.0
    assert bad.sum() == 8  # every wall face a needle (2.4 degrees)
    w, g = ladders(v, f, bad=bad, min_angle=10.0)
    assert _closed_manifold(g)
    # rungs at most four widths apart: every angle at least atan(1/4)
    assert min_angles(w, g).min() >= np.degrees(np.arctan(0.25)) - 1e-9
    assert np.allclose(_volume(w, g), _volume(v, f))
    np.testing.assert_array_equal(w[:len(v)], v)  # the new points lie on the vertical edges
    assert np.allclose(w[len(v):, :2] % 0.5, 0.0) and len(w) == len(v) + 4 * 5
    assert not self_intersecting_faces(w, g).any()
    assert len(g) == 4 + 4 * 2 * 6


def test_a_wide_column_or_good_faces_are_left_alone():
    v, f = _column(4.0, 12.0)
    bad = min_angles(v, f) < 10.0
    assert not bad.any()
    w, g = ladders(v, f, bad=bad, min_angle=10.0)
    assert w is v or np.array_equal(w, v)
    np.testing.assert_array_equal(g, f)


def test_a_polygon_with_collinear_edges_is_simple_unless_they_overlap():
    strip = np.array([[0, 0], [1, 0], [1, 1], [1, 2], [0, 2], [0, 1]], float)
    assert _simple(strip)
    folded = np.array([[0, 0], [2, 0], [2, 1], [1, 0], [1, 2], [0, 2]], float)
    assert not _simple(folded)


def test_polish_flips_the_edge_that_helps_when_the_longest_does_not():
    # the top of the donkey's column: a 9.5 degree face whose longest edge's flip is worse
    v = np.array([[-0.07, 0.96, -0.73], [-0.07, 0.75, 3.63], [-0.22, -1.9, -0.97],
                  [-0.08, -1.09, -1.27]])
    f = np.array([[3, 1, 2], [1, 3, 0]])
    assert min_angles(v, f).min() < 10.0
    w, g = _SliverFix(v, f).run(10.0)
    assert min_angles(w, g).min() < 10.0
    w, g = _SliverFix(v, f).polish(10.0)
    assert min_angles(w, g).min() >= 10.0
    np.testing.assert_array_equal(w, v)  # a flip: the same points
