"""Assembly: open reliefs, closed solids, the manifold3d union."""

import manifold3d as m3d
import numpy as np
import pytest
import triangle
import trimesh
from scipy.spatial import cKDTree

from inkray.input.annotations import parse_annotations
from _reliefs import disk_part
from inkray.numerics.arap import signed_areas
from inkray.numerics.tri_intersection import self_intersecting_faces
from inkray.relief.assembly import (MIN_ANGLE, _WALL_REACH, _boundary_edges, _closed_manifold,
                                    _envelope_solid, _paired, _position_ids, _sheets,
                                    _stitched, _uncrowded, _unwalled,
                                    _min_angles, _skirted, _untangle, assemble, close_part, remesh_solid,
                                    shell_parts, union_parts)
from inkray.relief.completion import complete_regions
from inkray.errors import StageError
from inkray.formats.mesh_report import mesh_quality
from inkray.relief.inflation import inflate_region
from inkray.relief.ordering import depth_order
from inkray.relief.patches import repair_patches
from inkray.relief.model import Part
from inkray.relief.stitching import stitch
from inkray.input.constraints import constraints


def _scene(profile_b="sqrt"):
    """A disk body, a limb grafted on it, a flat badge on the body; and the image frame
    cuts the limb (a Neumann stretch of outline)."""
    h, w = 200, 300
    yy, xx = np.mgrid[:h, :w]
    body = (xx - 110) ** 2 + (yy - 100) ** 2 <= 80 ** 2
    limb = (xx >= 140) & (np.abs(yy - 100) <= 22)  # runs into the right frame edge
    badge = (xx - 90) ** 2 + (yy - 70) ** 2 <= 15 ** 2
    labels = np.full((h, w), -1, np.int32)
    labels[body] = 0
    labels[limb] = 1
    labels[badge] = 2
    ann = parse_annotations({
        "format": "inkray-annotations", "version": 1, "size": [w, h],
        "regions": [{"name": "body", "scribbles": [[[60, 120]]]},
                    {"name": "limb", "scribbles": [[[250, 100]]]},
                    {"name": "badge", "scribbles": [[[90, 70]]], "profile": profile_b}],
        "order": [{"front": [200, 100], "back": [120, 150]}, {"front": [90, 70], "back": [90, 95]}],
        "boundaries": [{"type": "graft", "path": [[139.5, 80], [139.5, 120]]}]})
    c = complete_regions(labels, names=[r.name for r in ann.regions])
    relations, _ = depth_order(constraints(ann), labels, c, seams=ann.boundaries)
    c = c.ordered(relations)
    inflated = [inflate_region(c.completed(i), visible=c.visible(i), labels=labels, region=i,
                               name=r.name, boundaries=ann.boundaries, profile=r.profile)
                for i, r in enumerate(ann.regions)]
    return stitch(inflated, relations, c, seams=ann.boundaries), labels


@pytest.fixture(scope="module")
def scene():
    return _scene(profile_b="flat")


def test_open_relief_parts_follow_the_regions(scene):
    layers, labels = scene
    relief = assemble(layers, size=(300, 200))
    assert [p.name for p in relief.parts] == ["body", "limb", "badge"]
    assert min(p.vertices[:, 2].min() for p in relief.parts) == pytest.approx(0.0)
    for i, p in enumerate(relief.parts):
        np.testing.assert_allclose(p.vertices[:, 2] - p.vertices[:, 2].min(),
                                   layers.z(i) - layers.z(i).min(), atol=1e-9)
        mesh = trimesh.Trimesh(p.vertices * [1, -1, 1], p.faces, process=False)
        # faces toward the viewer: in the y-up frame every normal has +z
        assert (mesh.face_normals[:, 2] > 0).mean() > 0.99
        assert not p.closed


