import numpy as np
import pytest

from inkray.errors import InputError
from inkray.formats.layer_files import LAYER_SUFFIXES, read_layers, write_layers
from inkray.relief.cutout import Cutout, CutoutLayer


def _stack():
    back = np.zeros((3, 4, 4), np.uint8)
    back[..., 0] = back[..., 3] = 255
    front = np.zeros((2, 2, 4), np.uint8)
    front[..., 2] = front[..., 3] = 255
    front[0, 0, 3] = 0
    return Cutout([CutoutLayer("back", 0, 0, 0, back, np.zeros((3, 4), bool)),
                   CutoutLayer("front", 1, 1, 2, front, np.zeros((2, 2), bool))], (5, 4))


@pytest.mark.parametrize("suffix", LAYER_SUFFIXES)
def test_both_formats_read_back_the_same_stack(tmp_path, suffix):
    stack = _stack()
    path = tmp_path / f"parts{suffix.upper()}"  # the suffix is matched in any case
    assert write_layers(stack, path) == [path]
    back = read_layers(path)
    assert back.size == stack.size
    assert [(l.name, l.top, l.left) for l in back.layers] == [("back", 0, 0), ("front", 1, 2)]
    for ours, theirs in zip(stack.layers, back.layers):
        assert np.array_equal(ours.rgba, theirs.rgba)
    assert np.array_equal(back.flatten(), stack.flatten())


def test_other_suffixes_are_refused_before_writing(tmp_path):
    with pytest.raises(InputError, match=r"\.tiff.*expected \.psd, \.ora"):
        write_layers(_stack(), tmp_path / "parts.tiff")
    assert not list(tmp_path.iterdir())
    with pytest.raises(InputError, match="unsupported layered file type"):
        read_layers(tmp_path / "parts")
