"""Depth from sparse (in)equalities: exact QP, fast approximation, outputs, CLI."""

import json
from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp
from PIL import Image

from inkray.input.annotations import Order, parse_annotations, rescale_annotations
from inkray.cli import main
from inkray.depthmap.estimation import DepthSession, depth, depth_constraints
from inkray.input.drawing import drawing_from_array
from inkray.errors import InputError
from inkray.input.loading import load_input
from inkray.depthmap.quadratic_program import GroundedLaplacian, constraint_cycle, solve_depth_qp
from inkray.numerics.grid import edge_weights, grid_laplacian
from inkray.input.scribbles import seed_image
from inkray.segmentation import lazybrush

from conftest import EXAMPLES, shared_drawing_names


def _ann(size, order=(), equal=(), **extra):
    doc = {"format": "inkray-annotations", "version": 1, "size": list(size),
           "order": [{"front": list(f), "back": list(b)} for f, b in order],
           "equal": [{"a": list(a), "b": list(b)} for a, b in equal]}
    doc.update(extra)
    return parse_annotations(doc)


def _line_image(h=40, w=60, col=30, width=3):
    gray = np.ones((h, w))
    gray[:, col - width // 2: col + width // 2 + 1] = 0.0
    return gray


# -- the exact QP ----------------------------------------------------------------

@pytest.mark.parametrize("method", ["exact", "fast"])
def test_ramp_in_an_ink_free_strip_is_linear(method):
    w = 101
    ann = _ann((w, 1), order=[((0, 0), (w - 1, 0))])
    d = depth(ann, np.ones((1, w)), method=method).depth[0]
    ramp = np.linspace(d[0], d[-1], w)
    assert d[0] - d[-1] >= 1.0 - 1e-9
    assert np.abs(d - ramp).max() < 0.01 * (d[0] - d[-1])


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_step_at_an_ink_line(method):
    gray = _line_image()
    ann = _ann((60, 40), order=[((10, 20), (50, 20))])
    d = depth(ann, gray, method=method).depth
    left, right = d[:, :27], d[:, 33:]
    # Each side is flat and the whole step of epsilon sits at the line.
    assert np.ptp(left) < 0.01 and np.ptp(right) < 0.01
    assert left.mean() - right.mean() == pytest.approx(1.0, abs=0.01)


def test_exact_meets_kkt_measured_independently():
    rng = np.random.default_rng(1)
    gray = _line_image(24, 30, col=12)
    gray[8, :] = 0.0
    h, w = gray.shape
    wx, wy, _ = edge_weights(gray)
    L = grid_laplacian(wx, wy)
    truth = rng.standard_normal(h * w)
    pts = rng.choice(h * w, size=(12, 2), replace=False)
    front = truth[pts[:, 0]] > truth[pts[:, 1]]
    p = np.where(front, pts[:, 0], pts[:, 1])
    q = np.where(front, pts[:, 1], pts[:, 0])
    # Two equalities between points no order relates.
    free = np.setdiff1d(np.arange(h * w), pts)[[0, 100, 200, 300]]
    p, q = np.r_[p, free[0], free[2]], np.r_[q, free[1], free[3]]
    ineq = np.r_[np.ones(12, bool), False, False]
    r = solve_depth_qp(L, p, q, ineq, epsilon=1.0, shape=(h, w))
    d, lam = r.depth, r.multipliers
    slack = d[p] - d[q] - np.where(ineq, 1.0, 0.0)
    ct = np.bincount(p, lam, minlength=h * w) - np.bincount(q, lam, minlength=h * w)
    assert slack[ineq].min() >= -1e-6 and np.abs(slack[~ineq]).max() <= 1e-6
    assert lam[ineq].min() >= -1e-9
    assert np.abs(lam * slack)[ineq].max() <= 1e-6
    assert np.abs(L @ d - ct).max() <= 1e-6 * max(1.0, np.abs(ct).max())
    assert abs(d.mean()) < 1e-9
    assert max(r.kkt.values()) <= 1e-6


def _osqp_solution(L, p, q, ineq, eps):
    osqp = pytest.importorskip("osqp")
    n, m = L.shape[0], len(p)
    C = sp.csc_matrix((np.tile([1.0, -1.0], m), (np.repeat(np.arange(m), 2),
                                                 np.stack([p, q], 1).ravel())), shape=(m, n))
    A = sp.vstack([C, sp.csc_matrix(np.ones((1, n)))]).tocsc()
    lo = np.r_[np.where(ineq, eps, 0.0), 0.0]
    hi = np.r_[np.where(ineq, np.inf, 0.0), 0.0]
    solver = osqp.OSQP()
    solver.setup(P=sp.triu(L).tocsc(), q=np.zeros(n), A=A, l=lo, u=hi, eps_abs=1e-10,
                 eps_rel=1e-10, max_iter=200000, polishing=True, verbose=False)
    res = solver.solve(raise_error=False)
    return res.x - res.x.mean()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_exact_matches_osqp_on_small_problems(seed):
    rng = np.random.default_rng(seed)
    h, w = 18, 22
    gray = np.ones((h, w))
    gray[rng.integers(0, h), :] = 0.1
    gray[:, rng.integers(0, w)] = 0.0
    gray = np.clip(gray + 0.05 * rng.random((h, w)), 0, 1)
    wx, wy, _ = edge_weights(gray)
    L = grid_laplacian(wx, wy)
    truth = rng.permutation(h * w)  # a total order, so the constraints are consistent
    pts = rng.choice(h * w, size=(10, 2), replace=False)
    p = np.where(truth[pts[:, 0]] > truth[pts[:, 1]], pts[:, 0], pts[:, 1])
    q = np.where(truth[pts[:, 0]] > truth[pts[:, 1]], pts[:, 1], pts[:, 0])
    # Redundant and dependent rows: a duplicate and an implied order.
    p, q = np.r_[p, p[0]], np.r_[q, q[0]]
    ineq = np.ones(len(p), bool)
    # One equality between two points that no order relates.
    free = np.setdiff1d(np.arange(h * w), np.r_[p, q])[:2]
    p, q, ineq = np.r_[p, free[0]], np.r_[q, free[1]], np.r_[ineq, False]
    ours = solve_depth_qp(L, p, q, ineq, epsilon=1.0, shape=(h, w)).depth
    ref = _osqp_solution(L, p, q, ineq, 1.0)
    assert np.abs(ours - ref).max() <= 1e-4 * np.abs(ref).max()


def test_dependent_equalities_and_orders():
    # Path of 5 nodes: equal(0,1), equal(1,2), equal(0,2) (a cycle of equalities is fine),
    # order(2,4) twice and order(0,4): all the same constraint in the end.
    L = grid_laplacian(np.ones((1, 4)), np.zeros((0, 5)))
    r = solve_depth_qp(L, [0, 1, 0, 2, 2, 0], [1, 2, 2, 4, 4, 4],
                       [False, False, False, True, True, True], epsilon=2.0)
    d = r.depth
    assert d[0] == pytest.approx(d[2], abs=1e-9)
    assert d[2] - d[4] == pytest.approx(2.0, abs=1e-9)
    assert max(r.kkt.values()) <= 1e-6


def test_grounded_laplacian_on_a_grid_and_as_a_graph():
    wx, wy, _ = edge_weights(np.random.default_rng(0).random((7, 9)))
    L = grid_laplacian(wx, wy)
    assert np.abs(L @ np.ones(63)).max() < 1e-12
    r = np.random.default_rng(1).standard_normal(63)
    r -= r.mean()
    p, q = np.array([3, 40, 62]), np.array([17, 5, 0])
    Ct = np.zeros((63, 3))
    Ct[p, np.arange(3)] += 1.0
    Ct[q, np.arange(3)] -= 1.0
    Hs = []
    for shape in ((7, 9), None):
        f = GroundedLaplacian(L, shape=shape)
        d = f.solve(r)
        assert np.abs(L @ d - r).max() < 1e-10 and d[f.ground] == 0.0
        H, primal = f.dual(p, q)
        assert np.allclose(H, Ct.T @ f.solve(Ct), atol=1e-10)
        lam = np.array([1.0, -0.5, 2.0])
        x = primal(lam)
        assert np.abs(x - f.solve(Ct @ lam)).max() < 1e-10 and x[f.ground] == 0.0
        Hs.append(H)
    assert np.allclose(Hs[0], Hs[1], atol=1e-10)
    with pytest.raises(InputError, match="not a 4-neighbour operator"):
        GroundedLaplacian(L, shape=(9, 7))


def test_default_sigma_is_the_mean_squared_contrast():
    gray = _line_image(10, 10, col=5, width=1)
    wx, wy, sigma = edge_weights(gray)
    dx2, dy2 = np.diff(gray, axis=1) ** 2, np.diff(gray, axis=0) ** 2
    assert sigma == pytest.approx((dx2.sum() + dy2.sum()) / (dx2.size + dy2.size))
    assert wx.min() == pytest.approx(np.exp(-1.0 / sigma)) and wy.min() == 1.0
    wx, _, _ = edge_weights(gray, sigma=0.01)
    assert wx.min() == 1e-5                            # the floor

# -- contradictions ----------------------------------------------------------------

def test_cycle_lists_the_entries():
    ann = _ann((20, 20), order=[((1, 1), (10, 10)), ((15, 3), (4, 4)), ((10, 10), (1, 1))])
    for method in ("exact", "fast"):
        with pytest.raises(InputError, match=r"^order\[0\] -> order\[2\] -> order\[0\]: "):
            depth(ann, np.ones((20, 20)), method=method)


def test_equality_joining_the_two_sides_of_an_order():
    ann = _ann((20, 20), order=[((1, 1), (10, 10))], equal=[((10, 10), (5, 5)), ((5, 5), (1, 1))])
    with pytest.raises(InputError, match=r"^order\[0\] -> equal\[0\] -> equal\[1\] -> order\[0\]"):
        depth(ann, np.ones((20, 20)))


def test_cycle_search_on_longer_chains():
    assert constraint_cycle([0, 1, 2, 3], [1, 2, 3, 1], [True, True, True, True]) == [1, 2, 3]
    assert constraint_cycle([0, 1], [1, 0], [False, False]) == []


def test_cli_contradiction_exits_2_and_writes_nothing(tmp_path):
    Image.fromarray(np.full((20, 30), 255, np.uint8)).save(tmp_path / "d.png")
    doc = {"format": "inkray-annotations", "version": 1, "drawing": "d.png", "size": [30, 20],
           "order": [{"front": [2, 2], "back": [20, 10]}, {"front": [20, 10], "back": [2, 2]}]}
    (tmp_path / "a.inkray.json").write_text(json.dumps(doc))
    out = tmp_path / "out"
    code = main(["--quiet", "depth", str(tmp_path / "a.inkray.json"), "-o", str(out / "d.png"),
                 "--npy", str(out / "d.npy")])
    assert code == 2
    assert not out.exists() or not any(out.iterdir())


# -- fast method and session -------------------------------------------------------

def test_session_add_remove_reuses_the_segmentation():
    gray = np.ones((40, 60))
    gray[:, 20] = 0.0
    gray[:, 40] = 0.0
    s = DepthSession(gray)
    a = s.add((10, 20), (30, 20))
    d1 = s.solve()
    labels = s.labels.copy()
    b = s.add((30, 20), (50, 20))            # new endpoint: only its segment is re-cut
    d2 = s.solve()
    assert d2[20, 10] > d2[20, 30] > d2[20, 50]
    assert (s.labels[:, :19] == labels[:, :19]).all()
    c = s.add((10, 20), (50, 20), label="order[9]")   # no new endpoint: same segments
    seg = s.labels.copy()
    s.solve()
    assert (s.labels == seg).all()
    s.remove(b)
    s.remove(c)
    assert np.allclose(s.solve(), d1, atol=1e-9)
    s.remove(a)
    with pytest.raises(InputError):
        s.remove(a)


def test_session_with_scribbles_keeps_regions():
    gray = np.ones((30, 60))
    gray[:, 30] = 0.0
    seeds = np.full((30, 60), -2, np.int32)
    seeds[15, 5:25] = 0
    seeds[15, 35:55] = 1
    s = DepthSession(gray, seeds=seeds)
    s.add((10, 5), (50, 25))
    d = s.solve()
    assert d[:, :29].min() - d[:, 32:].max() > 0.98
    s.add((50, 25), (12, 10))                  # left > right > left, at different points
    d = s.solve()                              # the left region is split in two parts
    assert d[5, 10] - d[25, 50] >= 1 - 1e-9 and d[25, 50] - d[10, 12] >= 1 - 1e-9
    assert len(np.unique(s.parts[:, :29])) == 2 and (s.labels[:, :29] == 0).all()
    s.add((12, 10), (10, 5), label="order[7]")  # closes a cycle of the points themselves
    with pytest.raises(InputError, match=r"^order\[0\] -> order\[1\] -> order\[7\] -> order\[0\]"):
        s.solve()


def _rings():
    """Two interlocking rings (bundled as examples/rings): a over b at the top crossing,
    b over a at the bottom."""
    return load_input(EXAMPLES / "rings" / "drawing.inkray.json")


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_interlocking_rings_have_two_local_orders(method):
    ann, drawing = _rings()
    d = depth(ann, drawing, method=method).depth
    p, q, _, _ = depth_constraints(ann)
    assert len(p) == 2 and (d.flat[p] - d.flat[q] >= 1 - 1e-6).all()


def test_fast_entry_inside_one_region_splits_it():
    ann, drawing = _rings()
    # Both points in ring_a, far apart along the ring, where no line is drawn.
    ann = replace(ann, order=ann.order + [Order(index=2, front=(67.0, 100.0), back=(125.0, 158.0))])
    r = depth(ann, drawing, method="fast")
    p, q, _, _ = depth_constraints(ann)
    assert (r.depth.flat[p] - r.depth.flat[q] >= 1 - 1e-6).all()
    ring_a = r.info["labels"].flat[p[2]], r.info["labels"].flat[q[2]]
    assert ring_a[0] != ring_a[1]                  # one part per point
    assert set(r.info["levels"]) >= set(ring_a)


def test_fast_still_names_a_real_cycle():
    ann, drawing = _rings()
    back = Order(index=2, front=ann.order[0].back, back=ann.order[0].front)
    with pytest.raises(InputError, match=r"^order\[0\] -> order\[2\] -> order\[0\]: contradictory"):
        depth(replace(ann, order=ann.order + [back]), drawing, method="fast")


def _three_boxes(gap=False):
    """Three inked boxes on paper, each with a region scribble: the drawing and the seeds.
    With ``gap`` the third box's top side has a gap (its depth then passes smoothly
    through it: a fill that needs a factorization)."""
    gray = np.ones((96, 128))
    seeds = np.full(gray.shape, -2, np.int32)
    for k, (y0, x0) in enumerate(((10, 10), (10, 70), (55, 40))):
        gray[y0, x0:x0 + 40] = gray[y0 + 30, x0:x0 + 40] = 0.0
        gray[y0:y0 + 31, x0] = gray[y0:y0 + 31, x0 + 40] = 0.0
        seeds[y0 + 15, x0 + 5:x0 + 35] = k
    if gap:
        gray[55, 56:64] = 1.0
    return gray, seeds


def test_session_updates_its_factorization_and_matches_a_fresh_solve():
    gray, seeds = _three_boxes(gap=True)
    s = DepthSession(gray, seeds=seeds)
    s.add((30, 25), (90, 25))
    s.solve()
    k = s.add((60, 70), (5, 90))                # the third box in front of the paper
    s.solve()                                   # factored afresh, keeping its updates
    s.remove(k)
    s.solve()
    s.add((60, 70), (5, 90))
    d = s.solve()                               # updated
    redone = s.refactored_fronts
    for incremental in (True, False):
        fresh = DepthSession(gray, seeds=seeds, incremental=incremental)
        fresh.add((30, 25), (90, 25))
        fresh.add((60, 70), (5, 90))
        assert np.abs(d - fresh.solve()).max() < 1e-9
    assert sum(u.nbytes for u in fresh._fills[False]._chol._updates if u is not None) == 0  # nothing kept
    assert 0 < redone < s._fills[False]._chol.fronts
    s.remove(k + 1)
    again = DepthSession(gray, seeds=seeds)
    again.add((30, 25), (90, 25))
    assert np.abs(s.solve() - again.solve()).max() < 1e-9


def _reduced(name, max_side=360):
    ann, drawing = load_input(f"{_shared()}/{name}/drawing.inkray.json")
    w, h = ann.size
    s = min(1.0, max_side / max(w, h))
    if s < 1:
        size = (round(w * s), round(h * s))
        rgb = np.asarray(Image.fromarray(drawing.rgb).resize(size, Image.LANCZOS))
        drawing = drawing_from_array(rgb)
        ann = rescale_annotations(ann, size)
    return ann, drawing


def _shared():
    from conftest import SHARED
    return SHARED


def _check_drawing(ann, drawing):
    p, q, ineq, _ = depth_constraints(ann)
    exact = depth(ann, drawing, method="exact")
    fast = depth(ann, drawing, method="fast")
    assert max(exact.info["kkt"].values()) <= 1e-6
    de, df = exact.depth.ravel(), fast.depth.ravel()
    assert (de[p] - de[q])[ineq].min() >= 1.0 - 1e-6
    assert np.abs(de[p] - de[q])[~ineq].max(initial=0.0) <= 1e-6
    # fast: the order of every constrained pair is right, and agrees with exact.
    assert ((df[p] - df[q])[ineq] > 0).all()
    assert (np.sign(df[p] - df[q]) == np.sign(de[p] - de[q]))[ineq].all()


@pytest.mark.parametrize("name", shared_drawing_names())
def test_constraints_hold_on_shared_drawings(name, shared_drawings):
    _check_drawing(*_reduced(name))


@pytest.mark.slow
@pytest.mark.parametrize("name", shared_drawing_names())
def test_constraints_hold_on_shared_drawings_full_size(name, shared_drawings):
    _check_drawing(*load_input(shared_drawings / name / "drawing.inkray.json"))


def test_cli_writes_all_outputs(tmp_path):
    gray = (_line_image(30, 40, col=20) * 255).astype(np.uint8)
    Image.fromarray(gray).save(tmp_path / "d.png")
    doc = {"format": "inkray-annotations", "version": 1, "drawing": "d.png", "size": [40, 30],
           "order": [{"front": [5, 15], "back": [35, 15]}]}
    (tmp_path / "a.inkray.json").write_text(json.dumps(doc))
    for method in ("exact", "fast"):
        out = tmp_path / method
        code = main(["--quiet", "depth", str(tmp_path / "a.inkray.json"), "-o", str(out / "d.png"),
                     "--method", method, "--epsilon", "2", "--npy", str(out / "d.npy"),
                     "--normals", str(out / "n.png"), "--shading", str(out / "s.png")])
        assert code == 0
        d = np.load(out / "d.npy")
        assert d[15, 5] - d[15, 35] >= 2.0 - 1e-6
        assert json.loads((out / "d.json").read_text())["method"] == method
        assert np.asarray(Image.open(out / "d.png")).dtype == np.uint16


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_no_orders_or_only_equalities_give_a_flat_map(method):
    for extra in ({}, {"equal": [{"a": [1, 1], "b": [15, 8]}]}):
        ann = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [20, 10],
                                 **extra})
        assert np.abs(depth(ann, np.ones((10, 20)), method=method).depth).max() == 0.0


