"""Back plates and depth scaling: closed solids, order kept."""

import numpy as np
import pytest
import trimesh

from _reliefs import disk_relief
from inkray.errors import InputError
from inkray.relief.backing import back_plate, depth_scaled


def _solid(part):
    return trimesh.Trimesh(part.vertices * [1, -1, 1], part.faces, process=False)  # scene frame


def test_back_plate_closes_every_open_part_outward():
    relief = disk_relief(closed=False)
    plated = back_plate(relief)
    low = min(p.vertices[:, 2].min() for p in relief.parts)
    for before, part in zip(relief.parts, plated.parts):
        m = _solid(part)
        assert part.closed and m.is_watertight and m.is_winding_consistent and m.volume > 0
        np.testing.assert_array_equal(part.vertices[: len(before.vertices)], before.vertices)
        assert np.allclose(part.vertices[len(before.vertices):, 2], low - 1.0)
    closed = disk_relief(closed=True)
    assert back_plate(closed).parts[0] is closed.parts[0]  # closed parts kept


def test_depth_scale_keeps_every_order_and_rejects_nonsense():
    relief = disk_relief(closed=False)
    half = depth_scaled(relief, 0.5)
    for a, b in zip(relief.parts, half.parts):
        np.testing.assert_allclose(b.vertices[:, :2], a.vertices[:, :2])
        np.testing.assert_allclose(b.vertices[:, 2], a.vertices[:, 2] * 0.5)
    for bad in (0, -1, np.nan, 11):
        with pytest.raises(InputError, match="depth scale"):
            depth_scaled(relief, bad)
