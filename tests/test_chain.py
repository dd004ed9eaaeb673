"""The whole relief chain on real drawings, and the `inkray relief` command."""

import json

import numpy as np
import pytest
import trimesh

from _mesh import height_at
from conftest import EXAMPLES, SHARED, shared_drawing_names
from inkray import cli
from inkray.input.loading import load_input
from inkray.chain import build_relief
from inkray.numerics.polyline import point_polyline_distance
from inkray.relief.silhouette import grow_over_ink, ink_pixels, pad_ink_edge
from inkray.view.rasterization import rasterize

FAST = ("balls", "turtle")


def _relief_checks(result, ann, gray):
    relief, labels = result.relief, result.segmentation.labels
    # seen from the front, the parts cover exactly the character with its contour strokes
    raster = rasterize(relief, size=relief.size, scale=1.0)
    stroke = ink_pixels(gray, level=0.75)
    character = pad_ink_edge(grow_over_ink(labels, stroke), stroke) >= 0
    iou = (raster.mask & character).sum() / (raster.mask | character).sum()
    # 0.981 on the rings (stroke ends at the crossings), 0.987 on the man, >= 0.99 elsewhere
    assert iou >= 0.98, iou
    # every order entry holds at its own two points, wherever both meshes are there,
    # except within the band of a graft between its two regions (it gives way, with
    # a warning)
    parts = {p.name: p for p in relief.parts}
    checked = 0
    for rel in result.relations:
        if rel.source != "user" or rel.kind != "order" or rel.place is None:
            continue
        e = ann.order[rel.entry]
        front, back = parts[rel.front_name], parts[rel.back_name]
        pts = np.array([e.front, e.back], float)
        zf, df = height_at(front.vertices, front.faces, front.vertices[:, 2], pts)
        zb, db = height_at(back.vertices, back.faces, back.vertices[:, 2], pts)
        both = (df < 1e-6) & (db < 1e-6)
        for f, b, seam, width in result.layers.bands:
            if {f, b} == {rel.front, rel.back}:
                both &= point_polyline_distance(pts, seam) >= width
        if not np.array_equal((df < 1e-6) & (db < 1e-6), both):
            assert any(w.startswith(rel.label + ":") for w in result.warnings), rel.label
        assert np.all(zf[both] >= zb[both] + result.layers.epsilon - 1e-6), rel.label
        checked += int(both.any())
    assert result.layers.violation <= 1e-6
    return checked


@pytest.mark.parametrize("name", FAST)
def test_examples_build_a_faithful_relief(name):
    ann, drawing = load_input(EXAMPLES / name / "drawing.inkray.json")
    result = build_relief(ann, drawing)
    assert [p.name for p in result.relief.parts] == [r.name for r in ann.regions]
    assert _relief_checks(result, ann, drawing.gray) >= 1
    assert [t for t, _ in result.timings] == ["segment", "complete", "order", "inflate",
                                             "stitch", "assemble"]


@pytest.mark.slow
@pytest.mark.parametrize("name", shared_drawing_names())
def test_every_shared_drawing_builds(name):
    ann, drawing = load_input(SHARED / name / "drawing.inkray.json")
    result = build_relief(ann, drawing)
    _relief_checks(result, ann, drawing.gray)


def test_deterministic():
    ann, drawing = load_input(EXAMPLES / "balls" / "drawing.inkray.json")
    a = build_relief(ann, drawing).relief
    b = build_relief(ann, drawing).relief
    for p, q in zip(a.parts, b.parts):
        np.testing.assert_array_equal(p.vertices, q.vertices)
        np.testing.assert_array_equal(p.faces, q.faces)


def test_relief_command_writes_mesh_and_images(tmp_path, capsys):
    ann = EXAMPLES / "balls" / "drawing.inkray.json"
    out = tmp_path / "balls.glb"
    code = cli.main(["relief", str(ann), "-o", str(out), "--closed", "--depth-png", "--normals-png",
                     "--timings"])
    _, err = capsys.readouterr()
    assert code == 0, err
    assert {p.name for p in tmp_path.iterdir()} == {"balls.glb", "balls-depth.png",
                                                     "balls-normals.png"}
    assert "stitch" in err and "total" in err  # per-stage timing summary, asked for
    scene = trimesh.load(out)
    assert sorted(scene.geometry) == ["ball_big", "ball_mid", "ball_small"]
    # welded as a slicer welds them (vertices are copied where the drawing meets the paper)
    assert all(trimesh.Trimesh(g.vertices, g.faces).is_watertight for g in scene.geometry.values())
    assert cli.main(["check", str(out), "--require", "watertight,manifold,oriented"]) == 0
    capsys.readouterr()
    code = cli.main(["--quiet", "relief", str(ann), "-o", str(tmp_path / "u.obj"), "--closed",
                     "--union"])
    _, err = capsys.readouterr()
    assert code == 0 and err == ""
    assert cli.main(["check", str(tmp_path / "u.obj"), "--require", "watertight,manifold"]) == 0
    assert "o u\n" in (tmp_path / "u.obj").read_text()  # the solid is named after the file