def test_order_whose_points_round_to_one_pixel():
    ann = _ann((20, 10), order=[((1.2, 1), (1, 1.3))])
    pattern = r"^order\[0\]: front and back round to the same pixel \(1, 1\)"
    with pytest.raises(InputError, match=pattern):
        depth(ann, np.ones((10, 20)))


def test_bad_method_and_epsilon():
    ann = _ann((5, 5), order=[((0, 0), (4, 4))])
    with pytest.raises(InputError, match="method"):
        depth(ann, np.ones((5, 5)), method="slow")
    with pytest.raises(InputError, match="epsilon"):
        depth(ann, np.ones((5, 5)), epsilon=0)


def test_fast_chain_of_entries_inside_one_region():
    # A 30x200 strip of paper inside one ink frame and one scribble: six points along
    # it, each in front of the next, cut the region into six parts with rising levels.
    gray = np.ones((40, 220))
    gray[4, 5:215] = gray[35, 5:215] = 0.0
    gray[4:36, 5] = gray[4:36, 214] = 0.0
    seeds = np.full(gray.shape, -2, np.int32)
    seeds[20, 20:200] = 0
    xs = [20, 50, 80, 110, 140, 170]
    s = DepthSession(gray, seeds=seeds)
    for a, b in zip(xs, xs[1:]):
        s.add((a, 20), (b, 20))
    d = s.solve()
    assert all(d[20, a] - d[20, b] >= 1 - 1e-9 for a, b in zip(xs, xs[1:]))
    assert sorted(s.region_levels.values()) == [0, 1, 2, 3, 4, 5]
    assert len(np.unique(s.parts[10:30, 10:205])) == 6


