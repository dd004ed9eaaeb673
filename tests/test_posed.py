import numpy as np
import pytest
from scipy.spatial import cKDTree

from inkray.chain import ReliefChain
from inkray.errors import InputError
from inkray.formats.layer_files import read_layers, write_layers
from inkray.formats.meshes import export_relief
from inkray.input.loading import load_input
from inkray.input.pose import parse_pose
from inkray.relief.cutout import Cutout
from inkray.relief.model import Part, Relief
from inkray.view.posed import PosedDrawing, posed_image

from _bands import bar_outline_on_band
from conftest import EXAMPLES


@pytest.fixture(scope="module")
def turtle():
    ann, drawing = load_input(EXAMPLES / "turtle" / "drawing.inkray.json")
    chain = ReliefChain(ann, drawing)
    handles = [[250.0, 250.0], [330.0, 200.0]]
    return chain, PosedDrawing(chain.relief, chain.completion, chain.relations, drawing, handles)


def square(shift=(0.0, 0.0), z=1.0, name="sq"):
    v = np.array([[0, 0, z], [4, 0, z], [4, 4, z], [0, 4, z]], float) - [0.5, 0.5, 0]
    moved = v + [shift[0], shift[1], 0.0]
    return Part(name, moved, np.array([[0, 3, 2], [0, 2, 1]])), Part(name, v, np.array([[0, 3, 2], [0, 2, 1]]))


def test_a_translation_carries_the_drawing():
    rgb = np.zeros((6, 10, 3), np.uint8)
    rgb[:4, :4] = np.arange(16, dtype=np.uint8).reshape(4, 4)[..., None] * 10
    moved, rest = square((5.0, 2.0))
    img, part = posed_image(Relief([moved], size=(10, 6)), Relief([rest], size=(10, 6)),
                            Cutout([], (10, 6)), rgb)
    assert np.array_equal(img[2:6, 5:9, 0], rgb[:4, :4, 0])
    assert (img[2:6, 5:9, 3] == 255).all() and img[:2].sum() == 0 and (part[2:6, 5:9] == 0).all()


def test_a_pose_within_round_off_of_rest_draws_the_rest_picture():
    # Two squares meet along a pixel row (y = 4, through pixel centres): the lower one's top
    # edge covers that row. A solve that brings the lower one back to rest within round-off
    # (1e-11 px down) must not drop the row: the picture equals the rest picture.
    rgb = np.full((8, 4, 3), 90, np.uint8)
    v = np.array([[0, 0, 1], [3, 0, 1], [3, 4, 1], [0, 4, 1]], float)
    faces = np.array([[0, 3, 2], [0, 2, 1]])
    rest = Relief([Part("a", v, faces), Part("b", v + [0, 4, 0], faces)], size=(4, 8))
    at_rest, _ = posed_image(rest, rest, Cutout([], (4, 8)), rgb)
    assert (at_rest[:, :3, 3] == 255).all()
    for off in (1e-11, -1e-11):
        posed = Relief([Part("a", v, faces), Part("b", v + [0, 4 + off, 0], faces)], size=(4, 8))
        img, _ = posed_image(posed, rest, Cutout([], (4, 8)), rgb)
        assert np.array_equal(img, at_rest)


def test_the_higher_part_is_drawn_where_posed_parts_overlap():
    rgb = np.zeros((4, 12, 3), np.uint8)
    a_moved, a_rest = square((2.0, 0.0), z=1.0, name="a")
    b_moved, b_rest = square((0.0, 0.0), z=2.0, name="b")
    b_moved.vertices[:, 0] += 4.0     # b's rest square moved to x 4..7, a's to 2..5: overlap 4..5
    b_rest.vertices[:, 0] += 4.0
    rgb[:, :4] = 50
    rgb[:, 4:8] = 200
    posed = Relief([a_moved, b_moved], size=(12, 4))
    rest = Relief([a_rest, b_rest], size=(12, 4))
    _, part = posed_image(posed, rest, Cutout([], (12, 4)), rgb)
    assert (part[:, 2:4] == 0).all() and (part[:, 4:8] == 1).all()
    b_moved.vertices[:, 2] = 0.5       # now lower than a
    _, part = posed_image(posed, rest, Cutout([], (12, 4)), rgb)
    assert (part[:, 2:6] == 0).all() and (part[:, 6:8] == 1).all()


def test_posed_layers_keep_the_stack_and_round_trip(turtle, tmp_path):
    chain, posed = turtle
    x = posed.positions(np.array([[250.0, 250.0], [345.0, 170.0]]))
    stack = posed.layers(x)
    assert [layer.name for layer in stack.layers] == [layer.name for layer in posed.cutout.layers]
    again = read_layers(write_layers(stack, tmp_path / "p.ora")[0])
    assert np.array_equal(again.flatten(), stack.flatten())


