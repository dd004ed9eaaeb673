import json

import numpy as np
import pytest
from PIL import Image

from inkray import cli
from inkray.chain import ReliefChain
from inkray.errors import InputError
from inkray.formats.layer_files import read_layers
from inkray.input.loading import load_input
from inkray.input.scene import load_scene, parse_scene
from inkray.relief.cutout import cut_out
from inkray.view.posed import posed_image

from conftest import EXAMPLES

RINGS = EXAMPLES / "rings" / "drawing.inkray.json"


def scene_file(tmp_path, drawings, size=(640, 200)):
    path = tmp_path / "two.scene.json"
    path.write_text(json.dumps({"format": "inkray-scene", "version": 1, "size": list(size),
                                "drawings": drawings}))
    return path


def test_two_copies_side_by_side_equal_the_drawing_twice(tmp_path):
    ann, drawing = load_input(RINGS)
    chain = ReliefChain(ann, drawing)
    alone, _ = posed_image(chain.relief, chain.relief,
                           cut_out(chain.completion, chain.relations, drawing), drawing.rgb)
    scene = scene_file(tmp_path, [{"annotation": str(RINGS), "at": [159.5, 99.5]},
                                  {"annotation": str(RINGS), "at": [479.5, 99.5]}])
    out = tmp_path / "two.png"
    assert cli.main(["compose", str(scene), "-o", str(out), "--quiet"]) == 0
    both = np.asarray(Image.open(out))
    assert np.array_equal(both[:, :320], alone) and np.array_equal(both[:, 320:], alone)
    layers = tmp_path / "two.ora"
    assert cli.main(["compose", str(scene), "-o", str(layers), "--quiet"]) == 0
    names = [layer.name for layer in read_layers(layers).layers]
    assert names == ["d0-ring_a", "d0-ring_b", "d1-ring_a", "d1-ring_b"] or \
        names == ["d0-ring_b", "d0-ring_a", "d1-ring_b", "d1-ring_a"]


def test_depth_decides_which_drawing_is_in_front(tmp_path):
    # the same drawing twice, overlapping: the later one in front by order, the earlier by depth
    first = {"annotation": str(RINGS), "at": [159.5, 99.5]}
    second = {"annotation": str(RINGS), "at": [199.5, 99.5]}
    by_order = tmp_path / "order.png"
    cli.main(["compose", str(scene_file(tmp_path, [first, second], (400, 200))), "-o",
              str(by_order), "--quiet"])
    raised = tmp_path / "raised.png"
    cli.main(["compose", str(scene_file(tmp_path, [dict(first, depth=500), dict(second, depth=0)], (400, 200))),
              "-o", str(raised), "--quiet"])
    a, b = np.asarray(Image.open(by_order)), np.asarray(Image.open(raised))
    ann, drawing = load_input(RINGS)
    chain = ReliefChain(ann, drawing)
    alone, _ = posed_image(chain.relief, chain.relief,
                           cut_out(chain.completion, chain.relations, drawing), drawing.rgb)
    # where the second copy covers, the order picture shows it; the raised picture the first
    shifted = np.zeros_like(a)
    shifted[:, 40:360] = alone
    cover = shifted[..., 3] == 255
    assert np.mean(np.all(a[cover] == shifted[cover], axis=1)) > 0.99
    first_cover = alone[..., 3] == 255
    assert np.mean(np.all(b[:, :320][first_cover] == alone[first_cover], axis=1)) > 0.99


@pytest.mark.parametrize("change, message", [
    (dict(size=[0, 10]), "size: expected [width, height]"),
    (dict(drawings=[]), "drawings: expected 1..64 drawings"),
    (dict(drawings=[{"at": [1, 1]}]), "drawings[0].annotation: missing required key"),
    (dict(drawings=[{"annotation": "a", "at": [1, 1], "frame": 2}]), "drawings[0].frame: a frame needs a pose"),
    (dict(drawings=[{"annotation": "a", "at": [1, 1], "spin": 2}]), "drawings[0].spin: unknown key"),
])
def test_bad_scenes_name_the_key_path(change, message):
    doc = {"format": "inkray-scene", "version": 1, "size": [10, 10],
           "drawings": [{"annotation": "a", "at": [1, 1]}]}
    doc.update(change)
    with pytest.raises(InputError) as e:
        parse_scene(doc)
    assert str(e.value).startswith(message), str(e.value)


def test_compose_refuses_a_missing_drawing_with_its_entry(tmp_path, capsys):
    scene = scene_file(tmp_path, [{"annotation": "nowhere.inkray.json", "at": [1, 1]}])
    assert cli.main(["compose", str(scene), "-o", str(tmp_path / "x.png"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "drawings[0]:" in err[0]
    assert load_scene(scene).drawings[0].annotation == tmp_path / "nowhere.inkray.json"


def test_scene_relief_has_every_drawing_s_parts_textured_from_the_atlas(tmp_path):
    import trimesh

    scene = scene_file(tmp_path, [{"annotation": str(RINGS), "at": [159.5, 99.5]},
                                  {"annotation": str(RINGS), "at": [479.5, 99.5]}])
    out = tmp_path / "two.glb"
    assert cli.main(["compose", str(scene), "-o", str(out), "--quiet"]) == 0
    glb = trimesh.load(out, force="scene")
    names = sorted(glb.geometry)
    assert names == ["d0-ring_a", "d0-ring_b", "d1-ring_a", "d1-ring_b"]
    for part in ("ring_a", "ring_b"):
        a, b = (glb.geometry[f"d{k}-{part}"] for k in (0, 1))
        assert np.array_equal(a.faces, b.faces)
        ta = glb.graph.get(f"d0-{part}")[0]
        tb = glb.graph.get(f"d1-{part}")[0]
        wa = trimesh.transform_points(a.vertices, ta)
        wb = trimesh.transform_points(b.vertices, tb)
        shift = (wb - wa).mean(axis=0)
        assert np.allclose(wb - wa, shift, atol=1e-6) and shift[0] > 0 and abs(shift[1]) < 1e-6
        # the second copy's texture is the lower half of the atlas
        assert a.visual.uv[:, 1].min() >= 0.5 - 1e-6 and b.visual.uv[:, 1].max() <= 0.5 + 1e-6
