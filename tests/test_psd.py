import numpy as np
import pytest
from psd_tools import PSDImage

from inkray import cli
from inkray.chain import ReliefChain
from inkray.errors import InputError
from inkray.formats.psd import psd_bytes, read_psd
from inkray.formats.layer_files import write_layers
from inkray.input.loading import load_input
from inkray.relief.cutout import Cutout, CutoutLayer, cut_out

from conftest import EXAMPLES


@pytest.fixture(scope="module")
def turtle(tmp_path_factory):
    ann, drawing = load_input(EXAMPLES / "turtle" / "drawing.inkray.json")
    chain = ReliefChain(ann, drawing)
    stack = cut_out(chain.completion, chain.relations, drawing)
    path = tmp_path_factory.mktemp("psd") / "parts.psd"
    write_layers(stack, path)
    return chain, stack, path


def test_psd_tools_reads_every_layer_back(turtle):
    _, stack, path = turtle
    document = PSDImage.open(path)
    assert document.size == stack.size
    layers = list(document)
    assert [layer.name for layer in layers] == [layer.name for layer in stack.layers]
    for ours, theirs in zip(stack.layers, layers):
        assert (theirs.top, theirs.left) == (ours.top, ours.left)
        assert np.array_equal(np.asarray(theirs.topil().convert("RGBA")), ours.rgba)


def test_psd_tools_composite_is_the_drawing_where_the_character_is(turtle):
    chain, _, path = turtle
    flat = np.asarray(PSDImage.open(path).composite(force=True).convert("RGBA"))
    character = chain.segmentation.labels >= 0
    a = flat[..., 3:4] / 255.0   # the layers' soft edges over the (white) paper
    flat = flat[..., :3] * a + 255.0 * (1 - a)
    mse = np.mean((flat[character] - chain.drawing.rgb[character]) ** 2)
    assert mse == 0 or 10 * np.log10(255 ** 2 / mse) >= 35.0


def _merged_image(data):
    """The layer count (signed) and the merged image's channels, read with the specification
    (Adobe Photoshop File Formats: header, colour mode data, image resources, layer and mask
    information, then the merged image data), not with psd-tools."""
    import struct

    channels, height, width, depth = struct.unpack(">HIIH", data[12:24])
    at = 26
    at += 4 + struct.unpack(">I", data[at:at + 4])[0]          # colour mode data
    at += 4 + struct.unpack(">I", data[at:at + 4])[0]          # image resources
    (layers_and_masks,) = struct.unpack(">I", data[at:at + 4])
    (count,) = struct.unpack(">h", data[at + 8:at + 10])       # after the layer info's length
    at += 4 + layers_and_masks
    (compression,) = struct.unpack(">H", data[at:at + 2])
    at += 2
    assert depth == 8 and compression in (0, 1)                 # raw or RLE (PackBits) rows
    if compression == 0:
        planes = np.frombuffer(data[at:at + channels * height * width], np.uint8)
        return count, planes.reshape(channels, height, width).transpose(1, 2, 0)
    lengths = struct.unpack(f">{channels * height}H", data[at:at + 2 * channels * height])
    at += 2 * channels * height
    planes = []
    for c in range(channels):
        rows = []
        for n in lengths[c * height:(c + 1) * height]:
            rows.append(_unpackbits(data[at:at + n]))
            at += n
        planes.append(np.array(rows, np.uint8))
    return count, np.stack(planes, axis=-1)


def _unpackbits(row):
    out, i = bytearray(), 0
    while i < len(row):
        n = row[i] if row[i] < 128 else row[i] - 256
        if n >= 0:
            out += row[i + 1:i + 2 + n]
            i += 2 + n
        elif n != -128:
            out += bytes([row[i + 1]]) * (1 - n)
            i += 2
        else:
            i += 1
    return list(out)


def test_merged_image_keeps_the_stacks_transparency_flagged_as_such(turtle):
    _, stack, path = turtle
    count, merged = _merged_image(path.read_bytes())
    # A negative layer count: the merged image's first extra channel is its transparency
    # (not an extra channel), as Photoshop writes it and GIMP and ImageMagick read it.
    assert count == -len(stack.layers) and merged.shape[-1] == 4
    flat = stack.flatten()
    assert np.array_equal(merged[..., 3], flat[..., 3])       # clear around the character
    shown = flat[..., 3] == 255
    assert np.abs(merged[..., :3][shown].astype(int) - flat[..., :3][shown]).max() <= 1


def test_layer_order_follows_the_relations(turtle):
    chain, _, path = turtle
    names = [layer.name for layer in read_psd(path).layers]
    for r in chain.relations:
        if r.kind == "order":
            assert names.index(r.front_name) > names.index(r.back_name)


def test_same_stack_same_bytes(turtle):
    _, stack, path = turtle
    assert psd_bytes(stack) == path.read_bytes()


def test_any_name_survives_and_a_too_long_one_is_an_input_error(tmp_path):
    px = np.full((2, 2, 4), 255, np.uint8)
    name = "hlava_čelo 頭 over shell"
    stack = Cutout([CutoutLayer(name, 0, 1, 1, px, np.zeros((2, 2), bool))], (4, 3))
    path = tmp_path / "u.psd"
    path.write_bytes(psd_bytes(stack))
    assert [layer.name for layer in read_psd(path).layers] == [name]
    stack.layers[0].name = "x" * 256
    with pytest.raises(InputError, match="longer than PSD's 255"):
        psd_bytes(stack)


def test_unreadable_psd_is_an_input_error(tmp_path):
    bad = tmp_path / "bad.psd"
    bad.write_bytes(b"8BPS not really")
    with pytest.raises(InputError, match="bad.psd"):
        read_psd(bad)


def test_cli_layers_psd(tmp_path, capsys):
    ann = EXAMPLES / "balls" / "drawing.inkray.json"
    out = tmp_path / "parts.psd"
    assert cli.main(["--quiet", "layers", str(ann), "-o", str(out), "--background"]) == 0
    names = [layer.name for layer in read_psd(out).layers]
    assert names[0] == "background" and set(names[1:]) == {"ball_big", "ball_mid", "ball_small"}
    assert names.index("ball_mid") < names.index("ball_big")
    assert cli.main(["--quiet", "layers", str(ann), "-o", str(tmp_path / "x.tiff")]) == 2
    assert "unsupported output type" in capsys.readouterr().err
    bad_pad = ["--quiet", "layers", str(ann), "-o", str(tmp_path / "y.psd"), "--pad", "-2"]
    assert cli.main(bad_pad) == 2
    assert not (tmp_path / "y.psd").exists() and not (tmp_path / "x.tiff").exists()
