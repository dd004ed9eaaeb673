"""Hostile mesh files: one-line input errors naming what and where, before any parser runs."""

import os
import struct

import numpy as np
import pytest

from inkray import cli
from inkray.errors import InputError
from inkray.formats.mesh_inspection import inspect_mesh_file
from inkray.formats.meshes import export_relief, read_relief
from inkray.relief.model import Part, Relief

TRI = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
PLY = ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
       "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n")

CASES = [
    ("zero.obj", TRI + "f 0 1 2\n", "line 4: face index 0 (OBJ counts from 1)"),
    ("beyond.obj", TRI + "f 1 2 9\n", "line 4: face index 9 but the file has 3 vertices"),
    ("relative.obj", TRI + "f -1 -2 -9\n", "line 4: relative index -9 reaches before"),
    ("word.obj", TRI + "f 1 2 x\n", "line 4: 'x' is not a vertex index"),
    ("giant.obj", TRI + "f " + " ".join(["1"] * 2000) + "\n", "a polygon of 2000 corners"),
    ("latin.obj", b"o caf\xe9\n" + TRI.encode() + b"f 1 2 3\n", "line 1: not UTF-8 text"),
    ("nan.obj", TRI.replace("v 0 0 0", "v nan 0 0") + "f 1 2 3\n", "vertex 0 is not finite"),
    ("neg.ply", PLY + "0 0 0\n1 0 0\n0 1 0\n3 0 1 -7\n", "face 0 [0, 1, -7] uses a vertex outside 0..2"),
    ("big.ply", PLY + "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "uses a vertex outside 0..2"),
    ("nan.ply", PLY + "nan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "vertex 0 is not finite"),
    ("count.ply", PLY.replace("element vertex 3", "element vertex 4000000000").replace(
        "format ascii", "format binary_little_endian"), "declares 4000000000 vertex elements"),
    ("magic.glb", b"glTX" + b"\0" * 40, "not a GLB file"),
    ("version.glb", b"glTF" + struct.pack("<II", 7, 52) + b"\0" * 40, "GLB version 7"),
    ("short.glb", b"glTF" + struct.pack("<II", 2, 10 ** 9) + b"\0" * 20, "gives 1000000000 bytes"),
    ("chunk.glb", b"glTF" + struct.pack("<III", 2, 32, 999) + b"JSON" + b"\0" * 12,
     "a chunk of 999 bytes runs past the end"),
    ("json.glb", b"glTF" + struct.pack("<III", 2, 28, 8) + b"JSON" + b"{[[[[[[[",
     "the glTF JSON is malformed"),
]


@pytest.mark.parametrize("name,content,message", CASES, ids=[c[0] for c in CASES])
def test_hostile_meshes_are_one_line_input_errors(tmp_path, capsys, name, content, message):
    path = tmp_path / name
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    for command in (["check", str(path)], ["render", str(path), "-o", str(tmp_path / "o.png")]):
        code = cli.main(["--quiet", *command])
        err = capsys.readouterr().err
        assert code == 2 and message in err and err.count("\n") == 1, (command, err)
        assert err.startswith(f"inkray: error: {path}")
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_special_files_referenced_by_a_mesh(tmp_path):
    os.mkfifo(tmp_path / "pipe.mtl")
    (tmp_path / "m.obj").write_text("mtllib pipe.mtl\n" + TRI + "f 1 2 3\n")
    with pytest.raises(InputError, match="pipe.mtl: not a regular file \\(a FIFO\\)"):
        inspect_mesh_file(tmp_path / "m.obj")
    (tmp_path / "t.mtl").write_text("newmtl a\nmap_Kd -clamp on tex.png\n")
    (tmp_path / "tex.png").mkdir()
    (tmp_path / "t.obj").write_text("mtllib t.mtl\n" + TRI + "f 1 2 3\n")
    with pytest.raises(InputError, match="tex.png: not a regular file \\(a directory\\)"):
        inspect_mesh_file(tmp_path / "t.obj")
    with pytest.raises(InputError, match="not a regular file \\(a device\\)"):
        inspect_mesh_file("/dev/zero")


def test_corrupt_texture_in_a_glb(tmp_path):
    tri = Part("a", np.array([[0., 0, 0], [0, 9, 1], [9, 0, 0]]), np.array([[0, 1, 2]]))
    texture = np.random.default_rng(0).integers(0, 255, (10, 10, 3), dtype=np.uint8)
    path = export_relief(Relief([tri], (10, 10), texture), tmp_path / "r.glb")[0]
    data = bytearray(path.read_bytes())
    start = data.find(b"IDAT") + 4
    data[start:start + 40] = b"\0" * 40
    path.write_bytes(bytes(data))
    with pytest.raises(InputError, match="node a: the texture cannot be decoded"):
        read_relief(path)


def test_well_formed_files_pass(tmp_path):
    tri = Part("a", np.array([[0., 0, 0], [0, 9, 1], [9, 0, 0]]), np.array([[0, 1, 2]]))
    relief = Relief([tri], (10, 10), np.zeros((10, 10, 3), np.uint8))
    for suffix in (".glb", ".obj", ".ply"):
        path = export_relief(relief, tmp_path / f"r{suffix}")[0]
        assert inspect_mesh_file(path) == path

