"""Seeded generators of hostile input: annotation files, drawings and meshes.

Used by tests/test_fuzz_input.py (a small sample in every run) and by
benchmarks/fuzz.py (the long run with counts, subprocesses, memory and kills).
Every generator is a function ``(rng, folder, base) -> path`` that writes one
file into ``folder``; ``base`` is a valid file to start from.
"""

import io
import json
import struct
import zlib

import numpy as np
from PIL import Image

# -- annotation files --------------------------------------------------------


def _doc_text(base):
    return base.read_text("utf-8")


def _set_random_subtree(rng, doc):
    """Replace one randomly chosen node of the document with a hostile value."""
    values = [None, True, -1, 0, 10 ** 400, 1e308, -1e308, "", "x" * 300, "head\n", "\x1b[31m",
              [], {}, [[]], [[1e9, 1e9]], [[float("nan"), 0]], [["1", "2"]], [[-5, -5]],
              [[0, 0]] * 30000, {"format": None}]
    path, node = [], doc
    while isinstance(node, (dict, list)) and node and rng.random() < 0.8:
        keys = list(node) if isinstance(node, dict) else list(range(len(node)))
        key = keys[rng.integers(len(keys))]
        path.append(key)
        node = node[key]
    value = values[rng.integers(len(values))]
    if not path:
        return value
    parent = doc
    for key in path[:-1]:
        parent = parent[key]
    parent[path[-1]] = value
    return doc


def hostile_annotation(rng, folder, base, index):
    """One malformed annotation file next to a copy of the base drawing."""
    text = _doc_text(base)
    kind = rng.integers(9)
    if kind == 0:  # truncated
        text = text[: rng.integers(len(text))]
    elif kind == 1:  # a random byte changed
        i = rng.integers(len(text))
        text = text[:i] + chr(rng.integers(32, 127)) + text[i + 1:]
    elif kind == 2:  # deep nesting inside a comment
        depth = int(rng.choice([100, 1000, 100000]))
        text = text.replace("{", '{"_comment": ' + "[" * depth + "]" * depth + ", ", 1)
    elif kind == 3:  # a duplicate key
        text = text.replace('"version": 1', '"version": 1, "version": 1', 1)
    elif kind == 4:  # NaN / Infinity / huge integers
        token = ["NaN", "Infinity", "-Infinity", "1" * 500, "1" * 5000, "1e999"][rng.integers(6)]
        text = text.replace('"version": 1', f'"version": {token}', 1)
    elif kind == 5:  # bytes that are not UTF-8, a BOM, NUL
        data = text.encode()
        data = [b"\xef\xbb\xbf" + data, data[:20] + b"\xff\xfe" + data[20:], data.replace(
            b"{", b"{\x00", 1)][rng.integers(3)]
        path = folder / f"a{index}.inkray.json"
        path.write_bytes(data)
        return path
    else:  # a subtree replaced
        doc = _set_random_subtree(rng, json.loads(text))
        text = json.dumps(doc, allow_nan=True)
    path = folder / f"a{index}.inkray.json"
    path.write_text(text, "utf-8")
    return path


# -- drawings ----------------------------------------------------------------


def _png_chunks(width, height, chunks, mode=(8, 0)):
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    header = struct.pack(">IIBBBBB", width, height, mode[0], mode[1], 0, 0, 0)
    body = b"".join(chunk(k, d) for k, d in chunks)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + body
            + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b""))


