import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import trimesh

from _reliefs import DISKS, SIZE, disk_mask, disk_part, disk_relief, drawing, grid_part
from inkray.errors import InputError
from inkray.formats.meshes import (BACKS, FORMATS, export_relief, mesh_counts, pixel_coordinates,
                                   read_meshes, read_relief, scene_coordinates)
from inkray.formats.atomic import atomic_outputs
from inkray.view.rasterization import rasterize
from inkray.relief.backing import back_plate, back_sheet
from inkray.relief.model import Part, Relief

ROOT = Path(__file__).resolve().parents[1]
VALIDATOR = ROOT / ".ci" / "node" / "validate.js"
S = 0.001


def _load(path):
    """The file as trimesh reads it: {name: Trimesh} (OBJ split by group)."""
    options = {"group_material": False, "split_objects": True} if path.suffix == ".obj" else {}
    if path.suffix == ".ply":
        return {"ply": trimesh.load_mesh(path, process=False)}
    scene = trimesh.load_scene(path, process=False, **options)
    out = {}
    for geom in scene.geometry:
        for node in scene.graph.geometry_nodes[geom]:
            mesh = scene.geometry[geom].copy()
            mesh.apply_transform(scene.graph[node][0])  # placed as a viewer places it
            out[node] = mesh
    return out


def _glb_json(path):
    data = path.read_bytes()
    length = int.from_bytes(data[12:16], "little")
    return json.loads(data[20:20 + length])


BACKED = {"double-sided": back_sheet, "plate": back_plate, "none": lambda relief: relief}


def _drawing_faces(part):
    """Faces that show the drawing: turned less than arccos(0.1) from the viewer."""
    v = part.vertices * [1.0, -1.0, 1.0]  # scene frame: z toward the viewer
    t = v[part.faces]
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    return n[:, 2] >= 0.1 * np.linalg.norm(n, axis=1)


def _sources(part, written, s=S):
    """For each written vertex, the part's vertex at its position.

    GLB and PLY write the part's own vertices first, in order (trimesh orders an
    OBJ's vertices by the faces' corners).
    """
    from scipy.spatial import cKDTree

    dist, index = cKDTree(scene_coordinates(part.vertices, SIZE, units_per_pixel=s)).query(written)
    assert dist.max() < 1e-6
    assert len(np.unique(index)) == len(part.vertices)
    return index


def _concat(relief, key):
    return np.concatenate([getattr(p, key) for p in relief.parts])


@pytest.fixture(params=[False, True], ids=["open", "closed"])
def relief(request):
    return disk_relief(closed=request.param)


# -- round trip through trimesh -------------------------------------------------

@pytest.mark.parametrize("back", BACKS)
@pytest.mark.parametrize("suffix", [".glb", ".obj"])
def test_textured_formats_round_trip_per_part(relief, suffix, back, tmp_path):
    path = export_relief(relief, tmp_path / f"r{suffix}", units_per_pixel=S, back=back)[0]
    meshes = _load(path)
    assert sorted(meshes) == sorted(p.name for p in relief.parts)
    for part in BACKED[back](relief).parts:
        mesh = meshes[part.name]
        # the part's vertices, then copies of those where the drawing meets the paper
        source = _sources(part, mesh.vertices)
        np.testing.assert_array_equal(source[mesh.faces], part.faces)
        uv = np.asarray(mesh.visual.uv)
        assert uv.min() >= 0.0 and uv.max() <= 1.0
        drawn = _drawing_faces(part)
        corners = mesh.faces[drawn].ravel()
        np.testing.assert_allclose(uv[corners], relief.uv(part.vertices[source[corners]]),
                                   atol=1e-6)
        paper = uv[mesh.faces[~drawn].ravel()]
        assert len(np.unique(paper.round(7), axis=0)) == (0 if drawn.all() else 1)
        material = mesh.visual.material
        image = material.baseColorTexture if suffix == ".glb" else material.image
        assert image is not None, "texture missing"
        np.testing.assert_array_equal(np.asarray(image.convert("RGB")), relief.texture)