def test_cli_fast_depth_of_interlocking_rings(tmp_path):
    ann = EXAMPLES / "rings" / "drawing.inkray.json"
    code = main(["--quiet", "depth", str(ann), "-o", str(tmp_path / "d.png"), "--method", "fast",
                 "--npy", str(tmp_path / "d.npy")])
    assert code == 0
    d = np.load(tmp_path / "d.npy")
    assert d[54, 160] - d[71, 145] >= 1 - 1e-6       # ring_a over ring_b at the top crossing
    assert d[146, 160] - d[129, 175] >= 1 - 1e-6     # ring_b over ring_a at the bottom one


def test_interactive_chain_splits_a_region_when_an_entry_is_added():
    from inkray.chain import ChainOptions, ReliefChain

    ann, drawing = _rings()
    chain = ReliefChain(ann, drawing, options=ChainOptions(depth_method="fast", interactive=True))
    before = chain.depth_map
    inside = Order(index=2, front=(67.0, 100.0), back=(125.0, 158.0))   # both in ring_a
    after = chain.edit(replace(ann, order=ann.order + [inside])).depth_map
    d = after.depth
    assert d[100, 67] - d[158, 125] >= 1 - 1e-6
    assert d[54, 160] - d[71, 145] >= 1 - 1e-6 and d[146, 160] - d[129, 175] >= 1 - 1e-6
    assert len(after.info["levels"]) == len(before.info["levels"]) + 1    # one more part


