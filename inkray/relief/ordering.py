"""Depth order of neighbouring regions: the user's entries and predictions.

Ink-and-Ray (Sýkora et al., ACM TOG 33(2), 2014, section 4) predicts which of
two neighbouring parts is in front from the completion of illusory surfaces
(Geiger, Pao, Rubin, CVPR 1998; see :mod:`inkray.complete`): a part whose
completion ``B'`` continues its outline under ``A`` is behind ``A``. The
user's ``order`` arrows correct the prediction where they are drawn.

Order is local. Every relation belongs to a *place*, a connected overlap area
of two regions (:class:`inkray.relief.completion.Place`), so two interlocking rings (A
over B at one crossing, B over A at the other) are two consistent local
relations. Places that touch form a *site*; within a site the relations must
be acyclic.

Prediction, per place of a pair ``a``/``b``, from the cues of
:mod:`inkray.relief.order_cues` (T-junctions, the completion's area, how much
of each part's outline the contact is, which part's outline continues the
contact line, what the ink does at the junctions: the ink style carries the
drawing's ink, :attr:`inkray.relief.ink_style.InkStyle.mask`). By default,
given the drawing's ink style, the model learned
from generated drawings
(:func:`inkray.relief.order_model.load_order_model`) reads the measures of
:func:`inkray.relief.order_cues.place_features` and gives ``p``, the
calibrated probability that ``a`` is in front: ``confidence = |2 p - 1|`` (0
for a coin toss, towards 1 when sure). Given ``weights`` (e.g.
:data:`WEIGHTS`), or without the ink style (a label image alone: the learned
model was trained on drawings with their lines, and without them it reads
no continuation), the cues are combined as a logistic model instead,
``score = sum(weights[cue] * cue)``, the ``continuation`` cue trusted as far as
the drawing's lines are clean; its sign says who is in front and
``confidence = 2 * sigmoid(|score|) - 1``. :data:`WEIGHTS`,
:data:`JUNCTION_RADIUS`, :data:`CONTINUATION_WIDTHS` and
:data:`STROKE_END_SCALE` were fitted on the bundled drawings;
``benchmarks/bench_order.py`` measures the weighted cues leave-one-out
(weights fitted without the drawing scored), and with ``--generated`` both
predictors on real drawings none of which was used in training: the learned
model is the default because it is the better of the two there.
A global consistency step follows: predictions are
added strongest first, and one that would close a cycle within its site
(with the user's entries or stronger predictions) is dropped.

``equal`` entries say that two regions meet at the same depth where the entry
is drawn: that place gets a relation of kind ``"equal"``, no prediction, and
no hidden part (:meth:`inkray.relief.completion.Completion.ordered`); within a site an
equality merges the two regions, so ``A = B`` with ``A > B`` is a
contradiction like ``A > B > A``.
"""

from dataclasses import dataclass

import numpy as np

from inkray.errors import InputError
from inkray.numerics.order_graph import OrderGraph
from inkray.relief.order_cues import (CUES, order_cues, outline_lengths, place_features,
                                      region_stats)
from inkray.relief.order_model import load_order_model

__all__ = ["CONTINUATION_WIDTHS", "JUNCTION_RADIUS", "Relation", "STROKE_END_SCALE", "WEIGHTS",
           "depth_order", "predict_place"]

#: Weights of the cues of :func:`inkray.relief.order_cues.order_cues` (fitted
#: by ``python benchmarks/bench_order.py``, logistic on all bundled drawings).
WEIGHTS = {"junction": 4.369, "area": 0.797, "surround": 4.164, "continuation": 4.8}
#: Largest disk radius around a junction, in pixels (chosen by the same benchmark).
JUNCTION_RADIUS = 40.0
#: Radius, in stroke widths, of the ``continuation`` cue around a junction (chosen
#: by the same benchmark).
CONTINUATION_WIDTHS = 6.0
#: Stroke ends per 1000 stroke widths of ink at which the ``continuation`` cue keeps
#: ``1/e`` of its weight (:meth:`inkray.relief.ink_style.InkStyle.clarity`; chosen by
#: the same benchmark).
STROKE_END_SCALE = 10.0


