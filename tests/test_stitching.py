"""Stitching: inequalities, C0 stitches, C1 grafts (Ink-and-Ray, section 5)."""

from dataclasses import replace

import numpy as np
import pytest

from _mesh import height_at
from inkray.input.annotations import parse_annotations
from inkray.relief.completion import complete_regions
from inkray.errors import InputError
from inkray.relief.outline import MeshOptions
from inkray.relief.inflation import inflate_region
from inkray.relief.joins import open_joins
from inkray.relief.ordering import depth_order
from inkray.numerics.polyline import point_polyline_distance
from inkray.relief import stitching
from inkray.relief.stitching import stitch
from inkray.input.constraints import constraints


def _doc(size, regions=(), order=(), boundaries=()):
    return parse_annotations({
        "format": "inkray-annotations", "version": 1, "size": list(size),
        "regions": [{"name": n, "scribbles": [[list(p)]]} for n, p in regions],
        "order": [{"front": list(f), "back": list(b)} for f, b in order],
        "boundaries": [{"type": t, "path": [list(p) for p in path]} for t, path in boundaries]})


def _build(labels, ann, names, **kw):
    c = complete_regions(labels, names=names)
    relations, _ = depth_order(constraints(ann), labels, c, seams=ann.boundaries)
    c = c.ordered(relations)
    inflated = [inflate_region(c.completed(i), visible=c.visible(i), labels=labels, region=i,
                               name=n, boundaries=ann.boundaries, options=MeshOptions(max_area=30.0))
                for i, n in enumerate(names)]
    return stitch(inflated, relations, c, seams=ann.boundaries, **kw), c, relations


def _disks():
    h, w = 200, 280
    yy, xx = np.mgrid[:h, :w]
    a = (xx - 170) ** 2 + (yy - 100) ** 2 <= 60 ** 2
    b = (xx - 100) ** 2 + (yy - 100) ** 2 <= 70 ** 2
    labels = np.full((h, w), -1, np.int32)
    labels[b] = 1
    labels[a] = 0
    return labels


def test_front_disk_stays_above_back_disk_everywhere():
    labels = _disks()
    ann = _doc((280, 200), order=[((150, 100), (60, 100))])
    layers, c, rel = _build(labels, ann, ["A", "B"])
    assert [(r.front_name, r.back_name) for r in rel if r.kind == "order"] == [("A", "B")]
    A, B = layers.regions
    # a dense grid of the shared area, not only the constrained vertices
    yy, xx = np.mgrid[:200, :280]
    shared = c.completed(0) & c.completed(1)
    pts = np.column_stack([xx[shared], yy[shared]]).astype(float)
    za, da = height_at(A.mesh.vertices, A.mesh.faces, layers.z(0), pts)
    zb, db = height_at(B.mesh.vertices, B.mesh.faces, layers.z(1), pts)
    inside = (da < 1e-9) & (db < 1e-9)
    assert inside.sum() > 1000
    gap = za[inside] - zb[inside]
    # the gap is linear on each cell of the two meshes' overlay, whose corners (the
    # vertices and the edge crossings) all carry a row: it holds everywhere
    assert gap.min() >= layers.epsilon - 1e-6
    assert layers.violation <= 1e-6
    # the parts move rigidly: a constant offset per region
    assert np.ptp(layers.offset[0]) < 0.05 and np.ptp(layers.offset[1]) < 0.05


def _square_over_disk():
    """A coarse square in front of a finely meshed dome: min(z_A - z_B - epsilon) over a
    quarter-pixel grid of their overlap."""
    h, w = 200, 200
    yy, xx = np.mgrid[:h, :w]
    labels = np.full((h, w), -1, np.int32)
    labels[np.hypot(xx - 100, yy - 100) <= 70] = 1
    labels[60:141, 60:141] = 0
    ann = _doc((w, h), order=[((100, 100), (100, 20))])
    c = complete_regions(labels, names=["A", "B"])
    relations, _ = depth_order(constraints(ann), labels, c, seams=())
    c = c.ordered(relations)
    inflated = [inflate_region(c.completed(i), visible=c.visible(i), labels=labels, region=i,
                               name=n, options=MeshOptions(max_area=area))
                for i, (n, area) in enumerate([("A", 800.0), ("B", 8.0)])]
    layers = stitch(inflated, relations, c)
    pts = (np.column_stack([xx.ravel(), yy.ravel()])[:, None, :]
           + 0.5 * np.array([[0, 0], [1, 0], [0, 1], [1, 1]])[None]).reshape(-1, 2)
    (za, da), (zb, db) = (height_at(r.mesh.vertices, r.mesh.faces, layers.z(i), pts)
                          for i, r in enumerate(inflated))
    both = (da < 1e-9) & (db < 1e-9)
    assert both.sum() > 20000
    return float((za - zb)[both].min() - layers.epsilon)


