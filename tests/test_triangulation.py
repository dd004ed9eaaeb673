"""Quality triangulation of region outlines: angles, areas, fidelity, orientation."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial import cKDTree
from skimage.measure import find_contours

from inkray.errors import InputError
from inkray.relief.outline import FLAT, INTERIOR, edge_length, region_outline
from inkray.relief.triangulation import mesh_region, triangulate_outline
from inkray.relief.outline import MeshOptions


def _shapes():
    yy, xx = np.mgrid[:320, :360]
    disk = (xx - 180) ** 2 + (yy - 160) ** 2 <= 120 ** 2
    ring = disk & ((xx - 200) ** 2 + (yy - 150) ** 2 > 40 ** 2)
    blob = ((xx - 120) ** 2 / 90 ** 2 + (yy - 160) ** 2 / 50 ** 2 <= 1) | (
        (abs(xx - 240) < 60) & (abs(yy - 170) < 110))
    return {"disk": disk, "ring": ring, "blob": blob}


def _angles(v, f):
    p = v[f]
    out = []
    for i in range(3):
        a = p[:, (i + 1) % 3] - p[:, i]
        b = p[:, (i + 2) % 3] - p[:, i]
        cos = (a * b).sum(1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
        out.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.stack(out, axis=1)


def _signed_area(v, f):
    p = v[f]
    a, b = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    return 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])


def _dense(curves, step=0.1):
    out = []
    for c in curves:
        seg = np.diff(c, axis=0)
        n = np.maximum(1, np.ceil(np.linalg.norm(seg, axis=1) / step)).astype(int)
        for p, d, k in zip(c[:-1], seg, n):
            out.append(p + d * (np.arange(k) / k)[:, None])
    return np.vstack(out)


def _boundary_curves(mesh):
    e = np.sort(mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    return [mesh.vertices[pair] for pair in u[c == 1]]


@pytest.mark.parametrize("name", ["disk", "ring", "blob"])
def test_quality_orientation_and_fidelity(name):
    mask = _shapes()[name]
    mesh = mesh_region(mask, options=MeshOptions(max_area=50.0))
    ang = _angles(mesh.vertices, mesh.faces)
    area = _signed_area(mesh.vertices, mesh.faces)
    # The blob has two concave 90-degree-ish corners; Triangle keeps >= 20 deg everywhere here.
    assert ang.min() >= 20.0 - 1e-6
    assert np.all(area < 0)  # clockwise in (x, y): toward the viewer (inkray.relief)
    assert -area.max() > 1e-2 and -area.min() <= 50.0 + 1e-6  # none degenerate, none too big
    # Boundary within 1.5 px of the pixel mask's outline, both ways (Hausdorff
    # distance): the outline is smoothed (up to ~0.7 px where the pixel contour
    # has a flat run or a notch) and relaxed within 0.6 px of that.
    raw = [c[:, ::-1] - 1 for c in find_contours(np.pad(mask, 1).astype(float), 0.5)]
    ours, theirs = _dense(_boundary_curves(mesh)), _dense(raw)
    assert cKDTree(theirs).query(ours)[0].max() < 1.5
    assert cKDTree(ours).query(theirs)[0].max() < 1.5
    assert abs(-area.sum() - mask.sum()) < 0.01 * mask.sum()
    assert np.all(mesh.kind[np.unique(np.concatenate(_boundary_curves_idx(mesh)))] != INTERIOR)


def _boundary_curves_idx(mesh):
    e = np.sort(mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    return [u[c == 1].ravel()]


def test_sharp_corner_is_the_only_exception_to_the_angle_bound():
    # A thin wedge with a 10 degree tip: only triangles at the tip may be sharper than 20 deg.
    yy, xx = np.mgrid[:200, :320]
    tip = np.array([20.0, 100.0])
    ang = np.degrees(np.arctan2(yy - tip[1], xx - tip[0]))
    mask = (np.abs(ang) < 5) & (xx < 300) & (xx > 20)
    mesh = mesh_region(mask, options=MeshOptions(max_area=30.0))
    a = _angles(mesh.vertices, mesh.faces)
    bad = a.min(axis=1) < 20.0
    centroid = mesh.vertices[mesh.faces].mean(axis=1)
    assert np.all(np.linalg.norm(centroid[bad] - tip, axis=1) < 15.0)


def test_max_area_sets_the_resolution():
    mask = _shapes()["disk"]
    coarse = mesh_region(mask, options=MeshOptions(max_area=100.0))
    fine = mesh_region(mask, options=MeshOptions(max_area=25.0))
    assert 3.0 < len(fine.faces) / len(coarse.faces) < 5.0
    for mesh, a in ((coarse, 100.0), (fine, 25.0)):
        assert -_signed_area(mesh.vertices, mesh.faces).min() <= a + 1e-6
        b = _boundary_curves(mesh)
        assert max(np.linalg.norm(s[1] - s[0]) for s in b) <= edge_length(a) + 1e-6


def test_outline_vertices_and_stations_survive():
    mask = np.zeros((300, 300), bool)
    mask[50:250, 50:250] = True
    entry = SimpleNamespace(type="flat", path=np.array([[249.5, 60.0], [249.5, 240.0]]), index=0)
    out = region_outline(mask, boundaries=[entry])
    mesh = triangulate_outline(out)
    assert np.array_equal(mesh.vertices[:len(out.points)], out.points)
    st = mesh.station_vertices(0)
    assert np.array_equal(mesh.station[st], np.arange(len(st))) and len(st) >= 10
    assert np.all(mesh.kind[st] == FLAT)
    assert len(mesh.station_vertices(5)) == 0


@pytest.mark.parametrize("kw, msg", [({"max_area": 0.0}, "max_area"), ({"min_angle": 40.0}, "min_angle")])
def test_bad_options(kw, msg):
    with pytest.raises(InputError, match=msg):
        mesh_region(_shapes()["disk"], options=MeshOptions(**kw))


def test_small_regions_get_at_least_min_triangles():
    yy, xx = np.mgrid[:40, :40]
    dot = (xx - 20) ** 2 + (yy - 20) ** 2 <= 12 ** 2  # ~450 px^2: 9 triangles at 50 px^2
    mesh = mesh_region(dot, options=MeshOptions(max_area=50.0, min_triangles=200))
    assert len(mesh.faces) >= 200
    assert _angles(mesh.vertices, mesh.faces).min() >= 20.0 - 1e-6
    assert len(mesh_region(dot, options=MeshOptions(max_area=50.0, min_triangles=1, across=0)).faces) < 40


def test_narrow_parts_get_shorter_edges():
    mask = np.zeros((64, 440), bool)
    mask[20:44, 20:420] = True  # 24 px wide
    for across, longest in ((8, 24 / 8 * 1.2), (0, edge_length(50.0))):
        mesh = mesh_region(mask, options=MeshOptions(max_area=50.0, across=across))
        segs = _boundary_curves(mesh)
        mid = [s for s in segs if np.all(np.abs(s[:, 0] - 220) < 150)]
        lengths = np.array([np.linalg.norm(s[1] - s[0]) for s in mid])
        assert lengths.max() <= longest + 1e-6
    assert lengths.max() > 0.9 * edge_length(50.0)  # across=0: the plain spacing


# -- regions too small or thin to mesh: bounded, in a child process -----------------
# Triangle runs in C and cannot be interrupted: a degenerate outline loop (one vertex, a
# segment from a vertex to itself) makes it allocate without end. Each case runs in a
# child with a time and memory limit, so that a regression fails instead of hanging.

_LIMITED = """
import json, resource, sys
resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
import numpy as np
from inkray.errors import InputError
from inkray.relief.outline import MeshOptions, region_outline
from inkray.relief.triangulation import mesh_region, triangulate_outline
"""


def _bounded(code, timeout=60):
    import json
    import subprocess
    import sys
    proc = subprocess.run([sys.executable, "-c", _LIMITED + code], capture_output=True, text=True,
                          timeout=timeout)
    assert proc.returncode == 0, proc.stderr[-2000:] + proc.stdout[-2000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


_SMALL = {
    "pixel": "m[20, 30] = True",
    "corner pixel": "m[0, 0] = True",
    "diagonal line": "i = np.arange(30); m[5 + i, 10 + i] = True",
    "isolated pixels": "m[5, 5] = m[20, 30] = m[30, 50] = True",
    "scribble": "t = np.linspace(0, 5, 300); m[np.rint(20 + 12 * np.sin(t)).astype(int), "
                "np.rint(5 + 10 * t).astype(int)] = True",
    "2 px strip": "m[20:22, 5:55] = True",
}


@pytest.mark.parametrize("case", sorted(_SMALL))
def test_tiny_and_thin_regions_are_meshed(case):
    out = _bounded(f"""
