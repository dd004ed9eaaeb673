import json

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

from inkray import cli
from inkray.chain import ReliefChain
from inkray.errors import InputError
from inkray.formats.layer_files import read_layers
from inkray.input.drawing import drawing_from_array
from inkray.input.loading import load_input
from inkray.relief.completion import complete_regions
from inkray.relief.cutout import Cutout, CutoutLayer, cut_out, stack_order, stroke_style
from inkray.relief.ordering import Relation

from _bands import bar_outline_on_band, bar_over_band
from conftest import EXAMPLES


def psnr(a, b):
    mse = np.mean((np.asarray(a, float) - np.asarray(b, float)) ** 2)
    return np.inf if mse == 0 else 10 * np.log10(255.0 ** 2 / mse)


@pytest.fixture(scope="module", params=["turtle", "man"])
def drawn(request):
    ann, drawing = load_input(EXAMPLES / request.param / "drawing.inkray.json")
    chain = ReliefChain(ann, drawing)
    return chain, cut_out(chain.completion, chain.relations, drawing)


def _rank(stack):
    return {layer.region: k for k, layer in enumerate(stack.layers)}


def _over(rgba, paper):
    a = rgba[..., 3:4] / 255.0
    return rgba[..., :3] * a + np.asarray(paper, float) * (1 - a)


def _paper(rgb, labels):
    return np.median(rgb[ndimage.binary_erosion(labels < 0, iterations=10)], axis=0)


def test_flattened_stack_over_the_paper_is_the_drawing(drawn):
    chain, stack = drawn
    labels, rgb = chain.segmentation.labels, chain.drawing.rgb
    character = labels >= 0
    flat = stack.flatten()
    assert np.all(flat[..., 3][ndimage.binary_erosion(character, iterations=8)] == 255)
    shown = character | (flat[..., 3] > 0)
    assert psnr(_over(flat, _paper(rgb, labels))[shown], rgb[shown]) >= 35.0
    # Beyond the character only its contour strokes, as faint as they are drawn.
    beyond = ~character & (flat[..., 3] > 0)
    gray = chain.drawing.gray
    paper = np.median(gray[~character & (flat[..., 3] == 0)])
    core = np.median(gray[character & (gray < 0.5)])
    cover = (paper - gray[beyond]) / (paper - core)
    faint = cover < 0.7   # (at the strokes' core the tone varies: there anything goes)
    assert np.all(flat[..., 3][beyond][faint] / 255 <= cover[faint] + 0.1)


def _edge_share(layer):
    """The share of a layer's edge pixels (opaque at all, beside a transparent one) that
    are partly transparent."""
    alpha = np.pad(layer.rgba[..., 3], 1)
    clear = alpha == 0
    beside = clear[:-2, 1:-1] | clear[2:, 1:-1] | clear[1:-1, :-2] | clear[1:-1, 2:]
    edge = (alpha[1:-1, 1:-1] > 0) & beside
    return float(np.mean(alpha[1:-1, 1:-1][edge] < 255))


def test_layer_edges_are_antialiased_as_the_drawing(drawn):
    chain, stack = drawn
    shares = [_edge_share(layer) for layer in stack.layers]
    # Both drawings' strokes have soft edges: so do the layers, drawn and continued edges.
    assert np.median(shares) > 0.6, shares


def test_layers_follow_the_depth_order(drawn):
    chain, stack = drawn
    rank = _rank(stack)
    assert stack.splits == []
    for r in chain.relations:
        if r.kind == "order":
            assert rank[r.front] > rank[r.back], r.label