def test_order_holds_between_the_vertices_of_two_meshes():
    # z_A - z_B is linear on each cell of the two meshes' overlay; its corners are the
    # vertices and the crossings of an edge of one mesh with an edge of the other
    assert _square_over_disk() >= -1e-6


def test_without_the_edge_crossings_the_order_dips_between_its_rows(monkeypatch):
    monkeypatch.setattr(stitching, "segment_crossings", lambda a, b: np.zeros((0, 2)))
    assert _square_over_disk() < -1e-3


def test_constraints_that_already_hold_leave_offsets_zero():
    labels = _disks()
    ann = _doc((280, 200), order=[((150, 100), (60, 100))])
    layers, c, rel = _build(labels, ann, ["A", "B"])
    lifted = replace(layers.regions[0], height=layers.regions[0].height + 500.0)
    again = stitch([lifted, layers.regions[1]], rel, c, seams=ann.boundaries)
    assert again.active == 0
    assert np.abs(again.offset[0]).max() == 0 and np.abs(again.offset[1]).max() == 0


def _rings():
    """Two rings crossing twice, with a 12 px gap in each ring where the other passes."""
    h, w = 220, 320
    yy, xx = np.mgrid[:h, :w]
    ra = np.hypot(xx - 120, yy - 110)
    rb = np.hypot(xx - 200, yy - 110)
    a = (ra >= 55) & (ra <= 75)
    b = (rb >= 55) & (rb <= 75)
    labels = np.full((h, w), -1, np.int32)
    labels[a] = 0
    labels[b] = 1
    top = yy < 110
    labels[a & b & top] = 0  # A over B at the upper crossing
    labels[a & b & ~top] = 1  # B over A at the lower crossing
    return labels


def test_interlocking_rings_each_on_top_at_its_crossing():
    labels = _rings()
    cross_top = (160, 63)  # the upper crossing: both rings' centre lines meet near here
    cross_bot = (160, 157)
    ann = _doc((320, 220), order=[((160, 58), (176, 56)),   # A over B, upper crossing
                                  ((160, 162), (144, 164))])  # B over A, lower crossing
    assert labels[58, 160] == 0 and labels[56, 176] == 1
    assert labels[162, 160] == 1 and labels[164, 144] == 0
    layers, c, rel = _build(labels, ann, ["A", "B"])
    user = [(r.front_name, r.back_name) for r in rel if r.source == "user"]
    assert user == [("A", "B"), ("B", "A")]
    A, B = layers.regions
    for (x, y), front in ((cross_top, 0), (cross_bot, 1)):
        p = np.array([[x, y]], float)
        za, da = height_at(A.mesh.vertices, A.mesh.faces, layers.z(0), p)
        zb, db = height_at(B.mesh.vertices, B.mesh.faces, layers.z(1), p)
        assert da[0] < 1e-9 and db[0] < 1e-9
        if front == 0:
            assert za[0] >= zb[0] + layers.epsilon - 1e-6
        else:
            assert zb[0] >= za[0] + layers.epsilon - 1e-6


def _squares():
    h, w = 160, 260
    labels = np.full((h, w), -1, np.int32)
    labels[30:130, 30:130] = 0
    labels[30:130, 130:230] = 1
    return labels


