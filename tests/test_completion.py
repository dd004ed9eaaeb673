"""Region completion (inkray.complete): illusory surfaces under occluders."""

import numpy as np
import pytest
from scipy import ndimage

from inkray.numerics.grid import grid_laplacian
from inkray.relief.completion import _OUTSIDE, _dirichlet_system, complete_regions, continue_outline
from inkray.errors import InputError
from inkray.relief.ordering import Relation, depth_order

H = W = 200
YY, XX = np.mgrid[:H, :W]


def iou(a, b):
    return (a & b).sum() / (a | b).sum()


def behind_band(shape, fraction, offset):
    """A square (100 px) or disk (diameter 120 px) with a vertical band over it."""
    if shape == "square":
        true = (YY >= 50) & (YY < 150) & (XX >= 50) & (XX < 150)
        width = 100
    else:
        true = (XX - 100.0) ** 2 + (YY - 100.0) ** 2 <= 60 ** 2
        width = 120
    bw = int(round(fraction * width))
    c0 = 100 - bw // 2 + int(round(offset * width))
    band = (XX >= c0) & (XX < c0 + bw) & (YY >= 20) & (YY < 180)
    labels = np.full((H, W), -1, np.int32)
    labels[true] = 0
    labels[band] = 1
    return labels, true, band


def final_completion(labels, names=("shape", "band")):
    c = complete_regions(labels, names=list(names))
    relations, _ = depth_order([], labels, c)
    return c, relations, c.ordered(relations)


@pytest.mark.parametrize("shape", ["square", "disk"])
@pytest.mark.parametrize("fraction", [0.1, 0.2, 0.3, 0.4])
@pytest.mark.parametrize("offset", [-0.1, 0.0, 0.1])
def test_shape_behind_band_is_completed(shape, fraction, offset):
    labels, true, band = behind_band(shape, fraction, offset)
    c, relations, final = final_completion(labels)
    assert [(r.front, r.back) for r in relations] == [(1, 0)]
    completed = final.completed(0)
    assert iou(completed, true) >= 0.99
    invented = final.owner == 0
    assert invented.any()
    assert not (invented & ~band).any(), "invented pixels must lie inside the occluder"
    assert (final.hidden_by(0)[invented] == 1).all()
    # The band in front is not completed under the shape.
    assert not (final.owner == 1).any()


@pytest.mark.parametrize("fraction", [0.1, 0.25, 0.4])
def test_square_continues_straight_from_the_diffusion_alone(fraction):
    labels, true, band = behind_band("square", fraction, 0.0)
    c = complete_regions(labels)
    # Candidates: the square's pixels under the band are exactly the hidden ones.
    assert np.array_equal(c.owner[band] == 0, true[band])


def test_curvature_continuation_beats_the_chord():
    """The diffusion joins the ends of a circle by a nearly straight line; the
    curvature-continuing reshaping recovers the arc."""
    labels, true, band = behind_band("disk", 0.4, 0.0)
    c, relations, final = final_completion(labels)
    chord = iou(c.completed(0), true)
    arc = iou(final.completed(0), true)
    assert chord < 0.975 < 0.99 <= arc
    plain = c.ordered(relations, curvature=False)
    assert iou(plain.completed(0), true) == pytest.approx(chord)


def test_band_touching_the_frame_continues_straight():
    labels = np.full((80, 120), -1, np.int32)
    labels[20:60, 10:110] = 0
    labels[:, 50:70] = 1          # the band runs from frame to frame
    c = complete_regions(labels)
    rows = (np.arange(80) >= 20) & (np.arange(80) < 60)
    assert np.array_equal(c.owner[:, 50:70] == 0, np.repeat(rows[:, None], 20, axis=1))