def test_session_pins_an_arrow_between_held_segments_without_refactoring():
    # The new arrow's segments already hold endpoints, so only its two
    # endpoint pixels become fixed.
    gray, seeds = _three_boxes()
    arrows = [((30, 25), (90, 25)), ((60, 70), (90, 30)), ((20, 35), (75, 80))]
    s = DepthSession(gray, seeds=seeds)
    for front, back in arrows[:2]:
        s.add(front, back)
    s.solve()
    s.add(*arrows[2])                       # the first box one level up, two new pixels
    d = s.solve()
    assert s.refactored_fronts == 0
    fresh = DepthSession(gray, seeds=seeds, incremental=False)
    for front, back in arrows:
        fresh.add(front, back)
    assert np.abs(d - fresh.solve()).max() < 1e-9
    assert d[35, 20] - d[80, 75] >= 1 - 1e-9 and d[35, 20] - d[25, 90] >= 2 - 1e-9


def test_fast_cuts_a_region_holding_both_points_of_an_entry_on_the_dragon():
    # The editor benchmark's first document of the dragon (its last order entry
    # and the last scribble of its most scribbled region left out): the
    # scribbles' segmentation then holds both points of order[15] in one
    # region, which the fast method must cut, not call a contradiction.
    ann, drawing = _reduced("dragon", max_side=585)
    most = max(range(len(ann.regions)), key=lambda i: len(ann.regions[i].scribbles))
    regions = list(ann.regions)
    regions[most] = replace(regions[most], scribbles=regions[most].scribbles[:-1])
    ann = replace(ann, regions=regions, order=ann.order[:-1])
    p, q, ineq, labels = depth_constraints(ann)
    k = labels.index("order[15]")
    scribbled = lazybrush(drawing.gray, seed_image(ann), frame_background=False)
    assert scribbled.flat[p[k]] == scribbled.flat[q[k]]
    r = depth(ann, drawing, method="fast")
    assert r.info["labels"].flat[p[k]] != r.info["labels"].flat[q[k]]
    d = r.depth.ravel()
    assert (d[p[ineq]] - d[q[ineq]] >= 1 - 1e-6).all()


