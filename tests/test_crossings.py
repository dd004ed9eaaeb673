"""Crossings of two sets of segments."""

import numpy as np

from inkray.numerics.crossings import segment_crossings


def _brute(a, b):
    out = []
    for i, (p, p1) in enumerate(a):
        for j, (q, q1) in enumerate(b):
            r, s = p1 - p, q1 - q
            den = r[0] * s[1] - r[1] * s[0]
            if abs(den) < 1e-12:
                continue
            t = ((q - p)[0] * s[1] - (q - p)[1] * s[0]) / den
            u = ((q - p)[0] * r[1] - (q - p)[1] * r[0]) / den
            if 0 <= t <= 1 and 0 <= u <= 1:
                out.append(p + t * r)
    return np.array(out).reshape(-1, 2)


def test_crossings_match_every_pair_checked():
    rng = np.random.default_rng(3)
    a = rng.uniform(0, 50, (300, 1, 2)) + rng.uniform(-4, 4, (300, 2, 2))
    b = rng.uniform(0, 50, (200, 1, 2)) + rng.uniform(-9, 9, (200, 2, 2))
    got = segment_crossings(a, b)
    want = _brute(a, b)
    assert len(want) > 50
    np.testing.assert_allclose(got, want, atol=1e-9)  # the same order: by a, then b


def test_touching_ends_count_and_parallel_segments_do_not():
    a = np.array([[[0.0, 0.0], [1.0, 0.0]], [[0.0, 1.0], [1.0, 1.0]]])
    b = np.array([[[1.0, 0.0], [1.0, -1.0]], [[0.0, 2.0], [1.0, 2.0]]])
    assert segment_crossings(a, b).tolist() == [[1.0, 0.0]]
    assert segment_crossings(a, np.zeros((0, 2, 2))).shape == (0, 2)
