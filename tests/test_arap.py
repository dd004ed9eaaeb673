import numpy as np
import pytest
import scipy.sparse as sp

from inkray.numerics.arap import Arap, arap, arap_energy, cotangent_weights, signed_areas


def grid(nx, ny, step=1.0):
    """A rectangle of (nx + 1) x (ny + 1) vertices, two triangles per cell, counter-clockwise."""
    xs, ys = np.meshgrid(np.arange(nx + 1) * step, np.arange(ny + 1) * step)
    v = np.column_stack([xs.ravel(), ys.ravel()])
    f = []
    for j in range(ny):
        for i in range(nx):
            a = j * (nx + 1) + i
            f += [[a, a + 1, a + nx + 2], [a, a + nx + 2, a + nx + 1]]
    return v, np.array(f)


def turn(points, angle, about=(0.0, 0.0)):
    c, s = np.cos(angle), np.sin(angle)
    p = np.asarray(points, float) - about
    return p @ np.array([[c, s], [-s, c]]) + about


def test_cotangent_laplacian_reproduces_linear_functions():
    v, f = grid(6, 4)
    w = cotangent_weights(v, f)
    # sum over faces of w * (u_j - u_i) at an interior vertex vanishes for u linear
    n = len(v)
    L = sp.lil_matrix((n, n))
    for t, face in enumerate(f):
        for k in range(3):
            i, j = face[(k + 1) % 3], face[(k + 2) % 3]
            L[i, j] -= w[t, k]
            L[j, i] -= w[t, k]
            L[i, i] += w[t, k]
            L[j, j] += w[t, k]
    u = 2.0 * v[:, 0] - 3.0 * v[:, 1]
    interior = (v[:, 0] > 0) & (v[:, 0] < 6) & (v[:, 1] > 0) & (v[:, 1] < 4)
    assert np.allclose((L.tocsr() @ u)[interior], 0.0)


def test_identity_when_handles_stay():
    v, f = grid(8, 3)
    out = Arap(v, f, handles=[0, 8, 35]).solve(v[[0, 8, 35]], iterations=5)
    assert np.allclose(out, v, atol=1e-10)


@pytest.mark.parametrize("angle", [0.3, 1.0, np.pi / 2, 2.5])
def test_rigid_bar_turned_by_two_handles_turns_rigidly(angle):
    v, f = grid(20, 2)
    handles = [0, 20]
    targets = turn(v[handles], angle, about=(3.0, -2.0)) + [5.0, 1.0]
    out = Arap(v, f, handles=handles).solve(targets, iterations=10)
    assert np.allclose(out, turn(v, angle, about=(3.0, -2.0)) + [5.0, 1.0], atol=1e-8)
    assert arap_energy(v, f, out) < 1e-16


def test_handles_are_met_exactly_at_barycentric_points():
    v, f = grid(10, 10)
    # a handle inside face 37 and one on a vertex
    bary = np.array([0.2, 0.3, 0.5])
    row = np.zeros(len(v))
    row[f[37]] = bary
    C = sp.csr_matrix(np.vstack([row, np.eye(len(v))[0]]))
    targets = np.array([[14.0, 3.0], [-2.0, 1.0]])
    solver = Arap(v, f, handles=C)
    out = solver.solve(targets, iterations=6)
    assert np.abs(C @ out - targets).max() < 1e-9
    again = solver.solve(targets + 0.5, iterations=2)  # a drag: the same factorization
    assert np.abs(C @ again - (targets + 0.5)).max() < 1e-9


def test_limb_swung_sixty_degrees_does_not_fold():
    # an L: a body (fixed by two handles) and an arm swung about its joint
    v, f = grid(30, 4)
    body = [0, 4 * 31, 10 + 4 * 31]
    tip = 30 + 2 * 31
    joint = np.array([10.0, 2.0])
    for angle in (np.radians(60), -np.radians(60)):
        targets = np.vstack([v[body], turn(v[[tip]], angle, about=joint)])
        solver = Arap(v, f, handles=body + [tip])
        out = solver.solve(targets, iterations=40)
        assert np.all(signed_areas(out, f) > 0)
        assert np.abs(out[body + [tip]] - targets).max() < 1e-9