def test_half_plane_contact_gives_the_thales_half_disk():
    """Harmonic measure of a segment on a straight edge is angle / pi: the 0.5
    level is the half circle over the segment (closed form)."""
    n = 401
    labels = np.full((n, n), 0, np.int32)
    labels[:, :200] = -1                       # region 0 occupies x >= 200
    labels[170:230, 199] = 1                   # region 1 touches it along 60 px
    c = complete_regions(labels, names=["big", "small"])
    invented = c.owner == 1
    ys, xs = np.nonzero(invented)
    r = np.hypot(xs - 199.5, ys - 199.5)
    assert invented.sum() == pytest.approx(np.pi * 30 ** 2 / 2, rel=0.08)
    assert r.max() < 32


def test_one_owner_per_pixel_and_only_neighbours():
    labels = np.full((60, 90), -1, np.int32)
    labels[10:50, 5:30] = 0
    labels[10:50, 30:60] = 1
    labels[10:50, 60:85] = 2
    labels[25:35, 35:55] = 3                   # inside region 1
    c = complete_regions(labels)
    assert c.neighbours == [[1], [0, 2, 3], [1], [1]]
    for a in range(4):
        owners = set(np.unique(c.owner[labels == a])) - {-1}
        assert owners <= set(c.neighbours[a])
    # Region 1 has three neighbours solved from one factorization: each gets candidates.
    assert set(np.unique(c.owner[labels == 1])) - {-1} == {0, 2, 3}
    for b in range(4):
        assert (c.completed(b) >= (labels == b)).all()
    assert (c.owner[labels < 0] == -1).all()


def test_two_crossings_are_two_places():
    labels = np.full((60, 120), -1, np.int32)
    labels[20:40, 5:115] = 0                   # a long bar
    labels[5:55, 30:40] = 1                    # crossed twice by the same region
    labels[5:55, 80:90] = 1
    c = complete_regions(labels)
    places = [p for p in c.places if (p.a, p.b) == (0, 1)]
    assert len(places) == 2
    assert places[0].site != places[1].site
    for p in places:
        assert len(p.junctions) == 4
        x, y = p.where
        assert labels[y, x] in (0, 1)


def test_enclosed_region_has_a_closed_place_without_junctions():
    labels = np.where((YY - 100) ** 2 + (XX - 100) ** 2 < 70 ** 2, 0, -1).astype(np.int32)
    labels[(YY - 90) ** 2 + (XX - 110) ** 2 < 15 ** 2] = 1
    c = complete_regions(labels)
    assert len(c.places) == 1 and c.places[0].junctions == []
    # The enclosing region's completion fills the enclosed one entirely.
    assert (c.owner[labels == 1] == 0).all()


def test_region_without_boundary_values_and_empty_labels():
    c = complete_regions(np.zeros((10, 10), np.int32))
    assert (c.owner == -1).all() and c.places == [] and c.neighbours == [[]]
    labels = np.full((10, 10), -1, np.int32)
    labels[2:5, 2:5] = 2                       # labels 0 and 1 are absent
    c = complete_regions(labels)
    assert c.names == ["region0", "region1", "region2"]
    assert (c.owner == -1).all()


def test_continue_outline_is_exact_for_straight_edges():
    labels, true, band = behind_band("square", 0.3, 0.05)
    owner = np.where(band & (YY > 60) & (YY < 140), 0, -1).astype(np.int32)  # a poor first guess
    assert continue_outline(labels, owner, 1, 0, (0, H, 0, W), owner == 0)
    assert np.array_equal(owner == 0, band & true)


def test_continue_outline_needs_an_outline():
    labels = np.where((YY - 100) ** 2 + (XX - 100) ** 2 < 70 ** 2, 0, -1).astype(np.int32)
    labels[(YY - 100) ** 2 + (XX - 100) ** 2 < 15 ** 2] = 1
    owner = np.where(labels == 0, 1, -1).astype(np.int32)
    before = owner.copy()
    assert not continue_outline(labels, owner, 0, 1, (0, H, 0, W), owner == 1)
    assert np.array_equal(owner, before)


@pytest.mark.parametrize("bad, message", [
    (np.zeros((4, 4), float), "integer"),
    (np.zeros((2, 3, 4), np.int32), "shape"),
    (np.full((4, 4), -3, np.int32), r"pixel \(0, 0\) has label -3"),
])
def test_bad_labels(bad, message):
    with pytest.raises(InputError, match=message):
        complete_regions(bad)