def test_closed_parts_are_valid_solids(scene):
    layers, _ = scene
    relief = assemble(layers, size=(300, 200), closed=True)
    for p in relief.parts:
        assert p.closed
        mesh = trimesh.Trimesh(p.vertices * [1, -1, 1], p.faces, process=True)
        assert mesh.is_watertight, p.name
        assert mesh.is_winding_consistent, p.name
        assert mesh.is_volume and mesh.volume > 0, p.name
        solid = m3d.Manifold(m3d.Mesh(vert_properties=np.asarray(mesh.vertices, np.float32),
                                      tri_verts=np.asarray(mesh.faces, np.uint32)))
        assert solid.status() == m3d.Error.NoError, p.name
    # the flat badge is a slab of thickness epsilon, not a zero-volume sheet
    badge = relief.parts[2]
    z = badge.vertices[:, 2]
    assert np.ptp(z) == pytest.approx(layers.epsilon + np.ptp(layers.offset[2]), rel=1e-6)
    assert np.ptp(layers.offset[2]) < 0.01


def test_union_is_one_watertight_solid(scene):
    layers, _ = scene
    relief = assemble(layers, size=(300, 200), closed=True, union=True)
    assert [p.name for p in relief.parts] == ["union"]
    mesh = trimesh.Trimesh(relief.parts[0].vertices * [1, -1, 1], relief.parts[0].faces)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    # no two vertices at one position (other tools weld those into non-manifold edges)
    assert len(np.unique(relief.parts[0].vertices, axis=0)) == len(relief.parts[0].vertices)
    parts = assemble(layers, size=(300, 200), closed=True).parts
    volumes = [trimesh.Trimesh(p.vertices * [1, -1, 1], p.faces).volume for p in parts]
    assert mesh.volume >= max(volumes)
    assert len(mesh.split(only_watertight=False)) == 1 and not relief.warnings
    # the height field before remeshing has slivers (the steps where an outline crosses
    # another part); the remeshed solid none, and the same volume
    raw = union_parts(parts, remesh=False)
    before = _min_angles(raw.vertices, raw.faces)
    assert before.min() < 1.0
    assert _min_angles(relief.parts[0].vertices, relief.parts[0].faces).min() >= MIN_ANGLE
    raw_volume = trimesh.Trimesh(raw.vertices * [1, -1, 1], raw.faces).volume
    assert mesh.volume == pytest.approx(raw_volume, rel=1e-2)


def _envelope_volume(parts, step=0.1):
    """Volume between the highest front and the lowest back of closed parts, integrated
    on a fine grid (each sheet's height interpolated linearly on its triangles)."""
    xs = np.arange(0.0, 300.0, step)
    x, y = np.meshgrid(xs, np.arange(0.0, 120.0, step))
    top, bottom = np.full(x.shape, -np.inf), np.full(x.shape, np.inf)
    for p in parts:
        t = p.vertices[p.faces]
        e1, e2 = t[:, 1, :2] - t[:, 0, :2], t[:, 2, :2] - t[:, 0, :2]
        det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        for k in np.flatnonzero(det != 0.0):  # walls have no area in (x, y)
            (i0, j0), (i1, j1) = np.floor(t[k, :, :2].min(0) / step), np.ceil(t[k, :, :2].max(0) / step) + 1
            sl = slice(int(j0), int(j1)), slice(int(i0), int(i1))
            rx, ry = x[sl] - t[k, 0, 0], y[sl] - t[k, 0, 1]
            l1 = (rx * e2[k, 1] - ry * e2[k, 0]) / det[k]
            l2 = (e1[k, 0] * ry - e1[k, 1] * rx) / det[k]
            inside = (l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1)
            z = t[k, 0, 2] + l1 * (t[k, 1, 2] - t[k, 0, 2]) + l2 * (t[k, 2, 2] - t[k, 0, 2])
            top[sl] = np.where(inside, np.maximum(top[sl], z), top[sl])
            bottom[sl] = np.where(inside, np.minimum(bottom[sl], z), bottom[sl])
    covered = np.isfinite(top)
    return float((top - bottom)[covered].sum() * step * step)


def _discs(*disks):
    return [disk_part(f"d{i}", cx, cy, r, base=base, closed=True, max_area=24.0)
            for i, (cx, cy, r, base) in enumerate(disks)]


