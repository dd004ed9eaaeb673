"""The generated line drawings with a known depth order (benchmarks/order_drawings.py)."""

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from order_drawings import STYLES, generate  # noqa: E402

from inkray.input.annotations import parse_annotations  # noqa: E402
from inkray.input.drawing import drawing_from_array  # noqa: E402
from inkray.segmentation import segment  # noqa: E402


def test_same_seed_same_drawing():
    a, b = generate(11, size=(200, 180)), generate(11, size=(200, 180))
    assert np.array_equal(a.gray, b.gray) and a.annotation == b.annotation
    assert a.gray.shape == (180, 200) and a.annotation["size"] == [200, 180]
    assert not np.array_equal(a.gray, generate(12, size=(200, 180)).gray)


def test_styles_switch_off():
    plain = generate(4, styles=(), size=(220, 220))
    assert plain.styles == ()
    assert set(np.unique(plain.gray).tolist()) <= {0, 255}      # no anti-aliasing, no paper
    for seed in range(6):
        g = generate(seed, styles=("paper",), size=(160, 160))
        assert set(g.styles) <= {"paper"}
        if g.styles:
            assert len(np.unique(g.gray)) > 20                  # shading and grain
    with pytest.raises(ValueError, match="unknown style 'ink'"):
        generate(0, styles=("ink",))
    assert len(STYLES) == 12


def _unlined(g):
    """Mask of the pixels between two parts with no ink in their 3x3 neighbourhood."""
    labels, paper = g.labels, ndimage.minimum_filter(g.gray, size=3) == 255
    between = np.zeros(labels.shape, bool)
    between[:, 1:] |= (labels[:, 1:] != labels[:, :-1]) & (labels[:, 1:] >= 0) & (labels[:, :-1] >= 0)
    between[1:] |= (labels[1:] != labels[:-1]) & (labels[1:] >= 0) & (labels[:-1] >= 0)
    return between & paper


def test_fading_outlines_leave_parts_unlined():
    # Without a style every part meets the parts behind it along its outline's ink; a
    # fading outline stops a little way into them and leaves that contact without a line.
    faded = [generate(seed, styles=("fade",), size=(240, 240)) for seed in range(2, 4)]
    assert all(g.styles == ("fade",) for g in faded)
    assert all(_unlined(g).sum() > 10 for g in faded)
    assert not any(_unlined(generate(seed, styles=(), size=(240, 240))).any() for seed in range(2, 4))


def test_resting_parts_lie_over_what_they_rest_on():
    # The forelock over the head and the ears, the head over its collar, the teeth over the
    # head, an arm resting on a leg; a drawing that does not draw the style is the drawing
    # made without it (the style draws from a stream of its own).
    every = [s for s in STYLES if s != "rest"]
    seen = set()
    for seed in range(12):
        g = generate(seed, styles=every + ["rest"], size=(240, 240))
        if "rest" not in g.styles:
            plain = generate(seed, styles=every, size=(240, 240))
            assert np.array_equal(g.gray, plain.gray) and g.annotation == plain.annotation
            continue
        pairs = {(f.rstrip("0123456789"), b.rstrip("0123456789")) for f, b in g.relations}
        seen |= {n for pair in pairs for n in pair}
        # (front, back) pairs that would put a resting part behind what it rests on; a head
        # drawn behind the body is behind its collar too.
        wrong = {("head", "forelock"), ("ear", "forelock"), ("head", "tooth")}
        if ("body", "head") not in pairs:
            wrong.add(("collar", "head"))
        assert not pairs & wrong, (seed, pairs & wrong)
    assert {"forelock", "collar", "arm_rest", "tooth"} <= seen


def test_order_entries_point_into_their_parts():
    g = generate(1, size=(300, 300))
    names = g.names
    assert g.relations, "a character has overlapping parts"
    for entry in g.annotation["order"]:
        (fx, fy), (bx, by) = entry["front"], entry["back"]
        front, back = names[g.labels[int(fy), int(fx)]], names[g.labels[int(by), int(bx)]]
        assert (front, back) in g.relations
        assert names.index(front) > names.index(back)            # painted later


@pytest.mark.parametrize("seed", [1, 2, 7])
def test_drawings_segment_into_their_true_parts(seed):
    g = generate(seed, size=(280, 280))
    ann = parse_annotations(g.annotation)
    seg = segment(ann, drawing_from_array(g.gray))
    index = {n: i for i, n in enumerate(g.names)}
    found = np.full(seg.labels.shape, -1)
    for j, name in enumerate(seg.names):
        found[seg.labels == j] = index[name]
    # Away from the ink, where the segmentation's cut along a line may fall on either side,
    # and from the contacts a faded outline leaves without a line, where only the scribbles
    # place the cut.
    paper = ~ndimage.binary_dilation(g.gray < 128, iterations=2)
    paper &= ~ndimage.binary_dilation(_unlined(g), iterations=8)
    assert (found == g.labels)[paper].mean() > 0.98
    for name in seg.names:
        mine, true = (found == index[name]) & paper, (g.labels == index[name]) & paper
        assert (mine & true).sum() / (mine | true).sum() > 0.6, name