def test_prepared_session_keeps_its_answers():
    gray, seeds = _three_boxes(gap=True)
    arrows = [((30, 25), (90, 25)), ((60, 70), (5, 90))]
    s = DepthSession(gray, seeds=seeds)
    for front, back in arrows:
        s.add(front, back)
    before = s.solve()
    assert not s._fills[False]._chol.updatable       # a cold solve keeps no update matrices
    assert s.prepare() and s._fills[False]._chol.updatable
    assert np.abs(s.solve() - before).max() < 1e-12
    fewer = np.where(seeds == 0, -2, seeds)
    s.reseed(fewer)
    d = s.solve()
    fresh = DepthSession(gray, seeds=fewer, incremental=False)
    for front, back in arrows:
        fresh.add(front, back)
    assert np.abs(d - fresh.solve()).max() < 1e-9
    assert not fresh.prepare()


def test_session_reseeded_keeps_its_factorization_and_matches_a_fresh_one():
    gray, seeds = _three_boxes(gap=True)
    arrows = [((30, 25), (90, 25)), ((60, 70), (5, 90))]
    s = DepthSession(gray, seeds=seeds)
    for front, back in arrows:
        s.add(front, back)
    s.solve()
    fronts = s._fills[False]._chol.fronts
    fewer = np.where(seeds == 0, -2, seeds)           # the first box's scribble removed
    s.reseed(fewer)
    d = s.solve()
    # The fixed pixels moved only around components they settle: nothing refactored.
    assert s.refactored_fronts < fronts
    fresh = DepthSession(gray, seeds=fewer, incremental=False)
    for front, back in arrows:
        fresh.add(front, back)
    assert np.abs(d - fresh.solve()).max() < 1e-9
    s.reseed(None)                                    # back to segments of the endpoints
    alone = DepthSession(gray)
    for front, back in arrows:
        alone.add(front, back)
    assert np.abs(s.solve() - alone.solve()).max() < 1e-9