@dataclass
class Relation:
    """One local depth relation between two regions.

    Attributes
    ----------
    front, back : int
        Region indices: ``front`` is nearer the viewer than ``back`` where
        the relation applies. For ``kind == "equal"`` they are the regions of
        the entry's points ``a`` and ``b``, at the same depth.
    front_name, back_name : str
    where : (float, float)
        ``(x, y)`` in drawing pixels: the middle of the user's entry, or for
        a prediction a pixel in the middle of the regions' common outline.
    source : str
        ``"user"`` or ``"predicted"``.
    confidence : float
        In (0, 1]; 1 for the user's entries.
    place : int or None
        Index into :attr:`inkray.relief.completion.Completion.places`: the overlap
        area the relation applies to. ``None`` for a user entry between two
        regions that never touch.
    entry : int or None
        Index of the user's entry in the annotation's ``order`` (or
        ``equal``) list; ``None`` for predictions.
    kind : str
        ``"order"`` (front over back) or ``"equal"`` (same depth).
    points : ((float, float), (float, float)) or None
        The user's entry's two points in drawing pixels, ``(front, back)``
        (``(a, b)`` for ``equal``); ``None`` for predictions.
    """

    front: int
    back: int
    front_name: str
    back_name: str
    where: tuple
    source: str
    confidence: float
    place: int = None
    entry: int = None
    kind: str = "order"
    points: tuple = None

    @property
    def label(self):
        """The entry's key path (``order[3]``) or a description of the prediction."""
        if self.entry is not None:
            return f"{self.kind}[{self.entry}]"
        return f"predicted {self.front_name} over {self.back_name}"


