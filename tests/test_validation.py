"""validate(): every problem a run would meet, found without the heavy stages."""

import numpy as np
import pytest
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


def _relief_error(chain):
    """The error ``relief`` stops on for this chain's input, or None."""
    from inkray.errors import InputError

    try:
        chain.meshes
    except InputError as e:
        return str(e)
    return None


def test_a_duplicated_boundary_is_an_error_as_in_relief():
    from dataclasses import replace

    ann, drawing = load_input(EXAMPLES / "turtle" / "drawing.inkray.json")
    again = replace(ann.boundaries[0], index=len(ann.boundaries))
    chain = ReliefChain(ann, drawing).edit(replace(ann, boundaries=[*ann.boundaries, again]))
    errors = [p.message for p in validate(chain) if p.severity == "error"]
    assert errors == [_relief_error(ReliefChain(chain.annotations, drawing))]
    assert "marks the same outline stretch" in errors[0]


def test_a_boundary_is_judged_by_the_completed_outline_the_relief_snaps_to():
    # a path along the hidden part of the leg's outline (under the head, only the
    # completion has an outline there) lies far from every visible label edge.
    from dataclasses import replace

    ann, drawing = load_input(EXAMPLES / "turtle" / "drawing.inkray.json")
    base = ReliefChain(ann, drawing)
    outlines = [m.mesh for m in base.meshes if m is not None]
    snapped = {b.index: min(o.snap_distance[b.index] for o in outlines) for b in ann.boundaries}
    assert all(d <= 6 for d in snapped.values())
    for dy in (3.0, 12.0, 25.0):  # snaps; within 6 px of no outline
        moved = replace(ann.boundaries[0], path=ann.boundaries[0].path + [0.0, dy])
        chain = base.edit(replace(ann, boundaries=[moved]))
        errors = [p.message for p in validate(chain) if p.severity == "error"]
        assert errors == ([] if _relief_error(ReliefChain(chain.annotations, drawing)) is None
                          else [_relief_error(ReliefChain(chain.annotations, drawing))]), dy


@pytest.mark.slow
def test_validate_passes_the_frog_that_relief_builds():
    ann, drawing = load_input(EXAMPLES / "frog" / "drawing.inkray.json")
    chain = ReliefChain(ann, drawing)
    assert [p for p in validate(chain) if p.severity == "error"] == []
    assert _relief_error(chain) is None
