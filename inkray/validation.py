"""Validating an annotation against its drawing: every problem a run would meet.

Parsing (:mod:`inkray.input.annotations`) checks the file's form; this module
checks what only the drawing can tell: a blank or all-ink drawing, scribbles
lying on ink, regions that segment to almost nothing, order entries that
contradict each other, boundary paths that snap to no region outline or mark
a stretch another already marks. It runs the chain's stages up to the depth
order (segmentation, completion, order: LazyBrush, Sýkora et al. 2009;
Ink-and-Ray, Sýkora et al. 2014, section 4) and takes every region's outline
as its mesh does, so that boundary paths are judged by the relief's own rule
(:func:`inkray.relief.outline.boundary_problems`); it skips triangulation,
inflation, stitching and the depth-map QP. Every error it reports, ``relief``
refuses, and every file ``relief`` refuses for its annotation it reports; the
stitching's warnings (an ``order`` entry giving way to a graft) come only
from the commands that stitch. All problems of a file are reported at once,
each with its key path.
"""

from dataclasses import asdict, dataclass

import numpy as np
from inkray.errors import InputError
from inkray.relief.outline import boundary_problems, region_outline
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
        Its stages up to the depth order are computed (and kept in its
        cache) as far as the input allows.

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
    try:
        chain.relations
    except InputError as e:
        return errors + [_problem("error", str(e))] + warnings
    errors += [_problem("error", m) for m in _boundary_problems(chain)]
    warnings += [_problem("warning", w) for w in chain.warnings
                 if w not in {p.message for p in warnings}]
    return errors + warnings


def _boundary_problems(chain):
    """The relief's own rule on ``boundaries``: each region's outline as its mesh takes it."""
    ann = chain.annotations
    if not ann.boundaries:
        return []
    labels, completion, o = chain.silhouettes, chain.completion, chain.options.mesh
    outlines, out = [], []
    for i, region in enumerate(ann.regions):
        mask = completion.completed(i) | (labels == i)
        if not mask.any():
            continue
        try:
            outlines.append(region_outline(
                mask, visible=labels == i, labels=labels, region=i, name=region.name,
                boundaries=ann.boundaries, options=o.for_region(mask)))
        except InputError as e:  # two paths marking one stretch
            out.append(str(e))
    # with an outline missing, which paths it would have taken is unknown
    return out or boundary_problems(outlines, ann.boundaries, snap=o.snap)