def test_ply_round_trip_counts_colours_and_uvs(relief, tmp_path):
    path = export_relief(relief, tmp_path / "r.ply", units_per_pixel=S, back="none")[0]
    assert path.read_bytes().startswith(b"ply\nformat binary_little_endian 1.0\n")
    mesh = _load(path)["ply"]
    assert len(mesh.faces) == sum(len(p.faces) for p in relief.parts)
    raw = mesh.metadata["_ply_raw"]["vertex"]["data"]
    uv = np.stack([raw["s"], raw["t"]], axis=1)
    assert uv.min() >= 0.0 and uv.max() <= 1.0
    colours = np.stack([raw[c] for c in ("red", "green", "blue", "alpha")], axis=1)
    n = len(mesh.vertices)
    assert colours.shape == (n, 4) and np.all(colours[:, 3] == 255)
    start = 0
    for part in relief.parts:  # the parts one after the other, each as in the GLB
        faces = mesh.faces[start:start + len(part.faces)]
        start += len(part.faces)
        first, last = faces.min(), faces.max()
        source = _sources(part, mesh.vertices[first:last + 1])
        np.testing.assert_array_equal(source[faces - first], part.faces)
        drawn = faces[_drawing_faces(part)].ravel()
        np.testing.assert_allclose(uv[drawn], relief.uv(part.vertices[source[drawn - first]]),
                                   atol=1e-6)
    # The disks' rims sit on dark ink, their inside on bright colour: the
    # samples vary like the drawing does.
    assert colours[:, :3].std() > 20


def test_ply_colours_are_the_drawing_at_pixel_centres(tmp_path):
    tex = drawing()
    xs, ys = np.arange(10.0, 50.0), np.arange(20.0, 45.0)  # pixel centres are integers
    relief = Relief([grid_part("grid", xs, ys)], SIZE, tex)
    mesh = _load(export_relief(relief, tmp_path / "g.ply")[0])["ply"]
    raw = mesh.metadata["_ply_raw"]["vertex"]["data"]
    colours = np.stack([raw[c] for c in ("red", "green", "blue")], axis=1)
    front = colours[:len(xs) * len(ys)]  # then the sheet's back, in the paper's colour
    np.testing.assert_array_equal(front, tex[20:45, 10:50].reshape(-1, 3))


@pytest.mark.parametrize("suffix", FORMATS)
def test_read_meshes_returns_each_part(relief, suffix, tmp_path):
    path = export_relief(relief, tmp_path / f"r{suffix}", units_per_pixel=S)[0]
    meshes = {m.name: m for m in read_meshes(path)}
    assert sorted(meshes) == sorted(p.name for p in relief.parts)
    for part in back_sheet(relief).parts:
        m = meshes[part.name]
        source = _sources(part, m.vertices)
        np.testing.assert_array_equal(source[m.faces], part.faces)


# -- GLB structure ----------------------------------------------------------------

def test_glb_nodes_material_extras(relief, tmp_path):
    path = export_relief(relief, tmp_path / "r.glb", units_per_pixel=0.002, anchor="top-left")[0]
    tree = _glb_json(path)
    assert tree["scenes"][0]["extras"]["inkray"] == {
        "drawing_size": list(SIZE), "units_per_pixel": 0.002, "anchor": "top-left"}
    names = [p.name for p in relief.parts]
    assert [tree["nodes"][i]["name"] for i in tree["scenes"][0]["nodes"]] == names
    for node in tree["nodes"]:
        mesh = tree["meshes"][node["mesh"]]
        assert mesh["name"] == node["name"]
        (prim,) = mesh["primitives"]
        assert {"POSITION", "NORMAL", "TEXCOORD_0"} <= set(prim["attributes"])
        assert tree["accessors"][prim["indices"]]["componentType"] == 5125  # uint32
    (material,) = tree["materials"]
    pbr = material["pbrMetallicRoughness"]
    assert pbr["roughnessFactor"] == 1.0 and pbr["metallicFactor"] == 0.0
    texture = tree["textures"][pbr["baseColorTexture"]["index"]]
    assert texture["source"] == 0
    sampler = tree["samplers"][texture["sampler"]]
    assert sampler["wrapS"] == sampler["wrapT"] == 33071  # clamp: edges do not wrap around
    assert tree["images"][0]["mimeType"] == "image/png"


