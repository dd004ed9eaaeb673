"""The harmonic fill: the full grid's against a sparse direct solve, updates against
fresh factorizations, and the half-resolution draft against the full fill."""

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from scipy import ndimage

from inkray.errors import InputError
from inkray.numerics.grid import edge_weights, grid_laplacian
from inkray.numerics.harmonic_fill import PINNED, DraftFill, HarmonicFill


def _reference(wx, wy, fixed, values):
    """The Dirichlet problem by a sparse direct solve of the free pixels' equations."""
    L = grid_laplacian(wx, wy).tocsr()
    free = ~fixed.ravel()
    v = np.where(fixed, values, 0.0).ravel()
    d = v.copy()
    d[free] = spla.spsolve(L[free][:, free].tocsc(), -L[free][:, ~free] @ v[~free])
    return d.reshape(fixed.shape)


def _rings(h=120, w=150):
    """Paper with an ink circle and an ink square; fixed pixels on both sides of
    each outline, the circle's inside at 2, the square's inside at 1, outside 0."""
    yy, xx = np.mgrid[0:h, 0:w]
    r = np.hypot(yy - 60, xx - 50)
    circle = np.abs(r - 30) <= 1.5
    square = np.zeros((h, w), bool)
    square[20:100, 95:140] = True
    square[23:97, 98:137] = False
    gray = np.where(circle | square, 0.0, 1.0)
    fixed = np.zeros((h, w), bool)
    values = np.zeros((h, w))
    inside_c = ndimage.binary_dilation(circle) & ~circle & (r < 30)
    outside_c = ndimage.binary_dilation(circle) & ~circle & (r > 30)
    inner = np.zeros((h, w), bool)
    inner[23:97, 98:137] = True
    inside_s = ndimage.binary_dilation(square) & ~square & inner
    fixed |= inside_c | outside_c | inside_s
    values[inside_c] = 2.0
    values[inside_s] = 1.0
    return gray, fixed, values


def test_fill_matches_a_sparse_direct_solve():
    rng = np.random.default_rng(3)
    gray = rng.random((23, 31))
    wx, wy, _ = edge_weights(gray)
    fixed = rng.random(gray.shape) < 0.05
    values = rng.normal(size=gray.shape)
    d = HarmonicFill(wx, wy).solve(fixed, values)
    assert np.abs(d - _reference(wx, wy, fixed, values)).max() < 1e-9
    assert np.array_equal(d[fixed], values[fixed])