def test_hidden_parts_are_filled_with_the_parts_colour_and_outlined(drawn):
    chain, stack = drawn
    completion, gray = chain.completion, chain.drawing.gray
    _, width = stroke_style(chain.drawing.rgb, gray)
    checked = 0
    for layer in stack.layers:
        y0, y1, x0, x1 = layer.box
        whole = completion.completed(layer.region)
        shape = whole[y0:y1, x0:x1]
        alpha = layer.rgba[..., 3]
        depth = ndimage.distance_transform_edt(whole)[y0:y1, x0:x1]
        assert np.all(alpha[depth > width + 2] == 255)
        hidden = shape & (completion.labels[y0:y1, x0:x1] != layer.region)
        # Only strokes the segmentation left in another part's label differ (stubs, the
        # outline of a part in front): ink and its soft edge within two pixels of it, drawn
        # by the part whose strokes they are, filled under them by a part behind.
        differ = hidden ^ layer.hidden
        ink = differ & (gray[y0:y1, x0:x1] < 0.5)
        assert np.all(ndimage.binary_dilation(ink, structure=np.ones((3, 3)), iterations=2)[differ])
        inner = layer.hidden & (depth > 2 * width + 2)  # the local stroke may be wider
        rim = layer.hidden & (depth <= 1)
        if inner.sum() < 30:
            continue
        visible = completion.labels == layer.region
        paper = visible & (gray > 0.85 * np.median(gray[visible]))
        tone = np.median(chain.drawing.rgb[paper].astype(float), axis=0)
        fill = layer.rgba[..., :3][inner].astype(float)
        assert np.abs(fill - tone).mean() < 40, layer.name
        assert np.mean(layer.rgba[..., :3][rim].mean(axis=1) < 128) > 0.9, layer.name
        checked += 1
    assert checked >= 1


def test_pad_grows_parts_only_under_the_parts_in_front(drawn):
    chain, stack = drawn
    padded = cut_out(chain.completion, chain.relations, chain.drawing, pad=4)
    assert np.array_equal(padded.flatten(), stack.flatten())
    grown = [int((p.rgba[..., 3] > 0).sum() - (s.rgba[..., 3] > 0).sum())
             for p, s in zip(padded.layers, stack.layers)]
    assert min(grown) >= 0 and sum(grown) > 0
    assert grown[-1] == 0  # nothing is in front of the front part


def test_background_layer_makes_the_whole_drawing(drawn):
    chain, stack = drawn
    full = cut_out(chain.completion, chain.relations, chain.drawing, background=True)
    assert full.layers[0].name == "background" and full.layers[0].rgba.shape[:2] == \
        chain.drawing.rgb.shape[:2]
    flat = full.flatten()
    assert np.all(flat[..., 3] == 255) and psnr(flat[..., :3], chain.drawing.rgb) >= 35.0
    under = full.layers[0]
    character = chain.segmentation.labels >= 0
    assert np.all(under.rgba[..., 3] == 255) and np.all(under.hidden[character])

    # Paper continued under the character: as light as the paper around it.
    paper = np.median(chain.drawing.rgb[~character].astype(float))
    assert np.abs(under.rgba[..., :3][character].astype(float) - paper).mean() < 20


def test_harmonic_fill_blends_the_visible_colours_across_the_hidden_part():
    labels = np.full((40, 60), -1, np.int32)
    labels[10:30, 5:55] = 0
    labels[4:36, 25:35] = 1                      # a bar in front of a band
    rgb = np.full((40, 60, 3), 255, np.uint8)
    rgb[labels == 0] = (200, 40, 40)
    rgb[(labels == 0) & (np.arange(60) >= 30)] = (40, 40, 200)
    rgb[labels == 1] = (40, 200, 40)
    c = complete_regions(labels, names=["band", "bar"])
    rel = [Relation(1, 0, "bar", "band", (30, 20), "user", 1.0, place=c.places[0].index)]
    stack = cut_out(c.ordered(rel), rel, drawing_from_array(rgb))
    band = stack.layers[0]
    assert band.name == "band" and band.hidden.sum() == 20 * 10
    row = band.rgba[20 - band.top, 25 - band.left:35 - band.left, :3].astype(int)
    assert np.all(np.diff(row[:, 0]) < 0) and np.all(np.diff(row[:, 2]) > 0)  # red -> blue
    assert 60 < row[:, 0].mean() < 180 and np.all(row[:, 1] == 40)


