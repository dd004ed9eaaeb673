import numpy as np
import pytest
from PIL import Image

from inkray.errors import InputError
from inkray.formats.poses import animation_files, write_animation


def test_frames_and_preview(tmp_path):
    frames = []
    for f in range(3, 6):
        img = np.zeros((4, 5, 4), np.uint8)
        img[1:3, f - 3:f - 1] = [200, 10, 10, 255]
        frames.append((f, img))
    out = tmp_path / "walk"
    written = write_animation(frames, out, fps=10)
    assert written == animation_files(out, [3, 4, 5])
    for (f, img), path in zip(frames, written):
        assert np.array_equal(np.asarray(Image.open(path)), img)
    gif = Image.open(out / "preview.gif")
    assert gif.n_frames == 3 and gif.info["duration"] == 100


def test_nothing_written_on_bad_input(tmp_path):
    with pytest.raises(InputError, match="no frames"):
        write_animation([], tmp_path / "a")
    with pytest.raises(InputError, match="fps"):
        write_animation([(0, np.zeros((2, 2, 4), np.uint8))], tmp_path / "b", fps=0)
    assert not any(tmp_path.iterdir())