def test_relief_command_rejects_bad_input_and_writes_nothing(tmp_path, capsys):
    doc = json.loads((EXAMPLES / "turtle" / "drawing.inkray.json").read_text())
    doc["drawing"] = str(EXAMPLES / "turtle" / "drawing.png")
    doc["boundaries"] = [{"type": "graft", "path": [[5, 5], [40, 5]]}]  # far from any outline
    ann = tmp_path / "bad.inkray.json"
    ann.write_text(json.dumps(doc))
    out = tmp_path / "out" / "t.glb"
    assert cli.main(["relief", str(ann), "-o", str(out)]) == 2
    err = capsys.readouterr().err.splitlines()  # progress lines, then one error line
    assert err[-1].startswith("inkray: error: boundaries[0]: no region outline within")
    assert sum(line.startswith("inkray: error") for line in err) == 1
    assert not out.parent.exists() or not any(out.parent.iterdir())
    assert cli.main(["relief", str(ann), "-o", str(out), "--union"]) == 2
    assert ("inkray: error: --union: the union of open surfaces is not a solid (add --closed)"
            in capsys.readouterr().err)


# -- the resumable chain ---------------------------------------------------------

def _turtle():
    from inkray.examples import example_path

    return load_input(example_path("turtle"))


def _same_relief(a, b):
    assert [p.name for p in a.parts] == [p.name for p in b.parts]
    for p, q in zip(a.parts, b.parts):
        assert np.array_equal(p.faces, q.faces) and np.allclose(p.vertices, q.vertices, atol=1e-9)


def test_the_outlines_computed_beside_the_order_are_those_computed_after_it():
    from inkray.chain import ReliefChain

    ann, drawing = _turtle()
    beside = ReliefChain(ann, drawing)
    beside.relations                              # the silhouettes and joins beside the order
    assert beside.recomputed == ["segment", "complete", "order", "silhouettes", "joins"]
    after = ReliefChain(ann, drawing)
    after.candidates
    after.silhouettes                             # no order yet: none computed beside
    assert after.recomputed == ["segment", "complete", "silhouettes"]
    after.relations
    assert after.recomputed[-1] == "order" and "joins" not in after.recomputed
    assert np.array_equal(beside.silhouettes, after.silhouettes)
    # what makes that so: the order changes only the hidden parts, not the labels
    assert np.array_equal(beside.completion.labels, beside.candidates.labels)
    assert [(j.regions, j.path.tolist()) for j in beside.joins] == \
        [(j.regions, j.path.tolist()) for j in after.joins]


def test_an_edit_recomputes_only_what_it_touches_and_equals_a_fresh_chain():
    from dataclasses import replace

    from inkray.chain import ReliefChain

    ann, drawing = _turtle()
    without = replace(ann, order=ann.order[:-1])
    cold = ReliefChain(without, drawing)
    cold.relief
    assert cold.recomputed[:3] == ["segment", "complete", "order"]

    arrow = cold.edit(annotations=ann)            # one order entry more
    _same_relief(arrow.relief, ReliefChain(ann, drawing).relief)
    assert "segment" not in arrow.recomputed and "complete" not in arrow.recomputed
    assert "order" in arrow.recomputed and "stitch" in arrow.recomputed

    regions = list(ann.regions)
    regions[1] = replace(regions[1], inflation=regions[1].inflation * 2)
    rounder = replace(ann, regions=regions)
    inflated = arrow.edit(annotations=rounder)
    _same_relief(inflated.relief, ReliefChain(rounder, drawing).relief)
    assert inflated.recomputed == [f"mesh:{regions[1].name}", "stitch", "assemble"]

    undo = inflated.edit(annotations=ann)
    undo.relief
    assert undo.recomputed == []                  # every result from the cache
    _same_relief(undo.relief, arrow.relief)


