import json

import numpy as np
import pytest
import triangle
from PIL import Image

from inkray.cli import main
from inkray.errors import InputError
from inkray.formats.images import write_renderings
from inkray.formats.meshes import export_relief, read_relief
from inkray.relief.model import Part, Relief
from inkray.view.rendering import has_mitsuba, output_size, render, render_turntable
from inkray.view.shading import over_white

needs_mitsuba = pytest.mark.skipif(
    not has_mitsuba(), reason="Mitsuba 3 is not installed (pip install 'inkray[render]'); "
                              "the gi mode cannot be tested")


def _part(name, outline, height, max_area=6.0):
    """Heightfield z = height(x, y) over a polygon; faces counter-clockwise for the viewer."""
    outline = np.asarray(outline, float)
    n = len(outline)
    seg = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    t = triangle.triangulate({"vertices": outline, "segments": seg}, f"pq30a{max_area}")
    xy, f = t["vertices"], t["triangles"].astype(np.int64)
    a, b = xy[f[:, 1]] - xy[f[:, 0]], xy[f[:, 2]] - xy[f[:, 0]]
    ccw = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] > 0
    f[ccw] = f[ccw][:, [0, 2, 1]]
    return Part(name, np.column_stack([xy, height(xy[:, 0], xy[:, 1])]), f)


def _circle(cx, cy, r, n=72):
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.stack([cx + r * np.cos(a), cy + r * np.sin(a)], axis=1)


def _square(x0, y0, x1, y1):
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def _dome(name, cx, cy, r, base=0.0):
    def height(x, y):
        return base + 0.8 * np.sqrt(np.maximum(r ** 2 - (x - cx) ** 2 - (y - cy) ** 2, 0))
    return _part(name, _circle(cx, cy, r), height)


# A body with a head in front of it (80 x 60 drawing), ink along both outlines.
DISKS = [(34, 30, 24), (60, 34, 14)]


def _figure(texture=True):
    parts = [_dome("body", *DISKS[0]), _dome("head", *DISKS[1], base=20)]
    tex = None
    if texture:
        yy, xx = np.mgrid[0:60, 0:80]  # pixel centres are integers
        tex = np.full((60, 80, 3), [250, 240, 200], np.uint8)
        for cx, cy, r in DISKS:
            tex[np.abs(np.hypot(xx - cx, yy - cy) - r) < 0.8] = 20
    return Relief(parts, size=(80, 60), texture=tex)


def _silhouette(size):
    """The figure's analytic silhouette at `size` (the 80 x 60 drawing fitted, centred)."""
    w, h = size
    s = min(w / 80, h / 60)
    ox, oy = (w - 80 * s) / 2, (h - 60 * s) / 2
    # output pixel centres (j + 0.5, i + 0.5) in drawing coordinates (centres at integers)
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    x, y = (xx - ox) / s - 0.5, (yy - oy) / s - 0.5
    return np.any([np.hypot(x - cx, y - cy) < r for cx, cy, r in DISKS], axis=0)


def _iou(a, b):
    return (a & b).sum() / (a | b).sum()


def _covered(rendering):
    """Non-background pixels: depth > 0, or at least half covered."""
    img = rendering.image
    return img > 0 if img.ndim == 2 else img[..., 3] >= 128


@pytest.mark.parametrize("mode", ["shade", "normals", "depth", "stereo",
                                  pytest.param("gi", marks=needs_mitsuba)])
def test_each_mode_gives_the_requested_size_and_the_silhouette(mode):
    size = (64, 64) if mode == "gi" else (150, 100)
    r = render(_figure(), mode=mode, size=size, spp=4, backdrop=False)
    assert r.image.shape[:2] == (size[1], size[0])
    assert _iou(_covered(r), _silhouette(size)) >= 0.95


def test_shade_lights_the_side_facing_the_light_and_keeps_the_ink():
    relief = _figure()
    r = render(relief, mode="shade", size=(160, 120), light=(-1, 0, 0.3))
    lum = r.image[..., :3].astype(float).mean(axis=2)
    # on the body (scale 2), left flank toward the light, right flank away
    assert lum[60, 68 - 30] > lum[60, 68 + 20] + 40
    # the ink ring stays dark and thin: dark on the outline, bright 3 px inside it
    cx, cy, rad = (2 * v for v in DISKS[0])
    assert lum[cy, cx - rad] < 80 and lum[cy, cx - rad + 4] > 150


