import numpy as np

from inkray.numerics.polyline import arc_length, point_polyline_distance, resample_polyline


def test_resampled_points_keep_the_ends_and_lie_on_the_line():
    line = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 5.0]])
    pts = resample_polyline(line, 0.7)
    assert np.allclose(pts[0], line[0]) and np.allclose(pts[-1], line[-1])
    assert np.abs(point_polyline_distance(pts, line)).max() < 1e-12
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert steps.max() <= 0.7 + 1e-12 and np.isclose(arc_length(pts)[-1], 15.0, atol=0.3)


def test_distance_to_segments_and_to_a_single_point():
    line = np.array([[0.0, 0.0], [4.0, 0.0]])
    assert np.allclose(point_polyline_distance(np.array([[2.0, 3.0], [7.0, 4.0], [-1, 0]]), line),
                       [3.0, 5.0, 1.0])
    assert point_polyline_distance((3.0, 4.0), [[0.0, 0.0]]) == 5.0
