"""The annotation file format, version 1 (``<name>.inkray.json``).

Reads and validates the input contract of ``shared/ANNOTATIONS.md``: region
scribbles, background scribbles, depth (in)equalities in the sense of
Sýkora et al., "Adding Depth to Cartoons Using Sparse Depth (In)equalities"
(CGF 2010) and boundary conditions of Sýkora et al., "Ink-and-Ray" (TOG 2014).
Every rule violation raises :class:`~inkray.errors.InputError` whose message
starts with the key path, e.g.
``regions[2].scribbles[0][3]: point (1302, 40) lies outside the 1180x1236 drawing``.

Keys beginning with ``_`` are comments and ignored anywhere; any other key the
format does not define is an error (a misspelt ``boundries`` must not be
silently dropped).
"""

import json
import math
import numbers
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from inkray.errors import InputError
from inkray.input.files import read_bytes
from inkray.input.limits import DEFAULT_LIMITS

__all__ = [
    "Annotations", "Region", "Order", "Equal", "Boundary",
    "load_annotations", "decode_annotations", "parse_annotations", "rescale_annotations",
    "PROFILES", "BOUNDARY_TYPES",
]

FORMAT = "inkray-annotations"
VERSION = 1
PROFILES = ("sqrt", "linear", "flat")
BOUNDARY_TYPES = ("stitch", "graft", "flat")
DEFAULT_INFLATION = 2.0
#: Largest ``inflation``: c = 4 gives a hemisphere, 1000 a part ~16 times as tall
#: as it is wide; beyond, heights stop being a relief (and soon a float).
MAX_INFLATION = 1000.0
_NAME = re.compile(r"[A-Za-z0-9_-]+")  # matched whole (fullmatch): no trailing newline
_TOP_KEYS = ("format", "version", "drawing", "size", "regions", "background",
             "order", "equal", "boundaries")
_REGION_KEYS = ("name", "scribbles", "inflation", "profile")


@dataclass
class Region:
    """A part of the character.

    Attributes
    ----------
    name : str
        Unique name (letters, digits, ``_``, ``-``).
    scribbles : list of (k, 2) float arrays
        Polylines in drawing pixels, ``[x, y]`` rows; one point is a dot.
    inflation : float
        The constant ``c`` of ``-lap f = c``.
    profile : str
        Cross-section function: ``"sqrt"``, ``"linear"`` or ``"flat"``.
    pixels : (n, 2) int array or None
        Extra seed pixels ``[x, y]`` (from a scribble PNG layer).
    """

    name: str
    scribbles: list
    inflation: float = DEFAULT_INFLATION
    profile: str = "sqrt"
    pixels: np.ndarray = None


@dataclass
class Order:
    """``front`` is nearer the viewer than ``back``; ``index`` is its place in ``order``."""

    front: tuple
    back: tuple
    index: int


@dataclass
class Equal:
    """``a`` and ``b`` have the same depth; ``index`` is its place in ``equal``."""

    a: tuple
    b: tuple
    index: int


@dataclass
class Boundary:
    """A boundary condition along a polyline ``path`` near a region outline."""

    type: str
    path: np.ndarray
    index: int


@dataclass
class Annotations:
    """A validated annotation file.

    Attributes
    ----------
    size : tuple of int
        ``(width, height)`` of the drawing the coordinates refer to.
    regions, background, order, equal, boundaries
        As in the format; ``background`` is a list of (k, 2) float arrays.
    drawing : pathlib.Path or None
        The drawing, resolved relative to the annotation file.
    source : pathlib.Path or None
        The annotation file itself.
    background_pixels : (n, 2) int array or None
        Extra background seed pixels ``[x, y]`` (from a scribble PNG layer).
    """

    size: tuple
    regions: list = field(default_factory=list)
    background: list = field(default_factory=list)
    order: list = field(default_factory=list)
    equal: list = field(default_factory=list)
    boundaries: list = field(default_factory=list)
    drawing: Path = None
    source: Path = None
    background_pixels: np.ndarray = None

    @property
    def width(self):
        return self.size[0]

    @property
    def height(self):
        return self.size[1]

    def region_index(self, name):
        """Index of the region called ``name`` (``KeyError`` when absent)."""
        for i, r in enumerate(self.regions):
            if r.name == name:
                return i
        raise KeyError(name)


