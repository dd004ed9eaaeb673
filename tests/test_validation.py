"""validate(): every problem a run would meet, found without the heavy stages."""

import numpy as np
from scipy import ndimage

from inkray.chain import ReliefChain
from inkray.input.annotations import Boundary
from inkray.input.loading import load_input
from inkray.validation import validate

from conftest import EXAMPLES


def test_bundled_drawings_have_no_errors():
    for name in ("turtle", "fox"):
        ann, drawing = load_input(EXAMPLES / name / "drawing.inkray.json")
        problems = validate(ReliefChain(ann, drawing))
        assert [p for p in problems if p.severity == "error"] == [], name


def test_a_boundary_far_from_every_outline_is_found_before_meshing():
    from dataclasses import replace

    ann, drawing = load_input(EXAMPLES / "turtle" / "drawing.inkray.json")
    chain = ReliefChain(ann, drawing)
    labels = chain.segmentation.labels
    edges = np.zeros(labels.shape, bool)
    edges[:, 1:] |= labels[:, 1:] != labels[:, :-1]
    edges[1:, :] |= labels[1:, :] != labels[:-1, :]
    y, x = np.unravel_index(np.argmax(ndimage.distance_transform_edt(~edges)), labels.shape)
    far = Boundary(type="graft", path=np.array([[x - 2.0, y], [x + 2.0, y]]),
                   index=len(ann.boundaries))
    edited = chain.edit(replace(ann, boundaries=[*ann.boundaries, far]))
    problems = validate(edited)
    errors = [p for p in problems if p.severity == "error"]
    assert [p.key for p in errors] == [f"boundaries[{far.index}]"]
    assert errors[0].message.startswith(f"boundaries[{far.index}]: no region outline within 6 px "
                                        f"of the graft path starting at ({x - 2:g}, {y:g})")
    assert "meshes" not in edited._memo and "segment" in edited._memo  # nothing heavy ran