@pytest.mark.parametrize("small", [(60.0, 60.0, 12.0, 70.0),    # floats in front, inside
                                   (95.0, 60.0, 12.0, 70.0)])  # and hanging over the edge
def test_a_disc_floating_in_front_joins_the_disc_behind(small):
    big = (60.0, 60.0, 40.0, 0.0)
    parts = _discs(big, small)
    # the slabs do not meet: the small disc's back is above the big disc's front
    assert parts[1].vertices[:, 2].min() > parts[0].vertices[:, 2].max()
    solid = union_parts(parts)
    q = mesh_quality(solid.vertices * [1, -1, 1], solid.faces)
    assert q["watertight"] and q["edge_manifold"] and q["vertex_manifold"]
    assert q["consistently_oriented"] and q["volume"] > 0
    assert q["shells"] == 1 and shell_parts(solid, parts) == [["d0", "d1"]]
    assert q["min_angle_deg"] >= MIN_ANGLE
    # the gap between them is filled: the volume is that of the envelopes
    envelope = _envelope_volume(parts)
    separate = sum(trimesh.Trimesh(p.vertices * [1, -1, 1], p.faces).volume for p in parts)
    raw = union_parts(parts, remesh=False, skirt=0.0)  # the booleans' solid: the envelope
    assert mesh_quality(raw.vertices * [1, -1, 1], raw.faces)["volume"] == pytest.approx(
        envelope, rel=1e-3)
    # remeshed around the slivers, and the fronts reaching a skirt beyond the outlines
    assert q["volume"] == pytest.approx(envelope, rel=0.015)
    balls = sum(4.0 / 3.0 * np.pi * r ** 3 for _, _, r, _ in (big, small))  # the parts alone
    assert q["volume"] - separate >= 0.5 * (envelope - balls)


def test_union_is_remeshed_at_the_parts_resolution():
    # three overlapping discs, one on another: the solid has about as many faces as
    # the closed parts (not many times more), every angle >= MIN_ANGLE
    parts = _discs((60.0, 60.0, 40.0, 0.0), (90.0, 60.0, 25.0, 10.0), (40.0, 50.0, 15.0, 20.0))
    solid = union_parts(parts)
    q = mesh_quality(solid.vertices * [1, -1, 1], solid.faces)
    assert q["watertight"] and q["shells"] == 1 and q["min_angle_deg"] >= MIN_ANGLE
    assert q["self_intersecting_faces"] == 0
    assert len(solid.faces) <= 1.5 * sum(len(p.faces) for p in parts)


def test_union_is_deterministic():
    parts = _discs((60.0, 60.0, 40.0, 0.0), (95.0, 60.0, 12.0, 70.0))
    a, b = union_parts(parts), union_parts(parts)
    assert a.vertices.tobytes() == b.vertices.tobytes() and a.faces.tobytes() == b.faces.tobytes()


def test_union_names_the_parts_that_stay_apart():
    far = disk_part("far", 260.0, 40.0, 15.0, closed=True)
    near = disk_part("near", 60.0, 40.0, 15.0, closed=True)
    solid = union_parts([near, far])
    assert shell_parts(solid, [near, far]) == [["near"], ["far"]] or \
        shell_parts(solid, [near, far]) == [["far"], ["near"]]
    v, f = remesh_solid(solid.vertices, solid.faces, target=2.0)
    assert len(f) > 0


def test_union_needs_closed_parts(scene):
    with pytest.raises(StageError, match="union needs closed parts"):
        assemble(scene[0], size=(300, 200), union=True)


