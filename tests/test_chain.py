"""The whole relief chain on real drawings, and the `inkray relief` command."""

import json

import numpy as np
import pytest
import trimesh

from _mesh import height_at
from conftest import EXAMPLES, SHARED, shared_drawing_names
from inkray import cli
from inkray.input.loading import load_input
from inkray.chain import build_relief
from inkray.view.rasterization import rasterize

FAST = ("balls", "turtle")


def _relief_checks(result, ann):
    relief, labels = result.relief, result.segmentation.labels
    # seen from the front, the parts cover exactly the character
    raster = rasterize(relief, size=relief.size, scale=1.0)
    character = labels >= 0
    iou = (raster.mask & character).sum() / (raster.mask | character).sum()
    assert iou >= 0.99, iou
    # every order entry holds at its own two points, wherever both meshes are there
    parts = {p.name: p for p in relief.parts}
    checked = 0
    for rel in result.relations:
        if rel.source != "user" or rel.kind != "order" or rel.place is None:
            continue
        e = ann.order[rel.entry]
        front, back = parts[rel.front_name], parts[rel.back_name]
        pts = np.array([e.front, e.back], float)
        zf, df = height_at(front.vertices, front.faces, front.vertices[:, 2], pts)
        zb, db = height_at(back.vertices, back.faces, back.vertices[:, 2], pts)
        both = (df < 1e-6) & (db < 1e-6)
        assert np.all(zf[both] >= zb[both] + result.layers.epsilon - 1e-6), rel.label
        checked += int(both.any())
    assert result.layers.violation <= 1e-6
    return checked


@pytest.mark.parametrize("name", FAST)
def test_examples_build_a_faithful_relief(name):
    ann, drawing = load_input(EXAMPLES / name / "drawing.inkray.json")
    result = build_relief(ann, drawing)
    assert [p.name for p in result.relief.parts] == [r.name for r in ann.regions]
    assert _relief_checks(result, ann) >= 1
    assert [t for t, _ in result.timings] == ["segment", "complete", "order", "inflate",
                                             "stitch", "assemble"]


@pytest.mark.slow
@pytest.mark.parametrize("name", shared_drawing_names())
def test_every_shared_drawing_builds(name):
    ann, drawing = load_input(SHARED / name / "drawing.inkray.json")
    result = build_relief(ann, drawing)
    _relief_checks(result, ann)


def test_deterministic():
    ann, drawing = load_input(EXAMPLES / "balls" / "drawing.inkray.json")
    a = build_relief(ann, drawing).relief
    b = build_relief(ann, drawing).relief
    for p, q in zip(a.parts, b.parts):
        np.testing.assert_array_equal(p.vertices, q.vertices)
        np.testing.assert_array_equal(p.faces, q.faces)


def test_relief_command_writes_mesh_and_images(tmp_path, capsys):
    ann = EXAMPLES / "balls" / "drawing.inkray.json"
    out = tmp_path / "balls.glb"
    code = cli.main(["relief", str(ann), "-o", str(out), "--closed", "--depth-png", "--normals-png"])
    _, err = capsys.readouterr()
    assert code == 0, err
    assert {p.name for p in tmp_path.iterdir()} == {"balls.glb", "balls-depth.png",
                                                     "balls-normals.png"}
    assert "stitch" in err and "total" in err  # per-stage timing summary
    scene = trimesh.load(out)
    assert sorted(scene.geometry) == ["ball_big", "ball_mid", "ball_small"]
    assert all(g.is_watertight for g in scene.geometry.values())
    assert cli.main(["check", str(out), "--require", "watertight,manifold,oriented"]) == 0
    capsys.readouterr()
    code = cli.main(["--quiet", "relief", str(ann), "-o", str(tmp_path / "u.obj"), "--closed",
                     "--union"])
    _, err = capsys.readouterr()
    assert code == 0 and err == ""
    assert cli.main(["check", str(tmp_path / "u.obj"), "--require", "watertight,manifold"]) == 0


def test_relief_command_rejects_bad_input_and_writes_nothing(tmp_path, capsys):
    doc = json.loads((EXAMPLES / "turtle" / "drawing.inkray.json").read_text())
    doc["drawing"] = str(EXAMPLES / "turtle" / "drawing.png")
    doc["boundaries"] = [{"type": "graft", "path": [[5, 5], [40, 5]]}]  # far from any outline
    ann = tmp_path / "bad.inkray.json"
    ann.write_text(json.dumps(doc))
    out = tmp_path / "out" / "t.glb"
    assert cli.main(["relief", str(ann), "-o", str(out)]) == 2
    err = capsys.readouterr().err.splitlines()  # progress lines, then one error line
    assert err[-1].startswith("inkray: error: boundaries[0]: no region outline within")
    assert sum(line.startswith("inkray: error") for line in err) == 1
    assert not out.parent.exists() or not any(out.parent.iterdir())
    assert cli.main(["relief", str(ann), "-o", str(out), "--union"]) == 2
    assert "--union needs --closed" in capsys.readouterr().err
