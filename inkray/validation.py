"""Validating an annotation against its drawing: every problem a run would meet.

Parsing (:mod:`inkray.input.annotations`) checks the file's form; this module
checks what only the drawing can tell: a blank or all-ink drawing, scribbles
lying on ink, regions that segment to almost nothing, order entries that
contradict each other, boundary paths that snap to no region outline or mark
a stretch another already marks. It runs the relief's stages up to the
stitching (segmentation, completion, the depth order, the meshes and their
stitching: LazyBrush, Sýkora et al. 2009; Ink-and-Ray, Sýkora et al. 2014,
sections 4-5), so that it says exactly what ``relief`` says, errors and
warnings alike; it skips the assembly, the export and the depth-map QP.
Problems found before the depth order are all reported at once, each with
its key path; the first of the later stages' errors ends the run, as it ends
``relief``'s.
"""

from dataclasses import asdict, dataclass

import numpy as np
from inkray.errors import InputError
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
        Its stages up to the stitching are computed (and kept in its cache)
        as far as the input allows.

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
        # The relief's own stages decide: a boundary path must snap to a completed
        # region's outline within the snap distance, and two paths must not mark one
        # stretch (inkray.relief.outline), then the parts are stitched in depth order.
        chain.layers
    except InputError as e:
        errors.append(_problem("error", str(e)))
    warnings += [_problem("warning", w) for w in chain.warnings
                 if w not in {p.message for p in warnings}]
    return errors + warnings
