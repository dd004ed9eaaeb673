"""Exact self-intersection test of triangle meshes."""

import numpy as np
import pytest

from inkray.numerics.tri_intersection import crossing_faces, self_intersecting_faces


def _pair(p, q):
    return np.array(p + q, float), np.array([[0, 1, 2], [3, 4, 5]])


def test_crossing_and_apart_pairs():
    flat = [[0, 0, 0], [2, 0, 0], [0, 2, 0]]
    v, f = _pair(flat, [[0.5, 0.5, -1], [0.5, 0.5, 1], [3, 3, 1]])  # pierces the flat one
    assert self_intersecting_faces(v, f).tolist() == [True, True]
    v, f = _pair(flat, [[0.5, 0.5, 0.1], [1.5, 0.5, 1], [0.5, 1.5, 1]])  # hovers above it
    assert self_intersecting_faces(v, f).tolist() == [False, False]


@pytest.mark.parametrize("offset", [0.0, 250.0, 1e4])
def test_near_disjoint_pair_far_from_the_origin(offset):
    # two triangles of one sheet 0.05 apart in the plane: disjoint wherever they lie
    v, f = _pair([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1.05, 0.05, 0.0], [1.05, 1, 0], [0.1, 1, 0]])
    assert not self_intersecting_faces(v + offset, f).any()
    v[3:, :2] -= 0.1  # now they overlap
    assert self_intersecting_faces(v + offset, f).all()


def test_shared_corner_counts_only_a_fold():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [1, 0.2, 0]], float)
    beside = np.array([[0, 1, 2], [0, 3, 4]])  # meet only at vertex 0
    folded = np.array([[0, 1, 2], [0, 5, 4]])  # the second lies over the first
    assert not self_intersecting_faces(v, beside).any()
    assert self_intersecting_faces(v, folded).all()


def test_matches_libigl_on_a_random_soup():
    igl = pytest.importorskip("igl")
    rng = np.random.default_rng(3)
    centres = rng.uniform(0, 6, (60, 1, 3))
    tris = centres + rng.normal(0, 1, (60, 3, 3))
    v, f = tris.reshape(-1, 3), np.arange(180).reshape(-1, 3)
    expected = np.zeros(60, bool)
    for i in range(60):
        for j in range(i + 1, 60):
            args = [x.reshape(1, 3).copy() for x in (*tris[i], *tris[j])]
            if igl.tri_tri_intersection_test_3d(*args)[0]:
                expected[[i, j]] = True
    assert 0 < expected.sum() < 60
    assert self_intersecting_faces(v, f).tolist() == expected.tolist()


def test_faces_touching_within_a_rounding_cross_once_stored_as_float32():
    # a corner 1e-9 short of the other triangle's plane, at coordinates near 1e3: apart
    # in double precision, on or through the plane once rounded to float32 (2^-24 of it)
    v = np.array([[1000.0, 1000.0, 1000.0], [1002.0, 1000.0, 1000.0], [1000.0, 1002.0, 1000.0],
                  [1000.5, 1000.5, 1000.0 - 1e-9], [1000.5, 1000.5, 999.0], [1001.0, 1000.5, 999.0]])
    f = np.array([[0, 1, 2], [3, 4, 5]])
    assert not self_intersecting_faces(v, f).any()
    assert self_intersecting_faces(v, f, float32_scales=(1.0,)).all()
    rounded = (v * 1.0).astype(np.float32).astype(float)
    assert self_intersecting_faces(rounded, f).all()  # the same as testing the rounded copy


def _soup(count=80, seed=5):
    rng = np.random.default_rng(seed)
    tris = rng.uniform(0, 8, (count, 1, 3)) + rng.normal(0, 1, (count, 3, 3))
    return tris.reshape(-1, 3), np.arange(3 * count).reshape(-1, 3)


def test_crossing_faces_rows_are_the_precisions_apart():
    v, f = _soup()
    v = v + 1000.0  # where a float32 rounding is 6e-5
    rows = crossing_faces(v, f, float32_scales=(1.0, 0.001))
    assert rows.shape == (3, len(f))
    assert rows[0].tolist() == self_intersecting_faces(v, f).tolist()
    assert rows.any(axis=0).tolist() == self_intersecting_faces(
        v, f, float32_scales=(1.0, 0.001)).tolist()
    rounded = (v * 0.001).astype(np.float32).astype(float)
    assert rows[2].tolist() == self_intersecting_faces(rounded, f).tolist()


def test_crossing_faces_among_tests_only_pairs_with_one_of_them():
    v, f = _soup()
    full = crossing_faces(v, f)[0]
    assert 0 < full.sum() < len(f)
    among = np.zeros(len(f), bool)
    among[::3] = True
    part = crossing_faces(v, f, among=among)[0]
    assert part[among].tolist() == full[among].tolist()  # exact for those faces
    assert not (part & ~full).any()  # the others only where they cross one of them
    t = v[f]
    lo, hi = t.min(axis=1), t.max(axis=1)
    touching = ((lo[:, None] <= hi[among][None]).all(axis=2)
                & (hi[:, None] >= lo[among][None]).all(axis=2)).any(axis=1)
    assert not (part & ~among & ~touching).any()
    assert crossing_faces(v, f, among=np.ones(len(f), bool))[0].tolist() == full.tolist()
    assert not crossing_faces(v, f, among=np.zeros(len(f), bool)).any()