def load_annotations(path, *, limits=DEFAULT_LIMITS):
    """Read and validate an annotation file.

    Parameters
    ----------
    path : str or pathlib.Path
        The ``.inkray.json`` file.
    limits : inkray.input.limits.Limits, optional
        Bounds on the file's size, nesting, points and entries.

    Returns
    -------
    Annotations
        With ``drawing`` resolved relative to the file's folder.

    Raises
    ------
    InputError
        When the file is missing or not a regular file, is too large, is not
        UTF-8 JSON, or breaks a rule of the format; the message names the key
        path.

    Examples
    --------
    >>> ann = load_annotations("examples/turtle/drawing.inkray.json")  # doctest: +SKIP
    >>> [r.name for r in ann.regions]  # doctest: +SKIP
    ['head', 'leg_front', 'shell', 'foot_hind']
    """
    path = Path(path)
    raw = read_bytes(path, "annotation file", limit=limits.file_bytes)
    ann = parse_annotations(decode_annotations(raw, where=str(path), limits=limits),
                            limits=limits)
    ann.source = path
    if ann.drawing is not None:
        ann.drawing = (path.parent / ann.drawing)
    return ann


def decode_annotations(raw, *, where="annotations", limits=DEFAULT_LIMITS):
    """Decode the JSON text of an annotation file, refusing what JSON leaves open.

    Duplicate keys, ``NaN``/``Infinity``, integers of more than 30 digits and
    nesting deeper than ``limits.depth`` are errors that name the key path and
    the line and column.

    Parameters
    ----------
    raw : bytes or str
    where : str, default "annotations"
        Names the document in messages (its path).
    limits : inkray.input.limits.Limits, optional

    Returns
    -------
    object
        The decoded document (for :func:`parse_annotations`).

    Raises
    ------
    InputError

    Examples
    --------
    >>> decode_annotations(b'{"order": [{"front": [1, 2], "front": [3, 4]}]}')
    Traceback (most recent call last):
    ...
    inkray.errors.InputError: annotations: order[0].front: duplicate key (line 1, column 30)
    """
    if isinstance(raw, bytes):
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError as e:
            raise InputError(f"{where}: not UTF-8 text (byte {e.start})") from None
    else:
        text = raw
    problem = _json_problem(text, limits.depth, limits.values)
    if problem:
        raise InputError(f"{where}: {problem}")
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        raise InputError(f"{where}: not valid JSON: {e.msg} (line {e.lineno}, column {e.colno})") from None
    except (RecursionError, ValueError) as e:  # the scan above should have caught these
        raise InputError(f"{where}: not valid JSON ({type(e).__name__})") from None


_JSON_TOKEN = re.compile(r'[{}\[\]:,"]|[^\s{}\[\]:,"]+')
_MAX_DIGITS = 30


def _json_tokens(text):
    """``(start, end)`` of every token: brackets, colons, commas, whole strings, other runs.

    Linear in time and memory: a string is skipped to its closing quote with
    ``str.find`` (a regular expression with an alternation inside a repeat
    keeps a backtracking mark per character: gigabytes for a long string).
    An unterminated string ends the scan; the JSON parser says where.
    """
    pos = 0
    while True:
        for m in _JSON_TOKEN.finditer(text, pos):
            start = m.start()
            if text[start] != '"':
                yield start, m.end()
                continue
            pos = _string_end(text, start)
            if pos < 0:
                return
            yield start, pos
            break
        else:
            return


def _string_end(text, start):
    """The index after the string opened at ``start``, or -1 when it is not closed."""
    j = start + 1
    while True:
        q = text.find('"', j)
        if q < 0:
            return -1
        run = text[j:q]
        j = q + 1
        if (len(run) - len(run.rstrip("\\"))) % 2 == 0:  # an even run escapes only itself
            return j