m = np.zeros((40, 60), bool)
{_SMALL[case]}
mesh = mesh_region(m, options=MeshOptions(max_area=50.0))
print(json.dumps(dict(v=mesh.vertices.tolist(), f=mesh.faces.tolist(), w=mesh.warnings,
                      px=np.argwhere(m)[:, ::-1].tolist())))
""")
    v, f, px = np.array(out["v"]), np.array(out["f"]), np.array(out["px"], float)
    area = _signed_area(v, f)
    assert len(f) and np.all(area < 0) and out["w"] == []
    # The pixel contour (marching squares at 0.5) of n pixels encloses n less its cut
    # corners (n / 4 for a pixel in the image's corner); the smoothed outline strays
    # from it by under a pixel.
    assert 0.25 * len(px) - 1e-6 <= -area.sum() <= 1.1 * len(px) + 1
    # Every pixel centre of the region is on the mesh or within the smoothing's band of it.
    mesh = SimpleNamespace(vertices=v, faces=f)
    p = v[f]
    d = p[None] - px[:, None, None, :]
    cross = d[..., 0] * np.roll(d, -1, axis=2)[..., 1] - d[..., 1] * np.roll(d, -1, axis=2)[..., 0]
    inside = np.any(np.all(cross <= 1e-9, axis=2), axis=1)
    near = cKDTree(_dense(_boundary_curves(mesh), step=0.05)).query(px)[0] < 0.75
    # The level set's smoothing still loses short diagonal runs of a one-pixel scribble
    # (a fidelity limit of the outline, not of the triangulation).
    assert np.mean(inside | near) >= (0.85 if case == "scribble" else 1.0)


def test_loops_that_enclose_no_area_are_left_out_with_a_warning():
    out = _bounded("""
