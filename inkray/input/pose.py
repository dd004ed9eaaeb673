"""The pose file format, version 1 (``<name>.pose.json``).

A pose moves points of an annotated drawing (the handles) to new places; the
drawing follows by as-rigid-as-possible deformation (Igarashi, Moscovich and
Hughes, "As-rigid-as-possible shape manipulation", SIGGRAPH 2005)::

    {"format": "inkray-pose", "version": 1,
     "handles": [[x, y], ...],
     "keys": [{"frame": 0, "to": [[x, y], ...]}, {"frame": 12, "to": [[x, y], ...]}]}

``handles`` are points on the drawing in its pixels (as in the annotation
format); every key gives every handle's target. One key is one pose; several
keys are an animation whose in-between frames are interpolated per handle by
a cubic Hermite spline with Catmull-Rom tangents (finite differences over the
neighbouring keys' frames; zero at the first and last key, so motion eases in
and out). Keys beginning with ``_`` are comments. Every rule violation raises
:class:`~inkray.errors.InputError` whose message starts with the key path,
e.g. ``keys[1].to: expected 3 points (one per handle), got 2``.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inkray.errors import InputError
from inkray.input.annotations import (_check_keys, _expect, _finite, _is_int, _is_number, _kind,
                                      _show, decode_annotations)
from inkray.input.files import read_bytes
from inkray.input.limits import DEFAULT_LIMITS

__all__ = ["Pose", "Key", "load_pose", "parse_pose", "pose_path", "read_document", "check_header", "MAX_FRAMES", "MAX_HANDLES"]

FORMAT = "inkray-pose"
VERSION = 1
#: Most frames an animation may span (first key to last): each frame is a picture.
MAX_FRAMES = 1000
#: Most handles: each is a row of the deformation's constraint system.
MAX_HANDLES = 1000
#: Targets may leave the drawing (a limb swung out of frame), but not without bound.
_MAX_COORD = 1e6
_TOP_KEYS = ("format", "version", "handles", "keys")
_KEY_KEYS = ("frame", "to")


@dataclass
class Key:
    """One key pose: the handles' targets at ``frame``; ``index`` is its place in ``keys``."""

    frame: int
    to: np.ndarray
    index: int


@dataclass
class Pose:
    """A validated pose file.

    Attributes
    ----------
    handles : (k, 2) float array
        Points on the drawing ``[x, y]``.
    keys : list of Key
        In increasing frame order.
    source : pathlib.Path or None
    """

    handles: np.ndarray
    keys: list
    source: Path = None

    @property
    def frames(self):
        """The frames from the first key's to the last key's, inclusive."""
        return list(range(self.keys[0].frame, self.keys[-1].frame + 1))

    def at(self, frame):
        """The handles' targets at ``frame`` (clamped to the keys' range).

        Parameters
        ----------
        frame : float

        Returns
        -------
        (k, 2) float array

        Examples
        --------
        >>> pose = parse_pose({"format": "inkray-pose", "version": 1, "handles": [[0, 0]],
        ...                    "keys": [{"frame": 0, "to": [[0, 0]]}, {"frame": 10, "to": [[10, 0]]}]})
        >>> [float(pose.at(f)[0, 0]) for f in (0, 5, 10, 20)]   # eases in and out
        [0.0, 5.0, 10.0, 10.0]
        >>> float(pose.at(2)[0, 0]) < 2.0
        True
        """
        frames = np.array([k.frame for k in self.keys], float)
        points = np.stack([k.to for k in self.keys])
        f = float(np.clip(frame, frames[0], frames[-1]))
        if len(frames) == 1:
            return points[0].copy()
        i = int(np.clip(np.searchsorted(frames, f, side="right") - 1, 0, len(frames) - 2))
        tangents = np.zeros_like(points)
        tangents[1:-1] = (points[2:] - points[:-2]) / (frames[2:] - frames[:-2])[:, None, None]
        h = frames[i + 1] - frames[i]
        s = (f - frames[i]) / h
        h00, h10 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s
        h01, h11 = -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
        return (h00 * points[i] + h10 * h * tangents[i] + h01 * points[i + 1]
                + h11 * h * tangents[i + 1])


def pose_path(annotation):
    """The pose file beside an annotation file: ``X.inkray.json`` -> ``X.pose.json``.

    Examples
    --------
    >>> pose_path("shots/a/frame12.inkray.json").as_posix()
    'shots/a/frame12.pose.json'
    >>> pose_path("b.json").name
    'b.pose.json'
    """
    path = Path(annotation)
    name = path.name
    for suffix in (".inkray.json", ".json"):
        if name.endswith(suffix):
            name = name[:-len(suffix)]
            break
    return path.with_name(f"{name}.pose.json")


def load_pose(path, *, size=None, limits=DEFAULT_LIMITS):
    """Read and validate a pose file.

    Parameters
    ----------
    path : str or pathlib.Path
    size : (int, int), optional
        ``(width, height)`` of the drawing: the handles must lie on it.
    limits : inkray.input.limits.Limits, optional

    Returns
    -------
    Pose

    Raises
    ------
    InputError
        Naming the file and the key path.
    """
    path = Path(path)
    pose = read_document(path, "pose file", lambda data: parse_pose(data, size=size),
                         limits=limits)
    pose.source = path
    return pose