def _rings():
    """Two interlocking rings: a over b at the top crossing, b over a at the bottom."""
    y, x = np.mgrid[0:80, 0:120].astype(float)
    ring_a = np.abs(np.hypot(x - 40, y - 40) - 22) < 4
    ring_b = np.abs(np.hypot(x - 71, y - 40) - 22) < 4  # crossing at right angles
    labels = np.full(x.shape, -1, np.int32)
    labels[ring_a] = 0
    labels[ring_b & ~(ring_a & (y < 40))] = 1
    rgb = np.full(x.shape + (3,), 255, np.uint8)
    rgb[labels == 0] = (220, 60, 60)
    rgb[labels == 1] = (60, 60, 220)
    c = complete_regions(labels, names=["a", "b"])
    rels = []
    for p in c.places:
        top = p.box[0] + p.box[1] < 80
        front, back = (0, 1) if top else (1, 0)
        rels.append(Relation(front, back, "ab"[front], "ab"[back], p.where, "user", 1.0,
                             place=p.index))
    return labels, rgb, c.ordered(rels), rels


def test_interlocking_rings_are_reported_with_the_part_to_split():
    labels, rgb, completion, rels = _rings()
    assert len(completion.places) == 2
    stack = cut_out(completion, rels, drawing_from_array(rgb))
    assert len(stack.layers) == 2 and len(stack.splits) == 1
    (message,) = stack.warnings
    assert "must be split" in message and "(split_local splits it)" in message
    flat = stack.flatten()
    wrong = np.any(flat[..., :3] != rgb, axis=-1) & (labels >= 0)
    assert wrong.sum() > 20  # one crossing shows the wrong ring


def test_split_local_puts_the_crossing_on_its_own_layer():
    labels, rgb, completion, rels = _rings()
    stack = cut_out(completion, rels, drawing_from_array(rgb), split_local=True)
    assert len(stack.layers) == 3 and stack.warnings == []
    split = stack.splits[0]
    assert [layer.name for layer in stack.layers][-1] == f"{split.name} over {split.under_name}"
    character = labels >= 0
    assert psnr(stack.flatten()[..., :3][character], rgb[character]) == np.inf
    padded = cut_out(completion, rels, drawing_from_array(rgb), split_local=True, pad=3)
    assert np.array_equal(padded.flatten(), stack.flatten())


def test_flatten_shows_only_the_canvas_part_of_a_layer_past_its_edge():
    px = np.zeros((3, 3, 4), np.uint8)
    px[..., 0] = px[..., 3] = 255
    stack = Cutout([CutoutLayer("a", None, -1, 2, px, None)], (4, 2))
    flat = stack.flatten()
    assert flat[..., 3].tolist() == [[0, 0, 255, 255], [0, 0, 255, 255]]


def test_stack_order_keeps_the_users_relation_over_a_prediction():
    user = Relation(0, 1, "a", "b", (0, 0), "user", 1.0)
    guess = Relation(1, 0, "b", "a", (0, 0), "predicted", 0.9)
    assert stack_order(2, [guess, user]) == ([1, 0], [guess])


def test_bad_pad_is_rejected(drawn):
    chain, _ = drawn
    with pytest.raises(InputError, match="pad"):
        cut_out(chain.completion, chain.relations, chain.drawing, pad=-1)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.iterdir()
                                        if (p / "drawing.inkray.json").is_file()))
