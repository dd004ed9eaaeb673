"""The resumable chain: every stage of the method, computed once and reused.

The Ink-and-Ray chain (Sýkora et al., TOG 2014) runs segmentation ->
completion -> depth order -> per-region meshes and inflation -> stitching ->
assembly; the 2010 depth map (Sýkora et al., CGF 2010) runs beside it. A
:class:`ReliefChain` exposes each stage's result as a lazily computed
attribute. :meth:`ReliefChain.edit` makes the chain of changed annotations or
options; it shares a content-keyed cache with the chain it came from, so a
stage runs again only when what it reads changed:

- a new ``order`` arrow re-orders and re-stitches, but does not segment,
  complete or mesh again;
- a changed ``inflation`` of one region re-inflates that region only, then
  re-stitches;
- a new scribble segments again, and every region whose completed mask,
  neighbourhood and options did not change keeps its mesh;
- undo (the earlier annotations again) finds every result in the cache.

Stages read plain records, never the raw annotation file.
"""

import hashlib
import threading
from collections import OrderedDict
from dataclasses import dataclass, field, replace

import numpy as np

from inkray.depthmap.estimation import METHODS, DepthResult, DepthSession, depth, depth_constraints
from inkray.errors import InputError
from inkray.input.constraints import constraints
from inkray.input.scribbles import seed_image
from inkray.numerics.threads import thread_imap
from inkray.progress import Progress
from inkray.relief.assembly import assemble
from inkray.relief.completion import Completion, complete_regions
from inkray.relief.inflation import inflate_region
from inkray.relief.ink_style import ink_style
from inkray.relief.joins import open_joins
from inkray.relief.model import Relief
from inkray.relief.ordering import depth_order
from inkray.relief.outline import DEFAULT_MAX_AREA, MeshOptions, check_boundaries
from inkray.relief.silhouette import grow_over_ink, ink_pixels, pad_ink_edge
from inkray.relief.stitching import Layers, stitch
from inkray.segmentation import Segmentation, segment

__all__ = ["ChainOptions", "ReliefChain", "ReliefResult", "build_relief"]

_LABEL_MARGIN = 6  # px around a region's box that its outline's provenance reads
_STROKE_EDGE = 0.75  # grey level up to which a stroke's soft edge is part of its silhouette


@dataclass(frozen=True)
class ChainOptions:
    """Options of a chain; every field may be changed with :meth:`ReliefChain.edit`.

    Attributes
    ----------
    predict : bool, default True
        Predict the depth order where the user's entries are silent.
    max_area : float, default 50
        Largest triangle area in px^2 (the mesh resolution).
    epsilon : float, optional
        Depth step between a part and the part behind it (px); default 0.4 %
        of the drawing's longer side.
    closed : bool, default False
        Closed solids (mirrored backs) instead of front surfaces.
    union : bool, default False
        With ``closed``: one watertight solid.
    depth_method : {"exact", "fast"}, default "exact"
        Method of :attr:`ReliefChain.depth_map`.
    depth_epsilon : float, default 1
        Depth step of an ``order`` entry in the depth map.
    interactive : bool, default False
        Keep the fast depth method's factorization between edits (re-solves
        after an arrow cost back-substitutions; about 0.4 GB at 512x512).
    depth_draft : bool, default False
        With ``interactive``: a preview of the fast depth map whose Laplace
        fill is solved at half resolution above 0.3 Mpx (about a third of
        the time after an arrow; see
        :meth:`~inkray.depthmap.estimation.DepthSession.solve`).

    Examples
    --------
    >>> ChainOptions(max_area=20).mesh.max_area
    20.0
    """

    predict: bool = True
    max_area: float = DEFAULT_MAX_AREA
    epsilon: float = None
    closed: bool = False
    union: bool = False
    depth_method: str = "exact"
    depth_epsilon: float = 1.0
    interactive: bool = False
    depth_draft: bool = False

    def __post_init__(self):
        if self.union and not self.closed:
            raise InputError("union: the union of open surfaces is not a solid", option="union",
                             fix=("add {}", "closed"))
        if self.epsilon is not None and not (np.isfinite(self.epsilon) and self.epsilon > 0):
            raise InputError(f"epsilon: expected a positive depth step in px, got {self.epsilon!r}")
        if self.depth_method not in METHODS:
            raise InputError(f"method: unknown method {self.depth_method!r} "
                             f"(expected one of {', '.join(METHODS)})")
        if not (np.isfinite(self.depth_epsilon) and self.depth_epsilon > 0):
            raise InputError(f"epsilon: expected a positive number, got {self.depth_epsilon!r}")
        MeshOptions(max_area=self.max_area)  # validates max_area

    @property
    def mesh(self):
        """The :class:`~inkray.relief.outline.MeshOptions` of every region."""
        return MeshOptions(max_area=self.max_area)