def test_close_part_walls_the_outline():
    # a square sheet: height 0 on three sides, 5 on the fourth (a Neumann edge)
    xs = np.linspace(0, 10, 6)
    yy, xx = np.meshgrid(xs, xs, indexing="ij")
    v = np.column_stack([xx.ravel(), yy.ravel(), np.zeros(36)])
    v[:, 2] = np.where(np.isclose(v[:, 0], 10), 5.0, np.where(
        (v[:, 0] == 0) | (v[:, 1] == 0) | (v[:, 1] == 10), 0.0, 3.0))
    idx = np.arange(36).reshape(6, 6)
    quads = np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]], -1).reshape(-1, 4)
    faces = np.concatenate([quads[:, [0, 2, 1]], quads[:, [0, 3, 2]]])  # all-outline corner ears
    part = close_part(Part("sq", v, faces), -v[:, 2] - 0.5)
    mesh = trimesh.Trimesh(part.vertices * [1, -1, 1], part.faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    assert len(part.faces) == 2 * len(faces) + 2 * 20  # 20 outline edges
    # the thickness 2 h + 0.5 integrated over the square (h piecewise linear)
    e1, e2 = v[faces[:, 1], :2] - v[faces[:, 0], :2], v[faces[:, 2], :2] - v[faces[:, 0], :2]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    assert mesh.volume == pytest.approx(2 * area @ v[faces, 2].mean(1) + 0.5 * 100, rel=1e-9)
    with pytest.raises(StageError, match="does not lie below the front"):
        close_part(Part("sq", v, faces), v[:, 2])


def _box(x0, x1, top, name):
    """A closed box over [x0, x1] x [0, 4] from z = 0 to ``top``, sides cut into unit steps."""
    xs, ys = np.arange(x0, x1 + 0.5), np.arange(0.0, 5.0)
    yy, xx = np.meshgrid(ys, xs, indexing="ij")
    v = np.column_stack([xx.ravel(), yy.ravel(), np.full(xx.size, float(top))])
    nx = len(xs)
    q = (np.arange(len(ys) - 1)[:, None] * nx + np.arange(nx - 1)).ravel()
    faces = np.concatenate([np.stack([q, q + nx, q + 1], 1), np.stack([q + 1, q + nx, q + nx + 1], 1)])
    return close_part(Part(name, v, faces), np.zeros(len(v)))


def test_envelope_of_two_boxes_is_the_higher_box_and_a_step():
    low, high = _box(0.0, 6.0, 1.0, "low"), _box(3.0, 9.0, 3.0, "high")
    v, f = _envelope_solid([low, high], 0.0)
    q = mesh_quality(v, f)
    assert q["watertight"] and q["consistently_oriented"] and q["self_intersecting_faces"] == 0
    # closed form: the low box where the high one is not (3 x 4 x 1), then the high box
    # (6 x 4 x 3); y runs down, so the faces run clockwise seen from +z
    assert -q["volume"] == pytest.approx(12.0 + 72.0, rel=1e-12)
    top = v[:, 2] > 0.0
    assert set(np.unique(v[top, 2])) == {1.0, 3.0}
    assert (v[v[:, 2] == 1.0, 0] <= 3.0).all() and (v[v[:, 2] == 3.0, 0] >= 3.0).all()


def test_envelope_refuses_a_part_that_is_not_a_closed_slab():
    with pytest.raises(StageError, match="part d0 is not a closed slab"):
        _envelope_solid([disk_part("d0", 30.0, 30.0, 10.0)], 0.0)  # a front without a back


def test_a_slot_narrower_than_two_skirts_between_parts_is_filled():
    low, high = _box(0.0, 6.0, 1.0, "low"), _box(6.4, 12.4, 3.0, "high")  # 0.4 apart
    high.vertices[:, 2] -= 0.5  # (backs in one plane would overlap where the skirts do)
    assert mesh_quality(*_envelope_solid([low, high], 0.0))["shells"] == 2
    v, f = _envelope_solid([low, high], 0.3)
    q = mesh_quality(v, f)
    assert q["watertight"] and q["shells"] == 1 and q["self_intersecting_faces"] == 0
    # closed form: each box 0.3 wider on every side but within the parts' bounds
    # ([0, 12.4] x [0, 4], the drawing), the high one over the slot: 4 x (6.1 x 1 + 6.3 x 3)
    assert -q["volume"] == pytest.approx(4.0 * (6.1 + 18.9), rel=1e-12)
    assert np.ptp(v[:, :2], axis=0) == pytest.approx([12.4, 4.0])


def test_the_skirt_folds_no_triangle_at_a_sharp_spike():
    # a sheet around a spike of an outline (an eye's, in a drawing): its tip's move of
    # up to two skirts along the miter would fold the triangle with the interior vertex
    # 0.04 px from it, a sheet crossing itself, which pinches the booleans' solid
    xy = [[0.841, -3.197], [0.278, -0.169], [0.19, 0.31], [-1.584, -1.36], [1.524, 0.307],
          [0.866, 3.903], [0.861, -3.193], [0.297, -0.165], [0.203, 0.35], [-1.597, -1.346]]
    v = np.column_stack([xy, np.ones(10), np.zeros(10)])
    f = np.array([[7, 4, 6], [4, 8, 5], [4, 7, 8], [2, 3, 9], [0, 1, 7], [1, 2, 8],
                  [2, 9, 8], [1, 8, 7]])
    w, g = _skirted(v, f, 0.3, (np.full(2, -50.0), np.full(2, 50.0)))
    assert (np.sign(signed_areas(w, g)) == np.sign(signed_areas(v, f))).all()
    moved = np.linalg.norm(w[:, :2] - v[:, :2], axis=1)
    assert moved.max() <= 0.6 + 1e-12 and (moved > 0.0).sum() >= 6  # the rest still skirted


def test_untangle_moves_a_vertex_pushed_through_the_solid_back():
    box = _box(0.0, 4.0, 2.0, "box")
    v, f = box.vertices.copy(), box.faces
    centre = int(np.flatnonzero((v[:, 0] == 2.0) & (v[:, 1] == 2.0) & (v[:, 2] == 2.0))[0])
    v[centre, 2] = -1.0  # through the bottom
    assert self_intersecting_faces(v, f).any()
    out, crossing = _untangle(v, f, min_angle=10.0, near=np.ones(len(f), bool))
    assert not self_intersecting_faces(out, f).any() and not crossing.any()
    # closed form: its neighbours are all on the top, so the centroid of them is too
    assert out[centre, 2] == pytest.approx(2.0)
    moved = np.flatnonzero((out != v).any(axis=1))
    assert moved.tolist() == [centre]


def test_repair_patches_retriangulates_a_sliver_on_a_tilted_plane():
    # a grid on the plane z = 0.3 x - 0.2 y + 1 with one vertex pushed almost onto its
    # neighbour (needles), then past it (faces folded over others)
    xs = np.arange(7.0)
    xx, yy = np.meshgrid(xs, xs)
    xy = np.column_stack([xx.ravel(), yy.ravel()])
    q = (np.arange(6)[:, None] * 7 + np.arange(6)).ravel()
    faces = np.concatenate([np.stack([q, q + 1, q + 7], 1), np.stack([q + 1, q + 8, q + 7], 1)])
    centre = 3 * 7 + 3
    for x in (3.95, 4.4):  # a needle next to the vertex at (4, 3), then a fold past it
        p = xy.copy()
        p[centre] = [x, 3.0]
        v = np.column_stack([p, 0.3 * p[:, 0] - 0.2 * p[:, 1] + 1.0])
        assert _min_angles(v, faces).min() < 10.0
        assert self_intersecting_faces(v, faces).any() == (x > 4.0)
        w, g = repair_patches(v, faces, target=1.0, min_angle=10.0)
        assert _min_angles(w, g).min() >= 10.0
        assert not self_intersecting_faces(w, g).any()
        # closed form: every vertex still on the plane, the grid's outline and area kept
        assert np.allclose(w[:, 2], 0.3 * w[:, 0] - 0.2 * w[:, 1] + 1.0)
        t = w[g][:, :, :2]
        e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
        assert np.sum(np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])) / 2.0 == pytest.approx(36.0)
        border = (xy == 0.0).any(axis=1) | (xy == 6.0).any(axis=1)
        assert all((w == vert).all(axis=1).any() for vert in v[border])
        assert len(_boundary_edges(g)) == 24


