"""Back sheets, back plates and depth scaling: closed solids, order kept."""

from dataclasses import replace

import numpy as np
import pytest
import trimesh

from _reliefs import disk_relief, grid_part
from inkray.errors import InputError
from inkray.relief.backing import back_plate, back_sheet, depth_scaled
from inkray.relief.model import Relief


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


def test_back_sheet_is_a_thin_closed_copy_behind_the_front():
    relief = disk_relief(closed=False)
    sheet = back_sheet(relief, gap=0.5)
    for before, part in zip(relief.parts, sheet.parts):
        n, m = len(before.vertices), len(before.faces)
        np.testing.assert_array_equal(part.vertices[:n], before.vertices)  # the front as it was
        np.testing.assert_array_equal(part.faces[:m], before.faces)
        # the back: every front vertex exactly the gap behind, faces reversed
        np.testing.assert_array_equal(part.vertices[n:], before.vertices - [0, 0, 0.5])
        np.testing.assert_array_equal(part.faces[m:2 * m], before.faces[:, ::-1] + n)
        mesh = _solid(part)
        assert part.closed and mesh.is_watertight and mesh.is_winding_consistent
        # thin: its volume the front's projected area times the gap
        projected = trimesh.Trimesh(np.column_stack([before.vertices[:, :2], np.zeros(n)]),
                                    before.faces, process=False).area
        np.testing.assert_allclose(mesh.volume, projected * 0.5, rtol=1e-9)
    closed = disk_relief(closed=True)
    assert back_sheet(closed).parts[0] is closed.parts[0]  # closed parts kept
    for bad in (0.0, -1.0, np.nan):
        with pytest.raises(InputError, match="positive"):
            back_sheet(relief, gap=bad)


def test_backs_keep_a_posed_parts_texture_coordinates():
    part = grid_part("a", [2.0, 3.0, 4.0], [5.0, 6.0], z=1.0)
    part = replace(part, vertices=part.vertices + [10, 0, 0], texcoords=part.vertices[:, :2])
    for backed in (back_sheet, back_plate):
        out = backed(Relief([part], (40, 20))).parts[0]
        np.testing.assert_array_equal(out.texcoords, np.concatenate([part.texcoords] * 2))
