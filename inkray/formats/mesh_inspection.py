"""Checking a mesh file before a parser reads it.

Parsers (trimesh's among them) trust their input: a GLB header that claims a
gigabyte, a PLY that declares four billion vertices, an OBJ polygon of
100,000 corners, an index of 0 or one past the end, a material library that
is a FIFO, each ends in an exception deep inside the parser, a hang or
gigabytes of memory. :func:`inspect_mesh_file` reads the file's structure
first, in time and memory proportional to the file, and turns every such
problem into a one-line :class:`~inkray.errors.InputError` that says what and
where (byte offset, line, element).
"""

import json
import re
import struct
from pathlib import Path

from inkray.errors import InputError
from inkray.input.files import regular_file
from inkray.input.limits import DEFAULT_LIMITS

__all__ = ["inspect_mesh_file", "MAX_FACE_CORNERS"]

#: Most corners of one OBJ polygon: triangulating more is a fan of slivers.
MAX_FACE_CORNERS = 1024

_PLY_SIZES = {"char": 1, "int8": 1, "uchar": 1, "uint8": 1, "short": 2, "int16": 2,
              "ushort": 2, "uint16": 2, "int": 4, "int32": 4, "uint": 4, "uint32": 4,
              "float": 4, "float32": 4, "double": 8, "float64": 8}


def inspect_mesh_file(path, *, limits=DEFAULT_LIMITS):
    """Check a GLB/glTF, OBJ or PLY file's structure before it is parsed.

    Parameters
    ----------
    path : str or pathlib.Path
    limits : inkray.input.limits.Limits, optional
        ``mesh_bytes`` bounds the file (and the files it refers to).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    InputError
        Not a regular file, too large, or a structure no parser should be
        given: a GLB header or chunk that disagrees with the file, a PLY
        header that declares more than the file holds, an OBJ index of 0 or
        outside the vertices, a polygon of more than :data:`MAX_FACE_CORNERS`
        corners, text that is not UTF-8, or a referenced file (material
        library, texture, buffer) that is not a regular file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "t.obj"
    >>> _ = p.write_text("v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nf 1 2 0\\n")
    >>> inspect_mesh_file(p)
    Traceback (most recent call last):
    ...
    inkray.errors.InputError: ...t.obj: line 4: face index 0 (OBJ counts from 1)
    """
    path, size = regular_file(path, "mesh file")
    if size > limits.mesh_bytes:
        raise InputError(f"{path}: {size} bytes exceeds the limit of {limits.mesh_bytes} for a "
                         f"mesh file")
    suffix = path.suffix.lower()
    with open(path, "rb") as fh:
        data = fh.read(limits.mesh_bytes + 1)
    if suffix == ".glb":
        _inspect_glb(path, data)
    elif suffix == ".gltf":
        _inspect_gltf(path, data, limits)
    elif suffix == ".obj":
        _inspect_obj(path, data, limits)
    elif suffix == ".ply":
        _inspect_ply(path, data)
    return path


def _inspect_glb(path, data):
    name = str(path)
    if len(data) < 20 or data[:4] != b"glTF":
        raise InputError(f"{name}: not a GLB file (no 'glTF' magic and header)")
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise InputError(f"{name}: GLB version {version}; only glTF 2.0 is supported")
    if length != len(data):
        raise InputError(f"{name}: the GLB header gives {length} bytes but the file has "
                         f"{len(data)} (truncated or padded)")
    offset, chunks = 12, []
    while offset < length:
        if offset + 8 > length:
            raise InputError(f"{name}: byte {offset}: a chunk header runs past the end")
        size, kind = struct.unpack_from("<II", data, offset)
        if offset + 8 + size > length:
            raise InputError(f"{name}: byte {offset}: a chunk of {size} bytes runs past the "
                             f"end of the file")
        chunks.append((kind, offset + 8, size))
        offset += 8 + size
    if not chunks or chunks[0][0] != 0x4E4F534A:  # "JSON"
        raise InputError(f"{name}: the first GLB chunk is not JSON")
    _, start, size = chunks[0]
    _json(name, data[start:start + size])


def _json(name, raw):
    try:
        return json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as e:
        raise InputError(f"{name}: the glTF JSON is malformed ({' '.join(str(e).split())[:200]})"
                         ) from None