def _two_grids():
    """Two 4x2 grids overlapping over x in [3, 4]; ``at(mesh, point)`` finds a vertex."""
    a, fa = grid(4, 2)
    b, fb = grid(4, 2)
    b = b + [3.0, 0.0]
    v = np.vstack([a, b])
    f = np.vstack([fa, fb + len(a)])

    def at(mesh, point):
        own = a if mesh == 0 else b
        return mesh * len(a) + int(np.flatnonzero((own == point).all(1))[0])

    handles = [0, len(a) + 14]   # a's first vertex, b's far corner
    return v, f, at, handles, v[handles] + [[0, 0], [0, 6]]


def test_glue_rows_keep_two_meshes_together():
    v, f, at, handles, targets = _two_grids()
    # b's vertices at (3, 1) and (4, 1) equal a's there: glue rows e_b - e_a
    ia, ib, ja, jb = at(0, [3, 1]), at(1, [3, 1]), at(0, [4, 1]), at(1, [4, 1])
    G = sp.csr_matrix(([1.0, -1.0, 1.0, -1.0], ([0, 0, 1, 1], [ib, ia, jb, ja])), shape=(2, len(v)))
    soft = Arap(v, f, handles=handles, glue=G, exact_glue=False).solve(targets, iterations=30)
    assert 1e-3 < np.abs(G @ soft).max() < 0.3  # held together, loosely
    exact = Arap(v, f, handles=handles, glue=G)
    out = exact.solve(targets, iterations=30)
    assert exact.glue_held.all() and np.abs(G @ out).max() < 1e-9   # held exactly
    assert np.abs(exact.handles @ out - targets).max() < 1e-9
    loose = Arap(v, f, handles=handles).solve(targets, iterations=30)
    assert np.abs(G @ loose).max() > 1.0        # without glue b leaves a


def test_free_piece_without_handle_is_refused_unless_fixed():
    v, f = grid(3, 3)
    w = np.vstack([v, v + [10, 0]])
    g = np.vstack([f, f + len(v)])
    with pytest.raises(ValueError, match="no handle"):
        Arap(w, g, handles=[0]).solve(w[[0]])
    out = Arap(w, g, handles=[0], fixed=np.arange(len(v), 2 * len(v))).solve([[1.0, 1.0]])
    assert np.allclose(out[len(v):], w[len(v):])


def test_arap_one_shot_and_translation():
    v, f = grid(3, 2)
    out = arap(v, f, [0, 3], v[[0, 3]] + [2.0, -1.0])
    assert np.allclose(out, v + [2.0, -1.0])


def test_bad_input():
    v, f = grid(2, 2)
    with pytest.raises(ValueError, match="faces"):
        Arap(v, f + 100, handles=[0])
    with pytest.raises(ValueError, match="targets"):
        Arap(v, f, handles=[0, 1]).solve([[0.0, 0.0]])


def test_glue_rows_that_clash_stay_weighted():
    v, f, at, handles, targets = _two_grids()
    ia, ib, ja, jb = at(0, [3, 1]), at(1, [3, 1]), at(0, [4, 0]), at(1, [4, 0])
    # two rows on distinct vertices, then the first once more: its vertex is already solved for
    G = sp.csr_matrix(([1.0, -1.0, 1.0, -1.0, 1.0, -1.0], ([0, 0, 1, 1, 2, 2],
                                                           [ib, ia, ja, jb, ib, ia])),
                      shape=(3, len(v)))
    solver = Arap(v, f, handles=handles, glue=G)
    out = solver.solve(targets, iterations=30)
    # the repeated row stays weighted, and vanishes all the same
    assert solver.glue_held.tolist() == [True, True, False]
    assert np.abs(G @ out).max() < 1e-9


def _square_pushed():
    v, f = grid(6, 6)
    handles = [0, 7, 14, 21, 28, 35, 42, 24]  # the left side, and the centre
    return v, f, handles, np.vstack([v[handles[:-1]], [[0.5, 3.0]]])