from dataclasses import replace
yy, xx = np.mgrid[:60, :80]
o = region_outline((xx - 40) ** 2 + (yy - 30) ** 2 <= 20 ** 2, name="ball")
n = len(o.points)
extra = np.array([[40.0, 30.0], [70.0, 50.0], [72.0, 50.0]])  # a pinhole, a two-vertex stub
def grow(a, fill):
    return np.r_[a, np.full(3, fill, a.dtype)]
o = replace(o, points=np.r_[o.points, extra], loop=np.r_[o.loop, 1, 2, 2],
            hole=np.r_[o.hole, True, False], kind=grow(o.kind, 1),
            boundary_index=grow(o.boundary_index, -1), station=grow(o.station, -1),
            neighbour=grow(o.neighbour, -1), hole_points=np.array([[40.005, 30.0]]))
mesh = triangulate_outline(o, max_area=30.0)
try:
    triangulate_outline(replace(o, points=o.points[n:], loop=np.array([0, 1, 1]), hole=o.hole[1:],
                                kind=o.kind[n:], boundary_index=o.boundary_index[n:],
                                station=o.station[n:], neighbour=o.neighbour[n:]))
    err = ""
except InputError as e:
    err = str(e)
centre = int(np.flatnonzero(np.all(mesh.vertices == [40.0, 30.0], axis=1))[0])
print(json.dumps(dict(w=mesh.warnings, err=err, n=len(mesh.faces), kind=int(mesh.kind[centre]),
                      used=bool(np.isin(centre, mesh.faces)),
                      far=bool((mesh.vertices[:, 0] > 65).any()))))
