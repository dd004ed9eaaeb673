import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import trimesh

from _reliefs import SIZE, disk_mask, disk_relief, drawing, grid_part
from inkray.errors import InputError
from inkray.formats.meshes import (FORMATS, export_relief, pixel_coordinates, read_meshes, read_relief,
                           scene_coordinates)
from inkray.formats.atomic import atomic_outputs
from inkray.view.rasterization import rasterize
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


def _front_vertices(part):
    """Which vertices a face toward the viewer uses (the others show the part's paper)."""
    v = part.vertices * [1.0, -1.0, 1.0]  # scene frame: z toward the viewer
    t = v[part.faces]
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    facing = n[:, 2] >= 0.1 * np.linalg.norm(n, axis=1)
    out = np.zeros(len(v), bool)
    out[part.faces[facing].ravel()] = True
    return out


def _concat(relief, key):
    return np.concatenate([getattr(p, key) for p in relief.parts])


@pytest.fixture(params=[False, True], ids=["open", "closed"])
def relief(request):
    return disk_relief(closed=request.param)


# -- round trip through trimesh -------------------------------------------------

@pytest.mark.parametrize("suffix", [".glb", ".obj"])
def test_textured_formats_round_trip_per_part(relief, suffix, tmp_path):
    path = export_relief(relief, tmp_path / f"r{suffix}", units_per_pixel=S)[0]
    meshes = _load(path)
    assert sorted(meshes) == sorted(p.name for p in relief.parts)
    for part in relief.parts:
        mesh = meshes[part.name]
        assert len(mesh.vertices) == len(part.vertices)
        assert len(mesh.faces) == len(part.faces)
        np.testing.assert_array_equal(mesh.faces, part.faces)
        np.testing.assert_allclose(mesh.vertices, scene_coordinates(part.vertices, SIZE,
                                                                     units_per_pixel=S),
                                   atol=1e-7)
        uv = np.asarray(mesh.visual.uv)
        assert uv.min() >= 0.0 and uv.max() <= 1.0
        front = _front_vertices(part)
        np.testing.assert_allclose(uv[front], relief.uv(part.vertices[front]), atol=1e-6)
        assert len(np.unique(uv[~front].round(7), axis=0)) <= 1  # backs: one plain texel
        material = mesh.visual.material
        image = material.baseColorTexture if suffix == ".glb" else material.image
        assert image is not None, "texture missing"
        np.testing.assert_array_equal(np.asarray(image.convert("RGB")), relief.texture)


def test_ply_round_trip_counts_colours_and_uvs(relief, tmp_path):
    path = export_relief(relief, tmp_path / "r.ply", units_per_pixel=S)[0]
    assert path.read_bytes().startswith(b"ply\nformat binary_little_endian 1.0\n")
    mesh = _load(path)["ply"]
    n = sum(len(p.vertices) for p in relief.parts)
    assert len(mesh.vertices) == n
    assert len(mesh.faces) == sum(len(p.faces) for p in relief.parts)
    raw = mesh.metadata["_ply_raw"]["vertex"]["data"]
    uv = np.stack([raw["s"], raw["t"]], axis=1)
    assert uv.min() >= 0.0 and uv.max() <= 1.0
    front = np.concatenate([_front_vertices(p) for p in relief.parts])
    np.testing.assert_allclose(uv[front], relief.uv(_concat(relief, "vertices")[front]), atol=1e-6)
    colours = np.stack([raw[c] for c in ("red", "green", "blue", "alpha")], axis=1)
    assert colours.shape == (n, 4) and np.all(colours[:, 3] == 255)
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
    np.testing.assert_array_equal(colours, tex[20:45, 10:50].reshape(-1, 3))


@pytest.mark.parametrize("suffix", FORMATS)
def test_read_meshes_returns_each_part(relief, suffix, tmp_path):
    path = export_relief(relief, tmp_path / f"r{suffix}", units_per_pixel=S)[0]
    meshes = {m.name: m for m in read_meshes(path)}
    assert sorted(meshes) == sorted(p.name for p in relief.parts)
    for part in relief.parts:
        m = meshes[part.name]
        np.testing.assert_array_equal(m.faces, part.faces)
        np.testing.assert_allclose(m.vertices, scene_coordinates(part.vertices, SIZE,
                                                                 units_per_pixel=S), atol=1e-7)


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


def test_glb_normals_and_winding_face_the_viewer(tmp_path):
    relief = disk_relief(closed=False)
    for mesh in _load(export_relief(relief, tmp_path / "r.glb")[0]).values():
        # Spherical caps seen from the front: every face and vertex normal has +Z.
        assert np.all(mesh.face_normals[:, 2] > 0)
        normals = mesh.vertex_normals  # as stored in the file (process=False keeps them)
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-6)
        assert np.all(normals[:, 2] > 0)