def hostile_image(rng, folder, base, index):
    """One hostile drawing file (its suffix picks the reader)."""
    data = base.read_bytes()
    kind = rng.integers(10)
    name, payload = f"d{index}.png", None
    if kind == 0:
        payload = data[: rng.integers(8, len(data))]
    elif kind == 1:
        b = bytearray(data)
        for i in rng.integers(8, len(b), 20):
            b[i] = rng.integers(256)
        payload = bytes(b)
    elif kind == 2:
        side = int(rng.choice([5000, 20000, 60000, 2 ** 31 - 1]))
        payload = _png_chunks(side, side, [])
    elif kind == 3:
        payload = _png_chunks(8, 8, [(b"zTXt", b"c\0\0" + zlib.compress(b"x" * (4 << 20)))])
    elif kind == 4:
        payload = _png_chunks(8, 8, [(b"iCCP", b"p\0\0" + zlib.compress(b"x" * (4 << 20)))])
    elif kind == 5:
        name = f"d{index}.svg"
        side = ["20000", "1e9", "-5", "nan", "100%", "abc"][rng.integers(6)]
        payload = (f'<svg xmlns="http://www.w3.org/2000/svg" width="{side}" height="{side}">'
                   f'<circle cx="5" cy="5" r="4" stroke="black"/></svg>').encode()
    elif kind == 6:
        name = f"d{index}.svg"
        payload = [b"<svg", b"<!DOCTYPE x [<!ENTITY a 'aaaa'><!ENTITY b '&a;&a;&a;&a;'>]><svg "
                   b"xmlns='http://www.w3.org/2000/svg' width='10' height='10'><text>&b;</text></svg>",
                   b"<svg xmlns='http://www.w3.org/2000/svg' width='10' height='10'><image "
                   b"href='/etc/passwd' width='5' height='5'/></svg>", b""][rng.integers(4)]
    elif kind == 7:
        name = f"d{index}.tiff"
        buf = io.BytesIO()
        Image.fromarray(rng.random((16, 16)).astype(np.float32) * float(rng.choice([1, 1e6, -1])),
                        mode="F").save(buf, format="TIFF")
        payload = buf.getvalue()
    elif kind == 8:
        name = f"d{index}.gif"
        frames = [Image.fromarray(rng.integers(0, 255, (12, 12), dtype=np.uint8)) for _ in range(3)]
        buf = io.BytesIO()
        frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:])
        payload = buf.getvalue()
    else:
        name = f"d{index}.{['jpg', 'bmp', 'webp', 'png'][rng.integers(4)]}"
        payload = rng.integers(0, 256, int(rng.integers(0, 200)), dtype=np.uint8).tobytes()
    path = folder / name
    path.write_bytes(payload)
    return path


# -- meshes ------------------------------------------------------------------


def hostile_mesh(rng, folder, bases, index):
    """One hostile mesh: a valid GLB, OBJ or PLY with bytes changed, cut or lines replaced."""
    base = bases[rng.integers(len(bases))]
    data = base.read_bytes()
    kind = rng.integers(5)
    if kind == 0:
        data = data[: rng.integers(1, len(data))]
    elif kind == 1:
        b = bytearray(data)
        for i in rng.integers(0, len(b), int(rng.integers(1, 30))):
            b[i] = rng.integers(256)
        data = bytes(b)
    elif kind == 2 and base.suffix != ".glb":
        lines = data.split(b"\n")
        i = int(rng.integers(len(lines)))
        lines[i] = [b"f 0 1 2", b"f 1 2 999999", b"v nan 0 0", b"f -99999 1 2", b"3 0 1 -7",
                    b"element vertex 99999999999", b"mtllib /dev/zero", b"f " + b"1 " * 5000,
                    b"v 1e999 0 0"][rng.integers(9)]
        data = b"\n".join(lines)
    elif kind == 3 and base.suffix == ".glb":
        b = bytearray(data)
        struct.pack_into("<I", b, int(rng.choice([4, 8, 12])), int(rng.integers(0, 2 ** 32)))
        data = bytes(b)
    path = folder / f"m{index}{base.suffix}"
    path.write_bytes(data)
    if base.suffix == ".obj":  # keep its material library and texture beside it
        for extra in base.parent.glob(base.stem + "*"):
            if extra.suffix in (".mtl", ".png") and not (folder / extra.name).exists():
                (folder / extra.name).write_bytes(extra.read_bytes())
    return path