def test_session_edits_on_a_bundled_drawing_match_fresh_solves():
    # Each order added one at a time to one session (refactoring where a region
    # gets its first endpoint, pinning otherwise, the forward substitution kept
    # between them), then the first removed: every solve equals a fresh one.
    ann, drawing = _reduced("frog", max_side=160)
    seeds = seed_image(ann)
    p, q, ineq, labels = depth_constraints(ann)
    s = DepthSession(drawing.gray, seeds=seeds)
    handles, paths = [], set()
    for i in range(len(p)):
        handles.append(s.add(p[i], q[i], inequality=bool(ineq[i]), label=labels[i]))
        d = s.solve()
        paths.add(s.refactored_fronts == 0)
        fresh = DepthSession(drawing.gray, seeds=seeds, incremental=False)
        for k in range(i + 1):
            fresh.add(p[k], q[k], inequality=bool(ineq[k]), label=labels[k])
        ref = fresh.solve()
        assert np.abs(d - ref).max() <= 1e-8 * np.abs(ref).max()
    assert paths == {True, False}  # both the pinned and the refactoring path ran
    s.remove(handles[0])
    fresh = DepthSession(drawing.gray, seeds=seeds, incremental=False)
    for k in range(1, len(p)):
        fresh.add(p[k], q[k], inequality=bool(ineq[k]), label=labels[k])
    ref = fresh.solve()
    assert np.abs(s.solve() - ref).max() <= 1e-8 * np.abs(ref).max()