def test_flat_colors_give_one_colour_per_part():
    relief = _figure(texture=False)
    r = render(relief, mode="shade", size=(80, 60), flat_colors=True, light=(0, 0, 1),
               ambient=1.0)
    rgb = r.image[..., :3].astype(int)
    yy, xx = np.mgrid[0:60, 0:80]  # drawing pixel centres at scale 1
    inner = [np.hypot(xx - cx, yy - cy) < rad - 1 for cx, cy, rad in DISKS]
    outer = np.hypot(xx - DISKS[1][0], yy - DISKS[1][1]) < DISKS[1][2] + 1
    body, head = rgb[inner[0] & ~outer], rgb[inner[1]]
    # lighting changes brightness (a highlight adds white); the hue is the part's
    for c in (body, head):
        order = np.argsort(c, axis=1, kind="stable")
        assert (order == order[0]).all()
    assert np.abs(np.median(body, 0) - np.median(head, 0)).max() > 30


def test_normal_map_encodes_a_tilted_plane():
    plane = _part("plane", _square(0, 0, 40, 40), lambda x, y: 0.5 * x + 10)
    r = render(Relief([plane], size=(40, 40)), mode="normals")
    n = np.array([-0.5, 0, 1]) / np.linalg.norm([-0.5, 0, 1])  # y up: same for a plane in x
    assert np.abs(r.image[5:35, 5:35, :3].astype(float) - (n + 1) * 127.5).max() <= 1


def test_depth_map_is_16_bit_near_bright_with_its_range(tmp_path):
    r = render(_figure(), mode="depth")
    assert r.image.dtype == np.uint16 and r.image[~r.mask].max() == 0
    lo, hi = r.depth_range
    assert 0 <= lo < 5 and hi == pytest.approx(20 + 0.8 * 14, abs=0.5)
    assert r.image[34, 60] > r.image[30, 34] > r.image[30, 12]  # head top > body top > flank
    path = write_renderings(r, tmp_path / "d.png")[0]
    with Image.open(path) as im:
        assert im.mode.startswith("I") and np.array_equal(np.asarray(im), r.image)
        meta = json.loads(im.text["inkray:depth"])
    assert meta["near"] == [65535, hi] and meta["far"] == [1, lo]


def test_renderings_join_a_group_of_outputs(tmp_path):
    from inkray.formats.atomic import atomic_outputs

    r = render(_figure(), mode="normals")
    with pytest.raises(RuntimeError):
        with atomic_outputs() as group:
            write_renderings(r, tmp_path / "n.png", outputs=group)
            raise RuntimeError("a later output failed")
    assert list(tmp_path.iterdir()) == []
    with atomic_outputs() as group:
        written = write_renderings(r, tmp_path / "n.png", outputs=group)
    with Image.open(written[0]) as im:
        assert np.array_equal(np.asarray(im), r.image)


def _dark_centroid_x(channel, rows, cols):
    weight = 255.0 - channel[rows, cols].astype(float)
    x = np.arange(channel.shape[1])[cols] + 0.5
    return float((weight * x).sum() / weight.sum())


def test_stereo_disparity_is_zero_at_depth_zero_and_grows_with_depth():
    heights = [0.0, 10.0, 20.0]
    parts = [_part(f"s{i}", _square(10 + 40 * i, 20, 30 + 40 * i, 40),
                   lambda x, y, z=z: np.full_like(x, z)) for i, z in enumerate(heights)]
    relief = Relief(parts, size=(130, 60))
    r = render(relief, mode="stereo", size=(260, 120), disparity=8, flat_colors=True)
    red, cyan = r.image[..., 0], r.image[..., 1]  # left eye, right eye
    disparity = []
    for i in range(3):
        cols = slice(2 * (40 * i), 2 * (40 * i + 40))
        d = _dark_centroid_x(red, slice(30, 90), cols) - _dark_centroid_x(cyan, slice(30, 90), cols)
        disparity.append(d)
    assert abs(disparity[0]) < 0.25
    assert disparity[1] > 2 and disparity[2] > disparity[1] + 2
    assert disparity[2] == pytest.approx(8, abs=1.0)  # the highest point gets --disparity
    assert set(r.views) == {"left", "right"}


