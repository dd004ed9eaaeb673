import json

import numpy as np
import pytest
from PIL import Image

from inkray.input.annotations import parse_annotations
from inkray.errors import InputError
from inkray.input.loading import load_input
from inkray.input.scribbles import BACKGROUND, UNSEEDED, load_scribble_layer, polyline_pixels, seed_image


def test_polyline_is_connected_and_brush_widens_it():
    r, c = polyline_pixels([[1, 1], [8, 5]], (10, 10))
    assert len(r) == 8  # Bresenham: one pixel per column
    assert {(1, 1), (5, 8)} <= set(zip(r.tolist(), c.tolist()))
    r2, _ = polyline_pixels([[1, 1], [8, 5]], (10, 10), radius=1)
    assert len(r2) > 2 * len(r)
    r3, c3 = polyline_pixels([[0, 0]], (5, 5), radius=2)  # clipped at the border
    assert r3.min() == 0 and c3.min() == 0


def test_seed_image_labels_and_conflicts(minimal_doc):
    minimal_doc["regions"][1]["scribbles"] = [[[1, 4], [3, 0]]]  # crosses region a's stroke
    ann = parse_annotations(minimal_doc)
    seeds = seed_image(ann)
    assert seeds.shape == (8, 10)
    assert seeds[1, 1] == 0 and seeds[0, 5] == BACKGROUND
    crossing = (seed_image(ann, include_background=False) == UNSEEDED)
    # pixels claimed by both regions are left unseeded, the rest keep their label
    both = set(zip(*polyline_pixels([[1, 1], [3, 2]], (8, 10)))) & set(zip(*polyline_pixels([[1, 4], [3, 0]], (8, 10))))
    assert both and all(crossing[p] for p in both)
    assert (seeds == 1).any()


def _layer(tmp_path, size=(10, 8)):
    w, h = size
    rgba = np.zeros((h, w, 4), np.uint8)
    rgba[1, 1:4] = [255, 0, 0, 255]
    rgba[6, 5:8] = [0, 0, 255, 255]
    rgba[0, 0:10] = [0, 255, 0, 255]
    rgba[4, 4] = [255, 0, 0, 60]  # antialiased edge: ignored
    Image.fromarray(rgba, "RGBA").save(tmp_path / "s.png")
    return tmp_path / "s.png"


def test_scribble_layer_with_legend(tmp_path):
    path = _layer(tmp_path)
    regions, bg = load_scribble_layer(path, (10, 8), legend={"#ff0000": "body", "#0000FF": "arm",
                                                             "#00ff00": "background"})
    assert [r.name for r in regions] == ["body", "arm"]
    assert sorted(map(tuple, regions[0].pixels.tolist())) == [(1, 1), (2, 1), (3, 1)]
    assert len(bg) == 10
    unnamed, _ = load_scribble_layer(path, (10, 8))
    assert [r.name for r in unnamed] == ["region_00ff00", "region_ff0000", "region_0000ff"]


def test_scribble_layer_errors(tmp_path):
    path = _layer(tmp_path)
    with pytest.raises(InputError, match="scribble layer is 10x8 but the drawing is 12x8"):
        load_scribble_layer(path, (12, 8))
    with pytest.raises(InputError, match=r"colour #0000ff at pixel \(5, 6\) is not in the legend"):
        load_scribble_layer(path, (10, 8), legend={"#ff0000": "a", "#00ff00": "background"})
    with pytest.raises(InputError, match="legend.red: expected a colour key"):
        load_scribble_layer(path, (10, 8), legend={"red": "a"})
    Image.fromarray(np.zeros((8, 10, 4), np.uint8), "RGBA").save(tmp_path / "e.png")
    with pytest.raises(InputError, match="no opaque stroke pixels"):
        load_scribble_layer(tmp_path / "e.png", (10, 8))


def test_load_input_merges_layer_regions(tmp_path, minimal_doc):
    Image.fromarray(np.full((8, 10), 255, np.uint8)).save(tmp_path / "d.png")
    (tmp_path / "a.inkray.json").write_text(json.dumps(minimal_doc))
    path = _layer(tmp_path)
    (tmp_path / "legend.json").write_text(json.dumps({"#ff0000": "a", "#0000ff": "c", "#00ff00": "background"}))
    ann, drawing = load_input(tmp_path / "a.inkray.json", scribble_layer=path, legend=tmp_path / "legend.json")
    assert [r.name for r in ann.regions] == ["a", "b", "c"]
    assert ann.regions[0].pixels.shape == (3, 2) and len(ann.regions[0].scribbles) == 1
    seeds = seed_image(ann)
    assert seeds[6, 6] == 2 and seeds[0, 9] == BACKGROUND


def test_load_input_size_mismatch_and_rescale(tmp_path, minimal_doc):
    Image.fromarray(np.full((16, 20), 255, np.uint8)).save(tmp_path / "d.png")
    (tmp_path / "a.inkray.json").write_text(json.dumps(minimal_doc))
    with pytest.raises(InputError, match=r"^size: the annotation is for a 10x8 drawing but .* is 20x16"):
        load_input(tmp_path / "a.inkray.json")
    ann, drawing = load_input(tmp_path / "a.inkray.json", rescale=True)
    assert ann.size == drawing.size == (20, 16)
    minimal_doc.pop("drawing")
    (tmp_path / "a.inkray.json").write_text(json.dumps(minimal_doc))
    with pytest.raises(InputError, match="no drawing given"):
        load_input(tmp_path / "a.inkray.json")
    ann, _ = load_input(tmp_path / "a.inkray.json", drawing=tmp_path / "d.png", rescale=True)
    assert ann.drawing == tmp_path / "d.png"