def test_bad_names_and_threshold():
    with pytest.raises(InputError, match="names"):
        complete_regions(np.array([[0, 1]], np.int32), names=["only"])
    with pytest.raises(InputError, match="threshold"):
        complete_regions(np.array([[0, 1]], np.int32), threshold=0.4)


def test_deterministic():
    labels, _, _ = behind_band("disk", 0.3, 0.1)
    a = final_completion(labels)[2]
    b = final_completion(labels)[2]
    assert np.array_equal(a.owner, b.owner)


def test_ordering_keeps_a_hidden_part_without_an_outline_of_its_own():
    # A disk (0) inside a region (1) that fills the image: the disk's outline meets
    # nothing but its occluder, so there is no outline to continue.
    from inkray.relief.ordering import Relation

    yy, xx = np.mgrid[:60, :60]
    labels = np.where((yy - 30) ** 2 + (xx - 30) ** 2 <= 10 ** 2, 0, 1).astype(np.int32)
    c = complete_regions(labels, names=["disk", "sheet"])
    place = next(p for p in c.places if (p.a, p.b) == (0, 1))
    over = Relation(front=1, back=0, front_name="sheet", back_name="disk", where=place.where,
                    source="user", confidence=1.0, place=place.index, entry=0)
    memo = {}
    first = c.ordered([over], memo=memo)
    assert list(memo.values()) == [None]       # nothing reshaped: the diffusion's part is kept
    assert np.array_equal(first.owner, c.ordered([over], curvature=False).owner)
    assert np.array_equal(c.ordered([over], memo=memo).owner, first.owner)


def test_the_occluder_system_is_the_box_laplacian_cut_to_its_pixels():
    # built on the occluder's pixels only, it must equal the whole box's Laplacian with
    # every other pixel fixed (1 for the column's label, 0 for any other)
    rng = np.random.default_rng(5)
    crop = np.pad(rng.integers(-1, 4, (30, 40)), 1, constant_values=_OUTSIDE)
    crop[5:25, 8:30] = 0
    inside = crop == 0
    nbrs = np.array([1, 3])
    system, rhs = _dirichlet_system(crop, inside, nbrs)
    valid = crop != _OUTSIDE
    lap = grid_laplacian(valid[:, :-1] & valid[:, 1:], valid[:-1, :] & valid[1:, :]).tocsr()
    unknown, known = np.flatnonzero(inside.ravel()), np.flatnonzero(~inside.ravel())
    values = (crop.ravel()[known][:, None] == nbrs[None, :]).astype(float)
    assert abs(system - lap[unknown][:, unknown]).max() == 0
    np.testing.assert_array_equal(rhs, -(lap[unknown][:, known] @ values))
    assert rhs.sum() > 0


def _bands_over_a_square():
    labels = np.full((60, 90), -1, np.int32)
    labels[5:55, 5:85] = 0
    for k in range(4):  # four bands over the big square, each its own occluder
        labels[:, 12 + 18 * k:20 + 18 * k] = k + 1
    return labels


def test_occluders_solved_together_give_what_one_after_another_gives():
    from scipy import ndimage

    from inkray.relief.completion import _complete_under

    labels = _bands_over_a_square()
    c = complete_regions(labels)
    owner = np.full(labels.shape, -1, np.int32)
    for a, box in enumerate(ndimage.find_objects(labels + 1, max_label=5)):
        _complete_under(labels, a, box, owner, 0.5, 4.0, None)
    assert (owner >= 0).sum() > 100
    np.testing.assert_array_equal(c.owner, owner)


def test_completion_progress_runs_in_region_order_and_stops_on_an_error():
    class Stop(Exception):
        pass

    seen = []

    class Watch:
        def update(self, done, total):
            seen.append((done, total))
            if done == 2:
                raise Stop

    with pytest.raises(Stop):
        complete_regions(_bands_over_a_square(), progress=Watch())
    assert seen == [(1, 5), (2, 5)]


