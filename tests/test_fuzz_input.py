"""Seeded fuzzing of the input edge: hostile annotation files, drawings and meshes.

Every run ends with exit 0 or 2 (never an internal error), and a failure is
one line that starts with ``inkray: error:``; nothing is written. A long run
with counts, memory and kills: ``python benchmarks/fuzz.py``.
"""

import json

import numpy as np
import pytest
from PIL import Image

from inkray import cli
from inkray.formats.meshes import export_relief
from inkray.relief.model import Part, Relief

from _hostile import hostile_annotation, hostile_image, hostile_mesh


@pytest.fixture
def base(tmp_path, minimal_doc):
    drawing = np.full((8, 10), 255, np.uint8)
    drawing[1:, 5] = 0
    Image.fromarray(drawing).save(tmp_path / "d.png")
    path = tmp_path / "base.inkray.json"
    path.write_text(json.dumps(minimal_doc, indent=1))
    return path


def _check(capsys, argv, outputs=()):
    code = cli.main(["--quiet", *argv])
    out, err = capsys.readouterr()
    assert code in (0, 2), (argv, err)
    assert "internal error" not in err and "Traceback" not in err, err
    if code == 2:
        assert err.startswith("inkray: error: ") and err.count("\n") == 1, err
        assert not any(p.exists() for p in outputs), argv
    return code


def test_hostile_annotation_files(tmp_path, base, capsys):
    rng = np.random.default_rng(20261125)
    codes = [_check(capsys, ["validate", str(hostile_annotation(rng, tmp_path, base, i))])
             for i in range(150)]
    assert codes.count(2) > 100  # the generator mostly makes broken files


def test_hostile_drawings(tmp_path, base, capsys):
    rng = np.random.default_rng(7)
    for i in range(60):
        drawing = hostile_image(rng, tmp_path, tmp_path / "d.png", i)
        _check(capsys, ["validate", str(base), "--drawing", str(drawing)])


def test_hostile_meshes(tmp_path, capsys):
    rng = np.random.default_rng(11)
    grid = np.stack(np.meshgrid(np.arange(6.0), np.arange(6.0)), -1).reshape(-1, 2)
    faces = np.array([[i, i + 1, i + 6] for i in range(29) if i % 6 != 5])
    part = Part("a", np.column_stack([grid, np.ones(len(grid))]), faces)
    relief = Relief([part], (6, 6), rng.integers(0, 255, (6, 6, 3), dtype=np.uint8))
    source = tmp_path / "src"
    bases = [export_relief(relief, source / f"r{s}")[0] for s in (".glb", ".obj", ".ply")]
    work = tmp_path / "work"
    work.mkdir()
    for i in range(60):
        mesh = hostile_mesh(rng, work, bases, i)
        out = work / f"o{i}.png"
        _check(capsys, ["check", str(mesh)])
        _check(capsys, ["render", str(mesh), "-o", str(out), "--size", "32x32"], outputs=[out])
