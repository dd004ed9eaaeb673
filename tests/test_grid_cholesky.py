"""Tests of the nested-dissection multifrontal Cholesky of 5-point grid operators."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from inkray.errors import InputError, StageError
from inkray.numerics.grid import grid_operator
from inkray.numerics.grid_cholesky import GridCholesky


def _operator(h, w, seed=0, *, weak=0.0):
    """A grounded weighted grid Laplacian plus a small shift: SPD, with ink-like weak edges."""
    rng = np.random.default_rng(seed)
    wx = rng.uniform(0.5, 1.5, (h, w - 1))
    wy = rng.uniform(0.5, 1.5, (h - 1, w))
    if weak:
        wx[rng.random(wx.shape) < weak] = 1e-5
        wy[rng.random(wy.shape) < weak] = 1e-5
    diag = np.zeros((h, w))
    diag[:, :-1] += wx
    diag[:, 1:] += wx
    diag[:-1, :] += wy
    diag[1:, :] += wy
    diag += rng.uniform(0.0, 1e-3, (h, w))
    return diag, -wx, -wy


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (6, 1), (2, 2), (3, 7), (9, 4), (17, 33),
                                   (40, 41), (64, 5), (100, 77)])
def test_solve_matches_a_direct_sparse_solve(shape):
    diag, east, south = _operator(*shape, seed=shape[0] * 100 + shape[1], weak=0.05)
    A = grid_operator(diag, east, south).tocsc()
    b = np.random.default_rng(1).standard_normal((A.shape[0], 3))
    x = GridCholesky(diag, east, south).solve(b)
    ref = sla.spsolve(A, b)
    assert np.abs(x - ref).max() <= 1e-8 * max(1.0, np.abs(ref).max())
    assert np.abs(A @ x - b).max() < 1e-9


def test_solve_keeps_the_shape_of_the_right_hand_side():
    diag, east, south = _operator(5, 6)
    f = GridCholesky(diag, east, south)
    b = np.arange(30.0)
    assert f.solve(b).shape == (30,)
    assert np.allclose(f.solve(b[:, None])[:, 0], f.solve(b))


def test_exact_on_a_1d_closed_form():
    # The second difference with Dirichlet ends, -u'' = 1 on a path: u_i = i (n + 1 - i) / 2.
    n = 31
    f = GridCholesky(np.full((1, n), 2.0), -np.ones((1, n - 1)), np.zeros((0, n)))
    u = f.solve(np.ones(n))
    i = np.arange(1, n + 1)
    assert np.abs(u - i * (n + 1 - i) / 2).max() < 1e-10


@pytest.mark.parametrize("leaf", [1, 4, 16, 64])
def test_leaf_size_does_not_change_the_solution(leaf):
    diag, east, south = _operator(23, 31, seed=3)
    b = np.random.default_rng(2).standard_normal(23 * 31)
    x = GridCholesky(diag, east, south, leaf=leaf).solve(b)
    ref = GridCholesky(diag, east, south).solve(b)
    assert np.abs(x - ref).max() < 1e-10


def test_gram_is_the_inverse_quadratic_form_of_point_sources():
    h, w = 60, 45
    diag, east, south = _operator(h, w, seed=4, weak=0.1)
    f = GridCholesky(diag, east, south)
    rng = np.random.default_rng(5)
    B = np.zeros((h * w, 6))
    for k in range(6):
        p, q = rng.choice(h * w, 2, replace=False)
        B[p, k], B[q, k] = 1.0, -1.0
    G = f.gram(B)
    ref = B.T @ f.solve(B)
    assert np.allclose(G, G.T)
    assert np.abs(G - ref).max() <= 1e-10 * np.abs(ref).max()
    assert np.linalg.eigvalsh(G).min() > 0  # independent dipoles: positive definite
    # Sources that share fronts, one on the last pixel, given as a sparse matrix.
    B = np.zeros((h * w, 3))
    B[[5, 300], 0] = 1.0, -1.0
    B[[77, h * w - 1], 1] = 1.0, -1.0
    B[[5, 77], 2] = 1.0, -1.0
    ref = B.T @ f.solve(B)
    assert np.abs(f.gram(sp.csr_matrix(B)) - ref).max() <= 1e-10 * np.abs(ref).max()


def test_backward_completes_the_forward_substitution_of_point_sources():
    h, w = 57, 70
    diag, east, south = _operator(h, w, seed=8, weak=0.1)
    f = GridCholesky(diag, east, south)
    B = np.zeros((h * w, 4))
    B[[0, 1000, 2222, h * w - 1], [0, 1, 2, 3]] = 1.0
    B[[3000, 17, 2223, 5], [0, 1, 2, 3]] = -1.0
    fw = f.forward(B)
    coef = np.array([0.5, -2.0, 1.0, 3.0])
    ref = f.solve(B @ coef)
    assert np.abs(f.backward(fw, coef) - ref).max() <= 1e-10 * np.abs(ref).max()
    assert np.abs(fw.gram - B.T @ f.solve(B)).max() <= 1e-10 * np.abs(fw.gram).max()
    with pytest.raises(InputError, match="coef: expected 4"):
        f.backward(fw, coef[:3])


def _dirichlet(fixed, diag, east, south):
    """The operator with the ``fixed`` pixels' rows and columns made the identity,
    as the fast depth fill does."""
    return (np.where(fixed, 1.0, diag), np.where(fixed[:, :-1] | fixed[:, 1:], 0.0, east),
            np.where(fixed[:-1, :] | fixed[1:, :], 0.0, south))


def test_update_equals_a_fresh_factorization_and_redoes_only_a_window():
    h, w = 96, 80
    diag, east, south = _operator(h, w, seed=6, weak=0.05)
    f = GridCholesky(diag, east, south, updatable=True)
    fixed = np.zeros((h, w), bool)
    fixed[40:52, 30:44] = True
    d2, e2, s2 = _dirichlet(fixed, diag, east, south)
    redone = f.update(d2, e2, s2)
    total = f.fronts
    assert 0 < redone < total / 4
    b = np.random.default_rng(7).standard_normal(h * w)
    assert np.abs(f.solve(b) - GridCholesky(d2, e2, s2).solve(b)).max() < 1e-10
    assert f.update(d2, e2, s2) == 0  # nothing changed: nothing redone
    f.update(diag, east, south)  # and back
    assert np.abs(f.solve(b) - GridCholesky(diag, east, south).solve(b)).max() < 1e-10


def test_updates_in_sequence_that_redo_whole_groups_equal_fresh_factorizations():
    # A fixed row across the grid dirties every front it crosses, so groups of
    # large fronts are redone whole (in the arrays of the previous factorization).
    h, w = 130, 120
    diag, east, south = _operator(h, w, seed=8, weak=0.05)
    f = GridCholesky(diag, east, south, updatable=True)
    b = np.random.default_rng(9).standard_normal(h * w)
    for rows, cols in ((slice(60, 62), slice(None)), (slice(None), slice(33, 34)),
                       (slice(0, 0), slice(0, 0))):
        fixed = np.zeros((h, w), bool)
        fixed[rows, cols] = True
        d2, e2, s2 = _dirichlet(fixed, diag, east, south)
        f.update(d2, e2, s2)
        ref = GridCholesky(d2, e2, s2).solve(b)
        assert np.abs(f.solve(b) - ref).max() <= 1e-10 * np.abs(ref).max()


def test_update_of_given_rows_equals_the_update_that_compares_every_entry():
    h, w = 70, 90
    diag, east, south = _operator(h, w, seed=10, weak=0.05)
    hinted = GridCholesky(diag, east, south, updatable=True)
    full = GridCholesky(diag, east, south, updatable=True)
    b = np.random.default_rng(11).standard_normal(h * w)
    before = np.zeros((h, w), bool)
    for rows, cols in ((slice(10, 30), slice(5, 6)), (slice(0, 1), slice(None)),
                       (slice(69, 70), slice(80, 90)), (slice(0, 0), slice(0, 0))):
        fixed = np.zeros((h, w), bool)
        fixed[rows, cols] = True
        d2, e2, s2 = _dirichlet(fixed, diag, east, south)
        assert hinted.update(d2, e2, s2, rows=fixed ^ before) == full.update(d2, e2, s2)
        assert np.array_equal(hinted.solve(b), full.solve(b))
        before = fixed
    with pytest.raises(InputError, match="rows: shape"):
        hinted.update(diag, east, south, rows=np.zeros((h, w - 1), bool))


def test_kept_forward_substitution_follows_changes_of_the_factor_and_the_right_hand_side():
    # An updatable factorization redoes only the changed part of the last forward
    # substitution: after one or two updates, a local or a global change of the
    # right-hand side, and under pinning, it must agree with a fresh factorization.
    h, w = 60, 75
    diag, east, south = _operator(h, w, seed=12, weak=0.05)
    f = GridCholesky(diag, east, south, updatable=True)
    rng = np.random.default_rng(13)
    b = rng.standard_normal(h * w)
    before = np.zeros((h, w), bool)
    steps = [(slice(20, 40), slice(10, 11), False), (slice(5, 6), slice(0, 30), True),
             (slice(50, 52), slice(60, 70), False), (slice(0, 0), slice(0, 0), False)]
    for rows, cols, two in steps:
        fixed = before.copy()
        fixed[rows, cols] = True
        if two:  # two updates before the next solve
            f.update(*_dirichlet(fixed, diag, east, south), rows=fixed ^ before)
            before = fixed.copy()
            fixed[30:33, 40:45] = True
        op = _dirichlet(fixed, diag, east, south)
        f.update(*op, rows=fixed ^ before)
        b[rng.integers(0, h * w, 3)] += 1.0  # a local change
        fresh = GridCholesky(*op)
        for rhs in (b, rng.standard_normal(h * w)):
            ref = fresh.solve(rhs)
            assert np.abs(f.solve(rhs) - ref).max() <= 1e-10 * np.abs(ref).max()
        pins = [5, 700, 3001]
        ref = fresh.solve_pinned(b, pins, [1.0, -2.0, 0.5])
        assert np.abs(f.solve_pinned(b, pins, [1.0, -2.0, 0.5]) - ref).max() <= \
            1e-10 * np.abs(ref).max()
        before = fixed


def test_errors():
    diag, east, south = _operator(4, 5)
    with pytest.raises(StageError, match="not positive definite"):
        GridCholesky(-diag, east, south)
    with pytest.raises(InputError, match="updatable=True"):
        GridCholesky(diag, east, south).update(diag, east, south)
    f = GridCholesky(diag, east, south, updatable=True)
    with pytest.raises(InputError, match="differs from the factored"):
        f.update(np.ones((5, 4)), np.zeros((5, 3)), np.zeros((4, 4)))
    with pytest.raises(InputError, match="expected 20 rows"):
        f.solve(np.ones(19))
    with pytest.raises(InputError, match="non-empty"):
        GridCholesky(np.zeros((0, 3)), np.zeros((0, 2)), np.zeros((0, 3)))


def test_progress_reports_rising_percentages_up_to_100():
    diag, east, south = _operator(50, 60)
    seen = []

    class Recorder:
        def update(self, done, total):
            seen.append((done, total))

    GridCholesky(diag, east, south, progress=Recorder())
    assert seen[-1] == (100, 100) and len(seen) > 3
    assert all(a[0] < b[0] for a, b in zip(seen, seen[1:]))