@pytest.mark.parametrize("back", BACKS)
def test_glb_normals_and_winding_face_the_viewer(back, tmp_path):
    relief = disk_relief(closed=False)
    alone = _load(export_relief(relief, tmp_path / "none.glb", back="none")[0])
    for part in relief.parts:
        mesh = _load(export_relief(relief, tmp_path / f"{back}.glb", back=back)[0])[part.name]
        # Spherical caps seen from the front: every face and vertex normal has +Z.
        front = np.unique(mesh.faces[:len(part.faces)])
        assert np.all(mesh.face_normals[:len(part.faces), 2] > 0)
        normals = mesh.vertex_normals  # as stored in the file (process=False keeps them)
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-6)
        assert np.all(normals[front, 2] > 0)
        # the front is shaded as it is without a back: its normals ignore the back and walls
        np.testing.assert_allclose(normals[front], alone[part.name].vertex_normals[front],
                                   atol=1e-6)
        if back != "none":  # a closed solid, its faces outward
            assert (mesh.face_normals[len(part.faces):, 2] <= 1e-6).all()  # backs, walls
            assert _welded(mesh).is_watertight and _welded(mesh).volume > 0


def _welded(mesh):
    """The mesh with vertices at one position merged, as a slicer or ``inkray check`` sees it."""
    return trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)


def test_closed_glb_faces_point_outward(tmp_path):
    relief = disk_relief(closed=True)
    for name, mesh in _load(export_relief(relief, tmp_path / "r.glb")[0]).items():
        centre = mesh.bounds.mean(axis=0)
        outward = np.einsum("ij,ij->i", mesh.face_normals, mesh.triangles_center - centre)
        assert np.all(outward > 0), name
        assert _welded(mesh).is_watertight and _welded(mesh).volume > 0


def test_large_part_keeps_32_bit_indices(tmp_path):
    xs = np.linspace(0.0, SIZE[0] - 1.0, 300)
    ys = np.linspace(0.0, SIZE[1] - 1.0, 230)  # 69 000 vertices > 65 535
    part = grid_part("sheet", xs, ys, z=3.0)
    path = export_relief(Relief([part], SIZE, drawing()), tmp_path / "big.glb")[0]
    (mesh,) = _load(path).values()
    assert mesh.faces.max() >= 2 * len(part.vertices) - 1 > 65535  # the front and the back
    np.testing.assert_array_equal(mesh.faces[:len(part.faces)], part.faces)


# -- frame --------------------------------------------------------------------------

@pytest.mark.parametrize("anchor", ["center", "top-left"])
def test_frame_anchor_and_scale(anchor, tmp_path):
    w, h = SIZE
    # The drawing's corners: pixel centres are integers, so it spans [-0.5, W - 0.5].
    corners = grid_part("sheet", [-0.5, w - 0.5], [-0.5, h - 0.5], z=10.0)
    path = export_relief(Relief([corners], SIZE, drawing()), tmp_path / "c.obj",
                         units_per_pixel=0.01, anchor=anchor, back="none")[0]
    (mesh,) = _load(path).values()
    lo, hi = mesh.bounds
    if anchor == "center":
        np.testing.assert_allclose(lo, [-w / 200, -h / 200, 0.1])
        np.testing.assert_allclose(hi, [w / 200, h / 200, 0.1])
    else:
        np.testing.assert_allclose(lo, [0, -h / 100, 0.1])
        np.testing.assert_allclose(hi, [w / 100, 0, 0.1])
    # Top-left drawing corner (pixel (0, 0)) is the scene's top-left: max Y, min X.
    top_left = mesh.vertices[0]
    assert top_left[0] == lo[0] and top_left[1] == hi[1]


@pytest.mark.parametrize("anchor", ["center", "top-left"])
def test_pixel_coordinates_inverts_scene_coordinates(anchor):
    p = np.random.default_rng(1).uniform(-50, 300, (100, 3))
    q = scene_coordinates(p, SIZE, units_per_pixel=0.003, anchor=anchor)
    np.testing.assert_allclose(pixel_coordinates(q, SIZE, units_per_pixel=0.003, anchor=anchor),
                               p, atol=1e-9)


# -- texture registration -----------------------------------------------------------

def _front_view_of_file(path):
    """Unlit orthographic front view of a written file: its own UVs into its own texture."""
    meshes = _load(path)
    if path.suffix == ".glb":
        extras = _glb_json(path)["scenes"][0]["extras"]["inkray"]
        size, s, anchor = tuple(extras["drawing_size"]), extras["units_per_pixel"], extras["anchor"]
    else:
        size, s, anchor = SIZE, S, "center"
    names = list(meshes)
    parts = [Part(n, pixel_coordinates(meshes[n].vertices, size, units_per_pixel=s,
                                       anchor=anchor), np.asarray(meshes[n].faces))
             for n in names]
    raster = rasterize(Relief(parts, size))
    material = meshes[names[0]].visual.material
    image = material.baseColorTexture if path.suffix == ".glb" else material.image
    tex = np.asarray(image.convert("RGB"), float)
    out = np.zeros(raster.part.shape + (3,))
    hit = raster.mask
    rows, cols = np.nonzero(hit)
    for i, name in enumerate(names):
        sel = raster.part[hit] == i
        faces = np.asarray(meshes[name].faces)[raster.face[hit][sel]]
        file_uv = np.asarray(meshes[name].visual.uv)
        uv = np.einsum("nk,nkc->nc", raster.bary[hit][sel], file_uv[faces])
        out[rows[sel], cols[sel]] = _bilinear(tex, uv[:, 0] * tex.shape[1],
                                              (1 - uv[:, 1]) * tex.shape[0])
    return out, hit