def test_turntable_starts_frontal_and_swings_both_ways():
    relief = _figure()
    frames = render_turntable(relief, frames=4, angle=20, mode="depth")
    front = render(relief, mode="depth", frame_yaw=20)  # framed to hold every frame
    assert np.array_equal(frames[0].image, front.image)
    # frames 1 and 3 look from +20 and -20 degrees: mirror-like shifts of the raised head
    c1 = np.nonzero(frames[1].image[34] > 0)[0].mean()
    c3 = np.nonzero(frames[3].image[34] > 0)[0].mean()
    c0 = np.nonzero(frames[0].image[34] > 0)[0].mean()
    assert c1 < c0 < c3 or c3 < c0 < c1


@needs_mitsuba
def test_gi_renders_the_relief_on_a_backdrop_with_crisp_ink():
    r = render(_figure(), mode="gi", size=(64, 64), spp=4)
    img = r.image[..., :3].astype(float)
    assert r.image.shape == (64, 64, 4) and np.all(r.image[..., 3] == 255)
    assert img.std() > 10 and img.mean() > 60  # lit, not blank
    # the ink follows the outlines: the darkest pixels lie on them
    sil = _silhouette((64, 64))
    edge = sil ^ np.roll(sil, 1, 0) | sil ^ np.roll(sil, 1, 1)
    lum = img.mean(axis=2)
    assert lum[edge].mean() < lum[sil & ~edge].mean() - 40
    # the outer half of the outline, off the relief, is drawn on the backdrop
    # output pixel centres in drawing coordinates (scale 0.8, offset (0, 8))
    yy, xx = (np.mgrid[0:64, 0:64] + 0.5 - [[[8.0]], [[0.0]]]) / 0.8 - 0.5
    d = np.hypot(xx - DISKS[0][0], yy - DISKS[0][1]) - DISKS[0][2]
    left = xx < DISKS[0][0]  # away from the head
    assert lum[left & (d > 0.1) & (d < 0.7)].mean() < lum[left & (d > 3) & (d < 5)].mean() - 40


@needs_mitsuba
def test_gi_is_deterministic_per_seed_and_turns_like_the_rasterizer():
    relief = _figure()
    a, b, c = (render(relief, mode="gi", size=(48, 48), spp=2, seed=s).image for s in (1, 1, 2))
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    gi = render(relief, mode="gi", size=(64, 64), spp=4, yaw=20, backdrop=False)
    depth = render(relief, mode="depth", size=(64, 64), yaw=20)
    assert _iou(_covered(gi), _covered(depth)) >= 0.95
    assert _iou(_covered(depth), _silhouette((64, 64))) < 0.95  # the view did turn


@needs_mitsuba
def test_gi_reports_progress_per_pass():
    class Recorder:
        def __init__(self):
            self.calls = []

        def update(self, done, total):
            self.calls.append((done, total))

    rec = Recorder()
    render(_figure(), mode="gi", size=(16, 16), spp=5, progress=rec)
    assert rec.calls == [(k, 5) for k in range(1, 6)]


@needs_mitsuba
def test_gi_a_part_in_front_casts_a_shadow_on_the_part_behind():
    back = _part("back", _square(0, 0, 80, 80), lambda x, y: np.zeros_like(x), max_area=20)
    front = _part("front", _circle(30, 30, 12), lambda x, y: np.full_like(x, 15.0))
    light = (-1, 1, 1)  # upper left: the shadow falls to the lower right
    kw = dict(mode="gi", size=(64, 64), spp=4, light=light, backdrop=False)
    with_front = render(Relief([back, front], size=(80, 80)), **kw).image[..., :3].mean(axis=2)
    without = render(Relief([back], size=(80, 80)), **kw).image[..., :3].mean(axis=2)
    yy, xx = (np.mgrid[0:64, 0:64] + 0.5) / 0.8 - 0.5  # output pixel centres, drawing coords
    d = np.hypot(xx - 30, yy - 30)
    lee = (d > 13) & (d < 24) & (xx > 32) & (yy > 32)  # beside the disk, away from the light
    assert with_front[lee].mean() < 0.8 * without[lee].mean()


@needs_mitsuba
@pytest.mark.parametrize("backdrop", [True, False])
def test_gi_denoised_at_few_samples_is_closer_to_many_samples_than_raw(backdrop):
    relief = _figure()
    kw = dict(mode="gi", size=(64, 64), backdrop=backdrop)
    ref, raw, den = (render(relief, spp=spp, denoise=d, seed=seed, **kw).image
                     for spp, d, seed in ((128, False, 7), (4, False, 0), (4, True, 0)))
    # as seen over a white page (the transparent background's colour is irrelevant)
    err_raw, err_den = (np.sqrt(np.mean((over_white(x) - over_white(ref)) ** 2))
                        for x in (raw, den))
    assert err_den < 0.8 * err_raw
    # the same coverage and ink: only the noise of the light changed
    assert np.array_equal(den[..., 3], raw[..., 3])
    sil = _silhouette((64, 64))
    edge = sil ^ np.roll(sil, 1, 0) | sil ^ np.roll(sil, 1, 1)
    lum = den[..., :3].astype(float).mean(axis=2)
    assert lum[edge].mean() < lum[sil & ~edge].mean() - 40