def test_updates_match_fresh_factorizations():
    gray, fixed, values = _rings()
    wx, wy, _ = edge_weights(gray)
    fill = HarmonicFill(wx, wy)
    fill.solve(fixed, values)
    full = fill.refactored_fronts
    # A few more fixed pixels: pinned by point sources, nothing refactored.
    pins = fixed.copy()
    pins[5, 5:5 + PINNED // 2] = True
    d = fill.solve(pins, values)
    assert fill.refactored_fronts == 0
    assert np.abs(d - HarmonicFill(wx, wy, incremental=False).solve(pins, values)).max() < 1e-9
    # The square's inside freed: pinning cannot follow, so the fill factors afresh,
    # keeping the update matrices from now on.
    moved = fixed & (values != 1.0)
    d = fill.solve(moved, values)
    assert fill.refactored_fronts == full and fill._chol.updatable
    assert np.abs(d - _reference(wx, wy, moved, values)).max() < 1e-9
    # Fixed again: only the square's fronts and their ancestors refactored.
    d = fill.solve(fixed, values)
    assert 0 < fill.refactored_fronts < full
    assert np.abs(d - _reference(wx, wy, fixed, values)).max() < 1e-9
    # A fill that factors afresh every time keeps no update matrices.
    once = HarmonicFill(wx, wy, incremental=False)
    once.solve(fixed, values)
    once.solve(moved, values)
    assert not once._chol.updatable


@pytest.mark.parametrize("background", [False, True])
def test_prepared_fill_updates_its_first_change(background):
    gray, fixed, values = _rings()
    wx, wy, _ = edge_weights(gray)
    fill = HarmonicFill(wx, wy)
    cold = fill.solve(fixed, values)
    full = fill.refactored_fronts
    assert not fill._chol.updatable
    assert fill.prepare(background=background)
    assert not fill.prepare(background=background)      # already prepared or under way
    # A few more fixed pixels: pinned, whether or not the new factorization is done.
    pins = fixed.copy()
    pins[5, 5:25] = True
    d = fill.solve(pins, values)
    assert fill.refactored_fronts == 0
    assert np.abs(d - _reference(wx, wy, pins, values)).max() < 1e-9
    # The square's inside freed: the first change pinning cannot follow is an update.
    moved = fixed & (values != 1.0)
    d = fill.solve(moved, values)
    assert fill._chol.updatable and 0 < fill.refactored_fronts < full
    assert np.abs(d - _reference(wx, wy, moved, values)).max() < 1e-9
    assert np.abs(fill.solve(fixed, values) - cold).max() < 1e-9


def test_a_change_outside_the_box_stops_the_prepare():
    gray, fixed, values = _rings()
    wx, wy, _ = edge_weights(gray)
    inner = fixed.copy()
    inner[:, :90] = True                                 # only the square's side is left
    fill = HarmonicFill(wx, wy)
    fill.solve(inner, values)
    cold = fill.box
    assert cold[2] >= 90 and fill.prepare(background=True)
    d = fill.solve(fixed, values)                        # the circle's side too: a new box
    assert fill._preparing is None and fill.box != cold and fill._chol.updatable
    assert np.abs(d - _reference(wx, wy, fixed, values)).max() < 1e-9
    # A fill that keeps nothing has nothing to prepare.
    once = HarmonicFill(wx, wy, incremental=False)
    once.solve(fixed, values)
    assert not once.prepare()


@pytest.mark.parametrize("background", [False, True])
def test_a_cold_reduced_solve_is_close_and_prepare_makes_the_next_ones_exact(background):
    gray, fixed, values = _rings()
    wx, wy, _ = edge_weights(gray)
    fill = HarmonicFill(wx, wy, reduced_above=1000)
    assert fill.reduces(fixed, values)
    d = fill.solve(fixed, values)
    # The reduced system: no factorization kept, within a small part of the levels' step 1.
    assert fill.reduced and fill.fronts == 0
    assert 0 < np.abs(d - _reference(wx, wy, fixed, values)).max() < 0.02
    assert np.array_equal(d[fixed], values[fixed])
    pins = fixed.copy()
    pins[5, 5:25] = True
    d = fill.solve(pins, values)                         # nothing to reuse yet: reduced again
    assert fill.reduced and np.abs(d - _reference(wx, wy, pins, values)).max() < 0.02
    # prepare() factors the exact system of the last solve's fixed values.
    assert fill.prepare(background=background)
    if background:
        # Reduced while the prepare runs (which goes on: the box fits), or pinned once done.
        d = fill.solve(pins, values)
        assert np.abs(d - _reference(wx, wy, pins, values)).max() < 0.02
        preparing = fill._preparing
        if preparing is not None:
            preparing[0].join()
    assert not fill.reduces(pins, values)
    d = fill.solve(pins, values)
    assert not fill.reduced and fill.refactored_fronts == 0 and fill._chol.updatable
    assert np.abs(d - _reference(wx, wy, pins, values)).max() < 1e-9
    moved = fixed & (values != 1.0)                      # the square's inside freed: an update
    d = fill.solve(moved, values)
    assert 0 < fill.refactored_fronts < fill.fronts
    assert np.abs(d - _reference(wx, wy, moved, values)).max() < 1e-9
    # Without incremental every large solve is reduced, and nothing is prepared.
    once = HarmonicFill(wx, wy, incremental=False, reduced_above=1000)
    once.solve(fixed, values)
    assert once.reduced and not once.prepare()
    # Below the threshold the cold solve is exact.
    small = HarmonicFill(wx, wy, reduced_above=gray.size)
    assert np.abs(small.solve(fixed, values) - _reference(wx, wy, fixed, values)).max() < 1e-9
    assert not small.reduced


def test_draft_is_close_to_the_full_fill_and_keeps_the_steps():
    gray, fixed, values = _rings()
    wx, wy, _ = edge_weights(gray)
    full = HarmonicFill(wx, wy).solve(fixed, values)
    draft = DraftFill(wx, wy).solve(fixed, values)
    assert np.array_equal(draft[fixed], values[fixed])
    err = np.abs(draft - full)
    assert err.mean() < 0.02 * np.ptp(full)
    paper = gray > 0.5
    assert np.percentile(err[paper], 99) < 0.05 * np.ptp(full)
    # Across the circle's ink the step stays whole: no level bleeds over the line.
    yy, xx = np.mgrid[0:gray.shape[0], 0:gray.shape[1]]
    r = np.hypot(yy - 60, xx - 50)
    assert np.abs(draft[(r > 24) & (r < 27)] - 2.0).max() < 0.05
    assert np.abs(draft[(r > 33) & (r < 36) & (xx < 90)]).max() < 0.05


def test_draft_updates_match_a_fresh_draft():
    gray, fixed, values = _rings(121, 151)  # odd sizes: the last blocks are half blocks
    draft = DraftFill(*edge_weights(gray)[:2])
    draft.solve(fixed, values)
    moved = fixed & (values != 1.0)
    d = draft.solve(moved, values)
    assert 0 < draft.refactored_fronts
    assert np.abs(d - DraftFill(*edge_weights(gray)[:2], incremental=False).solve(moved, values)).max() < 1e-9
    assert d.shape == gray.shape


def test_bad_inputs_are_one_line_errors():
    with pytest.raises(InputError, match="wx, wy: expected shapes"):
        HarmonicFill(np.ones((3, 4)), np.ones((3, 5)))
    with pytest.raises(InputError, match="positive"):
        HarmonicFill(np.zeros((3, 4)), np.ones((2, 5)))
    fill = HarmonicFill(np.ones((3, 4)), np.ones((2, 5)))
    with pytest.raises(InputError, match="fixed, values: expected shape"):
        fill.solve(np.zeros((4, 5), bool), np.zeros((4, 5)))
    with pytest.raises(InputError, match="wx, wy"):
        DraftFill(np.ones((3, 4)), np.ones((3, 5)))


def test_the_kept_settle_follows_changed_values_on_the_same_fixed_pixels():
    # pending() and reduces() settle the fixed values and keep it for solve(); new
    # values on the same pixels must not reuse it
    fill = HarmonicFill(np.ones((6, 9)), np.ones((5, 10)), reduced_above=10)
    fixed = np.zeros((6, 10), bool)
    fixed[:, [0, 4, 9]] = True
    flat = np.where(fixed, 2.0, 0.0)
    assert fill.pending(fixed, flat) == 0 and not fill.reduces(fixed, flat)
    assert (fill.solve(fixed, flat) == 2.0).all()          # every room settles at 2
    ramp = np.where(fixed, np.arange(10.0), 0.0)
    assert fill.pending(fixed, ramp) == 6 * 8 and fill.reduces(fixed, ramp)  # columns 1-8
    d = fill.solve(fixed, ramp)
    assert np.allclose(d, np.arange(10.0))                  # linear between the columns
    assert (fill.solve(fixed, flat) == 2.0).all()          # and back