def _inspect_gltf(path, data, limits):
    doc = _json(str(path), data)
    refs = []
    for key in ("buffers", "images"):
        items = doc.get(key, []) if isinstance(doc, dict) else []
        for i, item in enumerate(items if isinstance(items, list) else []):
            uri = item.get("uri") if isinstance(item, dict) else None
            if isinstance(uri, str) and not uri.startswith("data:"):
                refs.append((f"{key}[{i}].uri", uri))
    _check_references(path, refs, limits)


def _check_references(path, refs, limits):
    for where, ref in refs:
        target = Path(path).parent / ref
        if not target.exists():
            continue  # a missing texture or library is the parser's to report
        _, size = regular_file(target, f"file referenced by {Path(path).name} {where}")
        if size > limits.mesh_bytes:
            raise InputError(f"{target}: {size} bytes exceeds the limit of {limits.mesh_bytes}")


def _text(path, data):
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise InputError(f"{path}: line {line}: not UTF-8 text (byte {e.start})"
                         ) from None


# A texture statement: options first, the file name last.
_MAP = re.compile(r"^\s*(?:map_\w+|bump|disp|decal|refl|norm)\s+.*?(\S+)\s*$")


def _inspect_obj(path, data, limits):
    name = str(path)
    text = _text(path, data)
    vertices = 0
    high = (0, 0)  # the largest positive vertex index and its line
    refs = []
    for number, line in enumerate(text.splitlines(), 1):
        head = line[:7]
        if head.startswith("v "):
            vertices += 1
        elif head.startswith("f ") or head.startswith("l "):
            corners = line.split()[1:]
            if len(corners) > MAX_FACE_CORNERS:
                raise InputError(f"{name}: line {number}: a polygon of {len(corners)} corners "
                                 f"(at most {MAX_FACE_CORNERS})")
            for corner in corners:
                token = corner.split("/", 1)[0]
                try:
                    i = int(token)
                except ValueError:
                    raise InputError(f"{name}: line {number}: {token[:40]!r} is not a vertex "
                                     f"index") from None
                if i == 0:
                    raise InputError(f"{name}: line {number}: face index 0 (OBJ counts from 1)")
                if i < 0 and -i > vertices:
                    raise InputError(f"{name}: line {number}: relative index {i} reaches before "
                                     f"the first vertex ({vertices} so far)")
                if i > high[0]:
                    high = (i, number)
        elif head.startswith("mtllib"):
            refs += [("mtllib", ref) for ref in line.split()[1:]]
    if high[0] > vertices:
        raise InputError(f"{name}: line {high[1]}: face index {high[0]} but the file has "
                         f"{vertices} vertices")
    _check_references(path, refs, limits)
    for _, ref in refs:
        library = Path(path).parent / ref
        if library.exists():
            mtl = _text(library, library.read_bytes())
            maps = [(f"{ref} map", m.group(1)) for m in map(_MAP.match, mtl.splitlines()) if m]
            _check_references(library, maps, limits)


def _inspect_ply(path, data):
    name = str(path)
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise InputError(f"{name}: not a PLY file (no 'ply' magic or no end_header)")
    header = data[:end].decode("ascii", "replace").splitlines()
    body = len(data) - (data.index(b"\n", end) + 1 if b"\n" in data[end:] else len(data))
    binary = any(line.split()[:2] in (["format", "binary_little_endian"],
                                      ["format", "binary_big_endian"]) for line in header)
    need = 0
    element = None
    for number, line in enumerate(header, 1):
        words = line.split()
        if words[:1] == ["element"]:
            if len(words) != 3 or not words[2].isdigit():
                raise InputError(f"{name}: header line {number}: malformed element {line!r}")
            element = [words[1], int(words[2]), 0]
            need += element[2]
        elif words[:1] == ["property"] and element is not None:
            if words[1:2] == ["list"]:
                size = _PLY_SIZES.get(words[2] if len(words) > 2 else "", 0)
            else:
                size = _PLY_SIZES.get(words[1] if len(words) > 1 else "", 0)
            if not size:
                raise InputError(f"{name}: header line {number}: unknown property type in "
                                 f"{line!r}")
            per_row = size if binary else 2  # ascii: at least a digit and a separator
            if binary or element[2] == 0:
                need += element[1] * per_row
                element[2] = 1
            if need > body:
                raise InputError(f"{name}: the header declares {element[1]} {element[0]} "
                                 f"elements, more than the {body} bytes after it can hold")
