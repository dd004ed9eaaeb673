"""Region outlines: provenance, boundary snapping, station correspondences."""

from types import SimpleNamespace

import numpy as np
import pytest

from inkray.errors import InputError
from inkray.relief.outline import (FLAT, FRAME, INKED, INVENTED, STITCH, MeshOptions,
                                   check_boundaries, edge_length, region_outline)


def _entry(kind, path, index=0):
    return SimpleNamespace(type=kind, path=np.asarray(path, float), index=index)


def _disk(h, w, cx, cy, r):
    yy, xx = np.mgrid[:h, :w]
    return (xx - cx) ** 2 + (yy - cy) ** 2 <= r ** 2


def _area(p):
    return 0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])


def test_disk_outline_is_close_oriented_and_spaced():
    out = region_outline(_disk(300, 300, 150, 150, 100), options=MeshOptions(max_area=50.0))
    r = np.hypot(*(out.points - 150).T)
    assert np.abs(r - 100).max() < 0.75  # the raster itself is only good to 0.5 px
    assert list(out.hole) == [False]
    assert _area(out.points) < 0  # outer loops clockwise in (x, y), like relief faces
    edges = np.linalg.norm(np.diff(np.vstack([out.points, out.points[:1]]), axis=0), axis=1)
    assert edges.max() <= edge_length(50.0) + 1e-9
    assert np.all(out.kind == INKED) and np.all(out.neighbour == -1)


def test_holes_are_kept_with_a_seed_point_inside_them():
    mask = _disk(300, 300, 150, 150, 100) & ~_disk(300, 300, 150, 150, 40)
    out = region_outline(mask)
    assert sorted(out.hole) == [False, True]
    hole_loop = out.points[out.loop == int(np.flatnonzero(out.hole)[0])]
    assert _area(hole_loop) > 0
    (seed,) = out.hole_points
    assert np.hypot(*(seed - 150)) < 40


def test_speckles_are_dropped():
    mask = _disk(200, 200, 100, 100, 50)
    mask[5, 5] = True
    mask[100, 100] = False
    assert len(region_outline(mask).hole) == 1
    tiny = np.zeros((10, 10), bool)
    tiny[4:6, 4:6] = True  # a 4 px^2 region is still meshed, not lost
    out = region_outline(tiny)
    assert list(out.hole) == [False] and np.all(np.abs(out.points - 4.5) <= 1.0)


def test_frame_invented_and_neighbour_provenance():
    # Region 0: a disk cut by the left image frame and partly hidden by region 1.
    h, w = 240, 300
    labels = np.full((h, w), -1, np.int32)
    mask = _disk(h, w, 60, 120, 100)
    occluder = np.zeros((h, w), bool)
    occluder[100:140, 100:220] = True
    visible = mask & ~occluder
    labels[visible] = 0
    labels[occluder] = 1
    out = region_outline(mask, visible=visible, labels=labels, region=0, name="disk")
    p = out.points
    on_frame = p[:, 0] < -0.49
    assert on_frame.sum() >= 10 and np.all(out.kind[on_frame] == FRAME)
    under = (p[:, 1] > 104) & (p[:, 1] < 136) & (p[:, 0] > 140)
    assert under.sum() >= 2 and np.all(out.kind[under] == INVENTED)
    assert np.all(out.neighbour[under] == 1)
    free = (np.abs(p[:, 1] - 120) > 30) & ~on_frame
    assert np.all(out.kind[free] == INKED) and np.all(out.neighbour[free] == -1)


def test_marked_stretch_becomes_stations():
    mask = np.zeros((300, 300), bool)
    mask[50:250, 50:250] = True
    entry = _entry("flat", [[249.5, 60], [249.5, 240]], index=3)
    out = region_outline(mask, boundaries=[entry], options=MeshOptions(station_spacing=10.0))
    marked = out.boundary_index == 3
    assert out.matched == (3,)
    assert np.all(out.kind[marked] == FLAT)
    assert np.all(np.abs(out.points[marked, 0] - 249.5) < 0.3)
    # One vertex per station, nothing else on the stretch: 180 px / 10 px -> 19 stations.
    assert sorted(out.station[marked]) == list(range(19))
    order = out.station[marked].argsort()
    ys = out.points[marked][order, 1]
    assert np.all(np.diff(ys) > 0)  # numbered in the direction of the path
    assert abs(ys[0] - 60) < 0.5 and abs(ys[-1] - 240) < 0.5


