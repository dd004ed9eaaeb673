import io
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest
from PIL import Image

from inkray import cli
from inkray.chain import ReliefChain
from inkray.errors import InputError
from inkray.formats.openraster import ora_bytes, read_ora
from inkray.formats.layer_files import write_layers
from inkray.input.loading import load_input
from inkray.relief.cutout import cut_out

from conftest import EXAMPLES


@pytest.fixture(scope="module")
def man(tmp_path_factory):
    ann, drawing = load_input(EXAMPLES / "man" / "drawing.inkray.json")
    chain = ReliefChain(ann, drawing)
    stack = cut_out(chain.completion, chain.relations, drawing)
    path = tmp_path_factory.mktemp("ora") / "parts.ora"
    write_layers(stack, path)
    return chain, stack, path


def _composite(size, layers):
    """Independent "over" compositing of (name, x, y, rgba) layers, bottom first."""
    w, h = size
    canvas = Image.new("RGBA", (w, h), (0, 0, 0, 0))
    for _, x, y, rgba in layers:
        canvas.alpha_composite(Image.fromarray(rgba, "RGBA"), (x, y))
    return np.asarray(canvas)


def test_zip_layout_and_stack_xml(man):
    chain, stack, path = man
    with zipfile.ZipFile(path) as z:
        first = z.infolist()[0]
        assert first.filename == "mimetype" and first.compress_type == zipfile.ZIP_STORED
        assert z.read("mimetype") == b"image/openraster"
        assert path.read_bytes()[30:38] == b"mimetype"  # readable by a magic-number sniffer
        names = set(z.namelist())
        assert {"stack.xml", "mergedimage.png", "Thumbnails/thumbnail.png"} <= names
        root = ET.fromstring(z.read("stack.xml"))
        assert (int(root.get("w")), int(root.get("h"))) == stack.size
        nodes = root.find("stack").findall("layer")
        layers = []
        for node in reversed(nodes):  # stack.xml lists the top layer first
            rgba = np.asarray(Image.open(io.BytesIO(z.read(node.get("src")))).convert("RGBA"))
            layers.append((node.get("name"), int(node.get("x")), int(node.get("y")), rgba))
        merged = np.asarray(Image.open(io.BytesIO(z.read("mergedimage.png"))).convert("RGBA"))
        with Image.open(io.BytesIO(z.read("Thumbnails/thumbnail.png"))) as thumb:
            assert max(thumb.size) <= 256
    assert [name for name, *_ in layers] == [layer.name for layer in stack.layers]
    flat = _composite(stack.size, layers)
    assert np.array_equal(flat, merged)
    character = chain.segmentation.labels >= 0
    a = flat[..., 3:4] / 255.0   # the layers' soft edges over the (white) paper
    over = flat[..., :3] * a + 255.0 * (1 - a)
    mse = np.mean((over[character] - chain.drawing.rgb[character]) ** 2)
    assert mse == 0 or 10 * np.log10(255 ** 2 / mse) >= 35.0
    for r in chain.relations:
        if r.kind == "order":
            order = [name for name, *_ in layers]
            assert order.index(r.front_name) > order.index(r.back_name)


def test_reader_round_trip(man):
    _, stack, path = man
    back = read_ora(path)
    assert back.size == stack.size
    for ours, theirs in zip(stack.layers, back.layers, strict=True):
        assert (theirs.name, theirs.top, theirs.left) == (ours.name, ours.top, ours.left)
        assert np.array_equal(theirs.rgba, ours.rgba)


def test_same_stack_same_bytes(man):
    _, stack, path = man
    assert ora_bytes(stack) == path.read_bytes()


def test_not_an_ora_file_is_an_input_error(tmp_path):
    bad = tmp_path / "bad.ora"
    with zipfile.ZipFile(bad, "w") as z:
        z.writestr("stack.xml", "<image/>")
    with pytest.raises(InputError, match="mimetype"):
        read_ora(bad)


def test_cli_layers_ora_split_and_pad(tmp_path):
    ann = EXAMPLES / "turtle" / "drawing.inkray.json"
    out = tmp_path / "parts.ora"
    assert cli.main(["--quiet", "layers", str(ann), "-o", str(out), "--pad", "3",
                     "--split-local"]) == 0
    names = [layer.name for layer in read_ora(out).layers]
    assert names.index("leg_front") > names.index("head") > names.index("shell")
