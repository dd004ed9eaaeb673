"""Back plates and depth scaling: closed solids, order kept."""

from dataclasses import replace

import numpy as np
import pytest
import trimesh

from _reliefs import disk_relief, grid_part
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
        plate = part.vertices[len(before.vertices):, 2]
        assert np.ptp(plate) == 0.0 and plate[0] < before.vertices[:, 2].min()
    closed = disk_relief(closed=True)
    assert back_plate(closed).parts[0] is closed.parts[0]  # closed parts kept


def test_back_plates_sit_behind_their_own_part_stacked_never_coplanar():
    # the head stands 12 px up on the body; a small flat eye on the head, and a
    # second eye at the same height (their plates would coincide)
    relief = disk_relief(closed=False)
    eye = grid_part("eye", [110.0, 111.0, 112.0], [40.0, 41.0], z=40.0)
    twin = grid_part("twin", [120.0, 121.0, 122.0], [40.0, 41.0], z=40.0)
    relief = replace(relief, parts=[*relief.parts, eye, twin])
    plated = back_plate(relief)  # depth 1 px, step 0.25 px
    plates = [p.vertices[len(q.vertices):, 2] for p, q in zip(plated.parts, relief.parts)]
    lows = [q.vertices[:, 2].min() for q in relief.parts]
    tops = [q.vertices[:, 2].max() for q in relief.parts]
    z = np.array([plate[0] for plate in plates])
    assert all(np.ptp(plate) == 0.0 for plate in plates)
    # just behind its own lowest point (a small part is a thin solid, not a deep prism)
    assert (z < lows).all() and (z >= np.array(lows) - 1.0 - 0.25 * len(z)).all()
    assert tops[2] - z[2] <= 1.0 + 0.25 * len(z)
    # stacked as the parts are: the head (and the eyes on it) in front of the body
    assert z[1] > z[0] and z[2] > z[1] and z[3] > z[1]
    gaps = np.abs(z[:, None] - z[None, :])[~np.eye(len(z), dtype=bool)]
    assert gaps.min() >= 0.25 - 1e-12  # no two backs in one plane
    for part in plated.parts:
        m = _solid(part)
        assert m.is_watertight and m.is_winding_consistent and m.volume > 0
    with pytest.raises(InputError, match="positive"):
        back_plate(relief, depth=0.0)


def test_depth_scale_keeps_every_order_and_rejects_nonsense():
    relief = disk_relief(closed=False)
    half = depth_scaled(relief, 0.5)
    for a, b in zip(relief.parts, half.parts):
        np.testing.assert_allclose(b.vertices[:, :2], a.vertices[:, :2])
        np.testing.assert_allclose(b.vertices[:, 2], a.vertices[:, 2] * 0.5)
    for bad in (0, -1, np.nan, 11):
        with pytest.raises(InputError, match="depth scale"):
            depth_scaled(relief, bad)