def test_stitch_stations_coincide_on_both_regions():
    labels = np.full((200, 400), -1, np.int32)
    labels[40:160, 40:200] = 0
    labels[40:160, 200:360] = 1
    entry = _entry("stitch", [[199.5, 50], [199.4, 100], [199.6, 150]])
    a = region_outline(labels == 0, labels=labels, region=0, boundaries=[entry])
    b = region_outline(labels == 1, labels=labels, region=1, boundaries=[entry])
    sa = a.points[a.station >= 0][np.argsort(a.station[a.station >= 0])]
    sb = b.points[b.station >= 0][np.argsort(b.station[b.station >= 0])]
    assert len(sa) == len(sb) >= 5
    # Each region smooths the shared outline on its own: a few hundredths of a pixel apart.
    assert np.abs(sa - sb).max() < 0.05
    assert np.all(a.kind[a.station >= 0] == STITCH)
    assert np.all(a.neighbour[a.boundary_index == 0] == 1)
    assert np.all(b.neighbour[b.boundary_index == 0] == 0)


def test_far_boundary_entry_is_an_error_naming_it():
    mask = _disk(200, 200, 100, 100, 50)
    chord = _entry("graft", [[50, 100], [100, 50]], index=0)  # cuts across, far from most of the arc
    a = np.linspace(-np.pi / 2, 0, 12)
    onit = _entry("flat", np.stack([100 + 52 * np.cos(a), 100 + 52 * np.sin(a)], axis=1), index=1)
    far = _entry("stitch", [[10, 190], [40, 190]], index=2)
    out = region_outline(mask, boundaries=[onit, far])
    assert out.matched == (1,)
    with pytest.raises(InputError, match=r"^boundaries\[2\]: no region outline within 6 px"):
        check_boundaries([out], [onit, far])
    check_boundaries([out], [onit])
    assert region_outline(mask, boundaries=[chord]).matched == ()


def test_overlapping_entries_are_rejected():
    mask = np.zeros((200, 200), bool)
    mask[50:150, 50:150] = True
    a = _entry("flat", [[149.5, 60], [149.5, 120]], index=0)
    b = _entry("graft", [[149.5, 100], [149.5, 140]], index=1)
    with pytest.raises(InputError, match=r"boundaries\[1\].*boundaries\[0\]"):
        region_outline(mask, boundaries=[a, b])


@pytest.mark.parametrize("bad", [np.zeros((10, 10)), np.zeros((10, 10, 2), bool)])
def test_bad_masks(bad):
    with pytest.raises(InputError, match="^mask"):
        region_outline(bad)


def test_empty_mask_names_the_region():
    with pytest.raises(InputError, match="region leg: the mask is empty"):
        region_outline(np.zeros((10, 10), bool), name="leg")


def test_a_max_area_too_fine_for_the_drawing_is_refused_up_front():
    from inkray.relief.outline import MAX_TRIANGLES

    from inkray.relief.triangulation import mesh_region

    mask = _disk(1000, 1000, 500, 500, 400)
    with pytest.raises(InputError, match=r"^max_area: 0.001 px\^2 asks for up to 1e\+09 "
                                         r"triangles on a 1000x1000 drawing") as e:
        mesh_region(mask, options=MeshOptions(max_area=0.001))
    assert e.value.option == "max_area" and "expected at least 1" in str(e.value)
    with pytest.raises(InputError, match=r"on a region of \d+ px"):
        region_outline(mask, options=MeshOptions(max_area=0.001))
    fine = 1000 * 1000 / MAX_TRIANGLES  # the finest allowed is still meshed
    assert len(region_outline(_disk(100, 100, 50, 50, 30), options=MeshOptions(max_area=fine)).points)


def test_a_region_of_a_few_pixels_in_a_big_drawing_is_meshed():
    """A small region's own triangles are finer (area / min_triangles): the bound
    on their count is the region's, so a 2-pixel part of a 1 Mpx drawing meshes."""
    from inkray.relief.triangulation import mesh_region

    mask = np.zeros((1000, 1000), bool)
    mask[500, 500:502] = True
    mesh = mesh_region(mask, options=MeshOptions())
    assert len(mesh.faces) >= 1
