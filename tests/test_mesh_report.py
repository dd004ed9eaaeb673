import json

import numpy as np
import pymeshlab
import pytest
import trimesh

from _reliefs import DISKS, disk_relief
from inkray.formats.mesh_report import (REQUIREMENTS, check_file, failed_requirements, format_report,
                          mesh_quality, parse_requirements, quality_report)
from inkray.cli import main
from inkray.errors import InputError
from inkray.formats.meshes import FORMATS, export_relief

SPHERE = trimesh.creation.icosphere(subdivisions=2)
TETRA_V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])  # outward


def _sphere(offset=(0.0, 0.0, 0.0)):
    return SPHERE.vertices + offset, SPHERE.faces.copy()


def _hole():
    v, f = _sphere()
    return v, f[1:]


def _flipped():
    v, f = _sphere()
    f[0] = f[0, ::-1]
    return v, f


def _fin():
    """A triangle hanging off one edge of the sphere: that edge has three faces."""
    v, f = _sphere()
    a, b = f[0, :2]
    return np.vstack([v, [[3.0, 3.0, 3.0]]]), np.vstack([f, [[a, b, len(v)]]])


def _bowtie():
    """Two tetrahedra touching at one vertex: every edge fine, that vertex not."""
    v = np.vstack([TETRA_V, -TETRA_V[1:]])
    mirrored = np.where(TETRA_F == 0, 0, TETRA_F + 3)[:, ::-1]  # a mirror flips the winding
    return v, np.vstack([TETRA_F, mirrored])


def _spheres(distance):
    """Two unit spheres in one mesh: overlapping (distance < 2) or apart."""
    v1, f1 = _sphere()
    # Off-axis, so that no vertex of one lands on a vertex of the other.
    v2, f2 = _sphere(distance * np.array([0.97, 0.2, 0.1]))
    return np.vstack([v1, v2]), np.vstack([f1, f2 + len(v1)])


def _pymeshlab_topology(v, f):
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=v, face_matrix=np.asarray(f, np.int32)))
    return ms.get_topological_measures()


# -- one mesh -------------------------------------------------------------------

def test_closed_sphere_is_clean():
    v, f = _sphere()
    q = mesh_quality(v, f)
    assert (q["vertices"], q["faces"]) == (len(v), len(f))
    assert q["watertight"] and q["edge_manifold"] and q["vertex_manifold"]
    assert q["consistently_oriented"] and q["self_intersecting_faces"] == 0
    assert q["boundary_loops"] == 0 and q["degenerate_faces"] == 0 and q["duplicate_faces"] == 0
    assert q["volume"] == pytest.approx(SPHERE.volume, rel=1e-12)
    # Reversing every face keeps it consistent but turns the volume negative.
    assert mesh_quality(v, f[:, ::-1])["volume"] == pytest.approx(-SPHERE.volume, rel=1e-12)


def test_hole_is_reported():
    q = mesh_quality(*_hole())
    assert q["boundary_edges"] == 3 and q["boundary_loops"] == 1
    assert not q["watertight"] and q["volume"] is None
    assert q["edge_manifold"] and q["consistently_oriented"]


def test_flipped_face_is_reported():
    q = mesh_quality(*_flipped())
    assert q["inconsistent_edges"] == 3 and not q["consistently_oriented"]
    assert q["watertight"] and q["volume"] is None


def test_non_manifold_edge_is_reported():
    q = mesh_quality(*_fin())
    assert q["non_manifold_edges"] == 1 and not q["edge_manifold"]
    assert not q["watertight"] and q["boundary_edges"] == 2


def test_non_manifold_vertex_is_reported():
    q = mesh_quality(*_bowtie())
    assert q["non_manifold_vertices"] == 1 and not q["vertex_manifold"]
    assert q["edge_manifold"] and q["watertight"] and q["consistently_oriented"]
    assert q["volume"] == pytest.approx(2 / 6)


def test_self_intersection_is_reported():
    crossing = mesh_quality(*_spheres(1.0))
    apart = mesh_quality(*_spheres(3.0))
    assert crossing["self_intersecting_faces"] > 0
    assert apart["self_intersecting_faces"] == 0
    # Nothing else tells them apart: both are closed, manifold and oriented.
    for q in (crossing, apart):
        assert q["watertight"] and q["edge_manifold"] and q["vertex_manifold"]
        assert q["consistently_oriented"]