def depth_order(constraints, labels, completion, *, seams=(), predict=True, weights=None,
                junction_radius=None, min_confidence=0.0, ink=None, continuation_widths=None,
                stroke_end_scale=None, memo=None, model=None):
    """Local depth relations of all neighbouring regions.

    Parameters
    ----------
    constraints : list of inkray.input.constraints.Constraint
        The user's ``order`` and ``equal`` entries.
    labels : (H, W) int array
        The segmentation the completion was computed on.
    completion : inkray.relief.completion.Completion
        From :func:`inkray.relief.completion.complete_regions` on ``labels``.
    seams : sequence of inkray.input.annotations.Boundary, default ()
        The ``boundaries`` entries; predictions give way near ``graft`` and
        ``stitch`` seams.
    predict : bool, default True
        Predict the order of the places the user's entries leave open.
    weights : dict, optional
        Weight of each cue (e.g. :data:`WEIGHTS`): predict with the weighted cues
        instead of the learned model, see :func:`predict_place`.
    junction_radius : float, optional
        Largest radius in pixels of the disk measured around a junction
        (default :data:`JUNCTION_RADIUS`).
    min_confidence : float, default 0.0
        Predictions below this confidence are not made (the pair is left
        unordered there, e.g. at a symmetric Y-junction).
    ink, continuation_widths, stroke_end_scale : optional
        As for :func:`predict_place` (``ink`` is
        :func:`inkray.relief.ink_style.ink_style` of the drawing's grey image).
    memo : dict, optional
        Predictions by place index, filled and reused: the cues depend on the
        completion, the seams and the drawing's ink, not on the user's
        entries, so an editor passes the same dict to every call with the
        same completion, ``seams`` and parameters, and a new arrow costs no
        cue (at 1 Mpx all the fox's places take about 0.1 s of CPU).
    model : inkray.relief.order_model.OrderModel, optional
        The learned model (default, without ``weights`` and given ``ink``: the
        shipped one), see :func:`predict_place`.

    Returns
    -------
    relations : list of Relation
        The user's relations in entry order (``order`` then ``equal``), then
        the predictions by place.
    warnings : list of str
        Entries that cannot be a relation between two regions (a point in
        the background, both points in one region), entries between regions
        that never touch, and predictions dropped because they closed a cycle.

    Raises
    ------
    InputError
        When ``labels`` does not match the completion, or when the user's
        entries contradict each other at one site;
        the message names the entries along the cycle, e.g.
        ``order[3] -> order[7] -> order[3]``.

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.completion import complete_regions
    >>> labels = np.full((40, 60), -1, np.int32)
    >>> labels[10:30, 10:50] = 0; labels[:, 26:34] = 1       # a band over a square
    >>> c = complete_regions(labels, names=["square", "band"])
    >>> rel, warn = depth_order([], labels, c)
    >>> [(r.front_name, r.back_name, r.source) for r in rel]
    [('band', 'square', 'predicted')]
    """
    labels = np.asarray(labels)
    if labels.shape != completion.labels.shape or not np.array_equal(labels, completion.labels):
        raise InputError(f"labels: the {labels.shape[1]}x{labels.shape[0]} label image is not "
                         f"the one the completion was computed on")
    warnings = []
    user = []
    for con in constraints:
        r = _user_relation(con.kind, con.entry, con.first, con.second, labels, completion,
                           warnings)
        if r is not None:
            user.append(r)
    graph = _SiteGraph(completion)
    for r in user:
        graph.add_user(r)
    relations = list(user)
    if predict:
        paths = [b.path for b in seams if b.type in ("graft", "stitch")]
        spoken = {r.place for r in user if r.place is not None}
        outlines = stats = None  # measured once, when some place is not in the memo
        predicted = []
        memo = {} if memo is None else memo
        for place in completion.places:
            if place.index in spoken:
                continue
            if place.index not in memo:
                if outlines is None:
                    outlines = outline_lengths(labels)
                    stats = region_stats(labels) if weights is None and ink is not None else None
                memo[place.index] = predict_place(
                    completion, place, weights=weights, junction_radius=junction_radius,
                    seams=paths, outlines=outlines, ink=ink,
                    continuation_widths=continuation_widths, stroke_end_scale=stroke_end_scale,
                    model=model, stats=stats)
            r = memo[place.index]
            if r is not None and r.confidence >= min_confidence:
                predicted.append(r)
        # Strongest first, so that in a cycle the weakest prediction is the one left out.
        predicted.sort(key=lambda r: (-r.confidence, r.place))
        kept = []
        for r in predicted:
            cycle = graph.add_prediction(r)
            if cycle is None:
                kept.append(r)
            else:
                warnings.append(f"predicted order {r.front_name} over {r.back_name} at "
                                f"({r.where[0]:g}, {r.where[1]:g}) (confidence {r.confidence:.2f}) "
                                f"dropped: it closes the cycle {cycle}")
        relations += sorted(kept, key=lambda r: r.place)
    return relations, warnings