@dataclass
class ReliefResult:
    """The stages of one relief, as :func:`build_relief` returns them.

    Attributes
    ----------
    relief : inkray.relief.model.Relief
    segmentation : inkray.segmentation.Segmentation
    completion : inkray.relief.completion.Completion
        After the depth order (only hidden parts under a region in front).
    relations : list of inkray.relief.ordering.Relation
    layers : inkray.relief.stitching.Layers
    warnings : list of str
    timings : list of (str, float)
        Seconds per stage.
    """

    relief: Relief
    segmentation: Segmentation
    completion: Completion
    relations: list
    layers: Layers
    warnings: list = field(default_factory=list)
    timings: list = field(default_factory=list)


class _Cache:
    """Results by content key, least recently used dropped first; shared by a chain's edits."""

    def __init__(self, capacity):
        self.capacity = capacity
        self._items = OrderedDict()
        self._lock = threading.Lock()
        # (key, DepthSession, {constraint: handle}, (its segmentation's or scribbles' key,
        # the digest of its labels or seed image)) of the interactive depth
        self.session = None
        # (drawing key, InkStyle) for the order prediction: kept apart from the stages so
        # that it costs no stage its place
        self.ink = None
        # What segmentations of the drawing share between edits (segment's memo), used by
        # one segmentation at a time
        self.segment_memo = {}
        self.segment_lock = threading.Lock()
        # the stitching's per-mesh factorizations, by mesh content (see stitch's memo)
        self.stitch = {}

    def get(self, key):
        with self._lock:
            if key in self._items:
                self._items.move_to_end(key)
                return self._items[key]
        return None

    def put(self, key, value):
        with self._lock:
            self._items[key] = value
            self._items.move_to_end(key)
            while len(self._items) > self.capacity:
                self._items.popitem(last=False)