def test_the_injective_solve_folds_no_face_where_the_plain_one_does_and_meets_the_handles():
    v, f, handles, targets = _square_pushed()
    solver = Arap(v, f, handles=handles)
    assert np.sum(signed_areas(solver.solve(targets, iterations=60), f) <= 0) > 0
    out = solver.solve_injective(targets, initial=v)
    assert np.all(signed_areas(out, f) > 0)
    assert np.allclose(out[handles], targets, atol=1e-4)
    assert np.array_equal(solver.pose, out)
    # the left side is held: the pushed centre compresses the square's left half
    assert out[24, 0] == pytest.approx(0.5, abs=1e-4) and np.all(out[:, 0] > -1e-9)


def test_the_injective_solve_keeps_a_pose_that_meets_its_handles_and_refuses_a_folded_start():
    v, f = grid(8, 3)
    solver = Arap(v, f, handles=[0, 8, 35])
    assert np.allclose(solver.solve_injective(v[[0, 8, 35]], initial=v), v, atol=1e-10)
    folded = v.copy()
    folded[10] = [5.0, -3.0]  # an interior vertex pulled across the bottom edge
    assert np.any(signed_areas(folded, f) < 0)
    with pytest.raises(ValueError, match="initial"):
        solver.solve_injective(v[[0, 8, 35]], initial=folded)


def test_first_flip_is_where_a_corner_crosses_the_opposite_edge():
    from inkray.numerics.arap import _first_flip

    v = np.array([[0.0, 0], [2, 0], [0, 2]])
    f = np.array([[0, 1, 2]])
    step = np.zeros((3, 2))
    step[2] = [0.0, -4.0]  # the apex reaches the base at a = 0.5
    assert _first_flip(v, f, np.array([1.0]), step) == pytest.approx(0.5)
    step[2] = [0.0, 4.0]  # away from it: never
    assert _first_flip(v, f, np.array([1.0]), step) == np.inf


def test_a_reweighted_solver_solves_as_one_built_with_those_stiffnesses():
    # exact glue and a handle inside a face: both substituted in the reweighted system
    v, f, at, handles, targets = _two_grids()
    ia, ib, ja, jb = at(0, [3, 1]), at(1, [3, 1]), at(0, [4, 1]), at(1, [4, 1])
    G = sp.csr_matrix(([1.0, -1.0, 1.0, -1.0], ([0, 0, 1, 1], [ib, ia, jb, ja])), shape=(2, len(v)))
    corners = f[5]
    H = sp.csr_matrix(([1.0, 0.2, 0.3, 0.5], ([0, 1, 1, 1], [handles[0], *corners])),
                      shape=(2, len(v)))
    to = np.vstack([targets[0], v[corners].T @ [0.2, 0.3, 0.5] + [1.0, 4.0]])
    k = np.linspace(1.0, 3.0, len(f))
    solver = Arap(v, f, handles=H, glue=G, stiffness=k)
    x = solver.solve(to, iterations=3, initial=v)
    for other in (k, 2.0 * k[::-1]):
        fresh = Arap(v, f, handles=H, glue=G, stiffness=other)
        got = solver._reweighted(other).solve(to, iterations=3, initial=v)
        assert np.allclose(got, fresh.solve(to, iterations=3, initial=v), atol=1e-9)
        assert np.abs(H @ got - to).max() < 1e-9 and np.abs(G @ got).max() < 1e-9
    assert not np.allclose(got, x)
    assert solver._stiffening is not None  # the maps, not the assembly


def test_compression_weights_grow_as_a_face_flattens():
    from inkray.numerics.arap import _compression_weights

    v = np.array([[0.0, 0], [1, 0], [0, 1]])
    f = np.array([[0, 1, 2]])
    s = np.array([1.0, 0.5, 0.1])
    # squashed along y to s: (s + 1)(s^2 + 1) / (4 s^3); stretched faces weigh 1
    squashed = [_compression_weights(v, f, v * [1.0, si])[0] for si in s]
    assert np.allclose(squashed, np.maximum((s + 1) * (s * s + 1) / (4 * s ** 3), 1.0))
    assert _compression_weights(v, f, turn(v, 0.7) * 2.0)[0] == 1.0