def test_posed_relief_export_keeps_the_rest_texture(turtle, tmp_path):
    import trimesh

    chain, posed = turtle
    x = posed.positions(np.array([[250.0, 250.0], [345.0, 170.0]]))
    moved = posed.relief(x)
    rest_glb = trimesh.load(export_relief(chain.relief, tmp_path / "rest.glb")[0], force="scene")
    posed_glb = trimesh.load(export_relief(moved, tmp_path / "posed.glb")[0], force="scene")
    for name, geom in rest_glb.geometry.items():
        other = posed_glb.geometry[name]
        assert np.array_equal(geom.faces, other.faces)
        assert np.allclose(geom.visual.uv, other.visual.uv)


def test_animation_frames_are_warm_started_and_single_frames_match(turtle):
    chain, posed = turtle
    pose = parse_pose({"format": "inkray-pose", "version": 1,
                       "handles": [[250, 250], [330, 200]],
                       "keys": [{"frame": 0, "to": [[250, 250], [330, 200]]},
                                {"frame": 4, "to": [[250, 250], [345, 170]]}]})
    frames = posed.frames(pose)
    assert [f for f, _ in frames] == [0, 1, 2, 3, 4]
    assert np.allclose(frames[0][1], posed.rig.vertices, atol=1e-6)
    assert np.allclose(posed.at(pose, 3), frames[3][1])
    with pytest.raises(InputError, match="frame: 9 is not a frame of the pose"):
        posed.at(pose, 9)


def test_drawn_meshes_carry_the_layers_and_move_with_the_pose(turtle):
    chain, posed = turtle
    meshes = posed.meshes()
    names = [m.name for m in meshes]
    assert sorted(names) == sorted(p.name for p in chain.relief.parts)
    # back to front: the order the layer stack draws them in
    stack = [layer.name for layer in posed.cutout.layers]
    assert names == sorted(names, key=stack.index)
    rest = posed.drawn_vertices(posed.rig.vertices)
    layers = {layer.name: layer for layer in posed.cutout.layers}
    for m, v in zip(meshes, rest):
        assert v.shape == (len(m.texcoords), 3) and m.faces.max() < len(v)
        assert 0 < m.inner < len(m.faces)  # front triangles, then the skirt
        # at rest every vertex, the skirt's too, is drawn where its colour is taken from
        assert np.allclose(v[:, :2], m.texcoords)
        top, bottom, left, right = layers[m.name].box
        x0, y0 = m.origin
        y1, x1 = y0 + m.texture.shape[0], x0 + m.texture.shape[1]
        inside = layers[m.name].rgba[max(y0 - top, 0):y1 - top, max(x0 - left, 0):x1 - left]
        assert np.array_equal(m.texture[max(top - y0, 0):][:inside.shape[0],
                                        max(left - x0, 0):][:, :inside.shape[1]], inside)
    x, _ = posed.posing.pose([[250.0, 250.0], [345.0, 170.0]], iterations=8)
    moved = posed.drawn_vertices(x)
    parts = {p.name: np.asarray(p.vertices, float) for p in posed.relief(x).parts}
    for m, v, r in zip(meshes, moved, rest):
        # the front triangles' vertices are the posed relief's, heights kept
        front = v[np.unique(m.faces[:m.inner])]
        assert cKDTree(parts[m.name]).query(front)[0].max() < 1e-9
        assert np.allclose(v[:, 2], r[:, 2])
    assert not all(np.allclose(v, r) for v, r in zip(moved, rest))


def test_other_handles_share_the_prepared_drawing(turtle):
    chain, posed = turtle
    other = posed.with_handles([[250.0, 250.0], [300.0, 180.0]])
    assert other.rig is posed.rig and other.cutout is posed.cutout
    assert other.posing is not posed.posing
    fresh = PosedDrawing(chain.relief, chain.completion, chain.relations, chain.drawing,
                         [[250.0, 250.0], [300.0, 180.0]])
    to = [[250.0, 250.0], [310.0, 160.0]]
    assert np.array_equal(other.positions(to), fresh.positions(to))
    assert posed.posing.handles.tolist() == [[250.0, 250.0], [330.0, 200.0]]