def test_every_bundled_drawing_stacks_back_into_itself(name):
    ann, drawing = load_input(EXAMPLES / name / "drawing.inkray.json")
    chain = ReliefChain(ann, drawing)
    # the interlocking rings need their split; elsewhere the plain stack is checked
    stack = cut_out(chain.completion, chain.relations, drawing, background=True, pad=4,
                    split_local=name == "rings")
    assert psnr(stack.flatten()[..., :3], drawing.rgb) >= 35.0
    rank = {layer.region: k for k, layer in enumerate(stack.layers)}
    # A split pair is ordered both ways (at two places): its split layer, checked by the
    # flattened image above, carries the order that the two base layers cannot.
    broken = {pair for s in stack.splits for pair in ((s.region, s.under), (s.under, s.region))}
    for r in chain.relations:
        if r.kind == "order" and (r.front, r.back) not in broken:
            assert rank[r.front] > rank[r.back], r.label


def _drawn_rings(folder):
    """A drawing of two interlocking rings (a over b at the top crossing, b over a at the
    bottom one) with a scribble in each ring and no order entry: the chain predicts both."""
    w, h = 160, 110
    y, x = np.mgrid[0:h, 0:w].astype(float)
    (ax, bx), cy, radius, half = (55, 95), 55, 30, 7
    da, db = np.hypot(x - ax, y - cy), np.hypot(x - bx, y - cy)
    band_a, band_b = np.abs(da - radius) < half, np.abs(db - radius) < half
    edge_a = np.abs(np.abs(da - radius) - half) < 1.2
    edge_b = np.abs(np.abs(db - radius) - half) < 1.2
    top = y < cy
    ink = (edge_a & ~(band_b & ~top)) | (edge_b & ~(band_a & top))
    Image.fromarray(np.where(ink, 0, 255).astype(np.uint8)).save(folder / "rings.png")

    def arc(cx, t0, t1):
        t = np.linspace(t0, t1, 12)
        return np.round(np.stack([cx + radius * np.cos(t), cy + radius * np.sin(t)], 1), 1).tolist()

    doc = {"format": "inkray-annotations", "version": 1, "drawing": "rings.png", "size": [w, h],
           "regions": [{"name": "a", "scribbles": [arc(ax, 0.9, 5.3)]},
                       {"name": "b", "scribbles": [arc(bx, -2.2, 2.2)]}],
           "background": [[[3, 3], [156, 3], [156, 106], [3, 106]], [[ax, cy]], [[bx + 5, cy]],
                          [[75, cy]]]}
    path = folder / "rings.inkray.json"
    path.write_text(json.dumps(doc))
    return path


def test_cli_reports_and_splits_interlocking_rings(tmp_path, capsys):
    ann = _drawn_rings(tmp_path)
    a, drawing = load_input(ann)
    character = ReliefChain(a, drawing).segmentation.labels >= 0
    assert cli.main(["--quiet", "layers", str(ann), "-o", str(tmp_path / "one.ora")]) == 0
    # Either ring may be the one split (the weaker of the two predicted crossings
    # decides); it is the back layer of the stack and of its split layer.
    err = capsys.readouterr().err
    (split_region,) = [x for x in "ab" if f"region '{x}' must be split" in err]
    assert "(--split-local splits it)" in err  # the command line names its flag
    other = "b" if split_region == "a" else "a"
    stuck = read_layers(tmp_path / "one.ora")
    assert [layer.name for layer in stuck.layers] == [split_region, other]
    assert psnr(stuck.flatten()[..., :3][character], drawing.rgb[character]) < 35.0
    assert cli.main(["--quiet", "layers", str(ann), "-o", str(tmp_path / "split.psd"),
                     "--split-local"]) == 0
    assert "must be split" not in capsys.readouterr().err
    split = read_layers(tmp_path / "split.psd")
    assert [layer.name for layer in split.layers] == [split_region, other,
                                                     f"{split_region} over {other}"]
    assert psnr(split.flatten()[..., :3][character], drawing.rgb[character]) >= 35.0


