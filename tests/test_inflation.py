"""Poisson inflation against closed forms: disk, long strip, mirror symmetry, scaling."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.interpolate import LinearNDInterpolator

from inkray.errors import InputError, StageError
from inkray.relief.inflation import (MAX_SLOPE, WALL_INSET, InflationSolver, apply_profile,
                                    dirichlet_vertices, inflate_mesh, inflate_region, rim_wall,
                                    walled_sqrt)
from inkray.relief.outline import FLAT, FRAME, INKED
from inkray.relief.triangulation import mesh_region
from inkray.relief.outline import MeshOptions

R = 200.0
C0 = 230.0


@pytest.fixture(scope="module")
def disk():
    yy, xx = np.mgrid[:460, :460]
    return (xx - C0) ** 2 + (yy - C0) ** 2 <= R ** 2


@pytest.fixture(scope="module")
def disk_mesh(disk):
    return mesh_region(disk, options=MeshOptions(max_area=50.0))


def _l2(mesh, solver, err):
    """Area-weighted RMS (the L2 norm over the region), not biased by boundary vertex density."""
    w = solver.mass.diagonal()
    return float(np.sqrt(np.sum(w * err ** 2) / np.sum(w)))


K = np.tan(np.radians(MAX_SLOPE))


def _walled_round(r, radius):
    """The walled ``sqrt`` profile of ``f = radius^2 - r^2`` (a disk's at ``c = 4``, a
    strip's at ``c = 2``): the circle where it is under ``MAX_SLOPE``, then its tangent of
    that slope."""
    a = np.radians(MAX_SLOPE)
    r = np.asarray(r, float)
    circle = np.sqrt(np.maximum(radius ** 2 - r ** 2, 0.0))
    cone = radius * np.cos(a) - K * (r - radius * np.sin(a))
    return np.where(r <= radius * np.sin(a), circle, cone)


def _slopes(vertices, faces, h):
    """Per face: its angle from the image plane (degrees)."""
    q = np.column_stack([vertices, h])[faces]
    n = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
    return np.degrees(np.arccos(np.abs(n[:, 2]) / np.linalg.norm(n, axis=1)))


def _gradients(mesh, h):
    p = mesh.vertices[mesh.faces]
    a = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], axis=1)
    dh = np.stack([h[mesh.faces[:, 1]] - h[mesh.faces[:, 0]], h[mesh.faces[:, 2]] - h[mesh.faces[:, 0]]], 1)
    return np.linalg.solve(a, dh[..., None])[..., 0]


def test_disk_hemisphere_c4(disk_mesh):
    res = inflate_mesh(disk_mesh, inflation=4.0)
    r = np.hypot(*(disk_mesh.vertices - C0).T)
    exact = np.sqrt(np.maximum(R ** 2 - r ** 2, 0.0))
    sphere = apply_profile(res.f)
    assert abs(sphere.max() - R) < 0.015 * R
    assert _l2(disk_mesh, res.solver, sphere - exact) < 0.01 * R
    # Away from the rasterised rim (+-0.5 px) the match is much closer still.
    inner = r < R - 5
    assert np.sqrt(np.mean((sphere - exact)[inner] ** 2)) < 0.002 * R
    # The walled profile: the sphere where it is under MAX_SLOPE, then its tangent cone.
    walled = _walled_round(r, R)
    assert np.array_equal(res.height[disk_mesh.outline], np.zeros(disk_mesh.outline.sum()))
    inside = ~disk_mesh.outline
    assert np.sqrt(np.mean((res.height - walled)[inside] ** 2)) < 0.01 * R
    assert np.all(res.height >= sphere - 1e-9)  # raised, never lowered
    gentle = r < R * np.sin(np.radians(MAX_SLOPE)) - 5
    assert np.abs(res.height - sphere)[gentle].max() < 1e-9


def test_rim_wall_is_a_wall_and_the_rest_is_capped(disk):
    mesh = mesh_region(disk, options=MeshOptions(max_area=50.0))
    res = inflate_region(disk, inflation=4.0, options=MeshOptions(max_area=50.0))
    walled, n = res.mesh, len(mesh.vertices)
    # The outline keeps its vertices; every one has a copy WALL_INSET inside.
    assert np.array_equal(walled.vertices[:n], mesh.vertices)
    assert len(walled.vertices) == n + mesh.outline.sum()
    r = np.hypot(*(walled.vertices - C0).T)
    rim = np.hypot(*(mesh.vertices[mesh.outline] - C0).T)
    assert np.allclose(rim - r[n:], WALL_INSET, rtol=0.05)
    # The strip: two faces per outline edge, each standing at more than 88 degrees, with a
    # front-view area of the inset times the perimeter (and of nothing else).
    strip = (walled.faces < n).any(axis=1) & np.isin(walled.faces, np.flatnonzero(mesh.outline)).any(axis=1)
    assert strip.sum() == 2 * mesh.outline.sum()
    slopes = _slopes(walled.vertices, walled.faces, res.height)
    assert slopes[strip].min() > 88.0
    p = walled.vertices[walled.faces[strip]]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    assert abs(area / (2 * np.pi * R * WALL_INSET) - 1) < 0.02
    # Inside it no face is steeper than MAX_SLOPE; the wall stands where the tangent cone
    # meets the outline (less where the first ring's vertices lie farther in).
    assert slopes[~strip].max() < MAX_SLOPE + 0.1
    top = _walled_round(R, R)
    assert abs(np.median(res.height[n:]) / top - 1) < 0.05 and res.height[n:].max() < 1.2 * top
    # The heights follow the closed form everywhere inside.
    inside = ~walled.outline
    assert np.abs(res.height - _walled_round(r, R))[inside].max() < 0.02 * R


def test_walled_sqrt_keeps_a_gentle_profile():
    # A strip 60 px wide at c = 0.05: h = sqrt(c (30^2 - y^2) / 2) is steeper than the cap
    # only within c 30 / (8 K^2) ~ 0.025 px of its long sides, so the first ring keeps the
    # sqrt profile (only f = 0 vertices lie there).
    mask = np.zeros((100, 400), bool)
    mask[20:80, 20:380] = True
    mesh = mesh_region(mask)
    solver = InflationSolver(mesh)
    f = solver.solve(0.05)
    h = walled_sqrt(mesh, f, dirichlet=solver.dirichlet)
    assert np.array_equal(h, apply_profile(f))
    with pytest.raises(InputError, match="max_slope"):
        walled_sqrt(mesh, f, max_slope=90)
    with pytest.raises(InputError, match="inset"):
        rim_wall(mesh, inset=0.0)


def test_long_strip_cross_section_is_a_semicircle():
    mask = np.zeros((200, 1100), bool)
    mask[50:150, 50:1050] = True  # 1000 x 100, outline at y = 49.5 and 149.5
    res = inflate_region(mask, inflation=2.0)
    v = res.mesh.vertices
    mid = (np.abs(v[:, 0] - 550) < 15) & ~res.mesh.outline
    y = v[mid, 1] - 99.5
    exact = _walled_round(np.abs(y), 50)  # the semicircle, walled
    assert abs(res.height[mid].max() - 50) < 0.02 * 50
    assert np.abs(res.height[mid] - exact).max() < 0.02 * 50
    # Fit a radius: h^2 + y^2 = rho^2 at the interior points.
    inner = np.abs(y) < 45
    rho = np.sqrt(res.height[mid][inner] ** 2 + y[inner] ** 2)
    assert np.abs(rho / 50 - 1).max() < 0.02


def test_scale_covariance():
    yy, xx = np.mgrid[:180, :260]
    mask = ((xx - 90) ** 2 / 70 ** 2 + (yy - 90) ** 2 / 50 ** 2 <= 1) | (
        (abs(xx - 170) < 60) & (abs(yy - 100) < 35))
    small = inflate_region(mask, inflation=2.0)
    big = inflate_region(np.kron(mask, np.ones((2, 2), bool)), inflation=2.0)
    assert abs(big.height.max() / (2 * small.height.max()) - 1) < 0.01
    # Pixel centre x of the small drawing sits at 2x + 0.5 in the big one. Compared where the
    # profile is not steep (linear interpolation of sqrt near the rim is not the question here).
    deep = small.f > 0.25 * small.f.max()
    hb = LinearNDInterpolator(big.mesh.vertices, big.height)(2 * small.mesh.vertices[deep] + 0.5)
    err = hb - 2 * small.height[deep]
    assert np.sqrt(np.mean(err ** 2)) < 0.01 * 2 * small.height.max()


def test_flat_side_equals_mirrored_rectangle():
    square = np.zeros((400, 600), bool)
    square[100:300, 100:300] = True
    flat = SimpleNamespace(type="flat", path=np.array([[299.5, 99.5], [299.5, 299.5]]), index=0)
    sq = inflate_region(square, boundaries=[flat], inflation=2.0)
    assert np.any(sq.mesh.kind == FLAT)
    rect = square.copy()
    rect[100:300, 300:500] = True  # mirrored across x = 299.5
    rc = inflate_region(rect, inflation=2.0)
    f_rect = LinearNDInterpolator(rc.mesh.vertices, rc.f)(sq.mesh.vertices)
    assert np.nanmax(np.abs(f_rect - sq.f)) < 0.01 * rc.f.max()
    assert abs(sq.height.max() / rc.height.max() - 1) < 0.01
    # Zero slope across the flat side; steep across the silhouette sides.
    # Zero normal slope at the flat side (x = 299.5), full slope at the opposite silhouette.
    g = _gradients(sq.mesh, sq.f)
    c = sq.mesh.vertices[sq.mesh.faces].mean(axis=1)
    band = (c[:, 1] > 150) & (c[:, 1] < 250)
    touches = np.isin(sq.mesh.kind[sq.mesh.faces], [FLAT, INKED])
    on_flat = band & (sq.mesh.kind[sq.mesh.faces] == FLAT).any(axis=1)
    on_left = band & touches.any(axis=1) & (c[:, 0] < 150)
    # Linear elements meet df/dn = 0 only weakly: a few px^2/px against ~130 at a silhouette.
    assert np.abs(g[on_flat, 0]).mean() < 0.05 * np.abs(g[on_left, 0]).mean()


def test_image_frame_is_neumann():
    # A disk whose centre lies on the left image frame: the Neumann frame mirrors it into
    # the whole disk, so the half keeps the hemisphere sqrt(R^2 - r^2), peak on the frame.
    yy, xx = np.mgrid[:460, :240]
    half = (xx + 0.5) ** 2 + (yy - C0) ** 2 <= R ** 2
    res = inflate_region(half, inflation=4.0)
    frame = res.mesh.kind == FRAME
    assert frame.sum() > 10 and dirichlet_vertices(res.mesh)[frame].sum() <= 2
    r = np.hypot(res.mesh.vertices[:, 0] + 0.5, res.mesh.vertices[:, 1] - C0)
    exact = np.where(res.mesh.outline & ~frame, 0.0, _walled_round(r, R))
    assert abs(res.height.max() - R) < 0.015 * R
    assert res.mesh.kind[np.argmax(res.height)] == FRAME
    assert _l2(res.mesh, res.solver, res.height - exact) < 0.01 * R


def test_flat_linear_and_callable_profiles(disk_mesh):
    solver = InflationSolver(disk_mesh)
    sq = inflate_mesh(disk_mesh, inflation=4.0, solver=solver)
    lin = inflate_mesh(disk_mesh, inflation=4.0, profile="linear", solver=solver)
    assert np.isclose(lin.height.max(), sq.height.max())
    assert np.all(lin.height <= sq.height + 1e-9)  # parabola under the round profile
    flat = inflate_mesh(disk_mesh, profile="flat")
    assert not flat.height.any()
    cube = inflate_mesh(disk_mesh, inflation=4.0, profile=np.cbrt, solver=solver)
    assert np.allclose(cube.height, np.cbrt(sq.f))


def test_convergence_halving_max_area(disk):
    peaks = [inflate_region(disk, inflation=4.0, options=MeshOptions(max_area=a)).height.max() for a in (50.0, 25.0)]
    assert abs(peaks[1] / peaks[0] - 1) < 0.005


def test_all_neumann_region_fails_unless_flat():
    everything = np.ones((60, 80), bool)
    with pytest.raises(StageError, match="no silhouette"):
        inflate_region(everything, name="sky")
    assert not inflate_region(everything, profile="flat").height.any()


@pytest.mark.parametrize("kw, msg", [({"inflation": 0.0}, "inflation"), ({"inflation": np.nan}, "inflation"),
                                     ({"profile": "round"}, "profile")])
def test_bad_options(disk, kw, msg):
    with pytest.raises(InputError, match=msg):
        inflate_region(disk, **kw)


def test_bad_callable_profile():
    with pytest.raises(InputError, match="profile"):
        apply_profile(np.ones(5), lambda f: f[:2])


def test_separate_parts_and_holes():
    # Two disks in one region, one of them with a hole: every outline vertex stays at 0,
    # each part gets its own peak.
    yy, xx = np.mgrid[:200, :400]
    left = (xx - 100) ** 2 + (yy - 100) ** 2 <= 80 ** 2
    right = ((xx - 300) ** 2 + (yy - 100) ** 2 <= 80 ** 2) & ((xx - 300) ** 2 + (yy - 100) ** 2 > 30 ** 2)
    # Finer than the default: the annulus is only 50 px wide and its log term is curved.
    res = inflate_region(left | right, inflation=4.0, options=MeshOptions(max_area=12.5))
    v, h = res.mesh.vertices, res.height
    assert np.all(h[res.mesh.outline] == 0)
    assert abs(h[v[:, 0] < 200].max() - 80) < 0.015 * 80
    # Annulus a = 30 < r < R = 80: f = (c/4)(R^2 - r^2 + (R^2 - a^2) ln(r/R) / ln(R/a)).
    r = np.hypot(v[:, 0] - 300, v[:, 1] - 100)
    exact = np.sqrt(np.maximum(80 ** 2 - r ** 2 + (80 ** 2 - 30 ** 2) * np.log(r / 80) / np.log(80 / 30), 0))
    inner = (v[:, 0] > 200) & (r > 40) & (r < 75)  # away from the rasterised rims
    assert np.abs(h[inner] - exact[inner]).max() < 0.02 * exact.max()
