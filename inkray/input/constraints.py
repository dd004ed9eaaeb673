"""The ``order`` and ``equal`` entries as self-contained constraint records.

An annotation's ``order`` entry says its ``front`` point is nearer the viewer
than its ``back`` point; an ``equal`` entry that ``a`` and ``b`` have the same
depth (Sýkora et al., "Adding Depth to Cartoons Using Sparse Depth
(In)equalities", CGF 2010). Resolved once from the annotations, a
:class:`Constraint` carries its points and its key path, so that later stages
never look the entry up again.
"""

from dataclasses import dataclass

__all__ = ["Constraint", "constraints"]


@dataclass(frozen=True)
class Constraint:
    """One ``order`` or ``equal`` entry.

    Attributes
    ----------
    kind : str
        ``"order"`` (``first`` in front of ``second``) or ``"equal"``.
    entry : int
        The entry's index in its list.
    first, second : (float, float)
        ``front`` and ``back`` (``a`` and ``b``), ``(x, y)`` in drawing pixels.
    """

    kind: str
    entry: int
    first: tuple
    second: tuple

    @property
    def key(self):
        """The entry's key path, e.g. ``order[3]``."""
        return f"{self.kind}[{self.entry}]"

    @property
    def ends(self):
        """The names of the two points in the format: ``("front", "back")`` or ``("a", "b")``."""
        return ("front", "back") if self.kind == "order" else ("a", "b")


def constraints(annotations):
    """The annotation's ``order`` entries, then its ``equal`` entries, as records.

    Parameters
    ----------
    annotations : inkray.input.annotations.Annotations

    Returns
    -------
    list of Constraint

    Examples
    --------
    >>> from inkray.input.annotations import parse_annotations
    >>> ann = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [10, 10],
    ...     "order": [{"front": [1, 2], "back": [5, 6]}], "equal": [{"a": [0, 0], "b": [9, 9]}]})
    >>> [(c.key, c.first, c.second) for c in constraints(ann)]
    [('order[0]', (1.0, 2.0), (5.0, 6.0)), ('equal[0]', (0.0, 0.0), (9.0, 9.0))]
    """
    def point(p):
        return (float(p[0]), float(p[1]))

    return ([Constraint("order", o.index, point(o.front), point(o.back)) for o in annotations.order]
            + [Constraint("equal", e.index, point(e.a), point(e.b)) for e in annotations.equal])