class ReliefChain:
    """Every stage of one annotated drawing, computed on first use and cached by content.

    Parameters
    ----------
    annotations : inkray.input.annotations.Annotations
    drawing : inkray.input.drawing.Drawing
    options : ChainOptions, optional
    progress : inkray.progress.Progress, optional
        Stage names, progress bars and timings of what this chain computes.
    cache_size : int, default 512
        Results kept (stage results, one per region for the meshes).

    Attributes
    ----------
    recomputed : list of str
        The stages this chain computed itself rather than took from the cache
        (``"mesh:<region>"`` per region).

    Examples
    --------
    >>> import numpy as np
    >>> from inkray.input.annotations import parse_annotations
    >>> from inkray.input.drawing import drawing_from_array
    >>> gray = np.ones((60, 80)); gray[10:50, 40] = 0.0; gray[10, 10:70] = 0.0
    >>> gray[50, 10:71] = 0.0; gray[10:51, 10] = 0.0; gray[10:51, 70] = 0.0
    >>> ann = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [80, 60],
    ...     "regions": [{"name": "a", "scribbles": [[[25, 30]]]},
    ...                 {"name": "b", "scribbles": [[[55, 30]]]}]})
    >>> chain = ReliefChain(ann, drawing_from_array(gray))
    >>> [p.name for p in chain.relief.parts]
    ['a', 'b']
    >>> from dataclasses import replace
    >>> rounder = replace(ann, regions=[ann.regions[0], replace(ann.regions[1], inflation=4.0)])
    >>> again = chain.edit(annotations=rounder)
    >>> again.relief is not chain.relief, again.recomputed
    (True, ['mesh:b', 'stitch', 'assemble'])
    """

    def __init__(self, annotations, drawing, *, options=None, progress=None, cache_size=512,
                 _cache=None, _drawing_key=None):
        self.annotations = annotations
        self.drawing = drawing
        self.options = options if options is not None else ChainOptions()
        if not isinstance(self.options, ChainOptions):
            raise InputError(f"options: expected ChainOptions, got {type(self.options).__name__}")
        w, h = annotations.size
        if tuple(drawing.size) != (w, h):
            raise InputError(f"size: the annotation is for a {w}x{h} drawing but the drawing is "
                             f"{drawing.size[0]}x{drawing.size[1]}")
        self.progress = progress if progress is not None else Progress(quiet=True)
        self.recomputed = []
        self._cache = _cache if _cache is not None else _Cache(cache_size)
        self._drawing_key = _drawing_key or _digest(drawing.gray, drawing.rgb)
        self._memo = {}

    def edit(self, annotations=None, *, progress=None, **changes):
        """The chain of other annotations or options, sharing this chain's cache.

        Parameters
        ----------
        annotations : Annotations, optional
            The new annotations (same drawing); default this chain's.
        progress : Progress, optional
            Default this chain's.
        **changes
            Fields of :class:`ChainOptions` to change.

        Returns
        -------
        ReliefChain
        """
        return ReliefChain(annotations if annotations is not None else self.annotations,
                           self.drawing, options=replace(self.options, **changes),
                           progress=progress if progress is not None else self.progress,
                           _cache=self._cache, _drawing_key=self._drawing_key)

    # -- stages ------------------------------------------------------------------

    @property
    def segmentation(self):
        """:class:`~inkray.segmentation.Segmentation` of the region and background scribbles."""
        return self._stage("segment", self._segment_key(), self._segment)

    @property
    def segmented(self):
        """Whether :attr:`segmentation` is already computed (then it costs nothing)."""
        return self._cache.get(self._segment_key()) is not None

    @property
    def candidates(self):
        """:class:`~inkray.relief.completion.Completion` of every neighbouring pair, before the order."""
        seg = self.segmentation
        grafts = [b.path for b in self.annotations.boundaries if b.type == "graft"]
        return self._stage("complete", ("complete", self._segment_key()), lambda: complete_regions(
            seg.labels, names=seg.names, grafts=grafts, progress=self.progress))

    @property
    def relations(self):
        """The user's and the predicted local depth relations (list of Relation)."""
        return self._ordered()[0]

    @property
    def completion(self):
        """The completion after the depth order: hidden parts only under a region in front."""
        return self._ordered()[1]

    @property
    def silhouettes(self):
        """The completion's labels grown over their contour strokes: what the meshes outline."""
        # The completion's labels are the candidates' (the order changes only the hidden
        # parts). The parts reach the outer edge of their contour strokes (the outline
        # on the mesh).
        labels = self.candidates.labels
        return self._stage("silhouettes", ("silhouettes", self._segment_key()),
                           lambda: _silhouettes(labels, self.drawing.gray), timed=False)

    @property
    def joins(self):
        """The open joins (:class:`~inkray.relief.joins.OpenJoin`): ink-free cuts between two
        regions that no ``boundaries`` entry marks, grafted like one."""
        labels = self.silhouettes
        return self._stage("joins", ("joins", self._segment_key()),
                           lambda: self._open_joins(labels), timed=False)

    @property
    def seams(self):
        """The ``boundaries`` entries, then the open joins: every seam the relief stitches."""
        return [*self.annotations.boundaries, *self.joins]

    @property
    def meshes(self):
        """Per region, its :class:`~inkray.relief.inflation.InflatedRegion` (None when empty)."""
        if "meshes" in self._memo:
            return self._memo["meshes"]
        completion = self.completion
        labels = self.silhouettes
        regions = self.annotations.regions
        entries, joins = self.annotations.boundaries, self.joins
        out, keys, todo = [], [], []
        with self.progress.stage("inflate"):
            for i, region in enumerate(regions):
                mask = completion.completed(i) | (labels == i)
                if not mask.any():
                    out.append(None)
                    keys.append(None)
                    continue
                # An open join marks the outlines of its own two regions only.
                seams = [*entries, *(j for j in joins if i in j.regions)]
                key = ("mesh", i, region.name, float(region.inflation), region.profile,
                       self.options.mesh, _digest(mask, _label_window(labels, mask), *(
                           (b.type, b.path, b.index) for b in seams)))
                keys.append(key)
                out.append(self._cache.get(key))
                if out[-1] is None:
                    todo.append((i, key, np.count_nonzero(mask),
                                 lambda i=i, mask=mask, r=region, seams=seams:
                                 inflate_region(mask, visible=labels == i, labels=labels,
                                                region=i, name=r.name, boundaries=seams,
                                                inflation=r.inflation, profile=r.profile,
                                                options=self.options.mesh)))

            # Two parts at a time, the largest first so that the two workers end about
            # together: their solves let go of the GIL (their outline tracing mostly
            # does not, so two threads gain most on a loaded machine). A superseded
            # edit's progress raises: the parts not yet started are dropped.
            todo.sort(key=lambda job: -job[2])
            cached = len(regions) - len(todo)
            for done, ((i, key, _, _), mesh) in enumerate(
                    zip(todo, thread_imap(lambda job: job[3](), todo)), cached + 1):
                self.progress.update(done, len(regions))
                self._cache.put(key, mesh)
                self.recomputed.append(f"mesh:{regions[i].name}")
                out[i] = mesh
            check_boundaries([r.mesh for r in out if r is not None], entries)
        self._memo["meshes"] = out
        self._memo["mesh_keys"] = keys
        return out

    @property
    def layers(self):
        """The stitched :class:`~inkray.relief.stitching.Layers` (offsets under the relations)."""
        meshes = self.meshes
        key = ("stitch", self._relations_key(), tuple(self._memo["mesh_keys"]), self.options.epsilon)
        return self._stage("stitch", key, lambda: stitch(
            meshes, self.relations, self.completion, seams=self.seams,
            epsilon=self.options.epsilon, memo=self._cache.stitch, progress=self.progress))

    @property
    def relief(self):
        """The assembled :class:`~inkray.relief.model.Relief`, textured with the drawing."""
        layers = self.layers
        o = self.options
        key = ("assemble", self._memo["stitch_key"], o.closed, o.union, self._drawing_key)
        return self._stage("assemble", key, lambda: assemble(
            layers, size=self.annotations.size, texture=self.drawing.rgb, closed=o.closed,
            union=o.union))

    @property
    def depth_map(self):
        """The 2010 depth map (:class:`~inkray.depthmap.estimation.DepthResult`) of the entries."""
        o = self.options
        ann = self.annotations
        # The segments: of the scribbles and, with regions, the boundaries (not the names).
        segments_key = _digest(_seeds_key(ann), bool(ann.regions) and tuple(
            (b.type, b.path) for b in ann.boundaries))
        draft = o.depth_draft and o.depth_method == "fast" and o.interactive
        key = ("depth", o.depth_method, o.depth_epsilon, self._drawing_key, _entries_key(ann),
               segments_key, draft)
        if o.depth_method == "fast" and o.interactive:
            return self._stage("depth", key, lambda: self._session_depth(segments_key))
        # depth() reports its own stage ("depth (exact QP)", "depth (fast)").
        return self._stage("depth", key, lambda: depth(
            ann, self.drawing, method=o.depth_method, epsilon=o.depth_epsilon,
            segmentation=self.segmentation.labels if ann.regions else None,
            progress=self.progress), timed=False)

    def prepare_drawing(self):
        """Compute what depends on the drawing alone (the ink style the order prediction
        reads, about 0.1 s at 1 Mpx), for a thread that waits meanwhile for the
        segmentation.

        Examples
        --------
        >>> from inkray.input.loading import load_input
        >>> from inkray.examples import example_path
        >>> chain = ReliefChain(*load_input(example_path("turtle")))
        >>> chain.prepare_drawing(); chain.recomputed
        []
        """
        self._ink_style()

    def prepare_depth(self, *, background=True):
        """Ready the kept fast depth session for the next edit
        (:meth:`~inkray.depthmap.estimation.DepthSession.prepare`), in time
        nobody waits on: after a cold open its fill has no update matrices.

        Parameters
        ----------
        background : bool, default True
            Factor in a thread of its own and return at once.

        Returns
        -------
        bool
            Whether there was a session with anything to do.
        """
        kept = self._cache.session
        return kept is not None and kept[1].prepare(background=background)

    @property
    def warnings(self):
        """Warnings of the stages computed so far (segmentation, then order)."""
        out = []
        if "segment" in self._memo:
            out += self._memo["segment"].warnings
        if "order" in self._memo:
            out += self._memo["order"][2]
        if "stitch" in self._memo:
            out += self._memo["stitch"].warnings
        if "assemble" in self._memo:
            out += self._memo["assemble"].warnings
        if "meshes" in self._memo:
            meshes = self._memo["meshes"]
            out += [f"region {r.name!r}: no pixels after segmentation; left out"
                    for r, m in zip(self.annotations.regions, meshes) if m is None]
            out += [w for m in meshes if m is not None for w in m.mesh.warnings]
        return out

    def result(self):
        """Every stage of the relief as a :class:`ReliefResult`."""
        relief = self.relief
        return ReliefResult(relief=relief, segmentation=self.segmentation,
                            completion=self.completion, relations=self.relations,
                            layers=self.layers, warnings=self.warnings,
                            timings=list(self.progress.timings))

    # -- internals -----------------------------------------------------------------

    def _stage(self, name, key, compute, *, timed=True):
        memo = name.split(":")[0]
        if key is not None and name in self._memo and self._memo.get(f"{memo}_key") == key:
            return self._memo[name]
        value = self._cache.get(key)
        if value is None:
            if timed:
                with self.progress.stage(name):
                    value = compute()
            else:
                value = compute()
            self._cache.put(key, value)
            self.recomputed.append(name)
        if ":" not in name:
            self._memo[name] = value
            self._memo[f"{name}_key"] = key
        return value

    def _segment_key(self):
        ann = self.annotations
        return ("segment", self._drawing_key, _scribbles_key(ann),
                _digest(*((b.type, b.path) for b in ann.boundaries)))

    def _relations_key(self):
        ann = self.annotations
        return ("order", self._segment_key(), _entries_key(ann), self.options.predict,
                _digest(*((b.type, b.path) for b in ann.boundaries)))

    def _ordered(self):
        if "order" in self._memo:
            return self._memo["order"]
        candidates = self.candidates
        labels = self.segmentation.labels

        # Reshaped hidden parts by (front, back, place): a new arrow reshapes only its own.
        memo_key = ("continuations", self._segment_key())
        memo = self._cache.get(memo_key)
        if memo is None:
            memo = {}
            self._cache.put(memo_key, memo)

        # Predictions by place: they depend on the segments and the seams, not on the
        # entries, so a new arrow predicts nothing again.
        predictions_key = ("predictions", self._segment_key(),
                           _digest(*((b.type, b.path) for b in self.annotations.boundaries)))
        predictions = self._cache.get(predictions_key)
        if predictions is None:
            predictions = {}
            self._cache.put(predictions_key, predictions)

        def compute():
            relations, notes = depth_order(constraints(self.annotations), labels, candidates,
                                           seams=self.annotations.boundaries,
                                           predict=self.options.predict, ink=self._ink_style(),
                                           memo=predictions)
            return relations, candidates.ordered(relations, memo=memo), notes

        # The silhouettes and the open joins need no order: computed beside it (the
        # order is mostly one thread), kept once the order is done.
        beside = {}
        skey = ("silhouettes", self._segment_key())
        if self._cache.get(skey) is None and self._cache.get(self._relations_key()) is None:
            def outlines():
                try:
                    grown = _silhouettes(candidates.labels, self.drawing.gray)
                    beside["outlines"] = grown, self._open_joins(grown)
                except Exception:  # noqa: BLE001 - the stage that asks computes and reports it
                    pass

            thread = threading.Thread(target=outlines, name="ReliefChain.outlines", daemon=True)
            thread.start()
            beside["thread"] = thread
        value = self._stage("order", self._relations_key(), compute)
        if "thread" in beside:
            beside["thread"].join()
            if "outlines" in beside:
                grown, joins = beside["outlines"]
                self._stage("silhouettes", skey, lambda: grown, timed=False)
                self._stage("joins", ("joins", self._segment_key()), lambda: joins, timed=False)
        return value

    def _open_joins(self, labels):
        ann = self.annotations
        return open_joins(labels, self.drawing.gray, boundaries=ann.boundaries,
                          names=[r.name for r in ann.regions])

    def _segment(self):
        """The segmentation, with the cache's kept memo unless another thread's segmentation
        is using it (then without: the same labels, computed in full)."""
        cache = self._cache
        if not cache.segment_lock.acquire(blocking=False):
            return segment(self.annotations, self.drawing, progress=self.progress)
        try:
            return segment(self.annotations, self.drawing, progress=self.progress,
                           memo=cache.segment_memo)
        finally:
            cache.segment_lock.release()

    def _ink_style(self):
        """The drawing's stroke width and stroke ends (for the order prediction), once per drawing."""
        cache = self._cache
        if cache.ink is None or cache.ink[0] != self._drawing_key:
            cache.ink = (self._drawing_key, ink_style(self.drawing.gray))
        return cache.ink[1]

    def _session_depth(self, segments_key):
        """The fast depth from the kept session: only the changed constraints are re-done,
        and new scribbles keep the session's factorization (it is updated where the
        segments moved). With regions the session's segments are this chain's
        segmentation (the same as the relief's and the labels preview's); the
        session is reseeded only when the scribbles or boundaries changed its labels."""
        o = self.options
        ann = self.annotations
        skey = (self._drawing_key, o.depth_epsilon)
        cache = self._cache
        if cache.session is not None and cache.session[0] == skey and \
                cache.session[3][0] == segments_key:
            _, session, handles, _ = cache.session
        else:
            if ann.regions:
                seeds, labels = None, self.segmentation.labels
                image = _digest(labels)
            else:
                seeds, labels = _seeds(ann), None
                image = None if seeds is None else _digest(seeds)
            if cache.session is None or cache.session[0] != skey:
                session, handles = DepthSession(self.drawing.gray, epsilon=o.depth_epsilon,
                                                seeds=seeds, labels=labels,
                                                incremental=True), {}
            else:
                _, session, handles, (_, seeded) = cache.session
                if image != seeded:
                    session.reseed(seeds, labels=labels)
            cache.session = (skey, session, handles, (segments_key, image))
        p, q, ineq, labels = depth_constraints(self.annotations)
        wanted = {(int(a), int(b), bool(c), lab) for a, b, c, lab in zip(p, q, ineq, labels)}
        for c in [c for c in handles if c not in wanted]:
            session.remove(handles.pop(c))
        try:
            for c in sorted(wanted - set(handles)):
                handles[c] = session.add(c[0], c[1], inequality=c[2], label=c[3])
            d = session.solve(draft=o.depth_draft)
        except InputError:
            cache.session = None  # a rejected edit must not stay in the kept session
            raise
        return DepthResult(depth=d, method="fast", epsilon=o.depth_epsilon,
                           info={"levels": dict(session.region_levels), "labels": session.parts,
                                 "timings": dict(session.timings), "draft": session.drafted})