def predict_place(completion, place, *, weights=None, junction_radius=None, seams=(),
                  seam_distance=6.0, outlines=None, ink=None, continuation_widths=None,
                  stroke_end_scale=None, model=None, stats=None):
    """Predict which region of a place is in front.

    Parameters
    ----------
    completion : inkray.relief.completion.Completion
    place : inkray.relief.completion.Place
    weights : dict, optional
        ``{cue: weight}`` for the cues of
        :func:`inkray.relief.order_cues.order_cues` (e.g. :data:`WEIGHTS`, the
        default without ``ink``), used instead of the learned model. The
        score is the weighted sum; its
        sign says who is in front and ``2 * sigmoid(|score|) - 1`` is the
        confidence.
    junction_radius : float, optional
        Largest radius of the disk measured around each junction (default
        :data:`JUNCTION_RADIUS`).
    seams : list of (k, 2) arrays
        Polylines ``[x, y]`` of the annotation's ``graft`` and ``stitch``
        boundaries: there one region grows out of the other or joins it, so a
        junction within ``seam_distance`` pixels of them is no occlusion cue.
    seam_distance : float, default 6.0
    outlines : (R,) array, optional
        :func:`inkray.relief.order_cues.outline_lengths` of the labels, when
        already known.
    ink : inkray.relief.ink_style.InkStyle, optional
        The drawing's lines, for the ``continuation`` cue (0 without it).
    continuation_widths : float, optional
        Radius in stroke widths of the ``continuation`` cue (default
        :data:`CONTINUATION_WIDTHS`).
    stroke_end_scale : float, optional
        How fast stroke ends discount the ``continuation`` cue (default
        :data:`STROKE_END_SCALE`).
    model : inkray.relief.order_model.OrderModel, optional
        The learned model (default, without ``weights`` and given ``ink``:
        :func:`inkray.relief.order_model.load_order_model`; ``weights`` must
        then be None): ``p`` the probability that ``place.a`` is in front,
        ``confidence = |2 p - 1|``. It was trained with the default radii and
        scale.
    stats : tuple, optional
        :func:`inkray.relief.order_cues.region_stats` of the labels, when
        already known.

    Returns
    -------
    Relation or None
        A ``"predicted"`` relation, or None when the place gives no cue (all
        its junctions on seams, or a score of exactly 0).

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.relief.completion import complete_regions
    >>> yy, xx = np.mgrid[:40, :40]
    >>> labels = np.where((yy - 20) ** 2 + (xx - 20) ** 2 < 300, 0, -1).astype(np.int32)
    >>> labels[(yy - 20) ** 2 + (xx - 20) ** 2 < 30] = 1      # an eye inside a head
    >>> c = complete_regions(labels, names=["head", "eye"])
    >>> r = predict_place(c, c.places[0])      # no ink style: the weighted cues
    >>> (r.front_name, r.back_name)
    ('eye', 'head')
    >>> from inkray.relief.ink_style import InkStyle
    >>> learned = predict_place(c, c.places[0], ink=InkStyle(width=2.0, stroke_ends=0.0))
    >>> (learned.front_name, learned.back_name)
    ('eye', 'head')
    """
    if model is not None and weights is not None:
        raise InputError("weights: give cue weights or a learned model, not both")
    if weights is None and model is None:
        # The learned model read drawings with their ink; a bare label image gets the cues.
        if ink is None:
            weights = WEIGHTS
        else:
            model = load_order_model()
    unknown = sorted(set(weights or ()) - set(CUES))
    if unknown:
        raise InputError(f"weights: unknown cue {unknown[0]!r} (expected {', '.join(CUES)})")
    radius = JUNCTION_RADIUS if junction_radius is None else float(junction_radius)
    if not radius > 0:
        raise InputError(f"junction_radius: expected a positive radius, got {junction_radius!r}")
    widths = CONTINUATION_WIDTHS if continuation_widths is None else float(continuation_widths)
    scale = STROKE_END_SCALE if stroke_end_scale is None else float(stroke_end_scale)
    if model is not None:
        features = place_features(completion, place, outlines=outlines, stats=stats, seams=seams,
                                  ink=ink, junction_radius=radius, continuation_widths=widths,
                                  stroke_end_scale=scale, seam_distance=seam_distance)
        if features is None:
            return None
        p = float(model.probability(features[None])[0])
        score, confidence = p - 0.5, abs(2.0 * p - 1.0)
    else:
        cues = order_cues(completion, place, outlines=outlines, seams=seams,
                          junction_radius=radius, seam_distance=seam_distance, ink=ink,
                          continuation_widths=widths, stroke_end_scale=scale)
        if cues is None:
            return None
        score = sum(float(w) * cues[k] for k, w in weights.items())
        confidence = float(np.tanh(abs(score) / 2.0))  # 2 * sigmoid(|score|) - 1 = |2 p - 1|
    if score == 0:
        return None
    a, b = place.a, place.b
    front, back = (a, b) if score > 0 else (b, a)
    names = completion.names
    return Relation(front=front, back=back, front_name=names[front], back_name=names[back],
                    where=tuple(float(v) for v in place.where), source="predicted",
                    confidence=confidence, place=place.index)


