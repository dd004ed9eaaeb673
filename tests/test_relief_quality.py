"""How clean the reliefs of the bundled drawings look, measured as a viewer sees them.

The figures come from ``benchmarks/relief_metrics.py`` (the same code as the
quality columns of ``python benchmarks/bench_relief.py``), measured on the
relief read back from its GLB export:

- outline ink on the mesh >= 97 % (the parts reach the outer edge of their
  contour strokes);
- silhouette turning <= 1.25 x that of the 3 px smoothed outline (no pixel
  stair-steps);
- every ``order`` entry holds along the whole segment between its points and
  over its place's overlap (outside the band of a graft between its regions,
  where it gives way with a warning);
- where two parts meet without ink (their surfaces within half the depth
  step of each other: an occlusion step through a gap in the ink is no
  seam), the normal jump is at most 5 degrees at the 90th percentile;
- where a part's outline stroke stops short inside the part behind it (an
  open join: a leg open at the top into the body), the normal jump across
  the join, steps included, is at most 5 degrees at the 90th percentile,
  with the join marked by a ``graft`` entry and without it;
- the ``--closed --union`` solid is watertight and manifold, and on the fast
  drawings has (almost) no slivers.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import EXAMPLES, shared_drawing_names
from inkray.chain import ReliefChain
from inkray.formats.meshes import export_relief, read_relief
from inkray.input.loading import load_input
from inkray.relief.assembly import MIN_ANGLE, _min_angles

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from relief_metrics import (normal_jumps, open_join_jumps, order_margins,  # noqa: E402
                            outline_ink_on_mesh, solid_figures, turning_ratio)

FAST = ("balls", "turtle")
JUMP_P90 = 5.0  # degrees, 90th percentile of the normal jump at ink-free seams
# The drawings with parts open into the part behind, and their open joins (graft entries).
OPEN = {"turtle": 1, "frog": 2, "donkey": 2}


def _p90(angles):
    return np.percentile(angles, 90) if len(angles) else 0.0


def _measure(name, tmp_path):
    ann, drawing = load_input(EXAMPLES / name / "drawing.inkray.json")
    chain = ReliefChain(ann, drawing)
    result = chain.result()
    path = tmp_path / f"{name}.glb"
    export_relief(result.relief, path, back="none")  # the surface, as stitched
    relief = read_relief(path)
    return ann, drawing, chain, result, relief


def _check(name, tmp_path):
    ann, drawing, chain, result, relief = _measure(name, tmp_path)
    gray, labels = drawing.gray, result.segmentation.labels
    assert outline_ink_on_mesh(relief, gray, labels) >= 0.97
    assert turning_ratio(relief) <= 1.25
    margins = order_margins(relief, result.relations, result.layers.epsilon,
                            completion=result.completion, bands=result.layers.bands)
    tol = -1e-3 * result.layers.epsilon - 1e-6
    for label, m in margins.items():
        assert np.all(m["segment"] >= tol), (label, m["segment"].min())
        assert np.all(m["place"] >= tol), (label, m["place"].min())
    jumps = normal_jumps(relief, gray, epsilon=result.layers.epsilon)
    assert _p90(jumps) <= JUMP_P90
    joins = open_join_jumps(relief, gray)
    assert (len(joins) > 0) == (name in OPEN) and _p90(joins) <= JUMP_P90
    closed = chain.edit(closed=True, union=True)
    union = closed.relief
    solid = solid_figures(union)
    assert solid["watertight"] and solid["manifold"]
    part = union.parts[0]
    if name in FAST:
        # (on the donkey the remeshed solid is not manifold and the raw union is
        # kept: see docs/relief.md)
        assert (_min_angles(part.vertices, part.faces) < MIN_ANGLE).mean() < 2e-3
        assert solid["max_aspect"] < 1000.0
    if solid["shells"] > 1:  # a floating piece is named, not lost
        assert any(w.startswith("union:") for w in closed.warnings)


@pytest.mark.parametrize("name", FAST)
def test_fast_drawings_are_clean(name, tmp_path):
    _check(name, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in shared_drawing_names() if n not in FAST])
def test_every_drawing_is_clean(name, tmp_path):
    _check(name, tmp_path)


@pytest.mark.parametrize("name", [pytest.param(n, marks=[] if n in FAST else [pytest.mark.slow])
                                  for n in OPEN])
def test_open_joins_are_seams_without_their_graft_entries(name, tmp_path):
    # The same drawing annotated without its graft entries: each open top is found
    # from the drawing and the part grows out of the one behind it there, as with
    # the entry (without the joins it stood on it as a cliff: 87-123 degrees).
    import dataclasses

    ann, drawing = load_input(EXAMPLES / name / "drawing.inkray.json")
    result = ReliefChain(dataclasses.replace(ann, boundaries=[]), drawing).result()
    assert len(result.layers.bands) == OPEN[name]
    path = tmp_path / f"{name}.glb"
    export_relief(result.relief, path)
    relief = read_relief(path)
    joins = open_join_jumps(relief, drawing.gray)
    assert len(joins) > 0 and _p90(joins) <= JUMP_P90
    margins = order_margins(relief, result.relations, result.layers.epsilon,
                            completion=result.completion, bands=result.layers.bands)
    tol = -1e-3 * result.layers.epsilon - 1e-6
    assert all(np.all(m["segment"] >= tol) for m in margins.values())


def test_turtle_order_gives_way_to_the_graft_with_a_warning(tmp_path):
    # An arrow putting the turtle's front leg before the head across the leg's graft
    # seam (the bundled file keeps its arrow out of the seam's band): it holds
    # beyond the band and gives way, warned, inside it
    import dataclasses

    ann, drawing = load_input(EXAMPLES / "turtle" / "drawing.inkray.json")
    across = dataclasses.replace(ann.order[1], front=(210.0, 357.0), back=(172.0, 315.0))
    ann.order = [*ann.order[:1], across, *ann.order[2:]]
    result = ReliefChain(ann, drawing).result()
    assert any(w.startswith("order[1]: gives way to the graft seam of boundaries[0]")
               for w in result.warnings)
    assert len(result.layers.bands) == 1