def test_union_is_remeshed_only_around_its_slivers():
    parts = _discs((60.0, 60.0, 40.0, 0.0), (90.0, 60.0, 25.0, 10.0))
    raw = union_parts(parts, remesh=False)
    solid = union_parts(parts)
    t = raw.vertices[raw.faces]
    centre = t.mean(axis=1)
    sliver = _min_angles(raw.vertices, raw.faces) < MIN_ANGLE
    edge = np.median(np.linalg.norm(t - np.roll(t, 1, axis=1), axis=2))
    # (the remeshing reaches a few rings around a sliver, each ring about an edge)
    far = cKDTree(centre[sliver]).query(centre)[0] > 5.0 * edge
    assert sliver.any() and far.sum() > 50
    # every face far from the booleans' slivers is in the solid as it was, bit for bit
    kept = {tuple(sorted(map(tuple, tri))) for tri in solid.vertices[solid.faces].tolist()}
    assert all(tuple(sorted(map(tuple, tri))) in kept for tri in t[far].tolist())


def test_outlines_within_a_pixel_of_each_other_are_made_to_coincide():
    low, high = _box(0.0, 6.0, 1.0, "low"), _box(6.4, 12.4, 3.0, "high")  # 0.4 apart
    high.vertices[:, 2] -= 0.5  # (the two slabs meet in height)
    v, f = _envelope_solid([low, high], 0.0, 1.0)
    q = mesh_quality(v, f)
    assert q["watertight"] and q["shells"] == 1 and q["self_intersecting_faces"] == 0
    # closed form: the high box's near side moved onto the low box's (x = 6), no slot
    assert -q["volume"] == pytest.approx(4.0 * (6.0 * 1.0 + 6.4 * 3.0), rel=1e-12)
    assert not ((v[:, 0] > 6.0) & (v[:, 0] < 7.4)).any()