@needs_mitsuba
def test_gi_denoises_a_single_pass_without_a_variance():
    relief = _figure()
    raw, den = (render(relief, mode="gi", size=(32, 32), spp=1, denoise=d).image
                for d in (False, True))
    assert den.shape == raw.shape and not np.array_equal(den, raw)
    # smoother: neighbours differ less than in the raw render
    rough = [np.abs(np.diff(x[..., :3].astype(float), axis=1)).mean() for x in (raw, den)]
    assert rough[1] < rough[0]


@needs_mitsuba
def test_gi_denoising_keeps_a_shadow_on_the_part_behind():
    back = _part("back", _square(0, 0, 80, 80), lambda x, y: np.zeros_like(x), max_area=20)
    front = _part("front", _circle(30, 30, 12), lambda x, y: np.full_like(x, 15.0))
    kw = dict(mode="gi", size=(64, 64), spp=4, light=(-1, 1, 1), backdrop=False)
    img = render(Relief([back, front], size=(80, 80)), **kw).image[..., :3].mean(axis=2)
    yy, xx = (np.mgrid[0:64, 0:64] + 0.5) / 0.8 - 0.5
    d = np.hypot(xx - 30, yy - 30)
    lee = (d > 13) & (d < 20) & (xx > 32) & (yy > 32)
    lit = (d > 13) & (d < 20) & (xx < 28) & (yy < 28)
    assert img[lee].mean() < 0.8 * img[lit].mean()


@needs_mitsuba
def test_cli_render_gi_denoises_unless_told_not_to(tmp_path):
    glb = export_relief(_figure(), tmp_path / "fig.glb")[0]
    base = ["--quiet", "render", str(glb), "--mode", "gi", "--width", "48", "--spp", "2"]
    assert main(base + ["-o", str(tmp_path / "d.png")]) == 0
    assert main(base + ["-o", str(tmp_path / "r.png"), "--no-denoise"]) == 0
    assert main(base + ["-o", str(tmp_path / "d2.png"), "--denoise"]) == 0
    d, r, d2 = ((tmp_path / f).read_bytes() for f in ("d.png", "r.png", "d2.png"))
    assert d == d2 and d != r


