"""The scene file format, version 1 (``<name>.scene.json``): several annotated drawings in one picture.

Fragment composition, one of the uses Ink-and-Ray names for its layered
reliefs (Sýkora et al., TOG 2014, section 1; Sýkora, Buriánek and Žára,
"Colorization of black-and-white cartoons", 2005): every drawing is placed by
a similarity transform, optionally posed (:mod:`inkray.input.pose`), and the
reliefs' heights decide what is in front, pixel by pixel::

    {"format": "inkray-scene", "version": 1, "size": [W, H],
     "drawings": [{"annotation": "a/drawing.inkray.json", "at": [x, y],
                   "rotate": 0, "scale": 1, "depth": 0,
                   "pose": "a/wave.pose.json", "frame": 0}, ...]}

A drawing's centre goes to ``at`` (scene pixels), turned by ``rotate``
degrees (clockwise on screen, as ``y`` grows downward) and scaled by
``scale``; its relief heights are scaled by ``scale`` and raised by
``depth`` (pixels). Without ``depth``, a drawing is put in front of every
drawing listed before it. Paths are relative to the scene file. Keys
beginning with ``_`` are comments; errors name the key path.
"""

from dataclasses import dataclass
from pathlib import Path

from inkray.errors import InputError
from inkray.input.annotations import _check_keys, _expect, _finite, _is_int, _is_number, _kind, _show
from inkray.input.limits import DEFAULT_LIMITS
from inkray.input.pose import check_header, read_document

__all__ = ["Scene", "Placement", "load_scene", "parse_scene", "MAX_DRAWINGS"]

FORMAT = "inkray-scene"
VERSION = 1
#: Most drawings in a scene: each is a whole relief chain.
MAX_DRAWINGS = 64
_TOP_KEYS = ("format", "version", "size", "drawings")
_ENTRY_KEYS = ("annotation", "at", "rotate", "scale", "depth", "pose", "frame")
_MAX_SCALE = 16.0


@dataclass
class Placement:
    """One drawing of a scene.

    Attributes
    ----------
    annotation : pathlib.Path
    at : (float, float)
        Where the drawing's centre goes, in scene pixels.
    rotate : float
        Degrees, clockwise on screen.
    scale : float
    depth : float or None
        Height added to its relief (scene pixels); None: in front of the
        drawings before it.
    pose : pathlib.Path or None
    frame : int or None
    index : int
    """

    annotation: Path
    at: tuple
    rotate: float = 0.0
    scale: float = 1.0
    depth: float = None
    pose: Path = None
    frame: int = None
    index: int = 0


@dataclass
class Scene:
    """A validated scene file: its ``size`` ``(W, H)`` and its ``drawings`` (Placement)."""

    size: tuple
    drawings: list
    source: Path = None


def load_scene(path, *, limits=DEFAULT_LIMITS):
    """Read and validate a scene file (paths resolved relative to it).

    Parameters
    ----------
    path : str or pathlib.Path
    limits : inkray.input.limits.Limits, optional

    Returns
    -------
    Scene

    Raises
    ------
    InputError
    """
    path = Path(path)
    scene = read_document(path, "scene file", lambda data: parse_scene(data, limits=limits),
                          limits=limits)
    for p in scene.drawings:
        p.annotation = path.parent / p.annotation
        if p.pose is not None:
            p.pose = path.parent / p.pose
    scene.source = path
    return scene


def parse_scene(data, *, limits=DEFAULT_LIMITS):
    """Validate a decoded scene document.

    Parameters
    ----------
    data : object
    limits : inkray.input.limits.Limits, optional

    Returns
    -------
    Scene
        Paths as written (relative).

    Examples
    --------
    >>> s = parse_scene({"format": "inkray-scene", "version": 1, "size": [100, 50],
    ...                  "drawings": [{"annotation": "a.inkray.json", "at": [25, 25]}]})
    >>> s.drawings[0].annotation.name, s.drawings[0].scale
    ('a.inkray.json', 1.0)
    >>> parse_scene({"format": "inkray-scene", "version": 1, "size": [100, 50],
    ...              "drawings": [{"annotation": "a.inkray.json", "at": [25, 25], "scale": 0}]})
    Traceback (most recent call last):
    ...
    inkray.errors.InputError: drawings[0].scale: expected a number within 0.0625..16, got 0
    """
    check_header(data, FORMAT, VERSION, _TOP_KEYS)
    size = data["size"]
    _expect(isinstance(size, list) and len(size) == 2 and all(_is_int(v) and v > 0 for v in size),
            "size", f"expected [width, height] in whole pixels > 0, got {_show(size)}")
    limits.check_pixels(size, "size")
    drawings = data["drawings"]
    _expect(isinstance(drawings, list), "drawings", f"expected a list, got {_kind(drawings)}")
    _expect(0 < len(drawings) <= MAX_DRAWINGS, "drawings",
            f"expected 1..{MAX_DRAWINGS} drawings, got {len(drawings)}")
    out = []
    for i, entry in enumerate(drawings):
        where = f"drawings[{i}]"
        _expect(isinstance(entry, dict), where, f"expected an object, got {_kind(entry)}")
        _check_keys(entry, _ENTRY_KEYS, where)
        for key in ("annotation", "at"):
            if key not in entry:
                raise InputError(f"{where}.{key}: missing required key")
        out.append(Placement(
            annotation=Path(_text(entry["annotation"], f"{where}.annotation")),
            at=_point(entry["at"], f"{where}.at"),
            rotate=_number(entry.get("rotate", 0.0), f"{where}.rotate", -3600.0, 3600.0),
            scale=_number(entry.get("scale", 1.0), f"{where}.scale", 1 / _MAX_SCALE, _MAX_SCALE),
            depth=(None if entry.get("depth") is None else
                   _number(entry["depth"], f"{where}.depth", -1e6, 1e6)),
            pose=None if entry.get("pose") is None else Path(_text(entry["pose"], f"{where}.pose")),
            frame=_frame(entry.get("frame"), f"{where}.frame"),
            index=i))
        if out[-1].frame is not None and out[-1].pose is None:
            raise InputError(f"{where}.frame: a frame needs a pose")
    return Scene(size=(int(size[0]), int(size[1])), drawings=out)


def _text(v, where):
    _expect(isinstance(v, str) and v.strip() != "", where, f"expected a file path, got {_show(v)}")
    return v


def _number(v, where, low, high):
    _expect(_is_number(v) and _finite(v) and low <= v <= high, where,
            f"expected a number within {low:g}..{high:g}, got {_show(v)}")
    return float(v)


def _point(v, where):
    _expect(isinstance(v, list) and len(v) == 2, where, f"expected a point [x, y], got {_show(v)}")
    return tuple(_number(c, f"{where}[{k}]", -1e6, 1e6) for k, c in enumerate(v))


def _frame(v, where):
    if v is None:
        return None
    _expect(_is_int(v) and 0 <= v <= 10 ** 9, where, f"expected a whole number >= 0, got {_show(v)}")
    return int(v)
