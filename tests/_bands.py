"""A bar drawn over a band: hand-made drawings for the cut-out and posed-picture tests."""

import numpy as np

from inkray.input.drawing import drawing_from_array
from inkray.relief.completion import complete_regions
from inkray.relief.cutout import cut_out
from inkray.relief.ordering import Relation


def bar_over_band(labels, rgb):
    """The layers of a drawing whose region 1 ("bar") lies over region 0 ("band")."""
    c = complete_regions(labels, names=["band", "bar"])
    place = next(p for p in c.places if (p.a, p.b) == (0, 1))
    rel = [Relation(1, 0, "bar", "band", place.where, "user", 1.0, place=place.index)]
    return cut_out(c.ordered(rel), rel, drawing_from_array(rgb))


def bar_outline_on_band():
    """A band behind a bar, drawn with 4 px black strokes; the bar's outline strokes, where
    they cross the band, lie wholly in the band's label (a segmentation that cut at their
    edge toward the bar). A crease of the band's own runs up to the bar's left stroke."""
    h, w = 100, 160
    gray = np.ones((h, w))
    labels = np.full((h, w), -1, np.int32)
    labels[20:80, 6:154] = 0
    gray[20:24, 6:154] = gray[76:80, 6:154] = 0.0      # the band's long sides
    gray[48:52, 20:56] = 0.0                            # its crease, ending on the bar
    labels[4:96, 56:104] = 1
    labels[20:80, 56:60] = labels[20:80, 100:104] = 0   # the bar's outline over the band
    gray[4:96, 60:100] = 1.0
    gray[4:96, 56:60] = gray[4:96, 100:104] = 0.0
    rgb = np.repeat(np.rint(gray * 255).astype(np.uint8)[..., None], 3, axis=2)
    return labels, rgb, bar_over_band(labels, rgb)