def test_scan_conversion_covers_every_pixel_centre_of_a_mesh_exactly_once():
    from scipy.spatial import Delaunay
    from skimage.measure import points_in_poly

    from inkray.view.posed import _scan

    rng = np.random.default_rng(3)
    a = np.radians(17.0)
    turn = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    square = np.array([[0.0, 0], [30, 0], [30, 30], [0, 30]])
    inner = rng.uniform(1, 29, (120, 2))
    points = np.vstack([square, inner]) @ turn.T + [12.3, 4.7]
    tri = Delaunay(points).simplices
    pix, face = _scan(points, tri, (50, 50))
    assert len(np.unique(pix)) == len(pix)           # no pixel twice: no overlaps at edges
    rows, cols = np.divmod(np.arange(2500), 50)
    inside = points_in_poly(np.column_stack([cols, rows]), square @ turn.T + [12.3, 4.7])
    assert np.array_equal(np.sort(pix), np.flatnonzero(inside))  # none missed: no cracks
    # each pixel is in the triangle that claims it
    t = points[tri[face]]
    c = np.column_stack([pix % 50, pix // 50]).astype(float)
    cross = [(t[:, (k + 1) % 3, 0] - t[:, k, 0]) * (c[:, 1] - t[:, k, 1])
             - (t[:, (k + 1) % 3, 1] - t[:, k, 1]) * (c[:, 0] - t[:, k, 0]) for k in range(3)]
    sign = np.sign(np.sum(cross, axis=0))
    assert np.all(np.stack(cross) * sign >= -1e-9)


def _folded(low, layers, rgb):
    # one part of two squares apart at rest, the square ``low`` lower; posed, the right
    # square lies on the left one
    z = [2.0, 2.0]
    z[low] = 1.0
    a, _ = square(z=z[0])
    b, _ = square((5.0, 0.0), z=z[1])
    rest = np.vstack([a.vertices, b.vertices])
    faces = np.vstack([a.faces, b.faces + 4])
    posed = rest.copy()
    posed[4:, 0] -= 5.0
    return posed_image(Relief([Part("p", posed, faces)], size=(9, 4)),
                       Relief([Part("p", rest, faces)], size=(9, 4)), layers, rgb)


@pytest.mark.parametrize("low", [0, 1])
def test_a_part_folded_over_itself_shows_its_highest_surface(low):
    # the left square drawn 200, the right 50: the higher of the two shows where they
    # overlap, whichever of them comes first among the faces
    rgb = np.zeros((4, 9, 3), np.uint8)
    rgb[:, :4], rgb[:, 5:] = 200, 50
    img, _ = _folded(low, Cutout([], (9, 4)), rgb)
    assert (img[:, :4, 0] == (50 if low == 0 else 200)).all()


@pytest.mark.parametrize("low", [0, 1])
def test_a_part_folded_over_itself_shows_the_piece_under_a_transparent_one(low):
    # the higher square's layer is paper (an open mouth swung over the neck): the lower
    # square shows through it, opaque, whichever of them is higher
    from inkray.relief.cutout import CutoutLayer

    rgba = np.zeros((4, 9, 4), np.uint8)
    rgba[:, slice(0, 4) if low == 0 else slice(5, 9)] = [120, 120, 120, 255]
    layer = CutoutLayer(name="p", region=0, top=0, left=0, rgba=rgba,
                        hidden=np.zeros((4, 9), bool))
    img, part = _folded(low, Cutout([layer], (9, 4)), np.zeros((4, 9, 3), np.uint8))
    assert (img[:, :4, 3] == 255).all() and (img[:, :4, 0] == 120).all()
    assert (part[:, :4] == 0).all()


@pytest.mark.parametrize("inked", [0, 1])
def test_where_a_part_s_skirt_overlaps_itself_its_ink_shows(inked):
    # one part of two squares apart at rest, its layer inked 2 px beyond one of them (its
    # soft edge, drawn by the skirt); posed, the squares come within 2 px of each other, so
    # both skirts cover the pixels between them: the one reaching the ink shows, whichever
    # of the squares comes first among the faces
    from inkray.relief.cutout import CutoutLayer

    a, _ = square()
    b, _ = square((10.0, 0.0))
    rest = np.vstack([a.vertices, b.vertices])
    faces = np.vstack([a.faces, b.faces + 4])
    posed = rest.copy()
    posed[4:, 0] -= 4.0                      # b's mesh now covers pixel centres 6..9
    rgba = np.zeros((4, 16, 4), np.uint8)
    rgba[:, :4, :3], rgba[:, 10:14, :3] = 200, 50
    rgba[:, :4, 3] = rgba[:, 10:14, 3] = 255
    ink = slice(4, 6) if inked == 0 else slice(8, 10)   # beside a, or beside b
    rgba[:, ink, 3] = 255
    layer = CutoutLayer(name="p", region=0, top=0, left=0, rgba=rgba,
                        hidden=np.zeros((4, 16), bool))
    img, part = posed_image(Relief([Part("p", posed, faces)], size=(16, 4)),
                            Relief([Part("p", rest, faces)], size=(16, 4)),
                            Cutout([layer], (16, 4)), np.zeros((4, 16, 3), np.uint8))
    assert (img[:, 4:6, 3] == 255).all() and (img[:, 4:6, 0] == 0).all()
    assert (part[:, :10] == 0).all()


def _rect(name, x0, x1, y0, y1):
    v = np.array([[x0, y0, 1], [x1, y0, 1], [x1, y1, 1], [x0, y1, 1]], float)
    v += [[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]]
    return Part(name, v, np.array([[0, 3, 2], [0, 2, 1]]))


@pytest.mark.parametrize("case", ["ink", "paper", "open"])
def test_a_speck_two_parts_leave_inside_the_picture_is_drawn_where_the_drawing_has_ink(case):
    # Two bars with a left and a right block between them; the blocks' layers fade out where
    # they meet (a column each at alpha 128), or leave paper there. The right block moved a
    # pixel right leaves column 6 to the two blocks' transparent rims: inside the picture
    # where the drawing has ink there, it is drawn (from its neighbours); paper stays
    # paper, and so does a speck joined to the outside (no bottom bar).
    from inkray.relief.cutout import CutoutLayer

    w, h = 12, 7
    boxes = {"top": (0, 11, 0, 1), "left": (0, 5, 2, 4), "right": (6, 11, 2, 4),
             "bottom": (0, 11, 5, 6)}
    if case == "open":
        del boxes["bottom"]
    layers, rest = [], []
    for k, (name, (x0, x1, y0, y1)) in enumerate(boxes.items()):
        rgba = np.zeros((h, w, 4), np.uint8)
        rgba[y0:y1 + 1, x0:x1 + 1] = [100, 100, 100, 255]
        rest.append(_rect(name, x0, x1, y0, y1))
        layers.append(CutoutLayer(name=name, region=k, top=0, left=0, rgba=rgba,
                                  hidden=np.zeros((h, w), bool)))
        if name in ("left", "right"):
            rgba[y0:y1 + 1, 5 if name == "left" else 6, 3] = 0 if case == "paper" else 128
    cutout = Cutout(layers, (w, h))
    rest = Relief(rest, size=(w, h))
    rgb = np.full((h, w, 3), 100, np.uint8)
    still, _ = posed_image(rest, rest, cutout, rgb)
    assert np.array_equal(still, cutout.flatten())
    moved = Relief([Part(p.name, p.vertices + ([1.0, 0, 0] if p.name == "right" else 0.0),
                         p.faces) for p in rest.parts], size=(w, h))
    img, part = posed_image(moved, rest, cutout, rgb)
    speck = img[2:5, 6, 3]
    if case == "ink":
        assert (speck > 0).all() and (part[2:5, 6] >= 0).all()
        assert (img[2:5, 6, :3] == 100).all()
    else:
        assert (speck == 0).all() and (part[2:5, 6] == -1).all()


def _quad(name, x0, x1, y0, y1, z):
    """A part covering the pixel centres ``x0..x1 - 1``, ``y0..y1 - 1`` at height ``z``."""
    v = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], float) - [0.5, 0.5, 0]
    return Part(name, v, np.array([[0, 3, 2], [0, 2, 1]]))


def test_a_part_moved_sideways_carries_its_outline_off_the_part_behind():
    # A bar over a band, outlined with 4 px black strokes; where the bar's outline crosses
    # the band the segmentation gave it to the band, and the bar's mesh ends inside it.
    _, rgb, layers = bar_outline_on_band()
    band = _quad("band", 6, 154, 20, 80, 1.0)
    rest = Relief([band, _quad("bar", 60, 100, 4, 96, 2.0)], size=(160, 100))
    img, _ = posed_image(rest, rest, layers, rgb)
    assert np.array_equal(img, layers.flatten())            # at rest: the stack
    bar = rest.parts[1]
    moved = Relief([band, Part("bar", bar.vertices + [20.0, 0, 0], bar.faces)], size=(160, 100))
    img, _ = posed_image(moved, rest, layers, rgb)
    for x0, x1 in ((56, 60), (100, 104)):
        # the bar's stroke moved with it: none left on the band, all of it 20 px on
        assert img[26:74, x0:x1, :3].min() > 200 and np.all(img[26:74, x0:x1, 3] == 255)
        assert img[26:74, x0 + 20:x1 + 20, :3].max() == 0