def test_closed_glb_faces_point_outward(tmp_path):
    relief = disk_relief(closed=True)
    for name, mesh in _load(export_relief(relief, tmp_path / "r.glb")[0]).items():
        centre = mesh.bounds.mean(axis=0)
        outward = np.einsum("ij,ij->i", mesh.face_normals, mesh.triangles_center - centre)
        assert np.all(outward > 0), name
        assert mesh.is_watertight and mesh.volume > 0


def test_large_part_keeps_32_bit_indices(tmp_path):
    xs = np.linspace(0.0, SIZE[0] - 1.0, 300)
    ys = np.linspace(0.0, SIZE[1] - 1.0, 230)  # 69 000 vertices > 65 535
    part = grid_part("sheet", xs, ys, z=3.0)
    path = export_relief(Relief([part], SIZE, drawing()), tmp_path / "big.glb")[0]
    (mesh,) = _load(path).values()
    assert mesh.faces.max() == len(part.vertices) - 1 > 65535
    np.testing.assert_array_equal(mesh.faces, part.faces)


# -- frame --------------------------------------------------------------------------

@pytest.mark.parametrize("anchor", ["center", "top-left"])
def test_frame_anchor_and_scale(anchor, tmp_path):
    w, h = SIZE
    # The drawing's corners: pixel centres are integers, so it spans [-0.5, W - 0.5].
    corners = grid_part("sheet", [-0.5, w - 0.5], [-0.5, h - 0.5], z=10.0)
    path = export_relief(Relief([corners], SIZE, drawing()), tmp_path / "c.obj",
                         units_per_pixel=0.01, anchor=anchor)[0]
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
    report = _validate(export_relief(Relief([part], SIZE, drawing()), tmp_path / "big.glb")[0])
    assert report["issues"]["numErrors"] == 0 and report["issues"]["numWarnings"] == 0
    assert report["info"]["totalVertexCount"] == len(part.vertices)


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


def test_glb_names_nodes_at_part_centres_and_double_sided_materials(tmp_path):
    relief = disk_relief(closed=False)
    path = export_relief(relief, tmp_path / "turtle.glb", units_per_pixel=S)[0]
    tree = _glb_json(path)
    assert [m["name"] for m in tree["materials"]] == ["turtle"]
    assert [i["name"] for i in tree["images"]] == ["turtle"]
    assert all(m.get("doubleSided") for m in tree["materials"])
    for node in tree["nodes"]:
        part = next((p for p in relief.parts if p.name == node.get("name")), None)
        if part is None:
            continue
        v = scene_coordinates(part.vertices, SIZE, units_per_pixel=S)
        np.testing.assert_allclose(node["translation"], (v.min(0) + v.max(0)) / 2, atol=1e-6)
    tree = _glb_json(export_relief(relief, tmp_path / "one.glb", back="none")[0])
    assert not any(m.get("doubleSided") for m in tree["materials"])


def test_back_plate_makes_watertight_parts_seen_from_every_side(tmp_path):
    relief = disk_relief(closed=False)
    path = export_relief(relief, tmp_path / "r.glb", back="plate")[0]
    for name, mesh in _load(path).items():
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


@pytest.mark.parametrize("suffix", [".glb", ".ply"])
def test_backs_and_walls_show_the_parts_paper_not_the_drawing(suffix, tmp_path):
    # a flat square on paper of one colour, inked at its outline, closed by a plate:
    # from behind (the plate) and from the side (the walls' lower corners) the file
    # shows the paper colour, from the front the drawing
    tex = np.full((60, 80, 3), (200, 180, 150), np.uint8)
    tex[10:50, 20:24] = tex[10:50, 56:60] = tex[10:14, 20:60] = tex[46:50, 20:60] = 10
    tex[25:35, 35:45] = (200, 30, 30)  # a red patch in the middle of the front
    relief = Relief([grid_part("sq", np.arange(20.0, 60.0), np.arange(10.0, 50.0), z=5.0)],
                    (80, 60), tex)
    path = export_relief(relief, tmp_path / f"r{suffix}", back="plate")[0]
    back = read_relief(path)  # pixel frame, as the parts were
    part = back.parts[0]
    mesh = _load(path)["sq" if suffix == ".glb" else "ply"]
    n = len(relief.parts[0].vertices)
    if suffix == ".glb":
        uv = np.asarray(mesh.visual.uv)
        texel = np.stack([uv[:, 0] * 80 - 0.5, (1 - uv[:, 1]) * 60 - 0.5], axis=1)
        colours = tex[np.rint(texel[:, 1]).astype(int), np.rint(texel[:, 0]).astype(int)]
    else:
        raw = mesh.metadata["_ply_raw"]["vertex"]["data"]
        colours = np.stack([raw[c] for c in ("red", "green", "blue")], axis=1)
    plate = part.vertices[:, 2] < 4.5  # the plate one pixel behind z = 5
    assert plate.sum() == n and (colours[plate] == (200, 180, 150)).all()
    front = ~plate
    np.testing.assert_array_equal(colours[front], tex[np.rint(part.vertices[front, 1]).astype(int),
                                                      np.rint(part.vertices[front, 0]).astype(int)])