def test_a_part_floating_over_another_by_a_sliver_is_kept_clear_of_it():
    low, high = _box(0.0, 6.0, 1.0, "low"), _box(5.7, 11.7, 5.0, "high")  # 0.3 over it
    high.vertices[:, 2] += 3.0  # floats from 3 to 8 over the low one (0 to 1)
    high.vertices[:, 1] = 1.0 + 0.5 * high.vertices[:, 1]  # y in [1, 3]
    v, f = _envelope_solid([low, high], 0.0, 0.0)
    assert mesh_quality(v, f)["shells"] == 1  # joined by a column 0.3 px wide
    v, f = _envelope_solid([low, high], 0.0, 1.0)
    q = mesh_quality(v, f)
    assert q["watertight"] and q["shells"] == 2 and q["self_intersecting_faces"] == 0
    # closed form: the high box's near side half a pixel clear of the low box (x = 6.5)
    assert v[v[:, 2] > 1.0, 0].min() == pytest.approx(6.5, abs=1e-12)
    assert -q["volume"] == pytest.approx(4.0 * 6.0 * 1.0 + 2.0 * 5.2 * 5.0, rel=1e-12)


def _slab(outline, bottom, top, name):
    """A closed flat slab over the polygon ``outline`` from ``bottom`` to ``top``."""
    k = np.arange(len(outline))
    t = triangle.triangulate({"vertices": outline,
                              "segments": np.column_stack([k, np.roll(k, -1)])}, "pQ")
    v = np.column_stack([t["vertices"], np.full(len(t["vertices"]), float(top))])
    faces = np.asarray(t["triangles"], np.int64)[:, ::-1]  # clockwise in (x, y)
    return close_part(Part(name, v, faces), np.full(len(v), float(bottom)))