def test_dirichlet_system_with_given_values_matches_the_indicators():
    from inkray.relief.completion import _OUTSIDE, _dirichlet_system

    labels = _bands_over_a_square()
    crop = np.pad(labels, 1, constant_values=_OUTSIDE)
    inside = crop == 0
    nbrs = np.arange(1, 5)
    system, rhs = _dirichlet_system(crop, inside, nbrs)
    values = (crop[..., None] == nbrs).astype(float)
    values[inside] = 7.0  # the unknowns' own entries are never read
    system2, rhs2 = _dirichlet_system(crop, inside, nbrs, lambda yy, xx: values[yy, xx])
    assert abs(system - system2).max() == 0
    np.testing.assert_array_equal(rhs, rhs2)


def test_coarse_to_fine_completion_moves_the_owner_by_at_most_a_pixel():
    from scipy import ndimage

    # A disc behind two slanted bars and a small square: curved level sets, contact ends.
    yy, xx = np.mgrid[:240, :300]
    labels = np.full(yy.shape, -1, np.int32)
    labels[(yy - 120) ** 2 + (xx - 150) ** 2 < 110 ** 2] = 0
    labels[abs((yy - 0.6 * xx) - 10) < 9] = 1
    labels[abs((yy + 0.9 * xx) - 330) < 7] = 2
    labels[150:175, 60:85] = 3
    exact = complete_regions(labels, coarse_above=None).owner
    coarse = complete_regions(labels, coarse_above=1000).owner
    owned = exact >= 0
    differ = exact != coarse
    assert owned.sum() > 3000
    assert differ.sum() < 0.01 * owned.sum()
    # every differing pixel lies beside a pixel of another owner in the exact result
    change = np.zeros(labels.shape, bool)
    for axis in (0, 1):
        d = np.diff(exact, axis=axis) != 0
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        change[tuple(lo)] |= d
        change[tuple(hi)] |= d
    assert not (differ & ~ndimage.binary_dilation(change)).any()


def _longest_axis_run(mask):
    """The longest horizontal or vertical run of pixels of ``mask``."""
    best = 0
    for m in (mask, mask.T):
        padded = np.pad(m, ((0, 0), (1, 1))).astype(np.int8)
        d = np.diff(padded, axis=1)
        starts, ends = np.nonzero(d == 1), np.nonzero(d == -1)
        if starts[0].size:
            best = max(best, int((ends[1] - starts[1]).max()))
    return best


def test_diverging_outline_closes_without_a_straight_cut():
    # An ear whose sides splay outwards where they enter the head in front of it: continued,
    # they never meet; the hidden part must close along a curve, not along the reshaping's window.
    labels = np.full((H, W), -1, np.int32)
    wedge = (YY >= 20) & (YY < 90) & (np.abs(XX - 100) <= 4 + 0.5 * (YY - 20))
    labels[wedge] = 0
    labels[(YY - 150) ** 2 + (XX - 100) ** 2 < 90 ** 2] = 1          # the head, in front
    c = complete_regions(labels, names=["ear", "head"])
    place = next(p for p in c.places if (p.a, p.b) == (0, 1))
    rel = [Relation(1, 0, "head", "ear", place.where, "user", 1.0, place=place.index)]
    hidden = c.ordered(rel).owner == 0
    plain = c.ordered(rel, curvature=False).owner == 0
    assert hidden.sum() > plain.sum()             # the splaying sides are continued
    outline = hidden & ~ndimage.binary_erosion(hidden | (labels == 0), border_value=1)
    contact = int((hidden & ndimage.binary_dilation(labels == 0)).sum())
    assert _longest_axis_run(outline) < 0.5 * contact, (_longest_axis_run(outline), contact)


def _strip_under_a_square():
    """Two bars hidden under a square (2) whose hidden ends stop 2 px short of each other."""
    labels = np.full((30, 40), -1, np.int32)
    labels[5:25, 10:30] = 2
    labels[10:20, :10] = 0
    labels[10:20, 30:] = 1
    owner = np.full(labels.shape, -1, np.int32)
    owner[10:20, 10:19] = 0
    owner[10:20, 21:30] = 1
    return labels, owner


