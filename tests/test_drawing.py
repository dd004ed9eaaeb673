import numpy as np
import pytest
from PIL import Image

from inkray.input.drawing import drawing_from_array, flatten_paper, load_drawing
from inkray.errors import InputError


def _ring(h=120, w=160):
    yy, xx = np.mgrid[:h, :w]
    r = np.hypot(xx - w / 2, yy - h / 2)
    return np.where(np.abs(r - 40) < 2, 0, 255).astype(np.uint8)


def test_png_grey_and_colour(tmp_path):
    ring = _ring()
    Image.fromarray(ring).save(tmp_path / "g.png")
    Image.fromarray(np.stack([ring] * 3, -1)).save(tmp_path / "c.png")
    g = load_drawing(tmp_path / "g.png")
    c = load_drawing(tmp_path / "c.png")
    assert g.size == (160, 120) and g.gray.dtype == np.float32
    np.testing.assert_allclose(g.gray, ring / 255.0, atol=1e-6)
    np.testing.assert_allclose(c.gray, g.gray, atol=1e-6)
    assert c.rgb.shape == (120, 160, 3)


def test_jpg(tmp_path):
    Image.fromarray(_ring()).convert("RGB").save(tmp_path / "d.jpg", quality=95)
    d = load_drawing(tmp_path / "d.jpg")
    ink = _ring() == 0
    assert d.gray[ink].mean() < 0.3 and d.gray[~ink].mean() > 0.95


def test_alpha_is_composited_on_white(tmp_path):
    rgba = np.zeros((20, 30, 4), np.uint8)  # fully transparent black
    rgba[5:8, 5:25] = [0, 0, 0, 255]  # an opaque black bar
    rgba[12, 5:25] = [0, 0, 0, 128]  # half-transparent: mid grey
    Image.fromarray(rgba, "RGBA").save(tmp_path / "a.png")
    d = load_drawing(tmp_path / "a.png")
    assert d.gray[0, 0] == pytest.approx(1.0)
    assert d.gray[6, 10] == pytest.approx(0.0)
    assert d.gray[12, 10] == pytest.approx(127 / 255, abs=0.01)


def test_palette_with_transparency(tmp_path):
    im = Image.new("P", (10, 10), 0)
    im.putpalette([0, 0, 0, 255, 255, 255])
    im.info["transparency"] = 0
    im.save(tmp_path / "p.png", transparency=0)
    assert load_drawing(tmp_path / "p.png").gray.min() == pytest.approx(1.0)


def test_svg_is_rasterized(tmp_path):
    svg = ('<svg xmlns="http://www.w3.org/2000/svg" width="100" height="80">'
           '<circle cx="50" cy="40" r="30" fill="none" stroke="black" stroke-width="4"/></svg>')
    (tmp_path / "c.svg").write_text(svg)
    d = load_drawing(tmp_path / "c.svg")
    assert d.size == (100, 80)
    assert d.gray[40, 20] < 0.2  # on the stroke (x = 50 - 30)
    assert d.gray[40, 50] == pytest.approx(1.0)  # inside, transparent -> white
    assert load_drawing(tmp_path / "c.svg", svg_width=200).size == (200, 160)


def test_bad_files(tmp_path):
    with pytest.raises(InputError, match="no such drawing file"):
        load_drawing(tmp_path / "none.png")
    (tmp_path / "x.png").write_bytes(b"not an image")
    with pytest.raises(InputError, match="not a readable image"):
        load_drawing(tmp_path / "x.png")
    (tmp_path / "x.gif2").write_bytes(b"GIF89a")
    with pytest.raises(InputError, match="unsupported drawing format"):
        load_drawing(tmp_path / "x.gif2")
    (tmp_path / "x.svg").write_text("<svg")
    with pytest.raises(InputError, match="cannot rasterize SVG"):
        load_drawing(tmp_path / "x.svg")


def test_uneven_paper_is_flattened():
    h, w = 300, 400
    yy, xx = np.mgrid[:h, :w]
    shading = 0.55 + 0.4 * xx / w + 0.05 * np.sin(yy / 40.0)  # a photo lit from the right
    ink = _ring(h, w) == 0
    photo = shading * np.where(ink, 0.15, 1.0)
    flat = flatten_paper(photo.astype(np.float32))
    paper = ~ink & (np.abs(np.hypot(xx - w / 2, yy - h / 2) - 40) > 6)
    assert np.percentile(flat[paper], 5) > 0.9  # paper is white everywhere
    assert flat[ink].mean() < 0.3  # ink stays dark
    assert np.ptp(photo[paper]) > 0.4  # the input really was uneven