def test_c0_stitch_joins_two_regions_exactly():
    labels = _squares()
    ann = _doc((260, 160), boundaries=[("stitch", [(129.5, 35), (129.5, 125)])])
    layers, c, rel = _build(labels, ann, ["left", "right"])
    L, R = layers.regions
    sl, sr = L.mesh.station_vertices(0), R.mesh.station_vertices(0)
    assert len(sl) == len(sr) >= 5
    # Each region smooths the shared outline on its own (sub-pixel outlines): the
    # stations agree to a few hundredths of a pixel (a quarter at the seam's ends,
    # where the outlines turn apart), the heights exactly.
    gap = np.linalg.norm(L.mesh.vertices[sl] - R.mesh.vertices[sr], axis=1)
    assert gap[1:-1].max() < 0.05 and gap.max() < 0.25
    assert np.abs(layers.z(0)[sl] - layers.z(1)[sr]).max() < 1e-6


def _limb():
    """A limb drawn over a disk body, its open end inside the body (a graft there)."""
    h, w = 220, 360
    yy, xx = np.mgrid[:h, :w]
    body = (xx - 120) ** 2 + (yy - 110) ** 2 <= 90 ** 2
    limb = (xx >= 150) & (xx <= 320) & (np.abs(yy - 110) <= 25)
    labels = np.full((h, w), -1, np.int32)
    labels[body] = 0
    labels[limb] = 1
    return labels


def _graft_layers():
    labels = _limb()
    ann = _doc((360, 220), order=[((250, 110), (100, 110))],
               boundaries=[("graft", [(149.5, 88), (149.5, 132)])])
    return _build(labels, ann, ["body", "limb"])[0]


def _seam_slopes(layers, step=1.0):
    """dz/dx of the visible surface ``step`` px either side of the seam x = 149.5:
    the body's on the left, the limb's on the right, along five rows."""
    B, F = layers.regions
    out = []
    for y in (95.0, 100.0, 110.0, 120.0, 125.0):
        zl, _ = height_at(B.mesh.vertices, B.mesh.faces, layers.z(0),
                          np.array([[149.5 - step, y], [149.5, y]]))
        zr, _ = height_at(F.mesh.vertices, F.mesh.faces, layers.z(1),
                          np.array([[149.5, y], [149.5 + step, y]]))
        out.append((np.diff(zl)[0] / step, np.diff(zr)[0] / step))
    return np.array(out)


def test_graft_has_no_crack_and_no_crease():
    layers = _graft_layers()
    B, F = layers.regions
    st = F.mesh.station_vertices(0)
    assert len(st) >= 5
    zb, db = height_at(B.mesh.vertices, B.mesh.faces, layers.z(0), F.mesh.vertices[st])
    assert db.max() < 1e-9  # the body continues under the limb
    # No crack: the limb's seam rests on the body, lifted by the body's bulge over
    # the straight seam edges between stations (a fraction of a pixel), so that the
    # body does not show through between the stations either.
    lift = layers.z(1)[st] - zb
    assert lift.min() >= -1e-6 and lift.max() < 0.25
    seam = F.mesh.vertices[st]
    mid = 0.5 * (seam[1:] + seam[:-1])
    zfm, _ = height_at(F.mesh.vertices, F.mesh.faces, layers.z(1), mid)
    zbm, _ = height_at(B.mesh.vertices, B.mesh.faces, layers.z(0), mid)
    assert np.all(zfm >= zbm - 1e-6)
    # No crease (C1): the limb leaves the seam with the slope of the body it grows
    # out of. (Solved alone, the limb rises from the seam at 0.3-3 px per px while
    # the body falls at 0.24: see the next test.)
    slopes = _seam_slopes(layers)
    assert np.abs(slopes[:, 1] - slopes[:, 0]).max() < 0.08, slopes
    # the limb stays above the body over the whole band: no z-fighting
    (front, base, line, width), = layers.bands
    band = np.flatnonzero(point_polyline_distance(F.mesh.vertices, line) < width)
    under, d = height_at(B.mesh.vertices, B.mesh.faces, layers.z(0), F.mesh.vertices[band])
    assert (front, base) == (1, 0) and d.max() < 1e-9
    assert np.all(layers.z(1)[band] >= under - 1e-9)
    # the body is not dented by the limb: its offset stays rigid
    assert np.ptp(layers.offset[0]) < 0.01
    # the limb stands clear of the body beyond the graft band
    far = np.array([[260.0, 110.0]])
    assert height_at(F.mesh.vertices, F.mesh.faces, layers.z(1), far)[0][0] > 0