def test_gi_without_mitsuba_says_how_to_install(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_mitsuba(name, *args, **kwargs):
        if name == "mitsuba":
            raise ImportError("No module named 'mitsuba'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_mitsuba)
    monkeypatch.delitem(__import__("sys").modules, "mitsuba", raising=False)
    with pytest.raises(Exception, match=r"pip install 'inkray\[render\]'"):
        render(_figure(), mode="gi", size=(8, 8), spp=1)


def test_cli_renders_an_exported_glb(tmp_path):
    glb = export_relief(_figure(), tmp_path / "fig.glb")[0]
    relief = read_relief(glb)
    assert relief.size == (80, 60) and [p.name for p in relief.parts] == ["body", "head"]
    assert main(["--quiet", "render", str(glb), "-o", str(tmp_path / "s.png"),
                 "--width", "160", "--light", "-1", "0.5", "1"]) == 0
    with Image.open(tmp_path / "s.png") as im:
        assert im.size == (160, 120)
        assert _iou(np.asarray(im)[..., 3] >= 128, _silhouette((160, 120))) >= 0.95
    assert main(["--quiet", "render", str(glb), "-o", str(tmp_path / "st.png"),
                 "--mode", "stereo"]) == 0
    assert {p.name for p in tmp_path.iterdir()} >= {"st.png", "st-left.png", "st-right.png"}
    assert main(["--quiet", "render", str(glb), "-o", str(tmp_path / "t.png"),
                 "--turntable", "3", "--mode", "normals"]) == 0
    assert all((tmp_path / f"t-{k:03d}.png").is_file() for k in range(3))
    assert main(["--quiet", "render", str(glb), "-o", str(tmp_path / "t.gif"),
                 "--turntable", "5"]) == 0
    with Image.open(tmp_path / "t.gif") as im:
        assert im.n_frames == 5


@pytest.mark.parametrize("suffix", [".glb", ".obj", ".ply"])
def test_read_relief_places_inkray_files_in_drawing_pixels(tmp_path, suffix):
    relief = _figure()
    path = export_relief(relief, tmp_path / f"fig{suffix}", anchor="top-left", back="none")[0]
    back = read_relief(path)
    assert back.size == relief.size
    by_name = {p.name: p for p in back.parts}
    for p in relief.parts:
        assert np.abs(by_name[p.name].vertices - p.vertices).max() < 1e-3
        assert np.array_equal(by_name[p.name].faces, p.faces)
    if suffix == ".ply":
        assert back.texture.shape == relief.texture.shape  # baked from its vertex colours
    else:
        assert np.array_equal(back.texture, relief.texture)


@pytest.mark.parametrize("argv, message", [
    (["-o", "x.jpg"], "unsupported output type"),
    (["-o", "x.gif"], "unsupported output type"),
    (["-o", "x.png", "--light", "1", "2"], "--light"),
    (["-o", "x.png", "--size", "10x"], "--size"),
    (["-o", "x.png", "--size", "10x10", "--width", "4"], "--size"),
    (["-o", "x.png", "--mode", "gi", "--spp", "0"], "spp"),
    (["-o", "x.png", "--turntable", "0"], "--turntable"),
])
def test_cli_bad_input_exits_2_and_writes_nothing(tmp_path, capsys, argv, message):
    glb = export_relief(_figure(), tmp_path / "fig.glb")[0]
    argv = [a if not a.startswith("x.") else str(tmp_path / a) for a in argv]
    assert main(["--quiet", "render", str(glb)] + argv) == 2
    assert message in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.glb"]


def test_cli_missing_mesh_exits_2(tmp_path, capsys):
    assert main(["render", str(tmp_path / "none.glb"), "-o", str(tmp_path / "a.png")]) == 2
    assert "no such mesh file" in capsys.readouterr().err


def test_output_size_keeps_the_aspect_and_refuses_conflicts():
    assert output_size((80, 60), height=30) == (40, 30)
    assert output_size((80, 60)) == (80, 60)
    with pytest.raises(InputError, match="^width: expected an integer"):
        output_size((80, 60), width=0)
    with pytest.raises(InputError, match="^size: give either a size or a width and height"):
        output_size((80, 60), size=(10, 10), width=5)


@pytest.mark.parametrize("kwargs, match", [
    (dict(mode="x"), "unknown mode"),
    (dict(size=(0, 5)), "size"),
    (dict(light=(0, 0, 0)), "light"),
    (dict(ambient=2), "ambient"),
    (dict(yaw=120), "yaw"),
])
def test_render_refuses_bad_arguments(kwargs, match):
    with pytest.raises(InputError, match=match):
        render(_figure(), **kwargs)


def test_turntable_frames_never_repeat_and_never_crop():
    relief = _figure()
    for n in (3, 5, 6, 7):
        frames = render_turntable(relief, frames=n, angle=60, mode="depth")
        for a, b in zip(frames, frames[1:] + frames[:1]):
            assert not np.array_equal(a.image, b.image), n
    # a wide, deep slab: turned 60 degrees it reaches far past the drawing's frame
    v = np.array([[1, 5, 0], [78, 5, 40], [78, 55, 40], [1, 55, 0]], float)
    slab = Relief([Part("slab", v, np.array([[0, 3, 2], [0, 2, 1]]))], size=(80, 60))
    cropped = render(slab, mode="depth", yaw=-60, frame_yaw=0).mask
    assert cropped[:, 0].any() or cropped[:, -1].any()  # without the wider frame
    for f in render_turntable(slab, frames=6, angle=60, mode="depth"):
        assert not (f.mask[:, 0].any() or f.mask[:, -1].any())


@pytest.mark.parametrize("frames, angle, size, message", [
    (361, 15.0, None, "frames: 361: expected 1..360 frames"),
    (0, 15.0, None, "frames: 0: expected"),
    (24, float("inf"), None, "angle: inf: expected 0..60 degrees"),
    (360, 15.0, (1000, 1000), "more than 268435456 pixels together"),
])
def test_a_turntable_is_bounded_before_any_frame(frames, angle, size, message):
    from inkray.errors import InputError
    from inkray.view.rendering import check_turntable

    with pytest.raises(InputError, match=message.replace("..", r"\.\.")):
        check_turntable(frames=frames, angle=angle, size=size)