def _bilinear(img, x, y):
    h, w = img.shape[:2]
    x, y = np.clip(x - 0.5, 0, w - 1.001), np.clip(y - 0.5, 0, h - 1.001)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    top = img[y0, x0] * (1 - fx) + img[y0, x0 + 1] * fx
    bottom = img[y0 + 1, x0] * (1 - fx) + img[y0 + 1, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def _psnr(a, b):
    mse = np.mean((np.asarray(a, float) - np.asarray(b, float)) ** 2)
    return np.inf if mse == 0 else 10 * np.log10(255.0 ** 2 / mse)


@pytest.mark.parametrize("suffix", [".glb", ".obj"])
def test_front_view_reproduces_the_drawing(relief, suffix, tmp_path):
    path = export_relief(relief, tmp_path / f"r{suffix}", units_per_pixel=S)[0]
    view, covered = _front_view_of_file(path)
    mask = disk_mask()
    assert covered[mask].mean() > 0.99  # the mesh covers the character
    psnr = _psnr(view[mask], relief.texture[mask])
    assert psnr >= 30.0, f"PSNR {psnr:.1f} dB"
    # The check has teeth: the drawing moved by one pixel, or flipped, fails it.
    assert _psnr(view[mask], np.roll(relief.texture, 1, axis=1)[mask]) < 30.0
    assert _psnr(view[mask], relief.texture[::-1][mask]) < 30.0


# -- Khronos glTF Validator -----------------------------------------------------------

def _validate(path):
    node = shutil.which("node")
    if node is None:
        pytest.skip("Node.js is not installed: cannot run the Khronos glTF Validator")
    if not (ROOT / ".ci" / "node" / "node_modules" / "gltf-validator").is_dir():
        pytest.skip("gltf-validator is not installed: run "
                    "'cd .ci/node && npm ci' (see .ci/run)")
    done = subprocess.run([node, str(VALIDATOR), str(path)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
def test_glb_passes_khronos_validator(closed, tmp_path):
    path = export_relief(disk_relief(closed=closed), tmp_path / "r.glb")[0]
    report = _validate(path)
    issues = report["issues"]
    problems = [m for m in issues["messages"] if m["severity"] <= 1]
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, problems
    assert report["info"]["drawCallCount"] == 2


def test_large_glb_passes_khronos_validator(tmp_path):
    xs = np.linspace(0.0, SIZE[0] - 1.0, 300)
    ys = np.linspace(0.0, SIZE[1] - 1.0, 230)
    part = grid_part("sheet", xs, ys, z=3.0)
    relief = Relief([part], SIZE, drawing())
    report = _validate(export_relief(relief, tmp_path / "big.glb")[0])
    assert report["issues"]["numErrors"] == 0 and report["issues"]["numWarnings"] == 0
    assert report["info"]["totalVertexCount"] == mesh_counts(relief)[0] > 2 * len(part.vertices)


def test_glb_without_texture_passes_khronos_validator(tmp_path):
    relief = disk_relief()
    relief.texture = None
    report = _validate(export_relief(relief, tmp_path / "r.glb")[0])
    assert report["issues"]["numErrors"] == 0 and report["issues"]["numWarnings"] == 0


# -- files written together, nothing on bad input -----------------------------------

def test_obj_writes_groups_material_and_texture(tmp_path):
    relief = disk_relief()
    written = export_relief(relief, tmp_path / "r.obj")
    assert [p.name for p in written] == ["r.obj", "r.mtl", "r_drawing.png"]
    text = (tmp_path / "r.obj").read_text().splitlines()
    assert "mtllib r.mtl" in text
    assert [ln for ln in text if ln.startswith("g ")] == [f"g {p.name}" for p in relief.parts]
    assert "map_Kd r_drawing.png" in (tmp_path / "r.mtl").read_text().splitlines()


@pytest.mark.parametrize("suffix", FORMATS)
def test_output_is_deterministic(suffix, tmp_path):
    relief = disk_relief(closed=True)
    a = export_relief(relief, tmp_path / "a" / f"r{suffix}")
    b = export_relief(relief, tmp_path / "b" / f"r{suffix}")
    for pa, pb in zip(a, b):
        assert pa.read_bytes() == pb.read_bytes()


def _bad(**change):
    relief = disk_relief()
    part = relief.parts[0]
    for key, value in change.items():
        if key == "texture":
            relief.texture = value
        else:
            setattr(part, key, value)
    return relief


@pytest.mark.parametrize("relief, message", [
    (_bad(vertices=np.array([[1.0, 1, 0], [200, 1, 0], [1, 5, 0]]), faces=np.array([[0, 2, 1]])),
     "outside the 160x120 drawing"),
    (_bad(faces=np.array([[0, 1, 99999]])), "indexes past"),
    (_bad(name="head"), "duplicate part name"),
    (_bad(name="two words"), "without spaces"),
    (_bad(texture=np.zeros((10, 10, 3), np.uint8)), "relief.texture"),
    (_bad(vertices=np.full((3, 3), np.nan), faces=np.array([[0, 1, 2]])), "finite"),
    (Relief([], SIZE, None), "no parts"),
])
def test_bad_relief_is_refused_and_nothing_written(relief, message, tmp_path):
    for suffix in FORMATS:
        with pytest.raises(InputError, match=message):
            export_relief(relief, tmp_path / f"r{suffix}")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("kwargs, message", [
    ({"path": "r.stl"}, "unsupported mesh type"),
    ({"anchor": "middle"}, "anchor"),
    ({"units_per_pixel": 0}, "units_per_pixel"),
    ({"units_per_pixel": "big"}, "units_per_pixel"),
])
def test_bad_options_are_refused(kwargs, message, tmp_path):
    path = tmp_path / kwargs.pop("path", "r.glb")
    with pytest.raises(InputError, match=message):
        export_relief(disk_relief(), path, **kwargs)
    assert list(tmp_path.iterdir()) == []


def test_vertices_on_border_pixel_outlines_are_accepted(tmp_path):
    w, h = SIZE
    sheet = grid_part("sheet", [-0.5, w - 0.5], [-0.5, h - 0.5])  # the drawing's edges
    path = export_relief(Relief([sheet], SIZE, drawing()), tmp_path / "s.glb")[0]
    (mesh,) = _load(path).values()
    uv = np.asarray(mesh.visual.uv)
    assert uv.min() == 0.0 and uv.max() == 1.0


def test_export_joins_an_outer_output_group(tmp_path):
    with pytest.raises(RuntimeError):
        with atomic_outputs() as out:
            export_relief(disk_relief(), tmp_path / "r.obj", outputs=out)
            out.write_text(tmp_path / "depth.txt", "x")
            raise RuntimeError("a later step of the same command failed")
    assert list(tmp_path.iterdir()) == []
    with atomic_outputs() as out:
        export_relief(disk_relief(), tmp_path / "r.obj", outputs=out)
        assert not (tmp_path / "r.obj").exists()  # not before the group commits
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.mtl", "r.obj", "r_drawing.png"]


def test_read_meshes_applies_node_transforms_and_keeps_outward_winding(tmp_path):
    ball = trimesh.creation.icosphere(subdivisions=1)
    mirror = np.diag([-2.0, 2.0, 2.0, 1.0])  # mirrored and scaled: det < 0
    mirror[:3, 3] = [5.0, 0.0, 0.0]
    scene = trimesh.Scene()
    scene.add_geometry(ball, geom_name="ball", node_name="mirrored", transform=mirror)
    scene.export(tmp_path / "m.glb")
    (mesh,) = read_meshes(tmp_path / "m.glb")
    assert mesh.name == "mirrored"
    np.testing.assert_allclose(mesh.vertices, ball.vertices * [-2, 2, 2] + [5, 0, 0], atol=1e-6)
    assert trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).volume == pytest.approx(
        8 * ball.volume, rel=1e-5)


def test_read_meshes_refuses_unreadable_files(tmp_path):
    (tmp_path / "junk.glb").write_bytes(b"not a mesh at all")
    (tmp_path / "empty.obj").write_text("# nothing\n")
    (tmp_path / "a.stl").write_text("solid a\nendsolid a\n")
    for name, message in [("junk.glb", "not a GLB file"), ("empty.obj", "no triangles"),
                          ("a.stl", "unsupported mesh type"), ("missing.ply", "no such mesh file")]:
        with pytest.raises(InputError, match=message):
            read_meshes(tmp_path / name)


def test_export_never_writes_non_finite_geometry(tmp_path):
    tri = Part("a", np.array([[0., 0, 0], [0, 9, 1], [9, 0, 0]]), np.array([[0, 1, 2]]))
    relief = Relief([tri], (10, 10), np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(InputError, match="beyond finite 32-bit scene coordinates"):
        export_relief(relief, tmp_path / "r.glb", units_per_pixel=1e300)
    bad = Relief([Part("a", tri.vertices * np.array([1, 1, np.inf]), tri.faces)], (10, 10),
                 np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(InputError):
        export_relief(bad, tmp_path / "r.glb")
    assert list(tmp_path.iterdir()) == []


def test_glb_names_nodes_at_part_centres_and_single_sided_materials(tmp_path):
    relief = disk_relief(closed=False)
    path = export_relief(relief, tmp_path / "turtle.glb", units_per_pixel=S)[0]
    tree = _glb_json(path)
    assert [m["name"] for m in tree["materials"]] == ["turtle"]
    assert [i["name"] for i in tree["images"]] == ["turtle"]
    for node in tree["nodes"]:
        part = next((p for p in relief.parts if p.name == node.get("name")), None)
        if part is None:
            continue
        v = scene_coordinates(back_sheet(relief).parts[relief.parts.index(part)].vertices, SIZE,
                              units_per_pixel=S)
        np.testing.assert_allclose(node["translation"], (v.min(0) + v.max(0)) / 2, atol=1e-6)
    # a part's back is geometry of its own: no material shows the drawing from behind
    for back in BACKS:
        tree = _glb_json(export_relief(relief, tmp_path / f"{back}.glb", back=back)[0])
        assert [m["doubleSided"] for m in tree["materials"]] == [False]


def test_back_plate_makes_watertight_parts_seen_from_every_side(tmp_path):
    relief = disk_relief(closed=False)
    path = export_relief(relief, tmp_path / "r.glb", back="plate")[0]
    for name, mesh in _load(path).items():
        mesh = _welded(mesh)
        assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0, name


@pytest.mark.parametrize("suffix", [".obj", ".ply"])
def test_z_up_files_stand_up_and_read_back_in_place(tmp_path, suffix):
    relief = disk_relief(closed=False)
    y_up = read_relief(export_relief(relief, tmp_path / f"y{suffix}")[0])
    path = export_relief(relief, tmp_path / f"z{suffix}", up="z")[0]
    raw = np.concatenate([m.vertices for m in _load(path).values()])
    flat = np.concatenate([m.vertices for m in _load(tmp_path / f"y{suffix}").values()])
    # standing: the drawing's up along +Z, the side toward the viewer along -Y
    np.testing.assert_allclose(raw, flat[:, [0, 2, 1]] * [1, -1, 1], atol=1e-6)
    z_up = read_relief(path)
    for a, b in zip(y_up.parts, z_up.parts):
        np.testing.assert_allclose(a.vertices, b.vertices, atol=1e-4)
    with pytest.raises(InputError, match="GLB is always y"):
        export_relief(relief, tmp_path / "r.glb", up="z")


def test_ply_vertex_colours_come_back_as_the_drawing():
    import tempfile

    relief = disk_relief(closed=False)
    path = export_relief(relief, Path(tempfile.mkdtemp()) / "r.ply")[0]
    back = read_relief(path)
    assert back.texture is not None and back.texture.shape == relief.texture.shape
    mask = disk_mask()
    got = back.texture[mask].astype(float).ravel()
    same = np.corrcoef(got, relief.texture[mask].astype(float).ravel())[0, 1]
    flipped = np.corrcoef(got, relief.texture[::-1][mask].astype(float).ravel())[0, 1]
    assert same > 0.6 and same > flipped + 0.3, (same, flipped)  # blurred by the mesh only


def test_read_relief_reports_every_file_it_read(tmp_path):
    from inkray.relief.model import Part, Relief

    tri = Part("a", np.array([[0., 0, 0], [0, 9, 2], [9, 0, 0]]), np.array([[0, 1, 2]]))
    relief = Relief([tri], (10, 10), np.zeros((10, 10, 3), np.uint8))
    for suffix, expected in ((".obj", {"r.obj", "r.mtl", "r_drawing.png"}), (".glb", {"r.glb"}),
                             (".ply", {"r.ply"})):
        path = export_relief(relief, tmp_path / suffix[1:] / f"r{suffix}")[0]
        inputs = []
        read_relief(path, inputs=inputs)
        assert {p.name for p in inputs} == expected, suffix
        assert all(p.is_file() for p in inputs)


BODY, HEAD = (200, 180, 150), (90, 160, 220)  # the two disks' paper


def _two_papers():
    """The disks on paper of two colours, inked at their outlines, a red patch on the body."""
    w, h = SIZE
    y, x = np.mgrid[0:h, 0:w].astype(float)
    tex = np.full((h, w, 3), 250, np.uint8)
    for colour, (_, cx, cy, radius, _) in zip((BODY, HEAD), DISKS):
        tex[np.hypot(x - cx, y - cy) < radius] = colour
    for _, cx, cy, radius, _ in DISKS:
        tex[np.abs(np.hypot(x - cx, y - cy) - (radius - 2.0)) < 1.5] = 10
    tex[60:70, 60:70] = (200, 30, 30)
    name, cx, cy, radius, base = DISKS[1]  # the head three times as tall: a steep rim
    head = disk_part(name, cx, cy, radius, base=base, height=3 * radius)
    return Relief([disk_relief().parts[0], head], SIZE, tex)


@pytest.mark.parametrize("back", BACKS)
@pytest.mark.parametrize("suffix", FORMATS)
def test_backs_walls_and_steep_rims_show_the_parts_paper_the_front_the_drawing(suffix, back,
                                                                             tmp_path):
    relief = _two_papers()
    tex = relief.texture
    path = export_relief(relief, tmp_path / f"r{suffix}", back=back, units_per_pixel=S)[0]
    if suffix == ".ply":
        meshes = {m.name: m for m in read_meshes(path)}
    else:
        meshes = _load(path)
    for original, part, paper in zip(relief.parts, BACKED[back](relief).parts, (BODY, HEAD)):
        mesh = meshes[part.name]
        source = _sources(part, mesh.vertices)
        if suffix == ".ply":
            colours = mesh.colors
        else:  # the texel each corner's texture coordinates land on
            uv = np.asarray(mesh.visual.uv)
            col = np.rint(uv[:, 0] * SIZE[0] - 0.5).astype(int)
            row = np.rint((1 - uv[:, 1]) * SIZE[1] - 0.5).astype(int)
            colours = tex[row, col]
        drawn = _drawing_faces(part)
        assert back == "none" or (~drawn).sum() >= len(original.faces)  # a whole back
        assert part.name == "body" or (~drawn[:len(original.faces)]).sum() > 100  # a steep rim
        # backs, walls and steep rims: the part's paper, on all three corners of every face
        plain = colours[mesh.faces[~drawn]]
        assert (plain == paper).all(), (part.name, np.unique(plain.reshape(-1, 3), axis=0))
        # the front: the drawing where each vertex is
        corners = mesh.faces[drawn].ravel()
        xy = part.vertices[source[corners], :2]
        expected = _bilinear(tex.astype(float), xy[:, 0] + 0.5, xy[:, 1] + 0.5)
        if suffix == ".ply":
            np.testing.assert_allclose(colours[corners], expected, atol=1.0)
        else:
            np.testing.assert_allclose(uv[corners], relief.uv(xy), atol=1e-6)


@pytest.mark.parametrize("suffix", [".glb", ".obj"])
def test_front_view_is_the_same_for_every_back(suffix, tmp_path):
    relief = _two_papers()
    views = [_front_view_of_file(export_relief(relief, tmp_path / back / f"r{suffix}",
                                               back=back)[0])[0] for back in BACKS]
    for view in views[1:]:  # backs and walls lie behind the front, under its outline
        np.testing.assert_array_equal(view, views[0])
    # the drawing, but where the head's steep rim shows its paper (a thin ring)
    mask = disk_mask(disks=DISKS[:1]) & ~disk_mask(disks=DISKS[1:], inset=-1.0)
    assert np.abs(views[0][mask] - relief.texture[mask]).max(axis=1).mean() < 3.0
    ring = disk_mask(disks=DISKS[1:]) & ~disk_mask(disks=DISKS[1:], inset=4.0)
    assert (np.abs(views[0][ring] - HEAD).max(axis=1) < 1).mean() > 0.1


@pytest.mark.parametrize("back", BACKS)
@pytest.mark.parametrize("suffix", FORMATS)
def test_read_relief_gives_back_each_part_with_its_back(suffix, back, tmp_path):
    relief = _two_papers()  # the head with a steep rim: copies on its front surface
    read = read_relief(export_relief(relief, tmp_path / f"r{suffix}", back=back)[0])
    assert read.size == relief.size
    by_name = {p.name: p for p in read.parts}
    for original, part in zip(relief.parts, BACKED[back](relief).parts):
        got = by_name[part.name]
        assert len(got.faces) == len(part.faces)
        n, m = len(original.vertices), len(original.faces)
        if suffix == ".obj":  # trimesh orders an OBJ's vertices by the faces' corners
            _sources(part, scene_coordinates(got.vertices, SIZE, units_per_pixel=S))
            continue
        # the front merged back into one surface where the drawing meets the paper,
        # first and in order, as it was
        np.testing.assert_allclose(got.vertices[:n], original.vertices, atol=1e-3)
        np.testing.assert_array_equal(got.faces[:m], original.faces)


@pytest.mark.parametrize("back", BACKS)
@pytest.mark.parametrize("suffix", FORMATS)
def test_mesh_counts_are_what_the_file_holds(suffix, back, tmp_path):
    relief = _two_papers()
    path = export_relief(relief, tmp_path / f"r{suffix}", back=back)[0]
    if suffix == ".obj":
        lines = path.read_text().splitlines()
        held = (sum(ln.startswith("v ") for ln in lines), sum(ln.startswith("f ") for ln in lines))
    else:
        meshes = _load(path).values()
        held = (sum(len(m.vertices) for m in meshes), sum(len(m.faces) for m in meshes))
    assert mesh_counts(relief, suffix=suffix, back=back) == held


def test_paper_is_the_median_of_the_parts_seen_non_ink_pixels_posed_or_not(tmp_path):
    # the noisy drawing: no pixel has the median colour; the texel comes within 24 levels
    relief = disk_relief()
    tex = relief.texture.astype(int)
    w, h = SIZE
    y, x = np.mgrid[0:h, 0:w]
    ink = tex.max(axis=2) < 0.6 * np.percentile(tex.max(axis=2), 95)
    (_, bx, by, br, _), (_, hx, hy, hr, _) = DISKS
    seen = {"body": (np.hypot(x - bx, y - by) < br - 1) & (np.hypot(x - hx, y - hy) > hr + 1),
            "head": np.hypot(x - hx, y - hy) < hr - 1}
    # posed: moved right, textured from where they rest
    posed = Relief([Part(p.name, p.vertices + [8.0, 0, 0], p.faces, texcoords=p.vertices[:, :2])
                    for p in relief.parts], (w + 8, h), np.pad(relief.texture, ((0, 0), (0, 8),
                                                                                 (0, 0))))
    for r in (relief, posed):
        mesh = _load(export_relief(r, tmp_path / f"r{len(r.parts)}{r.size[0]}.glb")[0])
        for part in r.parts:
            m = mesh[part.name]
            uv = np.asarray(m.visual.uv)[m.faces[len(part.faces):].ravel()]  # the back
            (texel,) = np.unique(np.rint(uv * [r.size[0], r.size[1]] - 0.5).astype(int), axis=0)
            colour = tex[r.size[1] - 1 - texel[1], texel[0]]
            median = np.median(tex[seen[part.name] & ~ink], axis=0)
            assert np.abs(colour - median).sum() <= 24, (part.name, colour, median)


def test_a_part_too_small_for_the_paper_view_takes_the_colour_under_it(tmp_path):
    # a 1.5 px dot of dark blue paper on a 1024 x 768 drawing (seen at a quarter scale)
    tex = np.full((768, 1024, 3), 250, np.uint8)
    tex[400:404, 500:504] = (20, 40, 160)
    dot = grid_part("dot", [501.0, 502.0], [401.0, 402.0], z=2.0)
    relief = Relief([grid_part("sheet", [0.0, 1023.0], [0.0, 767.0]), dot], (1024, 768), tex)
    mesh = _load(export_relief(relief, tmp_path / "r.glb")[0])["dot"]
    uv = np.asarray(mesh.visual.uv)[mesh.faces[len(dot.faces):].ravel()]  # its back
    (texel,) = np.unique(np.rint(uv * [1024, 768] - 0.5).astype(int), axis=0)
    assert tuple(tex[767 - texel[1], texel[0]]) == (20, 40, 160)