def test_session_drafts_and_full_solves_keep_their_own_fills(monkeypatch):
    # A draft solves the fill at half resolution (here above 1000 pixels): the same
    # levels and fixed pixels, values close to the full fill's; draft and full
    # solves alternate without disturbing each other's kept factorization.
    from inkray.depthmap import estimation

    monkeypatch.setattr(estimation, "DRAFT_ABOVE", 1000)
    gray, seeds = _three_boxes(gap=True)
    s = DepthSession(gray, seeds=seeds)
    s.add((30, 25), (90, 25))
    s.solve(draft=True)
    s.add((60, 70), (5, 90))
    draft = s.solve(draft=True)              # the draft's own fill, updated for the new arrow
    levels = dict(s.region_levels)
    full = s.solve()
    assert s.region_levels == levels
    fresh = DepthSession(gray, seeds=seeds, incremental=False)
    fresh.add((30, 25), (90, 25))
    fresh.add((60, 70), (5, 90))
    assert np.abs(full - fresh.solve()).max() < 1e-9
    assert np.abs(draft - full).mean() < 0.02 * np.ptp(full)
    assert not np.array_equal(draft, full)
    assert np.array_equal(s.solve(draft=True), full)  # nothing changed: the full map
    s.add((30, 25), (90, 25))  # said again: the same fixed pixels and levels, solved again
    assert np.abs(s.solve(draft=True) - draft).max() < 1e-9  # both fills kept as they were
    assert np.abs(s.solve() - full).max() < 1e-9
    assert s.refactored_fronts == 0


def test_a_cold_draft_is_the_full_fill_when_the_fixed_values_settle_most_pixels(monkeypatch):
    # Closed boxes: every free component's fixed neighbours share one value, so
    # nothing is factored, and the first draft already is the exact fill.
    from inkray.depthmap import estimation

    monkeypatch.setattr(estimation, "DRAFT_ABOVE", 1000)
    gray, seeds = _three_boxes()
    s = DepthSession(gray, seeds=seeds)
    s.add((30, 25), (90, 25))
    draft = s.solve(draft=True)
    full = s.solve()
    assert set(s._fills) == {False} and s._fills[False].box is None  # no draft, no factor
    fresh = DepthSession(gray, seeds=seeds, incremental=False)
    fresh.add((30, 25), (90, 25))
    assert np.abs(fresh.solve() - draft).max() < 1e-9
    assert np.array_equal(draft, full)


def test_a_cold_solve_is_the_reduced_fill_and_prepare_makes_the_edits_exact(monkeypatch):
    # Above REDUCED_ABOVE pixels to solve and nothing factored yet, the fill comes from
    # the reduced system (quadtree blocks), close to the exact one; the cold draft is
    # that fill. prepare() factors the exact fill and the draft's, and the next edit's
    # draft and full map come from them.
    from inkray.depthmap import estimation

    monkeypatch.setattr(estimation, "DRAFT_ABOVE", 1000)
    monkeypatch.setattr(estimation, "REDUCED_ABOVE", 1000)
    gray, seeds = _three_boxes(gap=True)
    arrows = [((30, 25), (90, 25)), ((60, 70), (5, 90))]

    def exact(n):
        monkeypatch.setattr(estimation, "REDUCED_ABOVE", 10 ** 9)
        fresh = DepthSession(gray, seeds=seeds, incremental=False)
        for front, back in arrows[:n]:
            fresh.add(front, back)
        d = fresh.solve()
        monkeypatch.setattr(estimation, "REDUCED_ABOVE", 1000)
        return d

    s = DepthSession(gray, seeds=seeds)
    s.add(*arrows[0])
    draft = s.solve(draft=True)
    assert s._fills[False].reduced and set(s._fills) == {False}
    assert np.array_equal(s.solve(), draft) and s.refactored_fronts == 0
    assert 0 < np.abs(draft - exact(1)).max() < 0.02      # levels are 1 apart
    assert s.prepare() and set(s._fills) == {False, True}
    s.add(*arrows[1])
    draft = s.solve(draft=True)
    full = s.solve()
    assert not s._fills[False].reduced
    assert np.abs(full - exact(2)).max() < 1e-9
    assert not np.array_equal(draft, full) and np.abs(draft - full).mean() < 0.02 * np.ptp(full)


