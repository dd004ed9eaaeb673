import numpy as np

from inkray.view.shading import encode_normals, height_normals, lambert


def test_normals_of_a_plane_match_its_gradient():
    y, x = np.mgrid[0:20, 0:30].astype(float)
    n = height_normals(0.5 * x - 0.25 * y)        # rows grow downward, y up in the normal
    expect = np.array([-0.5, -0.25, 1.0]) / np.linalg.norm([-0.5, -0.25, 1.0])
    assert np.allclose(n[10, 15], expect)
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0)


def test_encoding_is_symmetric_and_masked():
    n = np.array([[[1.0, -1.0, 0.0], [0.0, 0.0, 1.0]]])
    rgba = encode_normals(n, np.array([[True, False]]))
    assert rgba[0, 0].tolist() == [255, 0, 128, 255] and rgba[0, 1].tolist() == [0, 0, 0, 0]


def test_lambert_is_ambient_facing_away_and_one_facing_the_light():
    n = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    assert np.allclose(lambert(n, light=(0, 0, 2), ambient=0.2), [1.0, 0.2])