def test_a_strip_between_two_hidden_parts_goes_to_the_one_behind():
    from inkray.relief.completion import close_gaps

    labels, owner = _strip_under_a_square()
    before = owner.copy()
    # bar 1 lies in front of bar 0 somewhere: what bar 1 uncovers as it moves is bar 0
    assert close_gaps(labels, owner, {(2, 0), (2, 1), (1, 0)}, width=6) > 0
    strip = (labels == 2) & (before < 0) & (owner >= 0)
    assert strip[11:19, 19:21].all() and (owner[strip] == 0).all()
    # nothing moves where a hidden part faces only the square, nor outside the square
    assert np.array_equal(owner[:10], before[:10]) and np.array_equal(owner[20:], before[20:])
    assert np.array_equal(owner[labels != 2], before[labels != 2])
    # without an order between the bars, each takes the side nearer to it
    labels, owner = _strip_under_a_square()
    close_gaps(labels, owner, {(2, 0), (2, 1)}, width=6)
    assert (owner[11:19, 19] == 0).all() and (owner[11:19, 20] == 1).all()


def test_closing_gaps_keeps_a_part_hidden_under_two_occluders_in_two_pieces():
    from inkray.relief.completion import close_gaps

    # region 0 hidden under 1 (left half) and under 2 (right half); the two pieces end a
    # pixel short of the 1|2 outline on both sides: the gap is not closed across it
    labels = np.full((30, 40), -1, np.int32)
    labels[:, :5] = 0
    labels[5:25, 5:20] = 1
    labels[5:25, 20:35] = 2
    owner = np.full(labels.shape, -1, np.int32)
    owner[10:20, 5:19] = 0
    owner[10:20, 21:35] = 0
    close_gaps(labels, owner, {(1, 0), (2, 0)}, width=6)
    pieces = ndimage.label(owner == 0)[1]
    assert pieces == 2


def test_ordered_completion_closes_gaps_by_default_and_not_with_zero():
    labels, true, band = behind_band("square", 0.3, 0.0)
    c = complete_regions(labels, names=["shape", "band"])
    relations, _ = depth_order([], labels, c)
    from inkray.relief.completion import GAP

    assert GAP > 0
    opened = c.ordered(relations, gap=0).owner
    closed = c.ordered(relations).owner
    # one hidden part, no other region near it: nothing to close
    assert np.array_equal(opened, closed)


def _junctions_one_block_at_a_time(labels):
    """Junction points as the definition reads: each 2x2 block with three labels, per pair."""
    found = {}
    h, w = labels.shape
    for y in range(h - 1):
        for x in range(w - 1):
            present = np.unique(labels[y:y + 2, x:x + 2])
            if present.size < 3:
                continue
            regions = present[present >= 0]
            for i, a in enumerate(regions):
                for b in regions[i + 1:]:
                    found.setdefault((int(a), int(b)), []).append((x, y))
    out = {}
    for pair, pts in found.items():
        img = np.zeros((h, w), bool)
        img[[p[1] for p in pts], [p[0] for p in pts]] = True
        comp, n = ndimage.label(img, structure=np.ones((3, 3)))
        out[pair] = [(float(cx) + 0.5, float(cy) + 0.5)
                     for cy, cx in ndimage.center_of_mass(img, comp, range(1, n + 1))]
    return out


def test_junction_points_match_the_block_by_block_definition():
    from inkray.relief.completion import _junction_points

    rng = np.random.default_rng(3)
    labels = np.kron(rng.integers(-1, 5, (12, 14)), np.ones((3, 3), int))
    labels[::7, ::5] = 2  # single pixels: blocks with four labels
    assert _junction_points(labels) == _junctions_one_block_at_a_time(labels)