@pytest.mark.parametrize("build", [_sphere, _hole, _flipped, _fin, _bowtie])
def test_topology_agrees_with_pymeshlab(build):
    v, f = build()
    q, pm = mesh_quality(v, f, self_intersections=False), _pymeshlab_topology(v, f)
    assert q["boundary_edges"] == pm["boundary_edges"]
    assert q["non_manifold_vertices"] == pm["non_two_manifold_vertices"]
    assert (q["non_manifold_edges"] > 0) == (pm["non_two_manifold_edges"] > 0)
    if q["edge_manifold"] and q["vertex_manifold"]:
        assert q["boundary_loops"] == pm["number_holes"]


def test_degenerate_and_duplicate_faces():
    v, f = _sphere()
    v = np.vstack([v, [[5.0, 0, 0], [6.0, 0, 0], [7.0, 0, 0]]])
    n = len(SPHERE.vertices)
    extra = [[n, n + 1, n + 2],  # collinear: zero area
             [n, n, n + 1],  # one vertex twice
             f[5], f[7, ::-1]]  # repeated faces, one of them flipped
    q = mesh_quality(v, np.vstack([f, extra]), self_intersections=False)
    assert q["degenerate_faces"] == 2
    assert q["duplicate_faces"] == 2
    assert q["min_angle_deg"] > 0  # statistics skip the degenerate faces


def test_angles_and_aspect_ratio_closed_forms():
    equilateral = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, np.sqrt(3) / 2, 0]])
    q = mesh_quality(equilateral, [[0, 1, 2]])
    assert q["min_angle_deg"] == pytest.approx(60.0)
    assert q["max_aspect_ratio"] == pytest.approx(1.0)
    right = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    q = mesh_quality(right, [[0, 1, 2]])
    assert q["min_angle_deg"] == pytest.approx(45.0)
    assert q["max_aspect_ratio"] == pytest.approx((np.sqrt(2) + 1) / np.sqrt(3))
    # A sliver: the smallest angle is atan(h / (L / 2)) for an isosceles of height h.
    sliver = np.array([[0.0, 0, 0], [10, 0, 0], [5, 0.1, 0]])
    q = mesh_quality(sliver, [[0, 1, 2]])
    assert q["min_angle_deg"] == pytest.approx(np.degrees(np.arctan(0.1 / 5)))
    assert q["degenerate_faces"] == 0


def test_split_vertices_are_welded_for_topology():
    v, f = _sphere()
    soup_v, soup_f = v[f].reshape(-1, 3), np.arange(3 * len(f)).reshape(-1, 3)
    q = mesh_quality(soup_v, soup_f)
    assert q["vertices"] == 3 * len(f) and q["welded_vertices"] == len(v)
    assert q["watertight"] and q["consistently_oriented"] and q["self_intersecting_faces"] == 0


def test_unreferenced_vertices_are_counted():
    v, f = _sphere()
    q = mesh_quality(np.vstack([v, [[9.0, 9, 9]]]), f, self_intersections=False)
    assert q["unreferenced_vertices"] == 1 and q["watertight"]


@pytest.mark.parametrize("vertices, faces, message", [
    (TETRA_V, [[0, 1, 4]], "face 0 .* indexes past the 4 vertices"),
    (TETRA_V, [[0, -1, 2]], "indexes past"),
    (np.vstack([TETRA_V, [[np.nan, 0, 0]]]), TETRA_F, "vertex 4 is not finite"),
    (TETRA_V[:, :2], TETRA_F, r"\(n, 3\)"),
    (TETRA_V, [[0.5, 1, 2]], "integer"),
])
def test_invalid_meshes_are_refused(vertices, faces, message):
    with pytest.raises(InputError, match=message):
        mesh_quality(vertices, faces)


# -- report and requirements ----------------------------------------------------------