def test_a_graft_without_the_blend_creases(monkeypatch):
    # The bound above tells a C1 graft from a C0 one: with only the QP's rows (the
    # limb meets the body at the seam, above it over the band) the slopes differ.
    monkeypatch.setattr(stitching, "_blend", lambda *args: None)
    slopes = _seam_slopes(_graft_layers())
    assert np.abs(slopes[:, 1] - slopes[:, 0]).max() > 0.5


def test_contradictory_constraints_name_the_entries():
    labels = _squares()
    # a stitch says equal along the seam, an order says 'left' well above 'right' there,
    # and the epsilon is larger than the rigid room the stitch leaves
    ann = _doc((260, 160), order=[((128, 80), (131, 80))],
               boundaries=[("stitch", [(129.5, 35), (129.5, 125)])])
    with pytest.raises(InputError) as e:
        _build(labels, ann, ["left", "right"], epsilon=5.0)
    assert "boundaries[0]" in str(e.value) and "order[0]" in str(e.value)


def test_a_memo_reuses_the_meshes_it_kept_and_changes_nothing(monkeypatch):
    labels = _disks()
    names = ["A", "B"]
    ann = _doc((280, 200), order=[((150, 100), (60, 100))])
    plain, c, relations = _build(labels, ann, names)
    inflated = plain.regions
    memo = {}
    first = stitch(inflated, relations, c, memo=memo)
    assert len(memo["meshes"]) == 2 and memo["held"]
    kept = dict(memo["meshes"])
    made = []
    monkeypatch.setattr(stitching, "_Mesh", lambda r: made.append(r) or kept[None])
    # the same meshes again (the other order): nothing is factored or located anew
    flipped = [replace(r, front=r.back, back=r.front, front_name=r.back_name,
                       back_name=r.front_name) if r.kind == "order" else r for r in relations]
    second = stitch(inflated, flipped, c, memo=memo)
    assert made == [] and memo["meshes"] == kept
    for a, b in zip(first.offset, plain.offset):
        np.testing.assert_array_equal(a, b)
    assert second.z(1).max() > second.z(0).max()  # B in front now


def test_the_rows_that_held_start_the_next_working_set():
    labels = _rings()
    ann = _doc((320, 220), order=[((160, 58), (176, 56)), ((160, 162), (144, 164))])
    cold, c, relations = _build(labels, ann, ["A", "B"])
    assert cold.rounds >= 2
    memo = {}
    first = stitch(cold.regions, relations, c, memo=memo)
    again = stitch(cold.regions, relations, c, memo=memo)
    assert first.rounds == cold.rounds and again.rounds < first.rounds
    for a, b in zip(again.offset, cold.offset):  # the same optimum, to round-off
        np.testing.assert_allclose(a, b, atol=1e-9)


def test_the_block_solves_equal_one_solve_of_every_column():
    # The rows of three disks' blocks, some of them with terms in two blocks: each block
    # solves only its own rows' columns, in narrow batches; the others stay zero.
    yy, xx = np.mgrid[:70, :70]
    meshes = [stitching._Mesh(inflate_region((xx - c) ** 2 + (yy - 35) ** 2 <= 14 ** 2))
              for c in (18, 35, 52)]
    blocks, start = [], 0
    for m in meshes:
        blocks.append(stitching._Region(m, start))
        start += len(m.h)
    owner = np.concatenate([np.full(len(m.h), i) for i, m in enumerate(meshes)])
    rng = np.random.default_rng(3)
    rows = stitching._Rows()
    for i, j in [(0, 1), (1, 2), (0, 0), (2, 2)]:
        k = 2 * stitching._BATCH + 5  # more columns than one batch
        idx = np.column_stack([blocks[i].start + rng.integers(0, len(meshes[i].h), (k, 3)),
                               blocks[j].start + rng.integers(0, len(meshes[j].h), (k, 3))])
        rows.extend(idx, rng.random((k, 6)), np.zeros(k), True, f"{i}-{j}", False,
                    np.zeros((k, 2)))
    C = rows.matrix(start)
    z = stitching._qinv_rows(C, blocks, owner)
    dense = C.toarray()
    for i, b in enumerate(blocks):
        sl = slice(b.start, b.start + len(b.h))
        expect = b.solve(dense[:, sl].T)
        np.testing.assert_allclose(z[sl], expect, rtol=1e-12, atol=1e-14)
        silent = ~dense[:, sl].any(axis=1)
        assert silent.any() and (z[sl][:, silent] == 0.0).all()