def test_a_new_scribble_segments_again_and_keeps_untouched_regions():
    from dataclasses import replace

    from inkray.chain import ReliefChain

    ann, drawing = _turtle()
    chain = ReliefChain(ann, drawing)
    chain.relief
    head = next(i for i, r in enumerate(ann.regions) if r.name == "head")
    regions = list(ann.regions)
    extra = np.asarray(regions[head].scribbles[0], float)[:1]   # a dot on the head's own scribble
    regions[head] = replace(regions[head], scribbles=regions[head].scribbles + [extra])
    more = chain.edit(annotations=replace(ann, regions=regions))
    _same_relief(more.relief, chain.relief)       # the same labels, so the same relief
    assert more.recomputed[0] == "segment"
    assert not any(s.startswith("mesh:") for s in more.recomputed)


def test_options_are_validated_and_edits_change_them():
    from inkray.chain import ChainOptions, ReliefChain
    from inkray.errors import InputError

    with pytest.raises(InputError, match=r"^union: .* \(add closed\)$") as e:
        ChainOptions(union=True)
    assert "--" not in str(e.value)  # library messages name parameters, not flags
    with pytest.raises(InputError, match="max_area"):
        ChainOptions(max_area=0)
    ann, drawing = _turtle()
    chain = ReliefChain(ann, drawing)
    closed = chain.edit(closed=True)
    assert closed.options.closed and not chain.options.closed
    assert all(p.closed for p in closed.relief.parts)


def test_the_interactive_depth_session_equals_the_one_shot_fast_method():
    from dataclasses import replace

    from inkray.chain import ReliefChain

    ann, drawing = _turtle()
    chain = ReliefChain(replace(ann, order=ann.order[:1]), drawing, options=None).edit(
        depth_method="fast", interactive=True)
    first = chain.depth_map.depth
    edited = chain.edit(annotations=ann)          # entries added to the kept session
    back = edited.edit(annotations=replace(ann, order=ann.order[:1]))
    once = ReliefChain(ann, drawing).edit(depth_method="fast").depth_map.depth
    assert np.allclose(edited.depth_map.depth, once, atol=1e-8)
    assert np.array_equal(back.depth_map.depth, first)   # undo: from the cache
    assert back.recomputed == []


def test_the_interactive_depth_is_reseeded_only_when_its_segmentation_changes(monkeypatch):
    from dataclasses import replace

    from inkray.chain import ReliefChain
    from inkray.depthmap.estimation import DepthSession

    reseeded = []
    original = DepthSession.reseed
    monkeypatch.setattr(DepthSession, "reseed", lambda self, seeds=None, labels=None: (
        reseeded.append(labels), original(self, seeds, labels=labels))[1])
    ann, drawing = _turtle()
    chain = ReliefChain(ann, drawing).edit(depth_method="fast", interactive=True)
    first = chain.depth_map.depth
    # A renamed region seeds the same image: the depth map comes from the cache.
    renamed = [replace(ann.regions[0], name="renamed")] + list(ann.regions[1:])
    same = chain.edit(annotations=replace(ann, regions=renamed))
    assert np.array_equal(same.depth_map.depth, first) and "depth" not in same.recomputed
    # A scribble nudged by a tenth of a pixel segments the same: solved again, not reseeded.
    nudged = [replace(ann.regions[0], scribbles=[np.asarray(s, float) + 0.1
                                                 for s in ann.regions[0].scribbles])]
    moved = chain.edit(annotations=replace(ann, regions=nudged + list(ann.regions[1:])))
    assert np.allclose(moved.depth_map.depth, first) and reseeded == []
    # A scribble fewer: reseeded, and the same as a fresh session's.
    fewer = [replace(ann.regions[0], scribbles=ann.regions[0].scribbles[:-1])]
    edited = chain.edit(annotations=replace(ann, regions=fewer + list(ann.regions[1:])))
    d = edited.depth_map.depth
    assert len(reseeded) == 1
    fresh = ReliefChain(edited.annotations, drawing).edit(depth_method="fast").depth_map.depth
    assert np.allclose(d, fresh, atol=1e-8)


def test_a_region_meshs_warnings_reach_the_chains(monkeypatch):
    """A loop left out of a region's mesh (too small to mesh) is said, not silent."""
    from dataclasses import replace

    from inkray import chain as chain_module
    from inkray.examples import example_path
    from inkray.input.loading import load_input

    inflate = chain_module.inflate_region

    def with_a_warning(mask, **kwargs):
        inflated = inflate(mask, **kwargs)
        return replace(inflated, mesh=replace(inflated.mesh, warnings=[
            f"region {kwargs['name']!r}: an outline piece at pixel (1, 1) encloses no area; "
            f"left out of the mesh"]))

    monkeypatch.setattr(chain_module, "inflate_region", with_a_warning)
    chain = chain_module.ReliefChain(*load_input(example_path("turtle")))
    chain.meshes
    said = [w for w in chain.warnings if "encloses no area" in w]
    assert len(said) == len(chain.annotations.regions)