def _user_relation(kind, index, p, q, labels, completion, warnings):
    """The relation of one user entry, or None (with a warning) when it names no region pair."""
    key = f"{kind}[{index}]"
    h, w = labels.shape
    ends = ("front", "back") if kind == "order" else ("a", "b")
    regions = []
    for end, (x, y) in zip(ends, (p, q)):
        lab = int(labels[min(int(round(y)), h - 1), min(int(round(x)), w - 1)])
        if lab < 0:
            warnings.append(f"{key}.{end}: point ({x:g}, {y:g}) lies in the background; "
                            f"the entry is not a relation between regions")
            return None
        regions.append(lab)
    u, v = regions
    names = completion.names
    if u == v:
        warnings.append(f"{key}: both points lie in region {names[u]!r}; a region is not "
                        f"ordered against itself here")
        return None
    lo, hi = min(u, v), max(u, v)
    candidates = [pl for pl in completion.places if pl.a == lo and pl.b == hi]
    place = None
    if candidates:
        place = min(candidates,
                    key=lambda pl: (min(pl.distance(p), pl.distance(q)), pl.index)).index
    else:
        warnings.append(f"{key}: regions {names[u]!r} and {names[v]!r} do not touch; "
                        f"the relation has no overlap area")
    where = ((p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0)
    return Relation(front=u, back=v, front_name=names[u], back_name=names[v], where=where,
                    source="user", confidence=1.0, place=place, entry=index, kind=kind,
                    points=(tuple(map(float, p)), tuple(map(float, q))))


class _SiteGraph:
    """One order graph of relations per site: strict edges front -> back,
    equalities both ways. A cycle with a strict edge is a contradiction."""

    def __init__(self, completion):
        self._sites = {p.index: p.site for p in completion.places}
        self._names = completion.names
        self._graphs = {}  # site -> OrderGraph of region indices, relations as labels

    def _graph(self, r):
        # A relation without a place stands on its own, shared only with its own pair.
        site = (self._sites[r.place] if r.place is not None
                else ("apart", min(r.front, r.back), max(r.front, r.back)))
        return self._graphs.setdefault(site, OrderGraph())

    def add_user(self, r):
        graph = self._graph(r)
        strict = r.kind == "order"
        ends = [(r.back, r.front)] if strict else [(r.back, r.front), (r.front, r.back)]
        for start, goal in ends:
            path = graph.path(start, goal, skip=_other_place(r))
            if path is not None and (strict or any(s for _, s in path)):
                chain = [r] + [rel for rel, _ in path]
                first = min(range(len(chain)), key=lambda i: (chain[i].kind, chain[i].entry))
                chain = chain[first:] + chain[:first]
                text = " -> ".join(c.label for c in chain + chain[:1])
                raise InputError(f"{chain[0].kind}: the entries contradict each other near "
                                 f"({r.where[0]:g}, {r.where[1]:g}): {text} "
                                 f"({self._cycle(r, path)})")
        graph.add(r.front, r.back, strict=strict, label=r)

    def add_prediction(self, r):
        """Add a strict edge; return the cycle it would close instead (as text), or None."""
        graph = self._graph(r)
        path = graph.path(r.back, r.front, skip=_other_place(r))
        if path is not None:
            return self._cycle(r, path)
        graph.add(r.front, r.back, label=r)
        return None

    def _cycle(self, r, path):
        """``a > b = c > a``: the regions around the cycle closed by ``r`` and ``path``."""
        text = [self._names[r.front], ">" if r.kind == "order" else "=", self._names[r.back]]
        node = r.back
        for rel, strict in path:
            node = rel.back if rel.front == node else rel.front
            text += [">" if strict else "=", self._names[node]]
        return " ".join(text)


def _other_place(new):
    """Relations of ``new``'s pair at another place are left out of its paths: a pair
    may overlap twice with opposite orders (interlocking rings)."""
    pair = {new.front, new.back}
    return lambda rel: {rel.front, rel.back} == pair and rel.place != new.place