def test_overall_aggregates_parts():
    parts = [("sphere", *_sphere()), ("hole", *_hole()), ("bowtie", *_bowtie())]
    report = quality_report(parts)
    overall, by_name = report["overall"], {p["name"]: p for p in report["parts"]}
    assert overall["parts"] == 3
    assert overall["faces"] == sum(len(f) for _, _, f in parts)
    assert overall["boundary_loops"] == 1 and overall["non_manifold_vertices"] == 1
    assert not overall["watertight"] and not overall["vertex_manifold"]
    assert overall["volume"] is None  # the open part has none
    assert overall["min_angle_deg"] == min(p["min_angle_deg"] for p in report["parts"])
    assert by_name["sphere"]["watertight"] and not by_name["hole"]["watertight"]
    assert failed_requirements(report, ["watertight", "manifold", "oriented"]) == [
        ("watertight", ["hole"]), ("manifold", ["bowtie"])]
    text = format_report(report)
    assert "hole:" in text and "open" in text and "NOT vertex-manifold (1 vertices)" in text


def test_requirement_names():
    assert parse_requirements(" watertight,,manifold ") == ["watertight", "manifold"]
    assert set(parse_requirements(list(REQUIREMENTS))) == set(REQUIREMENTS)
    with pytest.raises(InputError, match="unknown requirement 'closed'"):
        parse_requirements("watertight,closed")
    assert parse_requirements("min-angle = 10, shells=1") == ["min-angle=10", "shells=1"]
    for bad in ("min-angle", "min-angle=x", "shells=-1"):
        with pytest.raises(InputError, match="needs a bound"):
            parse_requirements(bad)


def test_shells_and_bounds():
    v, f = _sphere()
    two = (np.vstack([v, v + [10.0, 0, 0]]), np.vstack([f, f + len(v)]))
    report = quality_report([("one", v, f), ("two", *two)])
    by_name = {p["name"]: p for p in report["parts"]}
    assert by_name["one"]["shells"] == 1 and by_name["two"]["shells"] == 2
    assert report["overall"]["shells"] == 3
    assert failed_requirements(report, ["shells=1"]) == [("shells=1", ["two"])]
    angle = by_name["one"]["min_angle_deg"]
    assert failed_requirements(report, [f"min-angle={angle - 1:.3f}"]) == []
    assert failed_requirements(report, [f"min-angle={angle + 1:.3f}"])[0][1] == ["one", "two"]
    assert failed_requirements(report, ["max-aspect=1"])[0][1] == ["one", "two"]
    assert "2 shells" in format_report(report)


# -- files: inkray's and others' ------------------------------------------------------

@pytest.mark.parametrize("back", ["double-sided", "plate", "none"])
@pytest.mark.parametrize("suffix", FORMATS)
@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
def test_check_reads_inkray_exports(suffix, closed, back, tmp_path):
    from inkray.relief.backing import back_plate, back_sheet

    relief = disk_relief(closed=closed)
    s = 0.001
    report = check_file(export_relief(relief, tmp_path / f"r{suffix}", units_per_pixel=s,
                                      back=back)[0])
    by_name = {p["name"]: p for p in report["parts"]}
    assert sorted(by_name) == sorted(p.name for p in relief.parts)
    solid = closed or back != "none"
    backed = {"double-sided": back_sheet, "plate": back_plate}.get(back, lambda r: r)(relief)
    for part in backed.parts:
        q = by_name[part.name]
        # vertices where the drawing meets the paper are written twice, one surface
        assert (q["welded_vertices"], q["faces"]) == (len(part.vertices), len(part.faces))
        assert q["vertices"] >= len(part.vertices)
        assert q["edge_manifold"] and q["vertex_manifold"] and q["consistently_oriented"]
        assert q["self_intersecting_faces"] == 0 and q["degenerate_faces"] == 0
        assert q["min_angle_deg"] > 5.0  # triangle's quality bound (30 deg) on the disk
        assert q["watertight"] == solid
        assert q["boundary_loops"] == (0 if solid else 1)
    if closed:
        # Each closed disk is a sphere (front and mirrored back hemispheres): outward, and
        # its volume that of the ball, less the polygonal approximation.
        for name, _, _, radius, _ in DISKS:
            ball = 4 / 3 * np.pi * (radius * s) ** 3
            assert 0.97 * ball < by_name[name]["volume"] < ball