def _json_problem(text, depth, values=None):
    """The first duplicate key, non-JSON constant, huge integer, too deep nesting or too many
    values, or None.

    An iterative scan that keeps the key path, so any depth is safe; other
    syntax errors are left to the JSON parser. ``values`` bounds the number
    of JSON values (each costs the parser tens of bytes whatever its size in
    the file); keys count as values.
    """
    stack = []  # [kind, keys seen or index, key]

    def path(extra=None):
        out = ""
        for frame in stack:
            if frame[0] == "[":
                out += f"[{frame[1]}]"
            elif frame[2] is not None:
                out += ("." if out else "") + frame[2]
        if extra is not None:
            out += ("." if out else "") + extra
        return (out if len(out) <= 80 else out[:40] + "..." + out[-30:]) or "(top level)"

    def at(start):
        line = text.count("\n", 0, start) + 1
        column = start - (text.rfind("\n", 0, start) + 1) + 1
        return f"(line {line}, column {column})"

    expect_key = False
    count = 0
    for start, end in _json_tokens(text):
        first = text[start]
        if first in "{[":
            if len(stack) >= depth:
                return f"{path()}: nested deeper than {depth} levels {at(start)}"
            stack.append(["{", set(), None] if first == "{" else ["[", 0, None])
            expect_key = first == "{"
        elif first in "}]":
            if stack:
                stack.pop()
            expect_key = False
            continue
        elif first == ",":
            if stack and stack[-1][0] == "[":
                stack[-1][1] += 1
            expect_key = bool(stack) and stack[-1][0] == "{"
            continue
        elif first == ":":
            expect_key = False
            continue
        elif first == '"':
            if expect_key and stack:
                try:
                    key = json.loads(text[start:end])
                except ValueError:
                    return None  # a broken string: the parser says where
                if key in stack[-1][1]:
                    stack[-1][2] = None
                    return f"{path(key)}: duplicate key {at(start)}"
                stack[-1][1].add(key)
                stack[-1][2] = key
        else:
            tok = text[start:end]
            if tok in ("NaN", "Infinity", "-Infinity"):
                return f"{path()}: {tok} is not valid JSON {at(start)}"
            if tok.lstrip("-").isdigit() and len(tok.lstrip("-")) > _MAX_DIGITS:
                return (f"{path()}: an integer of {len(tok.lstrip('-'))} digits (at most "
                        f"{_MAX_DIGITS}) {at(start)}")
        count += 1
        if values is not None and count > values:
            return (f"{path()}: more than {values} JSON values and keys {at(start)}; too many "
                    f"for an annotation file")
    return None