def _outlined_band():
    """A band drawn with a soft 3 px grey outline (core 60, a half-tone pixel each side),
    a bar across it in front: the band's outline is continued under the bar."""
    h, w = 70, 120
    gray = np.ones((h, w))
    labels = np.full((h, w), -1, np.int32)
    labels[16:54, 4:116] = 0
    for top in (16, 49):                      # rows: soft, core, core, core... soft
        gray[top, 4:116] = 0.6
        gray[top + 1:top + 4, 4:116] = 60 / 255
        gray[top + 4, 4:116] = 0.6
    labels[6:64, 50:70] = 1                   # the bar, outlined on its long sides
    gray[6:64, 50:70] = 1.0
    for left in (50, 66):
        gray[6:64, left] = 0.6
        gray[6:64, left + 1:left + 3] = 60 / 255
        gray[6:64, left + 3] = 0.6
    rgb = np.repeat(np.rint(gray * 255).astype(np.uint8)[..., None], 3, axis=2)
    return labels, gray, rgb, bar_over_band(labels, rgb)


def test_continued_outline_has_the_drawings_tone_and_width():
    labels, gray, rgb, stack = _outlined_band()
    band = stack.layers[0]
    assert band.name == "band" and band.hidden.any()
    over = _over(band.rgba, (255, 255, 255))[..., 0] / 255   # the layer alone on paper
    drawn_cover = (1 - gray[:, 20]) / (1 - 60 / 255)          # across the visible outline
    for x in (58, 60, 62):                                    # across the continued outline
        column = np.full(gray.shape[0], 1.0)
        column[band.top:band.top + over.shape[0]] = over[:, x - band.left]
        cover = (1 - column) / (1 - 60 / 255)
        for rows in (slice(10, 30), slice(40, 60)):
            assert abs(cover[rows].sum() - drawn_cover[rows].sum()) < 0.5, (x, cover[rows])
            assert abs(column[rows].min() - 60 / 255) < 12 / 255           # the core's tone


def test_a_continued_outline_fades_at_its_edge():
    # A disk drawn with an anti-aliased 3 px outline, a bar in front across it.
    h = w = 100
    yy, xx = (np.mgrid[0:4 * h, 0:4 * w] + 0.5) / 4          # 4x4 samples per pixel
    r = np.hypot(yy - 50, xx - 50)
    ink = ((r > 27) & (r < 30)).reshape(h, 4, w, 4).mean(axis=(1, 3))
    inside = (r < 30).reshape(h, 4, w, 4).mean(axis=(1, 3)) >= 0.5
    gray = 1 - ink
    labels = np.where(inside, 0, -1).astype(np.int32)
    labels[:, 44:56] = 1
    rgb = np.repeat(np.rint(gray * 255).astype(np.uint8)[..., None], 3, axis=2)
    c = complete_regions(labels, names=["disk", "bar"])
    rel = [Relation(1, 0, "bar", "disk", p.where, "user", 1.0, place=p.index)
           for p in c.places if (p.a, p.b) == (0, 1)]
    disk = cut_out(c.ordered(rel), rel, drawing_from_array(rgb)).layers[0]
    alpha = np.pad(disk.rgba[..., 3], 1)
    clear = alpha == 0
    beside = clear[:-2, 1:-1] | clear[2:, 1:-1] | clear[1:-1, :-2] | clear[1:-1, 2:]
    edge = (alpha[1:-1, 1:-1] > 0) & beside
    continued = edge & ndimage.binary_dilation(disk.hidden, iterations=2)
    drawn = edge & ~continued
    assert continued.sum() >= 4 and drawn.sum() > 100
    share = np.mean(alpha[1:-1, 1:-1][continued] < 255)
    assert share >= 0.5 * np.mean(alpha[1:-1, 1:-1][drawn] < 255) > 0.3