@pytest.mark.parametrize("suffix", [".glb", ".obj", ".ply"])
def test_check_reads_other_writers_files(suffix, tmp_path):
    scene = trimesh.Scene()
    hole = trimesh.Trimesh(*_hole(), process=False)
    sphere = trimesh.Trimesh(*_sphere(), process=False)
    scene.add_geometry(hole, geom_name="holey", node_name="holey")
    scene.add_geometry(sphere, geom_name="ball", node_name="ball",
                       transform=trimesh.transformations.scale_and_translate(2.0, [5, 0, 0]))
    path = tmp_path / f"theirs{suffix}"
    (sphere if suffix == ".ply" else scene).export(path)
    report = check_file(path)
    if suffix == ".ply":
        (q,) = report["parts"]
        assert q["name"] == "theirs" and q["watertight"]
        assert q["volume"] == pytest.approx(SPHERE.volume, rel=1e-6)
        return
    by_name = {p["name"]: p for p in report["parts"]}
    assert by_name["holey"]["boundary_loops"] == 1 and not by_name["holey"]["watertight"]
    assert by_name["ball"]["watertight"]
    if suffix == ".glb":  # the node's transform is applied: 2x scale, 8x volume
        assert by_name["ball"]["volume"] == pytest.approx(8 * SPHERE.volume, rel=1e-5)


# -- the command line -------------------------------------------------------------------

def _write(tmp_path, name, v, f):
    path = tmp_path / name
    trimesh.Trimesh(v, f, process=False).export(path)
    return path


@pytest.mark.parametrize("name, build, fails, passes", [
    ("hole.ply", _hole, "watertight", "manifold,oriented,no-self-intersections"),
    ("flipped.obj", _flipped, "oriented", "watertight,manifold,no-self-intersections"),
    ("fin.glb", _fin, "edge-manifold", "vertex-manifold,oriented"),
    ("bowtie.ply", _bowtie, "manifold", "watertight,edge-manifold,oriented"),
    ("crossing.glb", lambda: _spheres(1.0), "no-self-intersections",
     "watertight,manifold,oriented"),
])
def test_cli_fails_the_requirement_each_defect_breaks(name, build, fails, passes, tmp_path,
                                                      capsys):
    path = _write(tmp_path, name, *build())
    assert main(["--quiet", "check", str(path), "--require", passes]) == 0
    capsys.readouterr()
    assert main(["--quiet", "check", str(path), "--require", fails]) == 1
    assert f"requirement '{fails}' failed" in capsys.readouterr().err


def test_cli_bounds_on_angles_and_shells(tmp_path, capsys):
    path = _write(tmp_path, "apart.ply", *_spheres(3.0))
    angle = mesh_quality(*_sphere())["min_angle_deg"]
    assert main(["--quiet", "check", str(path), "--require",
                 f"watertight,min-angle={angle - 0.5:.2f},shells=2"]) == 0
    assert "2 shells" in capsys.readouterr().out
    assert main(["--quiet", "check", str(path), "--require", "shells=1"]) == 1
    assert "requirement 'shells=1' failed for apart" in capsys.readouterr().err
    assert main(["--quiet", "check", str(path), "--require", f"min-angle={angle + 0.5:.2f}"]) == 1
    assert main(["--quiet", "check", str(path), "--require", "min-angle"]) == 2
    assert "min-angle needs a bound" in capsys.readouterr().err


def test_cli_writes_json_report(tmp_path, capsys):
    path = _write(tmp_path, "ball.glb", *_sphere())
    out = tmp_path / "report.json"
    assert main(["--quiet", "check", str(path), "-o", str(out),
                 "--require", ",".join(REQUIREMENTS)]) == 0
    report = json.loads(out.read_text())
    assert report["file"] == str(path)
    assert report["overall"]["watertight"] and report["parts"][0]["faces"] == len(SPHERE.faces)
    assert "overall (1 parts)" in capsys.readouterr().out


@pytest.mark.parametrize("argv_tail, content", [
    (["--require", "closed"], None),
    (["-o", "report.txt"], None),
    ([], b"glTF garbage"),
])
def test_cli_usage_and_unreadable_input_exit_2(argv_tail, content, tmp_path):
    path = tmp_path / "m.glb"
    if content is None:
        path = _write(tmp_path, "m.glb", *_sphere())
    else:
        path.write_bytes(content)
    argv = [a if a != "report.txt" else str(tmp_path / a) for a in argv_tail]
    before = sorted(tmp_path.iterdir())
    assert main(["--quiet", "check", str(path), *argv]) == 2
    assert sorted(tmp_path.iterdir()) == before
    assert main(["--quiet", "check", str(tmp_path / "missing.obj")]) == 2
