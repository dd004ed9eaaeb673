import json

import numpy as np
from PIL import Image

from inkray.formats.labels import label_palette, read_labels, write_labels
from inkray.segmentation import Segmentation


def test_label_palette_is_distinct():
    pal = label_palette(60)
    assert pal.shape == (61, 3) and pal.dtype == np.uint8
    assert len({tuple(c) for c in pal.tolist()}) == 61
    assert (pal[0] == 255).all() and not (pal[1:] == 255).all(axis=1).any()


def test_round_trip_indexed_and_rgb(tmp_path):
    rng = np.random.default_rng(1)
    for n in (3, 300):                     # indexed PNG, then RGB when the palette overflows
        labels = rng.integers(-1, n, (20, 30)).astype(np.int32)
        seg = Segmentation(labels=labels, names=[f"r{i}" for i in range(n)], warnings=["w"])
        files = write_labels(seg, tmp_path / f"l{n}.png", npy=tmp_path / f"l{n}.npy")
        with Image.open(files[0]) as im:
            assert im.mode == ("P" if n < 256 else "RGB")
        legend = json.loads(files[1].read_text())
        assert legend["regions"]["r1"]["pixels"] == int((labels == 1).sum())
        assert legend["background"]["pixels"] == int((labels == -1).sum())
        back, names = read_labels(files[0])
        assert np.array_equal(back, labels) and names == seg.names
        assert np.array_equal(np.load(files[2]), labels)