def test_a_floating_part_is_kept_clear_of_a_curved_outline_along_its_whole_edge():
    a = 2.0 * np.pi * np.arange(40) / 40
    circle = 10.0 * np.column_stack([np.cos(a), np.sin(a)])
    low = _slab(circle, 0.0, 1.0, "low")
    # one straight 8 px edge whose ends lie within a pixel outside the circle and whose
    # middle cuts 0.8 px into it; floating from 5 to 6 over the low slab
    high = _slab(np.array([[9.2, -4.0], [15.0, -4.0], [15.0, 4.0], [9.2, 4.0]]), 5.0, 6.0, "high")
    v, f = _envelope_solid([low, high], 0.0, 1.5)
    q = mesh_quality(v, f)
    # a column where the edge crosses the circle would join the two: apart, and the low
    # slab whole (closed form: the polygon's area times its thickness)
    assert q["watertight"] and q["shells"] == 2 and q["self_intersecting_faces"] == 0
    pieces = trimesh.Trimesh(v, f, process=False).split(only_watertight=True)
    lowest = min(pieces, key=lambda m: m.vertices[:, 2].max())
    x, y = circle.T
    area = 0.5 * abs((x * np.roll(y, -1) - np.roll(x, -1) * y).sum())
    assert abs(lowest.volume) == pytest.approx(area * 1.0, rel=1e-12)


def test_outline_vertices_moved_together_into_one_corner_stay_where_they_were():
    before = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0], [5.0, 5.0]])
    after = before.copy()
    after[1] = after[2] = [1.5, 0.7]  # moved onto one point: the union would pinch there
    after[2, 0] += 0.01
    after[3] = [3.0, 0.75]  # moved alone: kept
    out = _uncrowded(before, after, np.arange(4), 0.075)
    assert np.array_equal(out[[1, 2]], before[[1, 2]])
    assert np.array_equal(out[[0, 3, 4]], after[[0, 3, 4]])


def test_a_hole_smaller_than_the_fill_area_is_filled():
    box = _box(0.0, 4.0, 2.0, "holed")
    front = box.faces[:32]  # the front's 4 x 4 cells come first (then the back, the walls)
    # cut the front's unit cell at (1..2, 1..2) out (and its back), closing the part again
    v = box.vertices[:25]
    centre = v[front][:, :, :2].mean(axis=1)
    cell = ((centre > 1.0) & (centre < 2.0)).all(axis=1)
    holed = close_part(Part("holed", v, front[~cell]), np.zeros(len(v)))
    open_v, open_f = _envelope_solid([holed], 0.0, 0.0)
    assert -mesh_quality(open_v, open_f)["volume"] == pytest.approx(2.0 * 15.0, rel=1e-12)
    filled_v, filled_f = _envelope_solid([holed], 0.0, 0.0, fill=1.5)
    q = mesh_quality(filled_v, filled_f)
    assert q["watertight"] and q["shells"] == 1
    assert -q["volume"] == pytest.approx(2.0 * 16.0, rel=1e-12)  # the unit hole filled
    kept_v, kept_f = _envelope_solid([holed], 0.0, 0.0, fill=0.5)  # larger than the fill
    assert -mesh_quality(kept_v, kept_f)["volume"] == pytest.approx(2.0 * 15.0, rel=1e-12)


