import numpy as np
import pytest
import triangle

from inkray.errors import InputError
from inkray.view.rasterization import fit_view, rasterize
from inkray.relief.model import Part, Relief


def _orient(v, f):
    """Faces counter-clockwise for the viewer: clockwise in (x, y) with y down."""
    a = v[f[:, 1], :2] - v[f[:, 0], :2]
    b = v[f[:, 2], :2] - v[f[:, 0], :2]
    ccw = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] > 0
    f = f.copy()
    f[ccw] = f[ccw][:, [0, 2, 1]]
    return f


def _polygon_part(name, outline, height, max_area=4.0):
    """A heightfield z = height(x, y) over a polygon, triangulated with `triangle`."""
    n = len(outline)
    seg = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    t = triangle.triangulate({"vertices": np.asarray(outline, float), "segments": seg},
                             f"pq30a{max_area}")
    xy = t["vertices"]
    v = np.column_stack([xy, height(xy[:, 0], xy[:, 1])])
    return Part(name, v, _orient(v, t["triangles"].astype(np.int64)))


def _disk(cx, cy, r, n=96):
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.stack([cx + r * np.cos(a), cy + r * np.sin(a)], axis=1)


def _square(x0, y0, x1, y1):
    """Pixel centres are integers: pixels x0..x1 - 1 span [x0 - 0.5, x1 - 0.5]."""
    x0, y0, x1, y1 = x0 - 0.5, y0 - 0.5, x1 - 0.5, y1 - 0.5
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def test_flat_square_covers_its_pixels_with_its_depth_normal_and_uv():
    part = _polygon_part("sq", _square(10, 5, 30, 25), lambda x, y: np.full_like(x, 7.0))
    r = rasterize(Relief([part], size=(40, 32)))
    assert r.part.shape == (32, 40)
    inside = np.zeros((32, 40), bool)
    inside[5:25, 10:30] = True  # pixel centres (integers) strictly inside the square
    assert np.array_equal(r.mask, inside)
    assert np.allclose(r.depth[inside], 7.0)
    assert np.all(np.isneginf(r.depth[~inside]))
    assert np.allclose(r.normal[inside], [0, 0, 1])
    rows, cols = np.nonzero(inside)
    assert np.allclose(r.uv[inside], np.stack([(cols + 0.5) / 40, 1 - (rows + 0.5) / 32], 1))
    assert np.all(r.face[inside] >= 0) and np.all(r.face[~inside] == -1)


def test_tilted_plane_depth_and_normal_match_the_closed_form():
    a, b, c = 0.3, -0.2, 4.0
    part = _polygon_part("plane", _disk(30, 30, 25, 40), lambda x, y: a * x + b * y + c)
    r = rasterize(Relief([part], size=(60, 60)))
    rows, cols = np.nonzero(r.mask)
    x, y = cols, rows  # pixel centres are integers
    assert r.mask.sum() > 0.9 * np.pi * 25 ** 2
    assert np.allclose(r.depth[r.mask], a * x + b * y + c, atol=1e-9)
    expected = np.array([-a, -b, 1.0]) / np.linalg.norm([-a, -b, 1.0])
    assert np.allclose(r.normal[r.mask], expected, atol=1e-9)


def test_barycentrics_reproduce_the_pixel_centre():
    part = _polygon_part("plane", _disk(20, 20, 15, 30), lambda x, y: x * 0.1)
    r = rasterize(Relief([part], size=(40, 40)))
    m = r.mask
    b = r.bary[m]
    assert np.all(b >= -1e-9) and np.allclose(b.sum(axis=1), 1)
    corners = part.vertices[part.faces[r.face[m]]]
    p = np.einsum("nk,nkc->nc", b, corners)
    rows, cols = np.nonzero(m)
    assert np.allclose(p[:, :2], np.stack([cols, rows], 1))
    assert np.allclose(p, r.position[m])


def test_sphere_cap_normals_point_away_from_the_centre():
    R, cx, cy = 40.0, 50.0, 50.0
    def cap(x, y):
        return np.sqrt(np.maximum(R ** 2 - (x - cx) ** 2 - (y - cy) ** 2, 0))

    part = _polygon_part("ball", _disk(cx, cy, R, 160), cap, max_area=2.0)
    r = rasterize(Relief([part], size=(100, 100)))
    rows, cols = np.nonzero(r.mask)
    x, y = cols - cx, rows - cy
    core = np.hypot(x, y) < 0.8 * R
    expected = np.stack([x, y, np.sqrt(R ** 2 - x ** 2 - y ** 2)], 1)[core] / R
    angle = np.degrees(np.arccos(np.clip(np.sum(r.normal[r.mask][core] * expected, 1), -1, 1)))
    assert angle.max() < 3.0
    assert np.allclose(np.linalg.norm(r.normal[r.mask], axis=1), 1)
    # depth of the sphere within the facet error of the triangulation
    assert np.abs(r.depth[r.mask][core] - expected[:, 2] * R).max() < 0.5


