import numpy as np
import pytest

from inkray.errors import InputError
from inkray.view.ambient_occlusion import ambient_occlusion


def test_a_flat_field_is_fully_lit():
    assert np.array_equal(ambient_occlusion(np.full((20, 30), 3.0), radius=5), np.ones((20, 30)))


def test_the_foot_of_a_wall_is_darker_than_the_open_floor_and_the_top():
    h = np.zeros((40, 60))
    h[:, 30:] = 10.0
    ao = ambient_occlusion(h, radius=8)
    assert ao[20, 29] < 0.8                       # the crease
    assert ao[20, 29] < ao[20, 25] < ao[20, 10]   # darker the closer to the wall
    assert ao[20, 10] == 1.0 and ao[20, 45] == 1.0


def test_a_pit_is_darker_than_a_wide_valley():
    y, x = np.mgrid[0:41, 0:41] - 20.0
    cone = np.hypot(x, y)
    narrow = ambient_occlusion(cone * 2.0, radius=10)[20, 20]
    wide = ambient_occlusion(cone * 0.2, radius=10)[20, 20]
    assert narrow < wide < 1.0


def test_outside_the_mask_is_lit_and_the_ground_occludes_nothing():
    h = np.full((10, 10), 5.0)
    mask = np.zeros((10, 10), bool)
    mask[3:7, 3:7] = True
    ao = ambient_occlusion(h, mask=mask, radius=4)
    assert np.all(ao == 1.0)


def test_bad_input_is_rejected():
    with pytest.raises(InputError, match="radius"):
        ambient_occlusion(np.zeros((4, 4)), radius=0.5)
    with pytest.raises(InputError, match="mask"):
        ambient_occlusion(np.zeros((4, 4)), mask=np.ones((3, 3), bool))
    with pytest.raises(InputError, match="height"):
        ambient_occlusion(np.full((4, 4), np.nan))


def test_a_tilted_plane_occludes_nothing_but_a_step_on_it_does():
    y, x = np.mgrid[0:40, 0:60].astype(float)
    plane = 0.8 * x + 0.3 * y
    ao = ambient_occlusion(plane, radius=8)
    assert np.allclose(ao[8:-8, 8:-8], 1.0)
    stepped = plane + np.where(x >= 30, 10.0, 0.0)
    assert ambient_occlusion(stepped, radius=8)[20, 29] < 0.8


def test_a_huge_radius_costs_no_more_than_the_image():
    import tracemalloc

    h = np.zeros((40, 50))
    h[15:25, 20:30] = 5.0
    tracemalloc.start()
    ao = ambient_occlusion(h, radius=1e6, directions=8, steps=4)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 200 * h.size * 8  # the padding is bounded by the image, not the radius
    assert ao.shape == h.shape and ((ao >= 0) & (ao <= 1)).all()
    with pytest.raises(InputError, match="radius"):
        ambient_occlusion(h, radius=1e9)