# -- the background behind the parts -------------------------------------------------

def _boxes_on_paper():
    """Two inked boxes side by side on paper and a third inside the first; regions a, b, c."""
    gray = np.ones((80, 120))
    for y0, x0, y1, x1 in ((20, 10, 60, 50), (20, 60, 60, 100), (30, 20, 45, 40)):
        gray[y0, x0:x1 + 1] = gray[y1, x0:x1 + 1] = 0.0
        gray[y0:y1 + 1, x0] = gray[y0:y1 + 1, x1] = 0.0
    regions = [{"name": "a", "scribbles": [[[15, 55], [45, 55]]]},
               {"name": "b", "scribbles": [[[70, 40], [90, 40]]]},
               {"name": "c", "scribbles": [[[25, 37], [35, 37]]]}]
    return gray, regions


@pytest.mark.parametrize("background", [False, True])
@pytest.mark.parametrize("method", ["exact", "fast"])
def test_background_is_behind_every_part_when_no_entry_mentions_it(method, background):
    gray, regions = _boxes_on_paper()
    # c over a over b: without the default the paper took the mean of a and b,
    # in front of b.
    extra = {"background": [[[5, 5], [115, 5]]]} if background else {}
    ann = _ann((120, 80), order=[((30, 38), (30, 50)), ((30, 50), (80, 40))], regions=regions,
               **extra)
    d = depth(ann, gray, method=method).depth
    paper = np.ones(gray.shape, bool)
    paper[20:61, 10:101] = False
    a, b, c = d[50, 15:45], d[25:55, 65:95], d[35:42, 25:36]
    assert d[paper].max() < min(a.min(), b.min(), c.min())
    if method == "fast":  # one level below b, the lowest part
        assert np.abs(d[paper] - (b.min() - 1)).max() < 1e-9


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_regions_without_any_entry_still_stand_in_front_of_the_background(method):
    # A new file in the editor: parts scribbled, no arrow yet. The map is not flat.
    gray, regions = _boxes_on_paper()
    d = depth(_ann((120, 80), regions=regions), gray, method=method).depth
    paper = np.ones(gray.shape, bool)
    paper[20:61, 10:101] = False
    a, b, c = d[50, 15:45], d[25:55, 65:95], d[35:42, 25:36]
    assert d[paper].max() + 0.5 < min(a.min(), b.min(), c.min())


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_an_entry_on_the_background_overrides_the_default(method):
    gray, regions = _boxes_on_paper()
    # The paper in front of b: the entry wins, no implicit order is added.
    ann = _ann((120, 80), order=[((30, 50), (80, 40)), ((5, 5), (80, 40))], regions=regions)
    d = depth(ann, gray, method=method).depth
    assert d[5, 5] - d[40, 80] >= 1 - 1e-6


def test_fill_weights_are_the_drawings_edge_weights_kept_for_that_array_only():
    from inkray.depthmap.estimation import fill_weights

    rng = np.random.default_rng(3)
    gray = rng.uniform(0.0, 1.0, (30, 40)).astype(np.float32)
    wx, wy = fill_weights(gray)
    ex, ey, _ = edge_weights(gray.astype(np.float64))
    assert np.array_equal(wx, ex) and np.array_equal(wy, ey)
    assert fill_weights(gray)[0] is wx  # kept for the same drawing
    other = gray.copy()
    other[:, 20] = 0.0
    ox, _ = fill_weights(other)  # another drawing: its own weights
    assert ox is not wx and not np.array_equal(ox, wx)
    # a session of the drawing answers as with weights of its own
    s = DepthSession(other)
    s.add((5, 10), (35, 10))
    kept = s.solve()
    fill_weights(gray)  # the kept entry is another drawing's now
    fresh = DepthSession(other)
    fresh.add((5, 10), (35, 10))
    assert np.array_equal(kept, fresh.solve())


def test_a_solve_with_nothing_changed_since_the_full_fill_is_that_answer():
    gray = np.ones((40, 60)); gray[5:, 30] = 0.0  # a line with a gap: one free component
    s = DepthSession(gray)
    k = s.add((10, 20), (50, 20))
    first = s.solve()
    again = s.solve(draft=True)  # small: the draft is the full fill; nothing changed
    assert np.array_equal(first, again) and again is not first
    again[:] = 7.0  # the caller's copy
    assert np.array_equal(s.solve(), first)
    s.remove(k)
    s.add((50, 20), (10, 20))  # the same endpoints the other way round
    flipped = s.solve()
    assert np.allclose(flipped, -first)
