import json

import numpy as np
import pytest
from PIL import Image

from inkray.depthmap.estimation import DepthResult
from inkray.formats.depth_png import (depth_normals, depth_png, read_depth_png, shaded_preview,
                                      write_depth_outputs)


def test_round_trip_within_one_step_and_background_is_zero(tmp_path):
    rng = np.random.default_rng(0)
    d = rng.standard_normal((12, 16))
    mask = rng.random((12, 16)) > 0.2
    png, meta = depth_png(d, mask)
    (tmp_path / "x.png").write_bytes(png)
    with Image.open(tmp_path / "x.png") as im:
        v = np.asarray(im)
        record = json.loads(im.text["inkray:depth"])
    assert v[~mask].max() == 0 and v[mask].min() == 1 and v[mask].max() == 65535
    assert record["far"] == [1, d[mask].min()] and record["near"] == [65535, d[mask].max()]
    back, _ = read_depth_png(tmp_path / "x.png")
    assert np.isnan(back[~mask]).all()
    assert np.abs(back[mask] - d[mask]).max() <= meta["scale"] / 2 + 1e-12


def test_write_depth_outputs_writes_everything_or_nothing(tmp_path):
    d = np.add.outer(np.arange(12.0), np.arange(16.0))
    r = DepthResult(depth=d, method="fast", epsilon=1.0)
    files = write_depth_outputs(r, tmp_path / "o" / "depth.png", npy=tmp_path / "o" / "d.npy",
                                normals=tmp_path / "o" / "n.png", shading=tmp_path / "o" / "s.png")
    assert sorted(f.name for f in (tmp_path / "o").iterdir()) == sorted(f.name for f in files)
    side = json.loads((tmp_path / "o" / "depth.json").read_text())
    assert side["depth_min"] == d.min() and side["depth_max"] == d.max()
    assert np.array_equal(np.load(tmp_path / "o" / "d.npy"), d)
    back, _ = read_depth_png(tmp_path / "o" / "depth.png")
    assert np.abs(back - d).max() <= side["scale"]
    with pytest.raises(RuntimeError):
        from inkray.formats.atomic import atomic_outputs
        with atomic_outputs() as group:
            write_depth_outputs(r, tmp_path / "p" / "depth.png", outputs=group)
            raise RuntimeError("a later output failed")
    assert not (tmp_path / "p").exists() or not any((tmp_path / "p").iterdir())


def test_normals_of_a_tilted_plane_and_lambert():
    x = np.tile(np.arange(50.0), (40, 1))           # rises to the right
    n = depth_normals(x, relief=0.1)
    slope = 0.1 * 50 / 49                             # height per pixel
    expect = np.array([-slope, 0.0, 1.0]) / np.hypot(slope, 1.0)
    assert np.allclose(n[20, 25], expect)
    img = shaded_preview(x, light=(0, 0, 1), ambient=0.0)
    assert abs(int(img[20, 25, 0]) - round(255 * expect[2])) <= 1


def test_not_a_depth_png_is_an_input_error(tmp_path):
    from inkray.errors import InputError

    Image.fromarray(np.zeros((2, 2), np.uint8)).save(tmp_path / "g.png")
    with pytest.raises(InputError, match="not an inkray depth PNG"):
        read_depth_png(tmp_path / "g.png")