def test_split_local_writes_each_split_piece_once_with_unique_names():
    labels, rgb, completion, rels = _rings()
    # The same crossing given twice (an entry and a prediction there), and a third ring-like
    # crossing of the same pair elsewhere: one split layer per pair, every name once.
    again = [Relation(r.front, r.back, r.front_name, r.back_name, r.where, "predicted", 0.5,
                      place=r.place) for r in rels]
    stack = cut_out(completion, rels + again, drawing_from_array(rgb), split_local=True)
    names = [layer.name for layer in stack.layers]
    assert len(names) == len(set(names)) == 3, names
    character = labels >= 0
    assert psnr(stack.flatten()[..., :3][character], rgb[character]) == np.inf


def _thick_grey_ink():
    """A band behind a bar, both outlined by a 14 px grey (core 90) marker stroke with
    anti-aliased edges over slightly grainy paper, half of each stroke on either side of the
    boundary between the labels: the bar's outline lies on the band next to its hidden part."""
    h, w = 120, 160
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    labels = np.full((h, w), -1, np.int32)
    labels[30:90, 6:154] = 0
    labels[10:110, 65:95] = 1
    cover = np.zeros((h, w))
    for y in (30, 90):                                     # the band's long sides
        cover = np.maximum(cover, np.clip(7.5 - np.abs(yy - y), 0, 1) * (xx > 6) * (xx < 154))
    for x in (65, 95):                                     # the bar's long sides
        cover = np.maximum(cover, np.clip(7.5 - np.abs(xx - x), 0, 1) * (yy > 10) * (yy < 110))
    paper = 236 + np.random.default_rng(1).normal(0, 2.0, (h, w))
    gray = paper + cover * (90 - paper)
    rgb = np.repeat(np.clip(np.rint(gray), 0, 255).astype(np.uint8)[..., None], 3, axis=2)
    return labels, rgb, cover, bar_over_band(labels, rgb)


def test_a_hidden_part_next_to_thick_grey_ink_is_filled_with_its_paper():
    labels, rgb, cover, stack = _thick_grey_ink()
    band = stack.layers[0]
    assert band.name == "band" and band.hidden[45 - band.top:75 - band.top, 65 - band.left:95 - band.left].all()
    paper = rgb[..., 0][(labels == 0) & (cover == 0)].astype(float)
    floor = np.percentile(paper, 2)
    # The hidden part away from its continued outline (along the band's long sides).
    inner = band.rgba[45 - band.top:75 - band.top, 65 - band.left:95 - band.left]
    assert np.all(inner[..., 3] == 255)
    luma = inner[..., :3].astype(float) @ [0.299, 0.587, 0.114]
    assert luma.min() >= floor, (luma.min(), floor)
    assert abs(np.median(luma) - np.median(paper)) < 3


@pytest.mark.slow
def test_the_gingerbreads_hidden_parts_take_its_paper_tone():
    # Thick clean black strokes, wider than the closing that finds strokes.
    ann, drawing = load_input(EXAMPLES / "gingerbread" / "drawing.inkray.json")
    chain = ReliefChain(ann, drawing)
    labels = chain.completion.labels
    stack = cut_out(chain.completion, chain.relations, drawing)
    # whole levels: a grey of 254 is 253.99999999999997 in floating point
    luma = np.rint(drawing.rgb.astype(float) @ [0.299, 0.587, 0.114])
    checked = 0
    for layer in stack.layers:
        y0, y1, x0, x1 = layer.box
        own = labels[y0:y1, x0:x1] == layer.region
        depth = ndimage.distance_transform_edt(np.pad(layer.hidden | own, 1))[1:-1, 1:-1]
        inner = layer.hidden & (depth > 10)  # beyond the continued outline
        if not inner.any():
            continue
        paper = luma[y0:y1, x0:x1][own & ~ndimage.binary_dilation(luma[y0:y1, x0:x1] < 128,
                                                                   iterations=3)]
        fill = np.rint(layer.rgba[..., :3][inner].astype(float) @ [0.299, 0.587, 0.114])
        assert fill.min() >= np.percentile(paper, 2) - 1, layer.name
        checked += 1
    assert checked >= 1