def test_clean_drawing_is_unchanged_and_solid_fills_survive():
    a = np.full((200, 200), 255, np.uint8)
    a[90:110, 90:110] = 0  # a solid black eye
    d = drawing_from_array(a)
    np.testing.assert_array_equal(d.gray, a / 255.0)


def test_array_input_validation():
    with pytest.raises(InputError, match="expected an"):
        drawing_from_array(np.zeros((4, 4, 2)))
    d = drawing_from_array(np.ones((4, 5)), normalize=False)
    assert d.size == (5, 4) and d.rgb.dtype == np.uint8


def _png(width, height, chunks=()):
    """A PNG byte string with the given header size and extra chunks, no real pixel data."""
    import struct
    import zlib

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    body = b"".join(chunk(k, d) for k, d in chunks)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + body
            + chunk(b"IDAT", zlib.compress(b"\0" * 16)) + chunk(b"IEND", b""))


def test_size_is_checked_from_the_header_before_decoding(tmp_path):
    from inkray.input.limits import Limits

    (tmp_path / "large.png").write_bytes(_png(9000, 9000))
    with pytest.raises(InputError, match=r"large.png: 9000x9000 = 81000000 pixels exceeds "
                                         r"the limit of 16777216 \(raise it with limits.pixels\)"):
        load_drawing(tmp_path / "large.png")
    (tmp_path / "huge.png").write_bytes(_png(60000, 60000))
    with pytest.raises(InputError, match=r"huge.png: 3600000000 pixels exceeds the limit"):
        load_drawing(tmp_path / "huge.png")
    Image.fromarray(_ring()).save(tmp_path / "small.png")
    with pytest.raises(InputError, match="exceeds the limit of 1000"):
        load_drawing(tmp_path / "small.png", limits=Limits(pixels=1000))


def test_hostile_and_corrupt_images_are_input_errors(tmp_path):
    import zlib

    bomb = _png(8, 8, [(b"zTXt", b"comment\0\0" + zlib.compress(b"x" * (8 << 20)))])
    (tmp_path / "text.png").write_bytes(bomb)
    Image.fromarray(_ring()).save(tmp_path / "ok.png")
    data = (tmp_path / "ok.png").read_bytes()
    (tmp_path / "truncated.png").write_bytes(data[: len(data) // 2])
    (tmp_path / "garbage.tiff").write_bytes(b"II*\0" + b"\xff" * 64)
    for name in ("text.png", "truncated.png", "garbage.tiff"):
        with pytest.raises(InputError, match=rf"{name}: not a readable image \(\w+: .+\)"):
            load_drawing(tmp_path / name)


def test_special_files_are_refused_by_kind(tmp_path):
    import os

    os.mkfifo(tmp_path / "pipe.png")
    (tmp_path / "dir.png").mkdir()
    for path, kind in ((tmp_path / "pipe.png", "a FIFO"), (tmp_path / "dir.png", "a directory"),
                       ("/dev/zero", "a device")):
        with pytest.raises(InputError, match=f"not a regular file \\({kind}\\); expected a drawing"):
            load_drawing(path)
    with pytest.raises(InputError, match="cannot open the drawing file"):
        load_drawing(tmp_path / ("x" * 300 + ".png"))


def test_svg_size_is_checked_before_rasterizing(tmp_path):
    svg = ('<svg xmlns="http://www.w3.org/2000/svg" width="20000" height="20000">'
           '<circle cx="50" cy="50" r="40" fill="none" stroke="black"/></svg>')
    (tmp_path / "big.svg").write_text(svg)
    with pytest.raises(InputError, match="big.svg: 20000x20000 = 400000000 pixels exceeds"):
        load_drawing(tmp_path / "big.svg")
    (tmp_path / "mm.svg").write_text(svg.replace('width="20000" height="20000"',
                                                 'width="2000mm" height="10mm"'))
    with pytest.raises(InputError, match="mm.svg: 7560x38 = "):
        from inkray.input.limits import Limits

        load_drawing(tmp_path / "mm.svg", limits=Limits(pixels=1000))
    (tmp_path / "box.svg").write_text(svg.replace('width="20000" height="20000"',
                                                  'viewBox="0 0 100 60"'))
    assert load_drawing(tmp_path / "box.svg").size == (100, 60)
    (tmp_path / "bad.svg").write_text("<html></html>")
    with pytest.raises(InputError, match="root element is not <svg>"):
        load_drawing(tmp_path / "bad.svg")


def test_float_tiff_in_unit_range_is_not_all_ink(tmp_path):
    ring = _ring().astype(np.float32) / 255.0
    Image.fromarray(ring, mode="F").save(tmp_path / "f.tiff")
    d = load_drawing(tmp_path / "f.tiff")
    np.testing.assert_allclose(d.gray, ring, atol=1 / 255)