def check_header(data, fmt, version, keys):
    """Check a document's top level: an object with only ``keys`` (all required), ``fmt``, ``version``.

    Examples
    --------
    >>> check_header({"format": "x", "version": 2}, "x", 1, ("format", "version"))
    Traceback (most recent call last):
    ...
    inkray.errors.InputError: version: unsupported version 2 (this reads version 1)
    """
    _expect(isinstance(data, dict), "(top level)", f"expected an object, got {_kind(data)}")
    _check_keys(data, keys, "")
    for key in keys:
        if key not in data:
            raise InputError(f"{key}: missing required key")
    _expect(isinstance(data["format"], str) and data["format"] == fmt, "format",
            f"expected {fmt!r}, got {_show(data['format'])}")
    _expect(_is_int(data["version"]) and data["version"] == version, "version",
            f"unsupported version {_show(data['version'])} (this reads version {version})")


def read_document(path, what, parse, *, limits=DEFAULT_LIMITS):
    """Read a JSON document of the toolkit and ``parse`` it; errors start with the file's path.

    Parameters
    ----------
    path : pathlib.Path
    what : str
        Names the kind of file in messages (``"pose file"``).
    parse : callable
        ``parse(decoded JSON)``.
    limits : inkray.input.limits.Limits, optional

    Returns
    -------
    object
        What ``parse`` returns.
    """
    raw = read_bytes(path, what, limit=limits.file_bytes)
    data = decode_annotations(raw, where=str(path), limits=limits)
    try:
        return parse(data)
    except InputError as e:
        raise InputError(f"{path}: {e}") from None


def parse_pose(data, *, size=None):
    """Validate a decoded pose document.

    Parameters
    ----------
    data : object
        The decoded JSON.
    size : (int, int), optional
        ``(width, height)`` of the drawing: the handles must lie on it.

    Returns
    -------
    Pose

    Raises
    ------
    InputError

    Examples
    --------
    >>> parse_pose({"format": "inkray-pose", "version": 1, "handles": [[1, 2]],
    ...             "keys": [{"frame": 0, "to": [[1, 2], [3, 4]]}]})
    Traceback (most recent call last):
    ...
    inkray.errors.InputError: keys[0].to: expected 1 point (one per handle), got 2
    """
    check_header(data, FORMAT, VERSION, _TOP_KEYS)
    handles = _points(data["handles"], "handles", size=size)
    _expect(len(handles) > 0, "handles", "a pose needs at least one handle")
    for j in range(1, len(handles)):
        same = np.flatnonzero(np.all(np.abs(handles[:j] - handles[j]) < 1e-9, axis=1))
        _expect(not same.size, f"handles[{j}]",
                f"the same point as handles[{same[0] if same.size else 0}]: a point cannot "
                f"be moved to two places")
    keys = data["keys"]
    _expect(isinstance(keys, list), "keys", f"expected a list, got {_kind(keys)}")
    _expect(len(keys) > 0, "keys", "a pose needs at least one key")
    _expect(len(keys) <= MAX_FRAMES, "keys", f"{len(keys)} keys exceeds the limit of {MAX_FRAMES}")
    out = []
    for i, key in enumerate(keys):
        where = f"keys[{i}]"
        _expect(isinstance(key, dict), where, f"expected an object, got {_kind(key)}")
        _check_keys(key, _KEY_KEYS, where)
        for k in _KEY_KEYS:
            if k not in key:
                raise InputError(f"{where}.{k}: missing required key")
        frame = key["frame"]
        _expect(_is_int(frame) and 0 <= frame <= 10 ** 9, f"{where}.frame",
                f"expected a whole number >= 0, got {_show(frame)}")
        if out:
            _expect(frame > out[-1].frame, f"{where}.frame",
                    f"{frame} does not come after keys[{i - 1}].frame {out[-1].frame} (keys are "
                    f"in increasing frame order)")
        to = _points(key["to"], f"{where}.to", size=None)
        n = len(handles)
        _expect(len(to) == n, f"{where}.to",
                f"expected {n} point{'s' if n != 1 else ''} (one per handle), got {len(to)}")
        out.append(Key(frame=int(frame), to=to, index=i))
    span = out[-1].frame - out[0].frame + 1
    _expect(span <= MAX_FRAMES, f"keys[{len(out) - 1}].frame",
            f"the animation spans {span} frames, more than the limit of {MAX_FRAMES}")
    return Pose(handles=handles, keys=out)


def _points(value, where, *, size):
    _expect(isinstance(value, list), where, f"expected a list of points [x, y], got {_kind(value)}")
    _expect(len(value) <= MAX_HANDLES, where,
            f"{len(value)} points exceeds the limit of {MAX_HANDLES}")
    out = np.zeros((len(value), 2))
    for k, p in enumerate(value):
        here = f"{where}[{k}]"
        _expect(isinstance(p, list) and len(p) == 2, here, f"expected a point [x, y], got {_show(p)}")
        for c, v in enumerate(p):
            _expect(_is_number(v) and _finite(v) and abs(v) <= _MAX_COORD, f"{here}[{c}]",
                    f"expected a number of magnitude <= {_MAX_COORD:g}, got {_show(v)}")
        x, y = float(p[0]), float(p[1])
        if size is not None:
            w, h = size
            _expect(-0.5 <= x <= w - 0.5 and -0.5 <= y <= h - 0.5, here,
                    f"point ({x:g}, {y:g}) lies outside the {w}x{h} drawing")
        out[k] = x, y
    return out