def _thick_outlined_band():
    """A band behind a bar, each outlined by 12 px black strokes (a soft pixel each side),
    the band's strokes inside its label: wider than the closing that finds ink."""
    h, w = 130, 240
    gray = np.ones((h, w))
    labels = np.full((h, w), -1, np.int32)
    labels[20:110, 6:234] = 0
    for top in (20, 96):                      # rows: soft, 12 core, soft
        gray[top, 6:234] = gray[top + 13, 6:234] = 0.5
        gray[top + 1:top + 13, 6:234] = 0.0
    labels[4:126, 90:150] = 1                 # the bar, outlined on its long sides
    gray[4:126, 90:150] = 1.0
    for left in (90, 136):
        gray[4:126, left] = gray[4:126, left + 13] = 0.5
        gray[4:126, left + 1:left + 13] = 0.0
    rgb = np.repeat(np.rint(gray * 255).astype(np.uint8)[..., None], 3, axis=2)
    return gray, bar_over_band(labels, rgb)


def test_a_continued_outline_is_as_wide_as_thick_drawn_strokes():
    gray, stack = _thick_outlined_band()
    band = stack.layers[0]
    assert band.name == "band" and band.hidden.any()
    over = _over(band.rgba, (255, 255, 255))[..., 0] / 255   # the layer alone on paper
    drawn = (1 - gray[:, 40]).sum() / 2                      # one stroke's ink, 13 px
    for x in (114, 120, 126):                                # across the continued outline
        column = np.ones(gray.shape[0])
        column[band.top:band.top + over.shape[0]] = over[:, x - band.left]
        for rows in (slice(10, 60), slice(70, 120)):
            width = (1 - column[rows]).sum()
            assert abs(width / drawn - 1) < 0.25, (x, width, drawn)
            assert column[rows].min() < 0.1                  # black at its core


def _stubbed_band():
    """A band behind a bar, both drawn with 6 px black strokes; the band's two strokes run
    up to the bar's outline, but their last 6 px lie in the bar's label (a segmentation
    that cut them short of the bar's outline)."""
    h, w = 100, 160
    gray = np.ones((h, w))
    labels = np.full((h, w), -1, np.int32)
    labels[20:80, 6:154] = 0
    for top in (20, 74):                       # the band's long sides
        gray[top:top + 6, 6:154] = 0.0
    labels[4:96, 60:100] = 1
    gray[4:96, 60:100] = 1.0
    for left in (60, 94):                      # the bar's long sides
        gray[4:96, left:left + 6] = 0.0
    for top in (20, 74):                       # the stubs: the band's ink, the bar's label
        labels[top:top + 6, 54:60] = labels[top:top + 6, 100:106] = 1
    rgb = np.repeat(np.rint(gray * 255).astype(np.uint8)[..., None], 3, axis=2)
    return labels, rgb, bar_over_band(labels, rgb)


def test_the_stubs_of_a_parts_strokes_stay_with_it():
    labels, rgb, stack = _stubbed_band()
    band, bar = stack.layers
    assert (band.name, bar.name) == ("band", "bar")
    # The bar's layer ends at its outline: no ink of the band's strokes beside it.
    y0, y1, x0, x1 = bar.box
    assert x0 >= 59 and x1 <= 101, bar.box
    # The band's layer draws its strokes up to the bar's outline (within a pixel).
    y0, y1, x0, x1 = band.box
    for top in (20, 74):
        for x in range(54, 59):
            pixel = band.rgba[top + 2 - y0, x - x0]
            assert pixel[3] == 255 and pixel[:3].max() < 60, (top, x, pixel)
            assert not band.hidden[top + 2 - y0, x - x0]
    # The stack still draws every stroke of the drawing.
    ink = (labels >= 0) & (rgb[..., 0] == 0)
    flat = stack.flatten()
    assert np.all(flat[..., 3][ink] == 255) and np.all(flat[..., :3][ink] < 60)


