import json

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

from inkray import cli
from inkray.chain import ReliefChain
from inkray.errors import InputError
from inkray.formats.sprite_maps import read_sprite_maps, sprite_maps, write_sprite_maps
from inkray.input.loading import load_input
from inkray.view.shading import height_normals

from conftest import EXAMPLES


@pytest.fixture(scope="module")
def turtle():
    ann, drawing = load_input(EXAMPLES / "turtle" / "drawing.inkray.json")
    chain = ReliefChain(ann, drawing)
    seg = chain.segmentation
    return chain, sprite_maps(chain.relief, seg.labels, seg.names)


@pytest.fixture(scope="module")
def written(turtle, tmp_path_factory):
    out = tmp_path_factory.mktemp("maps")
    write_sprite_maps(turtle[1], out)
    return out


def _interior(parts, names, width=3):
    inner = np.zeros(parts.shape, bool)
    for i in range(len(names)):
        inner |= ndimage.binary_erosion(parts == i, iterations=width)
    return inner


def test_stored_normals_are_unit_length(written):
    maps = read_sprite_maps(written)
    length = np.linalg.norm(maps.normal, axis=-1)[maps.mask]
    assert np.abs(length - 1.0).max() < 0.015  # 8-bit quantization only


@pytest.mark.parametrize("convention, sign", [("opengl", 1.0), ("directx", -1.0)])
def test_normals_follow_the_height_gradient(turtle, convention, sign):
    chain, _ = turtle
    seg = chain.segmentation
    maps = sprite_maps(chain.relief, seg.labels, seg.names, convention=convention)
    expect = height_normals(np.nan_to_num(maps.height)) * [1.0, sign, 1.0]
    inner = _interior(maps.parts, maps.names)
    angle = np.degrees(np.arccos(np.clip((expect * maps.normal).sum(-1), -1, 1)))[inner]
    assert np.median(angle) < 3.0 and np.percentile(angle, 90) < 10.0
    # The y axis is where the two conventions differ: the wrong sign is far off.
    flipped = expect * [1.0, -1.0, 1.0]
    wrong = np.degrees(np.arccos(np.clip((flipped * maps.normal).sum(-1), -1, 1)))[inner]
    assert np.percentile(wrong, 90) > 2 * np.percentile(angle, 90)


def test_ambient_occlusion_is_dark_in_the_creases(turtle):
    chain, maps = turtle
    m = maps.mask
    height = np.where(m, maps.height, np.nanmin(maps.height))
    # Open: nothing within 10 px rises more than 1 px above the pixel.
    open_ = m & (ndimage.maximum_filter(height, size=21) - height < 1.0)
    assert open_.sum() > 1000 and maps.ao[open_].mean() > 0.95
    # A crease: a part's pixel within 2 px of the part in front of it, 5 px higher.
    creases = np.zeros(m.shape, bool)
    for r in chain.relations:
        front = np.where(maps.parts == r.front, height, -np.inf)
        crease = (maps.parts == r.back) & (ndimage.maximum_filter(front, size=5) - height > 5.0)
        if crease.sum() >= 100:
            assert maps.ao[crease].mean() < maps.ao[open_].mean() - 0.25, r.label
        creases |= crease
    assert creases.sum() > 500 and maps.ao[creases].mean() < 0.5


def test_alpha_is_the_character_mask(turtle, written):
    chain, _ = turtle
    character = chain.segmentation.labels >= 0
    with Image.open(written / "normal.png") as im:
        assert im.mode == "RGBA" and np.array_equal(np.asarray(im)[..., 3] > 0, character)
    with Image.open(written / "ao.png") as im:
        assert im.mode == "LA" and np.array_equal(np.asarray(im)[..., 1] > 0, character)
    with Image.open(written / "parts.png") as im:
        assert im.info["transparency"] == 0
        assert np.array_equal(np.asarray(im) > 0, character)
        assert np.array_equal(np.asarray(im).astype(int) - 1, chain.segmentation.labels)
    with Image.open(written / "height.png") as im:
        assert np.array_equal(np.asarray(im) > 0, character)
    maps = read_sprite_maps(written)
    assert np.array_equal(maps.mask, character) and maps.names == chain.segmentation.names


def test_empty_normals_are_flat_beyond_a_padded_edge(turtle, written):
    chain, _ = turtle
    character = chain.segmentation.labels >= 0
    with Image.open(written / "normal.png") as im:
        rgba = np.asarray(im).astype(int)
    distance, (iy, ix) = ndimage.distance_transform_edt(~character, return_indices=True)
    far = distance > 8
    assert far.any() and np.all(rgba[far][:, :3] == [128, 128, 255])
    # A few pixels around the character hold its edge's normals (texture filtering and
    # mipmaps average them in, not a normal of (-1, -1, -1)).
    pad = ~character & (distance <= 8)
    assert pad.sum() > 1000
    assert np.array_equal(rgba[pad][:, :3], rgba[iy[pad], ix[pad]][:, :3])
    # The average of any 4x4 block (a mipmap two levels down) is a normal facing the viewer.
    h, w = (s - s % 4 for s in character.shape)
    blocks = (rgba[:h, :w, :3] / 127.5 - 1).reshape(h // 4, 4, w // 4, 4, 3).mean(axis=(1, 3))
    assert blocks[..., 2].min() > 0


def test_legend_and_round_trip(turtle, written):
    _, maps = turtle
    legend = json.loads((written / "maps.json").read_text())
    assert legend["normal"]["convention"] == "opengl"
    assert legend["parts"]["head"]["index"] == maps.names.index("head") + 1
    back = read_sprite_maps(written)
    m = maps.mask
    span = np.ptp(maps.height[m])
    assert np.abs(back.height[m] - maps.height[m]).max() <= span / 65534 + 1e-9
    assert np.abs(back.ao[m] - maps.ao[m]).max() <= 0.5 / 255 + 1e-9


def test_same_input_same_bytes(turtle, written, tmp_path):
    write_sprite_maps(turtle[1], tmp_path)
    for name in ("normal.png", "height.png", "ao.png", "parts.png", "maps.json"):
        assert (tmp_path / name).read_bytes() == (written / name).read_bytes()


def test_bad_options_are_one_line_errors(turtle):
    chain, _ = turtle
    seg = chain.segmentation
    with pytest.raises(InputError, match="convention"):
        sprite_maps(chain.relief, seg.labels, seg.names, convention="vulkan")
    with pytest.raises(InputError, match="labels"):
        sprite_maps(chain.relief, seg.labels[1:], seg.names)


def test_cli_maps(tmp_path, capsys):
    ann = EXAMPLES / "balls" / "drawing.inkray.json"
    out = tmp_path / "maps"
    assert cli.main(["--quiet", "maps", str(ann), "-o", str(out), "--convention", "directx"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["ao.png", "height.png", "maps.json",
                                                     "normal.png", "parts.png"]
    assert json.loads((out / "maps.json").read_text())["normal"]["convention"] == "directx"
    assert cli.main(["--quiet", "maps", str(ann), "-o", str(tmp_path / "m.png")]) == 2
    assert "expected a folder" in capsys.readouterr().err
    assert not (tmp_path / "m.png").exists()