def test_the_part_in_front_wins_where_parts_overlap():
    back = _polygon_part("back", _square(0, 0, 40, 40), lambda x, y: np.zeros_like(x))
    front = _polygon_part("front", _disk(20, 20, 10), lambda x, y: np.full_like(x, 5.0))
    # listed first so that drawing order cannot be what decides
    r = rasterize(Relief([front, back], size=(40, 40)))
    rows, cols = np.mgrid[0:40, 0:40]
    near = np.hypot(cols - 20, rows - 20)
    assert np.all(r.part[near < 9.5] == 0) and np.allclose(r.depth[near < 9.5], 5)
    assert np.all(r.part[near > 10.5] == 1) and np.allclose(r.depth[near > 10.5], 0)


def test_scale_and_size_resample_the_silhouette():
    part = _polygon_part("sq", _square(4, 4, 16, 12), lambda x, y: np.ones_like(x))
    relief = Relief([part], size=(20, 16))
    r2 = rasterize(relief, scale=2)
    assert r2.part.shape == (32, 40) and r2.mask.sum() == 4 * 12 * 8
    # a square image: the drawing is fitted and centred
    r = rasterize(relief, size=(40, 40))
    assert (r.scale, r.offset) == fit_view((20, 16), (40, 40)) == (2.0, (0.0, 4.0))
    rows, cols = np.nonzero(r.mask)
    assert (rows.min(), rows.max(), cols.min(), cols.max()) == (12, 27, 8, 31)


def test_a_shear_view_moves_pixels_in_proportion_to_depth():
    flat = _polygon_part("low", _square(5, 5, 15, 15), lambda x, y: np.zeros_like(x))
    high = _polygon_part("high", _square(25, 5, 35, 15), lambda x, y: np.full_like(x, 10.0))
    relief = Relief([flat, high], size=(40, 20))
    view = np.eye(3, 4)
    view[0, 2] = 0.3  # x += 0.3 z
    r0, r1 = rasterize(relief), rasterize(relief, view=view)
    for i, shift in ((0, 0), (1, 3)):
        c0, c1 = np.nonzero(r0.part == i)[1], np.nonzero(r1.part == i)[1]
        assert c1.min() - c0.min() == shift and c1.max() - c0.max() == shift
    # normals are the relief's, not the view's
    assert np.allclose(r1.normal[r1.mask], [0, 0, 1])


def test_a_rotated_view_sees_a_side_of_a_step():
    low = _polygon_part("low", _square(0, 0, 20, 20), lambda x, y: np.zeros_like(x))
    high = _polygon_part("high", _square(8, 0, 12, 20), lambda x, y: np.full_like(x, 6.0))
    relief = Relief([low, high], size=(20, 20))
    a = np.radians(30)
    rot = np.array([[np.cos(a), 0, -np.sin(a), 0], [0, 1, 0, 0], [np.sin(a), 0, np.cos(a), 0]])
    r = rasterize(relief, view=rot)
    # the raised strip now projects 6*sin(30°) = 3 px to the left of where it was: its
    # edges x0, x1 land at x cos(a) - 3, and column j (centre at j) is covered when
    # its centre lies strictly between them
    x0, x1 = 8 - 0.5, 12 - 0.5  # the strip's edges (see _square)
    cols = np.nonzero(r.part == 1)[1]
    assert cols.min() == np.floor(x0 * np.cos(a) - 3) + 1
    assert cols.max() == np.ceil(x1 * np.cos(a) - 3) - 1


def test_empty_relief_gives_an_empty_raster():
    r = rasterize(Relief([], size=(5, 4)))
    assert r.part.shape == (4, 5) and not r.mask.any()


@pytest.mark.parametrize("kwargs, match", [
    (dict(size=(0, 4)), "output size"),
    (dict(scale=-1), "scale"),
    (dict(view=np.eye(3)), "view"),
])
def test_bad_arguments_raise_input_error(kwargs, match):
    part = Part("p", np.zeros((3, 3)), np.array([[0, 1, 2]]))
    with pytest.raises(InputError, match=match):
        rasterize(Relief([part], size=(5, 4)), **kwargs)


def test_bad_faces_name_the_part():
    part = Part("arm", np.zeros((3, 3)), np.array([[0, 1, 3]]))
    with pytest.raises(InputError, match=r"parts\[0\] \(arm\).*out of range"):
        rasterize(Relief([part], size=(5, 4)))


def test_a_million_pixels_rasterize_in_seconds():
    import time

    n = 300
    g = np.linspace(0, 1000, n)
    X, Y = np.meshgrid(g, g)
    v = np.stack([X.ravel(), Y.ravel(), 30 * np.sin(X.ravel() / 100)], 1)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1))
    a = (j * n + i).ravel()
    f = np.concatenate([np.stack([a, a + n, a + n + 1], 1), np.stack([a, a + n + 1, a + 1], 1)])
    t = time.perf_counter()
    r = rasterize(Relief([Part("hf", v, f)], size=(1000, 1000)))
    assert time.perf_counter() - t < 20  # generous: shared CI cores (about 1.5 s when idle)
    assert r.mask.all() and r.normal[..., 2].min() > 0