def _marker_band(scale):
    """:func:`_thick_outlined_band` drawn ``scale`` times as large with a grey marker: strokes
    6 ``scale`` px wide of core tone 0.35, a soft edge of ``scale`` px each side."""
    h, w = 130 * scale, 240 * scale
    gray = np.ones((h, w))
    labels = np.full((h, w), -1, np.int32)
    labels[20 * scale:110 * scale, 6 * scale:234 * scale] = 0
    core, soft, s = 0.35, 0.7, scale
    for top in (20, 96):
        t = top * s
        gray[t:t + s, 6 * s:234 * s] = gray[t + 7 * s:t + 8 * s, 6 * s:234 * s] = soft
        gray[t + s:t + 7 * s, 6 * s:234 * s] = core
    labels[4 * s:126 * s, 90 * s:150 * s] = 1
    gray[4 * s:126 * s, 90 * s:150 * s] = 1.0
    for left in (90, 142):
        x = left * s
        gray[4 * s:126 * s, x:x + s] = gray[4 * s:126 * s, x + 7 * s:x + 8 * s] = soft
        gray[4 * s:126 * s, x + s:x + 7 * s] = core
    rgb = np.repeat(np.rint(gray * 255).astype(np.uint8)[..., None], 3, axis=2)
    return gray, bar_over_band(labels, rgb)


@pytest.mark.parametrize("scale", [1, 2, 3])
def test_a_continued_outline_scales_with_the_drawing(scale):
    # Grey marker strokes 6, 12 and 18 px wide: the continued outline is as wide as the drawn
    # ones, in their tone, whatever the drawing's size.
    gray, stack = _marker_band(scale)
    band = stack.layers[0]
    assert band.name == "band" and band.hidden.any()
    over = _over(band.rgba, (255, 255, 255))[..., 0] / 255
    drawn = (1 - gray[:, 40 * scale]).sum() / 2               # one stroke's ink
    for x in (114, 120, 126):
        column = np.ones(gray.shape[0])
        column[band.top:band.top + over.shape[0]] = over[:, x * scale - band.left]
        for rows in (slice(10 * scale, 60 * scale), slice(70 * scale, 120 * scale)):
            width = (1 - column[rows]).sum()
            assert abs(width / drawn - 1) < 0.25, (x, width, drawn)
            assert abs(column[rows].min() - 0.35) < 0.1       # the marker's tone at its core


def test_the_outline_of_a_part_in_front_is_its_own():
    labels, rgb, stack = bar_outline_on_band()
    band, bar = stack.layers
    assert (band.name, bar.name) == ("band", "bar")

    def at(layer, rows, cols):
        y0, _, x0, _ = layer.box
        return (layer.rgba[rows.start - y0:rows.stop - y0, cols.start - x0:cols.stop - x0],
                layer.hidden[rows.start - y0:rows.stop - y0, cols.start - x0:cols.stop - x0])

    for cols in (slice(56, 60), slice(100, 104)):        # the bar's strokes over the band
        for rows in (slice(26, 46), slice(54, 74)):
            drawn, hidden = at(bar, rows, cols)
            assert np.all(drawn[..., 3] == 255) and np.all(drawn[..., :3] == 0), (rows, cols)
            filled, hidden = at(band, rows, cols)
            # the band's layer fills them in with its paper, as hidden
            assert hidden.all() and np.all(filled[..., 3] == 255) and np.all(filled[..., :3] > 240)
    # The crease stays the band's beyond one stroke width of the bar's outline: the band's
    # layer draws it, the bar's holds none of it.
    drawn, hidden = at(band, slice(48, 52), slice(20, 52))
    assert np.all(drawn[..., :3] == 0) and not hidden.any()
    assert bar.box[2] >= 52, bar.box
    # The stack draws the drawing, across the band between its outlines (the strokes moved).
    flat = stack.flatten()[26:74, 6:154]
    assert np.all(flat[..., 3] == 255) and np.array_equal(flat[..., :3], rgb[26:74, 6:154])