def test_rows_kept_in_blocks_read_as_rows_in_their_order():
    rows, other = stitching._Rows(), stitching._Rows()
    rows.extend([[0, 1, 2]], [[1.0, 0.5, 0.25]], [2.0], True, "a", False, [[1.0, 2.0]])
    other.extend([[3, 3, 3, 4, 4, 4], [0, 0, 0, 1, 1, 1]], np.ones((2, 6)), [0.0, -1.0], False,
                 "b", True, [[3.0, 4.0], [5.0, 6.0]])
    rows.merge(other)
    assert rows.rhs.tolist() == [2.0, 0.0, -1.0]
    assert rows.ineq.tolist() == [True, False, False]
    assert rows.graft.tolist() == [False, True, True]
    assert rows.label == ["a", "b", "b"]
    assert rows.xy.tolist() == [[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]]
    C = rows.matrix(5).toarray()
    np.testing.assert_array_equal(C, [[1.0, 0.5, 0.25, 0, 0], [0, 0, 0, 3.0, 3.0],
                                      [3.0, 3.0, 0, 0, 0]])
    assert stitching._Rows().matrix(4).shape == (0, 4)


def test_the_graft_band_test_agrees_with_the_distance_everywhere():
    rng = np.random.default_rng(5)
    line = np.array([[20.0, 30.0], [35.0, 32.0], [50.0, 45.0]])
    pts = rng.uniform(0.0, 80.0, (4000, 2))
    near = stitching._keepout([(0, 1, line, 9.0, "k", 0.0)])
    expect = point_polyline_distance(pts, line) < 9.0
    assert 0 < expect.sum() < len(pts)
    np.testing.assert_array_equal(near(1, 0, pts), expect)
    assert not near(0, 2, pts).any()
    assert not stitching._in_box(pts, line, 9.0)[expect == 0].all()
    assert stitching._in_box(pts, line, 9.0)[expect].all()


def test_edges_at_are_the_distinct_edges_of_the_marked_triangles():
    yy, xx = np.mgrid[:40, :40]
    blk = stitching._Mesh(inflate_region((xx - 20) ** 2 + (yy - 20) ** 2 <= 12 ** 2))
    sel = np.arange(0, len(blk.v), 7)
    f = blk.f[np.isin(blk.f, sel).any(axis=1)]
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1),
                  axis=0)
    np.testing.assert_array_equal(stitching._edges_at(blk, sel), blk.v[e])


def _open_limb():
    """The limb of :func:`_limb` drawn with 3 px strokes along its sides and end that
    stop at its open end inside the body (x = 150), and the body's outline."""
    labels = _limb()
    h, w = labels.shape
    yy, xx = np.mgrid[:h, :w]
    gray = np.ones((h, w))
    r = np.hypot(xx - 120, yy - 110)
    gray[(np.abs(r - 89) <= 1.5) & (labels == 0)] = 0.0
    gray[(xx >= 150) & (xx <= 320) & ((np.abs(yy - 86) <= 1) | (np.abs(yy - 134) <= 1))] = 0.0
    gray[(np.abs(xx - 319) <= 1) & (np.abs(yy - 110) <= 25)] = 0.0
    return labels, gray


def _open_layers(joined=True, **kw):
    labels, gray = _open_limb()
    joins = open_joins(labels, gray, names=["body", "limb"]) if joined else []
    ann = _doc((360, 220), order=[((250, 110), (100, 110))])
    c = complete_regions(labels, names=["body", "limb"])
    relations, _ = depth_order(constraints(ann), labels, c)
    c = c.ordered(relations)
    inflated = [inflate_region(c.completed(i), visible=c.visible(i), labels=labels, region=i,
                               name=n, boundaries=joins, options=MeshOptions(max_area=30.0))
                for i, n in enumerate(["body", "limb"])]
    return stitch(inflated, relations, c, seams=joins, **kw), joins