def build_relief(annotations, drawing, *, predict=True, max_area=DEFAULT_MAX_AREA, epsilon=None,
                 closed=False, union=False, progress=None):
    """Build the bas-relief of an annotated drawing in one call.

    The same as ``ReliefChain(annotations, drawing, options=ChainOptions(...)).result()``.

    Parameters
    ----------
    annotations : inkray.input.annotations.Annotations
    drawing : inkray.input.drawing.Drawing
    predict, max_area, epsilon, closed, union
        See :class:`ChainOptions`.
    progress : inkray.progress.Progress, optional

    Returns
    -------
    ReliefResult

    Raises
    ------
    InputError
        Bad annotations (no regions, boundaries far from any outline,
        contradictory order).
    StageError
        A stage failed on valid input.
    """
    if not annotations.regions:
        raise InputError("regions: a relief needs at least one region")
    options = ChainOptions(predict=predict, max_area=max_area, epsilon=epsilon, closed=closed,
                           union=union)
    return ReliefChain(annotations, drawing, options=options, progress=progress).result()


def _silhouettes(labels, gray):
    """The parts grown over their contour strokes (soft edges included) and one pixel of
    paper beyond them, so that the smoothed outlines keep the whole stroke on the mesh."""
    stroke = ink_pixels(gray, level=_STROKE_EDGE)
    return pad_ink_edge(grow_over_ink(labels, stroke), stroke)