def parse_annotations(data, *, limits=DEFAULT_LIMITS):
    """Validate a decoded annotation document and return typed objects.

    Parameters
    ----------
    data : object
        The result of ``json.load`` on an annotation file (see
        :func:`decode_annotations`).
    limits : inkray.input.limits.Limits, optional
        Bounds on points and entries.

    Returns
    -------
    Annotations
        ``drawing`` is the raw relative path (a ``Path``) or None.

    Raises
    ------
    InputError
        Naming the key path and the problem.

    Examples
    --------
    >>> ann = parse_annotations({"format": "inkray-annotations", "version": 1,
    ...                          "size": [10, 10], "order": [{"front": [1, 1], "back": [5, 5]}]})
    >>> ann.order[0].front
    (1.0, 1.0)
    """
    _expect(isinstance(data, dict), "(top level)", f"expected an object, got {_kind(data)}")
    _check_keys(data, _TOP_KEYS, "")
    budget = _Budget(limits)
    for key in ("format", "version", "size"):
        if key not in data:
            raise InputError(f"{key}: missing required key")
    _expect(data["format"] == FORMAT and isinstance(data["format"], str), "format",
            f"expected \"{FORMAT}\", got {_show(data['format'])}")
    version = data["version"]
    _expect(_is_int(version), "version", f"expected the integer 1, got {_show(version)}")
    _expect(version == VERSION, "version", f"unsupported version {version} (this inkray reads version 1)")

    drawing = data.get("drawing")
    if drawing is not None:
        _expect(isinstance(drawing, str) and drawing.strip() != "", "drawing",
                f"expected a non-empty path string, got {_show(drawing)}")
        _expect("\x00" not in drawing and _encodable(drawing), "drawing",
                f"{_show(drawing)} is not a file name (a NUL character or a lone surrogate)")
        drawing = Path(drawing)

    size = data["size"]
    _expect(isinstance(size, list) and len(size) == 2, "size",
            f"expected [width, height], got {_show(size)}")
    for i, s in enumerate(size):
        _expect(_is_int(s) and s > 0, f"size[{i}]", f"expected a positive integer, got {_show(s)}")
    size = (int(size[0]), int(size[1]))

    regions = []
    names = {}
    raw_regions = _list(data, "regions", "regions", budget)
    for i, r in enumerate(raw_regions):
        where = f"regions[{i}]"
        _expect(isinstance(r, dict), where, f"expected an object, got {_kind(r)}")
        _check_keys(r, _REGION_KEYS, where)
        for key in ("name", "scribbles"):
            if key not in r:
                raise InputError(f"{where}.{key}: missing required key")
        name = r["name"]
        _expect(isinstance(name, str), f"{where}.name", f"expected a string, got {_kind(name)}")
        _expect(bool(_NAME.fullmatch(name)), f"{where}.name",
                f"{name!r} may only contain letters, digits, '_' and '-'")
        _expect(name not in names, f"{where}.name",
                f"duplicate region name {name!r} (first used by regions[{names.get(name)}])")
        names[name] = i
        scribbles = r["scribbles"]
        _expect(isinstance(scribbles, list), f"{where}.scribbles",
                f"expected a list of polylines, got {_kind(scribbles)}")
        _expect(len(scribbles) > 0, f"{where}.scribbles", "a region needs at least one scribble")
        budget.entries(scribbles, f"{where}.scribbles")
        polylines = [_polyline(s, f"{where}.scribbles[{j}]", size, budget)
                     for j, s in enumerate(scribbles)]
        inflation = r.get("inflation", DEFAULT_INFLATION)
        _expect(_is_number(inflation) and _finite(inflation) and 0 < inflation <= MAX_INFLATION,
                f"{where}.inflation", f"expected a positive number at most {MAX_INFLATION:g}, "
                                      f"got {_show(inflation)}")
        profile = r.get("profile", "sqrt")
        _expect(isinstance(profile, str) and profile in PROFILES, f"{where}.profile",
                f"unknown profile {_show(profile)} (expected one of {', '.join(PROFILES)})")
        regions.append(Region(name=name, scribbles=polylines, inflation=float(inflation),
                              profile=profile))

    background = [_polyline(s, f"background[{j}]", size, budget)
                  for j, s in enumerate(_list(data, "background", "background", budget))]

    order = []
    for i, o in enumerate(_list(data, "order", "order", budget)):
        where = f"order[{i}]"
        pts = _pair(o, where, ("front", "back"), size)
        _expect(pts[0] != pts[1], where,
                f"front and back are the same point {_fmt_point(pts[0])}: it cannot be in front of itself")
        order.append(Order(front=pts[0], back=pts[1], index=i))

    equal = []
    for i, e in enumerate(_list(data, "equal", "equal", budget)):
        pts = _pair(e, f"equal[{i}]", ("a", "b"), size)
        equal.append(Equal(a=pts[0], b=pts[1], index=i))

    boundaries = []
    for i, b in enumerate(_list(data, "boundaries", "boundaries", budget)):
        where = f"boundaries[{i}]"
        _expect(isinstance(b, dict), where, f"expected an object, got {_kind(b)}")
        _check_keys(b, ("type", "path"), where)
        for key in ("type", "path"):
            if key not in b:
                raise InputError(f"{where}.{key}: missing required key")
        _expect(isinstance(b["type"], str) and b["type"] in BOUNDARY_TYPES, f"{where}.type",
                f"unknown boundary type {_show(b['type'])} (expected one of {', '.join(BOUNDARY_TYPES)})")
        path = _polyline(b["path"], f"{where}.path", size, budget)
        _expect(len(path) >= 2, f"{where}.path", "a boundary path needs at least 2 points")
        boundaries.append(Boundary(type=b["type"], path=path, index=i))

    return Annotations(size=size, regions=regions, background=background, order=order,
                       equal=equal, boundaries=boundaries, drawing=drawing)


def rescale_annotations(ann, size):
    """Scale every coordinate of ``ann`` to a drawing of another ``size``.

    Parameters
    ----------
    ann : Annotations
    size : (int, int)
        The new ``(width, height)``.

    Returns
    -------
    Annotations
        A copy; a point ``p`` maps to ``(p + 0.5) * new / old - 0.5`` so pixel
        centres stay pixel centres.
    """
    sx = size[0] / ann.size[0]
    sy = size[1] / ann.size[1]
    scale = np.array([sx, sy])

    def arr(p):
        q = (np.asarray(p, float) + 0.5) * scale - 0.5
        return np.clip(q, 0, np.array(size, float) - 1)

    def pt(p):
        return tuple(float(v) for v in arr(p))

    def pix(p):
        if p is None:
            return None
        return np.clip(np.round(arr(p)).astype(np.int64), 0, np.array(size) - 1)

    regions = [replace(r, scribbles=[arr(s) for s in r.scribbles], pixels=pix(r.pixels))
               for r in ann.regions]
    return replace(
        ann, size=(int(size[0]), int(size[1])), regions=regions,
        background=[arr(s) for s in ann.background],
        order=[replace(o, front=pt(o.front), back=pt(o.back)) for o in ann.order],
        equal=[replace(e, a=pt(e.a), b=pt(e.b)) for e in ann.equal],
        boundaries=[replace(b, path=arr(b.path)) for b in ann.boundaries],
        background_pixels=pix(ann.background_pixels),
    )