def test_the_rims_wall_strip_is_merged_away_keeping_the_outline():
    # a disk inflated with the rim's wall: every outline vertex has a copy 0.02 px inside
    # (the wall's top), joined to it by a strip of needles two faces per outline edge
    yy, xx = np.mgrid[:80, :80]
    region = inflate_region((xx - 40) ** 2 + (yy - 40) ** 2 <= 30 ** 2, name="disk")
    mesh = region.mesh
    part = close_part(Part("disk", np.column_stack([mesh.vertices, region.height]),
                           np.asarray(mesh.faces, np.int64)), -region.height - 1.0)
    v, front, back = _sheets(part)
    sheet, faces = _paired(v, front, back)
    outline = np.unique(_boundary_edges(faces))
    w, g = _unwalled(sheet, faces, _WALL_REACH)
    strip = 2 * len(outline)
    assert len(g) == len(faces) - strip and len(w) == len(sheet) - len(outline)
    a, b = _boundary_edges(g).T
    # the outline keeps its (x, y) exactly, at the wall's top: no face of the strip left
    assert sorted(map(tuple, w[a, :2].tolist())) == sorted(map(tuple, sheet[outline, :2].tolist()))
    top = np.sort(region.height[len(region.height) - len(outline):])  # the copies come last
    assert np.array_equal(np.sort(w[a, 2]), top) and top.min() > 0.5
    assert np.array_equal(np.sort(w[a, 3]), np.sort(-top - 1.0))
    assert _min_angles(w[:, :3], g).min() > _min_angles(sheet[:, :3], faces).min()
    assert (np.sign(signed_areas(w, g)) == np.sign(signed_areas(sheet, faces)[0])).all()
    again_v, again_f = _unwalled(w, g, _WALL_REACH)  # nothing more to merge
    assert np.array_equal(again_v, w) and np.array_equal(again_f, g)


def test_a_cut_is_stitched_back_where_its_border_moved_by_a_rounding_error():
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=300.0)
    v, f = np.asarray(sphere.vertices, float), np.asarray(sphere.faces, np.int64)
    cut = v[f].mean(axis=1)[:, 2] > 100.0
    used, sub = np.unique(f[cut], return_inverse=True)
    sub = sub.reshape(-1, 3)
    outside = np.zeros(len(v), bool)
    outside[f[~cut]] = True
    border = np.flatnonzero(outside[used])
    for shift, stitched in [(1e-13, True), (1e-3, False)]:
        sv = v[used].copy()
        sv[border[0]] += shift  # (a remeshing may move a border vertex by an ulp, not more)
        w, g = _stitched(v, f, cut, sv, sub)
        assert (g is not None) == stitched
        if stitched:
            assert len(g) == len(f) and len(w) == len(v) and _closed_manifold(g)
            # the border kept exactly where it was, so the faces are the old ones
            assert np.array_equal(np.unique(w, axis=0), np.unique(v, axis=0))
            assert np.array_equal(np.unique(np.sort(w[g].reshape(len(g), -1), axis=1), axis=0),
                                  np.unique(np.sort(v[f].reshape(len(f), -1), axis=1), axis=0))


def test_position_ids_number_equal_positions_alike():
    rng = np.random.default_rng(2)
    p = rng.normal(size=(500, 3))
    q = np.concatenate([p, p[::7], [[0.0, -0.0, 1.0], [-0.0, 0.0, 1.0]]])
    ids = _position_ids(q)
    assert ids.max() + 1 == 500 + 1  # the two zeros of either sign are one position
    assert ids[500:500 + len(p[::7])].tolist() == ids[:500:7].tolist()
    assert len(np.unique(ids[:500])) == 500
    flat = _position_ids(np.concatenate([p[:, :2], p[:3, :2]]))  # any number of coordinates
    assert flat[500:].tolist() == flat[:3].tolist() and flat.max() + 1 == 500


def test_a_solid_left_with_a_sliver_crossing_a_face_is_reported():
    from inkray.relief.assembly import _left_bad

    # A sliver (its smallest angle about 0.2 degrees) and a triangle standing across it.
    v = np.array([[0, 0, 0], [10, 0, 0], [5, 0.02, 0],
                  [5, -1, -1], [5, 1, -1], [5, 0, 1]], float)
    sliver = trimesh.Trimesh(v, [[0, 1, 2], [3, 4, 5]], process=False)
    (warning,) = _left_bad(sliver)
    assert warning.startswith(f"union: 1 faces with an angle under {MIN_ANGLE:g} degrees and 2 "
                              "crossing another")
    # Two well-shaped triangles apart: nothing to report.
    w = np.array([[0, 0, 0], [10, 0, 0], [5, 8, 0], [30, 0, 0], [40, 0, 0], [35, 8, 0]], float)
    fine = trimesh.Trimesh(w, [[0, 1, 2], [3, 4, 5]], process=False)
    assert _left_bad(fine) == []