# -- content keys ------------------------------------------------------------------

def _digest(*parts):
    """A short hash of arrays, numbers, strings and nested tuples of them."""
    h = hashlib.blake2b(digest_size=16)

    def feed(x):
        if isinstance(x, np.ndarray):
            h.update(f"a{x.dtype.str}{x.shape}".encode())
            h.update(np.ascontiguousarray(x).tobytes())
        elif isinstance(x, (tuple, list)):
            h.update(f"t{len(x)}".encode())
            for y in x:
                feed(y)
        else:
            h.update(f"s{x!r}".encode())
    feed(parts)
    return h.hexdigest()


def _scribbles_key(ann):
    return _digest(_seeds_key(ann), tuple(r.name for r in ann.regions))


def _seeds_key(ann):
    """What the seed image is made of: the scribbles and pixels in region order
    (not the regions' names), in far less time than rasterizing and hashing it."""
    return _digest(tuple(ann.size), *(
        (tuple(np.asarray(s, float) for s in r.scribbles),
         None if r.pixels is None else np.asarray(r.pixels)) for r in ann.regions),
        tuple(np.asarray(s, float) for s in ann.background),
        None if ann.background_pixels is None else np.asarray(ann.background_pixels))


def _entries_key(ann):
    return _digest(tuple((tuple(map(float, o.front)), tuple(map(float, o.back))) for o in ann.order),
                   tuple((tuple(map(float, e.a)), tuple(map(float, e.b))) for e in ann.equal))


def _seeds(ann):
    """The fast depth method's segmentation seeds, or None without scribbles."""
    if not ann.regions and not ann.background and ann.background_pixels is None:
        return None
    return seed_image(ann)


def _label_window(labels, mask):
    """The labels a region's outline reads: its box and a margin."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    h, w = labels.shape
    return labels[max(rows[0] - _LABEL_MARGIN, 0):min(rows[-1] + _LABEL_MARGIN + 1, h),
                  max(cols[0] - _LABEL_MARGIN, 0):min(cols[-1] + _LABEL_MARGIN + 1, w)]