def test_the_extrapolated_continuation_is_singular_exactly_when_cornered_here():
    from inkray.relief.completion import _cornered, _poisson_solve

    values = np.add.outer(np.arange(9.0), np.arange(11.0))
    for corner in range(4):
        hidden = np.zeros((9, 11), bool)
        ys = slice(0, 5) if corner < 2 else slice(4, 9)
        xs = slice(0, 6) if corner % 2 == 0 else slice(5, 11)
        hidden[ys, xs] = True
        assert _cornered(hidden)
        with pytest.raises(RuntimeError):
            _poisson_solve(values, hidden, 0.0, True)
        hidden[(1, 7)[corner // 2], (1, 9)[corner % 2]] = False  # the pixel diagonal to the corner
        assert not _cornered(hidden)
        x = _poisson_solve(values, hidden, 0.0, True)  # a linear function is reproduced
        np.testing.assert_allclose(x, values[hidden], atol=1e-9)


def test_distance_within_reach_is_the_full_transform_there():
    from inkray.relief.completion import _distance_within

    rng = np.random.default_rng(5)
    free = np.ones((60, 70), bool)
    free[20:26, 30:33] = rng.random((6, 3)) < 0.5
    full = ndimage.distance_transform_edt(free)
    near = _distance_within(free, 4.0)
    assert np.array_equal(near[full <= 4.0], full[full <= 4.0]) and (near[full > 4.0] > 4.0).all()


def _two_disks_under_a_bar():
    """Two disks side by side whose outlines meet under a bar in front of both."""
    yy, xx = np.mgrid[:120, :160]
    left = (xx - 52.0) ** 2 + (yy - 60.0) ** 2 <= 32 ** 2
    right = (xx - 108.0) ** 2 + (yy - 60.0) ** 2 <= 32 ** 2
    bar = (xx >= 66) & (xx < 94) & (yy >= 5) & (yy < 115)
    labels = np.full(bar.shape, -1, np.int32)
    labels[left], labels[right], labels[bar] = 0, 1, 2
    return labels, left, right, bar


def _user_orders(c, pairs):
    """A user's order relation per (front, back): at their place, else at none (apart)."""
    out = []
    for front, back in pairs:
        places = [p for p in c.places if {p.a, p.b} == {front, back}] or [None]
        for p in places:
            out.append(Relation(front, back, c.names[front], c.names[back],
                                (0.0, 0.0) if p is None else p.where, "user", 1.0,
                                place=None if p is None else p.index))
    return out


@pytest.mark.parametrize("front", [0, 1])
def test_two_parts_hidden_side_by_side_both_continue_under_the_other(front):
    from inkray.relief.cutout import stack_order

    labels, left, right, bar = _two_disks_under_a_bar()
    c = complete_regions(labels, names=["left", "right", "bar"])
    back = 1 - front
    relations = _user_orders(c, [(2, 0), (2, 1), (front, back)])
    o = c.ordered(relations)
    # The diffusion gives each pixel under the bar to one disk; their circles continued
    # overlap in a lens, kept by both: the one in front of the other in owner, the other
    # beneath it.
    assert (o.beneath == back).sum() > 100 and not (o.beneath == front).any()
    under = o.beneath >= 0
    assert (o.owner[under] == front).all() and (labels[under] == 2).all()
    order, _ = stack_order(c.count, relations)
    assert order.index(front) > order.index(back)
    # Each disk is completed whole under the bar, where the owner alone leaves one short.
    for region, disk in ((0, left), (1, right)):
        assert (o.completed(region) & disk & bar).sum() >= 0.99 * (disk & bar).sum()
    shorter = (o.owner == back) | (labels == back)
    truth = (left, right)[back]
    assert (shorter & truth & bar).sum() < 0.8 * (truth & bar).sum()
    # without the curvature there is no continuation, and no second layer
    assert not (c.ordered(relations, curvature=False).beneath >= 0).any()


def test_large_single_right_hand_sides_by_multigrid_match_the_factorization(monkeypatch):
    import inkray.relief.completion as completion

    # A disc behind a wide band (one neighbour each way) and its continuation under the band.
    yy, xx = np.mgrid[:200, :220]
    labels = np.full(yy.shape, -1, np.int32)
    labels[(yy - 100) ** 2 + (xx - 110) ** 2 < 90 ** 2] = 0
    labels[:, 80:150] = 1

    def run():
        c = complete_regions(labels)
        kept = c.ordered([Relation(1, 0, "band", "disc", p.where, "user", 1.0, place=p.index)
                          for p in c.places])
        return c.owner, kept.owner

    monkeypatch.setattr(completion, "COARSE_ABOVE", 10 ** 9)
    exact = run()
    monkeypatch.setattr(completion, "COARSE_ABOVE", 2000)  # the band and the disc: multigrid
    calls = []
    original = completion.multigrid_solve
    monkeypatch.setattr(completion, "multigrid_solve",
                        lambda *a, **k: calls.append(1) or original(*a, **k))
    fast = run()
    assert len(calls) >= 2
    assert (exact[1] >= 0).sum() > 3000
    for e, f in zip(exact, fast):
        np.testing.assert_array_equal(e, f)


def _thigh_on_a_disk():
    """A disk whose lower-left quadrant is a part of its own (a thigh folded against a
    body), cut from the rest across the paper by a graft along y = 100."""
    disk = (XX - 100.0) ** 2 + (YY - 100.0) ** 2 < 80 ** 2
    labels = np.where(disk, 0, -1).astype(np.int32)
    labels[disk & (YY >= 100) & (XX < 100)] = 1
    graft = np.array([[20.0, 100.0], [100.0, 100.0]])
    return labels, disk, graft


def test_a_graft_shares_the_round_silhouette_at_its_end():
    from inkray.relief.completion import shared_outlines

    labels, disk, graft = _thigh_on_a_disk()
    shared = shared_outlines(labels, [graft])
    # The thigh's silhouette (the quarter arc beyond the graft's end on it) continues the
    # body's outline to where the thigh ends; the body's continues the thigh's.
    beside = (labels < 0) & ndimage.binary_dilation(labels == 1)
    run = np.zeros(labels.shape, bool)
    run[tuple(shared[(1, 0)].T)] = True
    assert run.sum() >= 0.9 * beside.sum() and not (run & ~beside).any()
    assert (0, 1) in shared
    # A graft whose end lies off the silhouette shares nothing.
    assert shared_outlines(labels, [np.array([[60.0, 100.0], [100.0, 100.0]])]) == {}


def test_the_body_under_a_grafted_thigh_reaches_the_silhouette():
    labels, disk, graft = _thigh_on_a_disk()
    place = lambda c: next(p for p in c.places if (p.a, p.b) == (0, 1))  # noqa: E731
    completed = {}
    for grafts in ((), (graft,)):
        c = complete_regions(labels, names=["body", "thigh"], grafts=grafts)
        over = Relation(front=1, back=0, front_name="thigh", back_name="body",
                        where=place(c).where, source="user", confidence=1.0,
                        place=place(c).index, entry=0)
        completed[len(grafts)] = c.ordered([over]).completed(0)
    # The whole disk is the body's; without the graft the diffusion stops half-way across.
    assert iou(completed[1], disk) > 0.98
    assert iou(completed[0], disk) < 0.93


def test_a_straight_limb_below_a_round_body_keeps_its_own_outline():
    from inkray.relief.completion import shared_outlines

    # A bar hanging from a disk, its outer side running on tangent to the disk: the disk's
    # outline bends, the bar's runs straight, so the body does not follow it down.
    disk = (XX - 100.0) ** 2 + (YY - 70.0) ** 2 < 50 ** 2
    bar = (XX >= 50) & (XX < 90) & (YY >= 70) & (YY < 190)
    labels = np.where(disk, 0, -1).astype(np.int32)
    labels[bar] = 1
    shared = shared_outlines(labels, [np.array([[50.0, 70.0], [90.0, 70.0]])])
    run = shared.get((1, 0), np.zeros((0, 2), int))
    assert len(run) == 0 or run[:, 0].max() < 100
