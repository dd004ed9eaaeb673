"""Validating an annotation against its drawing: every problem a run would meet.

Parsing (:mod:`inkray.input.annotations`) checks the file's form; this module
checks what only the drawing can tell, up to the depth order: a blank or
all-ink drawing, scribbles lying on ink, regions that segment to almost
nothing, boundary paths far from every region outline, and order entries
that contradict each other. It runs the chain's cheap stages (segmentation,
completion and the depth order: LazyBrush, Sýkora et al. 2009; Ink-and-Ray,
Sýkora et al. 2014, section 4) and none of the heavy ones (meshing,
inflation, stitching, the depth-map QP), and reports all problems of a file
at once, each with its key path.
"""

from dataclasses import asdict, dataclass

import numpy as np
from scipy import ndimage

from inkray.errors import InputError
from inkray.relief.outline import DEFAULT_SNAP
from inkray.segmentation import INK_THRESHOLD, scribbles_on_ink

__all__ = ["Problem", "validate"]


@dataclass(frozen=True)
class Problem:
    """One finding of :func:`validate`.

    Attributes
    ----------
    severity : str
        ``"error"`` (a run fails) or ``"warning"`` (a run goes on, likely not
        as meant).
    key : str
        The key path (``order[3]``) or ``drawing``.
    message : str
        The CLI's one-line message, starting with ``key``.
    """

    severity: str
    key: str
    message: str

    @classmethod
    def from_message(cls, severity, message):
        """The problem of a one-line message ``"key: what"`` (the key before the first colon)."""
        return cls(severity, message.split(":", 1)[0].split(" (", 1)[0], message)

    def as_dict(self):
        return asdict(self)


_problem = Problem.from_message


def validate(chain):
    """Every problem of the chain's annotation and drawing that a run would meet.

    Parameters
    ----------
    chain : inkray.chain.ReliefChain
        Its segmentation, completion and depth order are computed (and kept
        in its cache) as far as the input allows.

    Returns
    -------
    list of Problem
        Errors first, then warnings, each group in file order.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.chain import ReliefChain
    >>> from inkray.input.annotations import parse_annotations
    >>> from inkray.input.drawing import drawing_from_array
    >>> ann = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [20, 20],
    ...     "regions": [{"name": "a", "scribbles": [[[5, 5], [9, 5]]]}]})
    >>> [p.message for p in validate(ReliefChain(ann, drawing_from_array(np.ones((20, 20)))))]
    ['drawing: blank (no pixel darker than 0.5): no lines to segment along']
    """
    gray = chain.drawing.gray
    ann = chain.annotations
    ink = int((gray < INK_THRESHOLD).sum())
    if ink == 0:
        return [_problem("error", f"drawing: blank (no pixel darker than {INK_THRESHOLD}): "
                                  f"no lines to segment along")]
    if ink == gray.size:
        return [_problem("error", f"drawing: all ink (no pixel lighter than {INK_THRESHOLD}): "
                                  f"no paper to segment")]
    errors = [_problem("error", m) for m in scribbles_on_ink(ann, gray)]
    if not ann.regions:
        errors.append(_problem("error", "regions: no region scribbles (a depth order and a "
                                        "relief need at least one region)"))
    if errors:
        return errors
    warnings = []
    try:
        seg = chain.segmentation
    except InputError as e:
        return [_problem("error", str(e))]
    warnings += [_problem("warning", w) for w in seg.warnings]
    errors += _far_boundaries(seg.labels, ann.boundaries)
    if not errors:
        try:
            chain.relations
        except InputError as e:
            errors.append(_problem("error", str(e)))
        else:
            warnings += [_problem("warning", w) for w in chain.warnings
                         if w not in {p.message for p in warnings}]
    return errors + warnings


def _far_boundaries(labels, boundaries):
    """Boundary paths whose points lie mostly farther than the snap distance from any outline."""
    if not boundaries:
        return []
    edges = np.zeros(labels.shape, bool)
    edges[:, 1:] |= labels[:, 1:] != labels[:, :-1]
    edges[1:, :] |= labels[1:, :] != labels[:-1, :]
    if not edges.any():
        distance = np.full(labels.shape, np.inf)
    else:
        distance = ndimage.distance_transform_edt(~edges)
    h, w = labels.shape
    out = []
    for b in boundaries:
        path = np.asarray(b.path, float)
        cols = np.clip(np.rint(path[:, 0]).astype(int), 0, w - 1)
        rows = np.clip(np.rint(path[:, 1]).astype(int), 0, h - 1)
        near = float(np.median(distance[rows, cols]))
        if near > DEFAULT_SNAP:
            out.append(_problem("error", f"boundaries[{b.index}]: no region outline within "
                                         f"{DEFAULT_SNAP:g} px of the {b.type} path starting at "
                                         f"({path[0, 0]:g}, {path[0, 1]:g}) (the nearest is "
                                         f"{near:.1f} px away)"))
    return out