""")
    assert len(out["w"]) == 2 and all(w.startswith("region ball: ") for w in out["w"])
    assert "hole at pixel (40, 30)" in out["w"][0] and "piece at pixel (71, 50)" in out["w"][1]
    # The pinhole is filled (its point an interior vertex, its hole point gone), the stub dropped.
    assert out["n"] > 40 and out["kind"] == INTERIOR and out["used"] and not out["far"]
    assert out["err"].startswith("region ball: too small or thin to mesh at pixel (")


_OUTLINE = """
from inkray.relief.outline import INKED, RegionOutline
def outline(loops, name="r"):
    pts = np.vstack(loops).astype(float)
    n = len(pts)
    return RegionOutline(name=name, points=pts, loop=np.repeat(np.arange(len(loops)), [len(p) for p in loops]),
                         hole=np.zeros(len(loops), bool), kind=np.full(n, INKED, np.int8),
                         boundary_index=np.full(n, -1), station=np.full(n, -1),
                         neighbour=np.full(n, -1), hole_points=np.zeros((0, 2)))
"""


@pytest.mark.parametrize("loop, area", [
    # Two triangles touching at a point, the point listed twice.
    ([[0, 0], [10, 0], [5, 5], [10, 10], [0, 10], [5, 5]], 50.0),
    # A square with a spike: an edge walked there and back (a one-pixel whisker).
    ([[0, 0], [10, 0], [10, 10], [5, 10], [5, 20], [5, 10], [0, 10]], 100.0),
])
def test_self_touching_outlines_are_meshed(loop, area):
    out = _bounded(_OUTLINE + f"""
mesh = triangulate_outline(outline([np.array({loop})]), max_area=1.0)
print(json.dumps(dict(v=mesh.vertices.tolist(), f=mesh.faces.tolist())))
""")
    v, f = np.array(out["v"]), np.array(out["f"])
    a = _signed_area(v, f)
    assert np.all(a < 0) and abs(-a.sum() - area) < 1e-6 and -a.min() <= 1.0 + 1e-9


def test_steiner_points_are_capped():
    out = _bounded(_OUTLINE + """
import inkray.relief.triangulation as T
T._STEINER_FACTOR, T._STEINER_SLACK = 0, 25
square = outline([np.array([[0, 0], [0, 30], [30, 30], [30, 0]])], name="sq")
mesh = triangulate_outline(square, max_area=1.0)
print(json.dumps(dict(n=len(mesh.vertices), w=mesh.warnings)))
""")
    # 2 * 4 outline vertices + 25 allowed, where the area bound alone asks for hundreds.
    assert out["n"] <= 4 + 8 + 25
    assert out["w"] == ["region sq: the mesh reached its limit of 33 added vertices; "
                        "some of its triangles may be sharper than asked"]


@pytest.mark.slow
@pytest.mark.parametrize("scribble", [[[30, 30]], [[20, 20], [60, 60]]])
def test_region_scribbled_on_paper_without_background(scribble):
    # A region scribbled on the paper around the fish, no background scribble: the image
    # frame takes the paper and the region is its one-pixel scribble.
    out = _bounded(f"""
from inkray.chain import ReliefChain
from inkray.examples import example_path
from inkray.input.annotations import parse_annotations
from inkray.input.drawing import load_drawing
path = example_path("fish")
raw = json.loads(path.read_text())
raw.pop("background")
raw["regions"].append({{"name": "paper", "scribbles": [{scribble}]}})
chain = ReliefChain(parse_annotations(raw), load_drawing(path.parent / raw["drawing"]))
print(json.dumps({{r.mesh.name: [len(r.mesh.faces), int(chain.completion.completed(i).sum())]
                  for i, r in enumerate(chain.meshes)}}))
""", timeout=240)
    assert out["paper"][0] > 0 and out["paper"][1] <= 60  # meshed, and only its scribble
    assert set(out) == {"tail", "fin_top", "fin_bottom", "body", "fin_side", "eye", "paper"}
