"""Writing the annotation file format, version 1 (``<name>.inkray.json``).

The reader and the rules are :mod:`inkray.input.annotations` (the input
contract of ``ANNOTATIONS.md``); this module turns :class:`Annotations`
records back into that document, for annotations that inkray makes (a key
frame's annotation carried to another frame). Coordinates are rounded to
hundredths of a pixel; points are written one per line per polyline, so the
same records give the same bytes.
"""

import json
import re

__all__ = ["annotation_document", "annotation_text", "transfer_report"]


def annotation_document(annotations, *, drawing=None):
    """The JSON document of an annotation.

    Parameters
    ----------
    annotations : inkray.input.annotations.Annotations
    drawing : str, optional
        The ``drawing`` key (a path relative to where the file is written);
        omitted when None.

    Returns
    -------
    dict
        Read back by :func:`inkray.input.annotations.parse_annotations` to the
        same records (to the rounding). Scribble-layer pixels are not part of
        the format and are left out.

    Examples
    --------
    >>> from inkray.input.annotations import parse_annotations
    >>> doc = {"format": "inkray-annotations", "version": 1, "size": [10, 10],
    ...        "regions": [{"name": "a", "scribbles": [[[1, 2], [3, 4]]], "profile": "flat"}]}
    >>> out = annotation_document(parse_annotations(doc))
    >>> out["regions"]
    [{'name': 'a', 'scribbles': [[[1, 2], [3, 4]]], 'inflation': 2, 'profile': 'flat'}]
    """
    doc = {"format": "inkray-annotations", "version": 1}
    if drawing is not None:
        doc["drawing"] = str(drawing)
    doc["size"] = [int(annotations.size[0]), int(annotations.size[1])]
    doc["regions"] = [{"name": r.name, "scribbles": [_points(s) for s in r.scribbles],
                       "inflation": _number(r.inflation), "profile": r.profile}
                      for r in annotations.regions]
    if annotations.background:
        doc["background"] = [_points(s) for s in annotations.background]
    if annotations.order:
        doc["order"] = [{"front": _point(o.front), "back": _point(o.back)} for o in annotations.order]
    if annotations.equal:
        doc["equal"] = [{"a": _point(e.a), "b": _point(e.b)} for e in annotations.equal]
    if annotations.boundaries:
        doc["boundaries"] = [{"type": b.type, "path": _points(b.path)} for b in annotations.boundaries]
    return doc


def annotation_text(document):
    """The file's text: indented JSON with each point on the line of its polyline.

    Parameters
    ----------
    document : dict
        As made by :func:`annotation_document`.

    Returns
    -------
    str
        Ending with a newline.

    Examples
    --------
    >>> print(annotation_text({"order": [{"front": [1, 2], "back": [3.5, 4]}]}))
    {
      "order": [
        {"front": [1, 2], "back": [3.5, 4]}
      ]
    }
    <BLANKLINE>
    """
    text = json.dumps(document, indent=2, ensure_ascii=False)
    # A point on one line, then a polyline (a list of points) on one line, then
    # an order/equal object on one line.
    text = re.sub(r"\[\s+(-?[\d.e+-]+),\s+(-?[\d.e+-]+)\s+\]", r"[\1, \2]", text)
    text = re.sub(r"\[\s+((?:\[-?[\d.e+-]+, -?[\d.e+-]+\],?\s*)+)\]",
                  lambda m: "[" + re.sub(r",\s+", ", ", m.group(1).strip()) + "]", text)
    text = re.sub(r"\{\s+(\"(?:front|a)\": \[[^\]]*\]),\s+(\"(?:back|b)\": \[[^\]]*\])\s+\}",
                  r"{\1, \2}", text)
    return text + "\n"


def _number(v):
    v = round(float(v), 2)
    return int(v) if v == int(v) else v


def _point(p):
    return [_number(p[0]), _number(p[1])]


def _points(line):
    return [_point(p) for p in line]


def transfer_report(transfer, *, key=None, frame=None):
    """The report of a carried annotation: the frame's confidence and every entry's match.

    Parameters
    ----------
    transfer : inkray.transfer.Transfer
    key, frame : str, optional
        The key annotation and the frame's drawing, as the report names them.

    Returns
    -------
    dict
        ``{"format": "inkray-transfer-report", "version": 1, "key", "frame",
        "confidence", "entries": [{"key", "name", "moved", "match",
        "check"}], "check": [warning lines]}``; numbers rounded to 3 places.

    Examples
    --------
    >>> from inkray.transfer import EntryCheck, Transfer
    >>> t = Transfer(annotations=None, confidence=0.91234, warnings=["order[0]: check it"],
    ...              entries=[EntryCheck("order[0]", moved=14.0, match=0.41, flagged=True)])
    >>> transfer_report(t)["entries"]
    [{'key': 'order[0]', 'name': None, 'moved': 14.0, 'match': 0.41, 'check': True}]
    """
    return {"format": "inkray-transfer-report", "version": 1,
            "key": None if key is None else str(key), "frame": None if frame is None else str(frame),
            "confidence": round(float(transfer.confidence), 3),
            "entries": [{"key": e.key, "name": e.name, "moved": round(float(e.moved), 3),
                         "match": round(float(e.match), 3), "check": bool(e.flagged)}
                        for e in transfer.entries],
            "check": list(transfer.warnings)}