# -- validation helpers ------------------------------------------------------

def _encodable(text):
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _expect(ok, where, message):
    if not ok:
        raise InputError(f"{where}: {message}")


def _is_int(v):
    return isinstance(v, numbers.Integral) and not isinstance(v, (bool, np.bool_))


def _is_number(v):
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


def _finite(v):
    try:
        return math.isfinite(v)
    except OverflowError:  # an integer too large for a float
        return False


def _kind(v):
    return {dict: "an object", list: "a list", str: "a string", bool: "a boolean",
            int: "a number", float: "a number", type(None): "null"}.get(type(v), type(v).__name__)


def _show(v):
    try:
        s = json.dumps(v, ensure_ascii=False, default=str)
    except (RecursionError, ValueError, TypeError):
        return _kind(v)
    s = s if len(s) <= 40 else s[:37] + "..."
    return s.encode("unicode_escape").decode("ascii") if not s.isprintable() else s


def _fmt_point(p):
    return "(" + ", ".join(f"{v:g}" for v in p) + ")"


def _check_keys(obj, allowed, where):
    for k in obj:
        if k.startswith("_") or k in allowed:
            continue
        prefix = f"{where}.{k}" if where else k
        raise InputError(f"{prefix}: unknown key (expected one of {', '.join(allowed)})")


def _list(data, key, where, budget):
    v = data.get(key, [])
    _expect(isinstance(v, list), where, f"expected a list, got {_kind(v)}")
    budget.entries(v, where)
    return v


class _Budget:
    """Counts points and entries against the limits while a document is parsed."""

    def __init__(self, limits):
        self.limits = limits
        self.points = 0

    def entries(self, items, where):
        if len(items) > self.limits.entries:
            raise InputError(f"{where}: {len(items)} entries exceeds the limit of "
                             f"{self.limits.entries}")

    def polyline(self, n, where):
        if n > self.limits.points:
            raise InputError(f"{where}: {n} points exceeds the limit of {self.limits.points} "
                             f"per polyline", fix=("raise it with {}", "limits.points"))
        self.points += n
        if self.points > self.limits.total_points:
            raise InputError(f"{where}: the file holds more than {self.limits.total_points} "
                             f"points", fix=("raise the limit with {}", "limits.points"))


def _point(p, where, size):
    _expect(isinstance(p, list) and len(p) == 2, where, f"expected a point [x, y], got {_show(p)}")
    for i, v in enumerate(p):
        _expect(_is_number(v) and _finite(v), f"{where}[{i}]",
                f"expected a number, got {_show(v)}")
    x, y = float(p[0]), float(p[1])
    w, h = size
    # Pixel centres are integers: the drawing covers [-0.5, W - 0.5] x [-0.5, H - 0.5].
    _expect(-0.5 <= x <= w - 0.5 and -0.5 <= y <= h - 0.5, where,
            f"point {_fmt_point((x, y))} lies outside the {w}x{h} drawing")
    return x, y


def _polyline(s, where, size, budget):
    _expect(isinstance(s, list), where, f"expected a polyline (a list of points), got {_kind(s)}")
    _expect(len(s) > 0, where, "a polyline needs at least one point")
    budget.polyline(len(s), where)
    return np.array([_point(p, f"{where}[{k}]", size) for k, p in enumerate(s)], dtype=float)


def _pair(obj, where, keys, size):  # two points: no polyline budget needed
    _expect(isinstance(obj, dict), where, f"expected an object, got {_kind(obj)}")
    _check_keys(obj, keys, where)
    for key in keys:
        if key not in obj:
            raise InputError(f"{where}.{key}: missing required key")
    return tuple(_point(obj[k], f"{where}.{k}", size) for k in keys)