def test_an_open_join_grows_the_limb_out_of_the_body_along_the_whole_cut():
    layers, joins = _open_layers()
    (join,) = joins
    assert join.regions == (0, 1)
    B, F = layers.regions
    (front, base, line, width), = layers.bands
    assert (front, base) == (1, 0)
    # every point of the seam, stations and the vertices between them, rests on the body
    seam = F.mesh.vertices[F.mesh.boundary_index == join.index]
    assert len(seam) > 2 * len(F.mesh.station_vertices(join.index))
    zb, db = height_at(B.mesh.vertices, B.mesh.faces, layers.z(0), seam)
    zf = layers.z(1)[F.mesh.boundary_index == join.index]
    assert db.max() < 1e-9 and np.all(zf - zb >= -1e-6) and np.all(zf - zb < 0.25)
    # and leaves it with its slope, a pixel in as well as along the seam
    for y in np.arange(92.0, 129.0, 1.0):
        zl, _ = height_at(B.mesh.vertices, B.mesh.faces, layers.z(0), [[148.5, y], [149.5, y]])
        zr, _ = height_at(F.mesh.vertices, F.mesh.faces, layers.z(1), [[149.5, y], [150.5, y]])
        assert abs((zr[1] - zr[0]) - (zl[1] - zl[0])) < 0.08, y


def test_without_the_join_the_limb_stands_on_the_body_as_a_cliff():
    layers, _ = _open_layers(joined=False)
    B, F = layers.regions
    pts = np.column_stack([np.full(9, 151.0), np.linspace(95, 125, 9)])
    zf, _ = height_at(F.mesh.vertices, F.mesh.faces, layers.z(1), pts)
    zb, _ = height_at(B.mesh.vertices, B.mesh.faces, layers.z(0), pts)
    assert np.all(zf - zb >= layers.epsilon - 1e-6)


def _seam_gap(layers, join):
    """Height of the grafted limb over the body at every vertex of the seam."""
    B, F = layers.regions
    on = F.mesh.boundary_index == join.index
    zb, _ = height_at(B.mesh.vertices, B.mesh.faces, layers.z(0), F.mesh.vertices[on])
    return layers.z(1)[on] - zb


def test_between_the_stations_the_solved_seam_rests_on_the_base(monkeypatch):
    # The QP alone (no blend) already puts the whole seam on the body; with rows at
    # the stations only, the limb's offset, pinned at points 10 px apart, bulges
    # between them: a sawtooth along the seam that the blend has to hide.
    monkeypatch.setattr(stitching, "_blend", lambda *args: None)
    layers, (join,) = _open_layers()
    gap = _seam_gap(layers, join)
    assert gap.min() >= -1e-6 and gap.max() < 0.25
    monkeypatch.setattr(stitching, "_seam_vertices", lambda mesh, index, stations:
                        mesh.station_vertices(index))
    layers, (join,) = _open_layers()
    assert _seam_gap(layers, join).max() > 1.0


def test_a_second_hidden_layer_stays_below_both_parts_over_it():
    # Two disks side by side behind a bar, the right one in front of the left: the left
    # disk's circle continued under the bar reaches under the right one's hidden part, its
    # second layer there, which must lie below that part and below the bar (the place of
    # the disks' own order lies elsewhere: no row of it speaks there).
    from test_completion import _two_disks_under_a_bar, _user_orders

    labels, *_ = _two_disks_under_a_bar()
    names = ["left", "right", "bar"]
    c = complete_regions(labels, names=names)
    relations = _user_orders(c, [(2, 0), (2, 1), (1, 0)])
    c = c.ordered(relations)
    beneath = c.beneath == 0
    assert beneath.sum() > 100
    inflated = [inflate_region(c.completed(i), visible=c.visible(i), labels=labels, region=i,
                               name=n, options=MeshOptions(max_area=30.0))
                for i, n in enumerate(names)]
    layers = stitch(inflated, relations, c)
    ys, xs = np.nonzero(beneath)
    pts = np.column_stack([xs, ys]).astype(float)
    z = [height_at(r.mesh.vertices, r.mesh.faces, layers.z(i), pts) for i, r in enumerate(inflated)]
    inside = (z[0][1] < 1e-9) & (z[1][1] < 1e-9) & (z[2][1] < 1e-9)
    assert inside.sum() > 0.9 * len(pts)
    for over in (1, 2):
        assert (z[over][0] - z[0][0])[inside].min() >= layers.epsilon - 1e-6
