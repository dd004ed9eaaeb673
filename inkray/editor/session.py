"""One editing session: an annotation document, its drawing and the chain of its results.

The editor serves the interactive workflow of Sýkora et al., "Adding Depth to
Cartoons Using Sparse Depth (In)equalities" (CGF 2010) and "Ink-and-Ray"
(TOG 2014): the artist adds a hint, the depth and the relief answer at once,
and predicted relations are accepted or flipped where they are wrong.

A :class:`EditSession` holds the current document (the v1 JSON object, kept
as sent so that a save writes exactly it), one
:class:`~inkray.chain.ReliefChain` whose content-keyed cache makes undo
instant, and a generation counter. Every replacement of the document bumps the
generation; a preview is computed under a lock for the newest generation and
is never answered for an older one.
"""

import hashlib
import json
import re
import threading
import time
from collections import OrderedDict
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from inkray.artefacts import ARTEFACTS
from inkray.chain import ChainOptions, ReliefChain
from inkray.depthmap.estimation import fill_weights
from inkray.errors import InkrayError, InputError
from inkray.formats.atomic import write_text
from inkray.formats.labels import label_palette
from inkray.input.annotations import FORMAT, VERSION, decode_annotations, parse_annotations
from inkray.input.drawing import load_drawing
from inkray.input.files import read_bytes
from inkray.input.limits import DEFAULT_LIMITS
from inkray.input.scribbles import polyline_pixels
from inkray.numerics.threads import reserve_core
from inkray.progress import Progress
from inkray.segmentation import INK_THRESHOLD
from inkray.validation import validate

__all__ = ["EditSession", "Preview", "PREVIEWS", "autosave_path", "dump_annotations",
           "entry_paths", "plain_contradiction"]

#: The previews a session computes, by the name of their endpoint file.
PREVIEWS = ("labels.png", "depth.png", "relief.glb")

_ENTRY = re.compile(r"\b(regions|background|order|equal|boundaries)\[(\d+)\]")
_SUGGEST_RADIUS = 40  # px around a prediction's pixel searched for its arrow's ends
#: An accepted arrow's ends lie this far inside their regions where they can (and at
#: least half as deep as the deepest pixel near the place), so that they stay in their
#: parts when the segmentation moves by a few pixels.
_SUGGEST_DEPTH = 12.0
_SNAP_RADIUS = 25  # px from a click to the region outline a two-click boundary follows
_PATH_TOLERANCE = 0.75  # px a two-click boundary's polyline may depart from the outline pixels
_FILES_BYTES = 256 * 2**20  # encoded previews kept for undo (a 1 Mpx relief GLB is ~10 MB)
_POLL = 0.005  # s between looks at a segmentation the depth map waits for
#: At most this long a relief waits for a depth map being computed (see _depth_first).
_DEPTH_WAIT = 0.4


@dataclass
class Preview:
    """One computed preview.

    Attributes
    ----------
    body : bytes
    media_type : str
    generation : int
        The document generation it shows.
    compute_ms : float
        Time spent computing it (0 when every stage came from the cache).
    draft : bool, default False
        A depth draft (the fill at half resolution); a draft request that
        got the full depth map has False, and the full map need not be asked.
    """

    body: bytes
    media_type: str
    generation: int
    compute_ms: float
    draft: bool = False


def autosave_path(path):
    """Where unsaved changes of annotation file ``path`` are kept: ``path`` + ``.autosave``.

    Examples
    --------
    >>> autosave_path("frog/drawing.inkray.json").name
    'drawing.inkray.json.autosave'
    """
    path = Path(path)
    return path.with_name(path.name + ".autosave")


def entry_paths(message):
    """The entries (``order[3]``, ``boundaries[0]``) an error message names, in order, once each.

    Examples
    --------
    >>> entry_paths("order[0] -> order[1] -> order[0]: contradictory depth constraints")
    ['order[0]', 'order[1]']
    """
    out = []
    for m in _ENTRY.finditer(message):
        key = f"{m.group(1)}[{m.group(2)}]"
        if key not in out:
            out.append(key)
    return out


class EditSession:
    """The annotation file being edited, its drawing and the previews of its current document.

    Parameters
    ----------
    path : str or pathlib.Path
        The annotation file. When it exists it is loaded (an autosave beside
        it, from an editor that was not saved, is loaded instead when valid);
        otherwise a new empty annotation is started for ``drawing``.
    drawing : str or pathlib.Path, optional
        The drawing; needed when ``path`` does not exist or has no
        ``drawing`` key.
    document : dict, optional
        The document to start from when ``path`` does not exist (its
        ``drawing`` key the drawing's path relative to ``path``), e.g. a
        frame's annotation carried from a key; default an empty annotation.

    Attributes
    ----------
    path, autosave : pathlib.Path
    drawing : inkray.input.drawing.Drawing
    restored : bool
        The document came from the autosave.

    Raises
    ------
    InputError
        A bad annotation file or drawing, with the CLI's message.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from inkray.examples import example_path
    >>> new = pathlib.Path(tempfile.mkdtemp()) / "turtle.inkray.json"
    >>> s = EditSession(new, drawing=example_path("turtle").parent / "drawing.png")
    >>> s.document["size"], s.generation, new.exists()
    ([512, 512], 0, False)
    """

    #: The :class:`inkray.editor.shot.Shot` whose frames this session steps through, if any.
    shot = None

    def __init__(self, path, *, drawing=None, document=None):
        self.path = Path(path)
        self.autosave = autosave_path(self.path)
        self.restored = False
        if self.path.exists():
            doc = self._read(self.path)
            ann = parse_annotations(doc)
            if drawing is None and ann.drawing is None:
                raise InputError(f"{self.path}: drawing: no drawing given (add a \"drawing\" key "
                                 f"or pass --drawing)")
            image_path = Path(drawing) if drawing is not None else self.path.parent / ann.drawing
        else:
            if drawing is None:
                raise InputError(f"{self.path}: no such file; pass --drawing to start a new "
                                 f"annotation for a drawing")
            image_path = Path(drawing)
            doc = None
        self.drawing = load_drawing(image_path)
        if doc is None and document is not None:
            doc = document
        elif doc is None:
            w, h = self.drawing.size
            rel = Path(_relative(image_path, self.path.parent)).as_posix()
            doc = {"format": FORMAT, "version": VERSION, "drawing": rel, "size": [w, h],
                   "regions": [], "background": [], "order": [], "equal": [], "boundaries": []}
        self._drawing_key = doc.get("drawing")
        # The depth map (2010) shares no stage with the relief (2014): each has its own
        # lock, so a slow depth factorization does not hold the relief back.
        self._locks = {"depth": threading.Lock(), "relief": threading.Lock()}
        self._state = threading.Lock()  # around the document, its chain and generation
        self._autosave_lock = threading.Lock()
        self._files = OrderedDict()  # (preview, document digest) -> bytes
        self._files_lock = threading.Lock()
        self._files_size = 0
        self.generation = 0
        self._closed = False
        self.saved = self.path.exists()
        self._chain = None
        self._parts = None
        self._file_doc = doc
        self._set(doc)
        if self.autosave.is_file():
            try:
                kept = self._read(self.autosave)
            except InputError:
                kept = None  # a broken autosave is left where it is; the file itself was loaded
            if kept is not None and kept == doc:
                self.autosave.unlink(missing_ok=True)  # nothing unsaved in it
            elif kept is not None:
                self._set(kept)
                self.restored = True
                self.saved = False

    # -- the document ------------------------------------------------------------

    @property
    def document(self):
        """The current document (a JSON-ready dict)."""
        return self._doc

    @property
    def palette(self):
        """``#rrggbb`` colours of the label preview: background, then each region in order."""
        n = len(self._doc.get("regions", []))
        return ["#%02x%02x%02x" % tuple(int(v) for v in c) for c in label_palette(n)]

    def replace(self, raw):
        """Replace the document with the JSON text ``raw``; nothing changes when it is bad.

        Parameters
        ----------
        raw : bytes or str

        Returns
        -------
        int
            The new generation.

        Raises
        ------
        InputError
            The CLI's one-line message, starting with the key path.
        """
        doc = decode_annotations(raw, where=self.path.name)
        return self._set(doc, write_autosave=True)

    def save(self):
        """Write the document to the annotation file (atomically) and drop the autosave.

        The document must pass :func:`inkray.validation.validate` as the file
        would: a document that ``inkray validate`` refuses (a contradictory
        order cycle, a boundary far from every outline) is not written.

        Returns
        -------
        pathlib.Path

        Raises
        ------
        InputError
            The first error ``inkray validate`` would report, one line; nothing written.
        """
        with self._state:
            text = dump_annotations(self._doc)
            generation = self.generation
            chain = self._chain
        errors = [p for p in validate(chain) if p.severity == "error"]
        if errors:
            raise InputError(errors[0].message)
        write_text(self.path, text)
        with self._state:
            if self.generation == generation:
                self.saved = True
                self.autosave.unlink(missing_ok=True)
        return self.path

    def discard(self):
        """Drop the autosave and go back to the file (or to the empty new document).

        Returns
        -------
        int
            The new generation.
        """
        with self._autosave_lock:
            self.autosave.unlink(missing_ok=True)
        generation = self._set(self._file_doc, write_autosave=True, autosave=False)
        with self._state:
            self.restored = False
            self.saved = self.path.exists()
        return generation

    def explain(self, message):
        """``message`` about contradictory entries in plain words, or None (see
        :func:`plain_contradiction`)."""
        with self._state:
            doc, chain = self._doc, self._chain
        if not chain.segmented:
            return None
        return plain_contradiction(message, doc, chain.segmentation.labels,
                                   chain.segmentation.names)

    def scribble_region(self, points, *, current=None):
        """The region a new region scribble along ``points`` extends, or None for a new one.

        A part of the drawing is an area of paper enclosed by ink; a scribble
        extends the region that already has a scribble in the part under
        most of its pixels (``current`` first when several do, then the one
        the segmentation gives most of its pixels to), and starts a new
        region in a part no region holds.

        Parameters
        ----------
        points : (k, 2) sequence of [x, y]
        current : int, optional
            The region picked in the page.

        Returns
        -------
        int or None
        """
        parts = self._paper_parts()
        part = _majority(parts, points)
        if part is None:
            return None
        with self._state:
            regions = self._doc.get("regions", [])
            chain = self._chain
        holders = [i for i, r in enumerate(regions)
                   if any(_majority(parts, line, every=True) & {part} for line in r["scribbles"])]
        if not holders:
            return None
        if current in holders:
            return current
        if len(holders) > 1 and chain.segmented:
            # parts joined through a gap in the ink: the region the segmentation gives the
            # scribble's pixels to
            rows, cols = polyline_pixels(np.asarray(points, float).reshape(-1, 2), parts.shape)
            votes = np.bincount(chain.segmentation.labels[rows, cols] + 1, minlength=len(regions) + 1)
            return max(holders, key=lambda i: votes[i + 1])
        return holders[0]

    def on_edge(self, points):
        """Whether the paper part under most of the polyline ``points`` touches the
        drawing's edge (the paper around the character, mostly)."""
        parts = self._paper_parts()
        part = _majority(parts, points)
        edge = np.concatenate([parts[0], parts[-1], parts[:, 0], parts[:, -1]])
        return part is not None and bool((edge == part).any())

    def outline_path(self, start, end):
        """A boundary path from ``start`` to ``end`` along the nearest region outline.

        Both points snap to the outline of the one region whose outline passes
        nearest to both (within a few pixels); the path is the shortest way
        between the two snapped pixels along that outline (8-connected), as a
        polyline within a pixel of it.

        Parameters
        ----------
        start, end : (float, float)
            ``[x, y]`` in drawing pixels.

        Returns
        -------
        dict
            ``{"path": [[x, y], ...], "region": name, "generation"}``.

        Raises
        ------
        InputError
            No region outline passes near both points.
        """
        def compute(chain, digest):
            seg = chain.segmentation
            path, region = _outline_path(seg.labels, start, end)
            return {"path": path, "region": seg.names[region]}

        return self.newest(compute, lock="relief", wrap=False)

    def switch(self, path, *, drawing=None, document=None):
        """Edit another annotation file in this session (the next frame of a shot).

        The parameters are those of :class:`EditSession`. The generation goes
        on from the current one, so no answer for the previous file is taken
        for one of the new; work under way for it stops at its next stage.

        Returns
        -------
        int
            The new generation.

        Raises
        ------
        InputError
            As :class:`EditSession`; nothing changes.
        """
        fresh = EditSession(path, drawing=drawing, document=document)
        kept = ("_locks", "_state", "_autosave_lock", "_files_lock", "generation", "_closed")
        with self._state:
            for name, value in vars(fresh).items():
                if name not in kept:
                    setattr(self, name, value)
            self.generation += 1
            generation = self.generation
        self._set(self._doc)  # the chain's progress answers to this session
        return generation

    def close(self):
        """Stop the work under way (at its next stage) and refuse new previews."""
        with self._state:
            self._closed = True
            self._watch = None

    # -- previews ----------------------------------------------------------------

    def preview(self, name, *, exact=False, draft=False):
        """The preview ``name`` (one of :data:`PREVIEWS`) of the newest document.

        Parameters
        ----------
        name : str
        exact : bool, default False
            The depth map by the exact method instead of the fast one.
        draft : bool, default False
            The fast depth map with its Laplace fill solved at half
            resolution (above 0.3 Mpx): the first answer after an edit,
            before the full one. On opening it is the full map (its
            reduced system is as fast): then it is encoded as the full map,
            which the full request reuses, and the answer's ``draft`` is
            False.

        Returns
        -------
        Preview

        Raises
        ------
        InputError
            The document cannot be computed (a contradiction, a boundary far
            from any outline, no region for a relief).
        """
        if name not in PREVIEWS:
            raise KeyError(name)
        artefact = _PREVIEW[name]
        if name == "depth.png":
            self._segmentation_first()
        elif name == "relief.glb":
            self._depth_first()
        params = {}
        if name == "depth.png" and exact:
            params = dict(method="exact")
        elif name == "depth.png" and draft:
            params = dict(draft=True)
        key = (name, *sorted(params.items()))
        # The depth map is the first answer the page waits for: while it computes, the
        # relief's maps of independent solves run one at a time beside it on two cores
        # instead of taking both.
        first = reserve_core() if name == "depth.png" else nullcontext()
        if name == "depth.png" and draft:
            def compute(chain, digest):
                body, drafted = self._draft(chain, digest)
                return body, artefact.media_type, drafted
        else:
            def compute(chain, digest):
                return (self._encoded((*key, digest), lambda: artefact.preview(chain, **params)),
                        artefact.media_type)
        try:
            with first:
                return self.newest(compute, lock="depth" if name == "depth.png" else "relief")
        finally:
            if name == "relief.glb":
                self._prepare_depth()

    def relations(self):
        """The user's and the predicted relations and the warnings of the newest document.

        Returns
        -------
        dict
            ``{"generation", "relations": [...], "warnings": [...], "error", "paths"}``;
            ``error`` is the message when the order cannot be computed and
            ``paths`` the entries it names.
        """
        def compute(chain, digest):
            try:
                relations = chain.relations
            except InputError as e:
                return {"relations": [], "warnings": chain.warnings, "error": str(e),
                        "paths": entry_paths(str(e))}
            labels = chain.segmentation.labels
            return {"relations": [_relation(r, labels) for r in relations],
                    "warnings": chain.warnings, "error": None, "paths": []}

        return self.newest(compute, lock="relief", wrap=False)

    # -- internals ------------------------------------------------------------------

    def _read(self, path):
        raw = read_bytes(path, "annotation file", limit=DEFAULT_LIMITS.file_bytes)
        return decode_annotations(raw, where=str(path))

    def _paper_parts(self):
        """The drawing's areas of paper enclosed by ink, labelled 1.. (0 on ink); kept."""
        if self._parts is None:
            self._parts = ndimage.label(self.drawing.gray >= INK_THRESHOLD)[0]
        return self._parts

    def _set(self, doc, *, write_autosave=False, autosave=True):
        ann = parse_annotations(doc)
        if doc.get("drawing") != self._drawing_key:
            raise InputError(f"drawing: this editor edits the annotation of "
                             f"{json.dumps(self._drawing_key)}; keep that value")
        ann.drawing = self.drawing.path
        ann.source = self.path
        watch = _Watch(self)
        if self._chain is None:
            chain = ReliefChain(ann, self.drawing, options=ChainOptions(
                interactive=True, depth_method="fast"), progress=watch)
        else:
            chain = self._chain.edit(annotations=ann, progress=watch)
        digest = hashlib.blake2b(json.dumps(doc, sort_keys=True).encode(), digest_size=16).digest()
        with self._state:
            self._doc = doc
            self._chain = chain
            self._digest = digest
            self._watch = watch
            self.generation += 1 if write_autosave else 0
            self.saved = self.saved and not write_autosave
            generation = self.generation
            text = dump_annotations(doc) if write_autosave and autosave else None
        if text is not None:
            with self._autosave_lock:
                if self.generation == generation:  # a newer edit writes its own
                    write_text(self.autosave, text)
        return generation

    def _segmentation_first(self):
        """Wait until the newest document's segmentation is computed, computing it
        when no one is.

        After a scribble the page asks for the segmentation and the depth map
        at once; the segmentation (the overlay drawn on the drawing) takes a
        few tenths of a second alone at 1 Mpx and twice that beside a depth
        computation, which takes seconds. So the depth map starts after it.
        When something else holds the relief lock, it is either that
        segmentation or a relief past it (a relief computes the segmentation
        first), so this polls until the segmentation is cached or the lock is
        free, computing meanwhile what the relief needs of the drawing alone.
        """
        prepared = False
        while True:
            with self._state:
                chain = self._chain
            if self._closed or chain.segmented:
                return
            lock = self._locks["relief"]
            if lock.acquire(timeout=_POLL):
                lock.release()
                try:
                    self.preview("labels.png")
                except Exception:  # noqa: BLE001 - its own request reports it
                    pass
                return
            if not prepared:
                # what the relief's order and the depth map's fill need of the drawing
                # alone, in time this thread waits anyway (a segmentation at 1 Mpx
                # takes about twice as long)
                chain.prepare_drawing()
                fill_weights(self.drawing.gray)
                prepared = True

    def _prepare_depth(self):
        """Ready the depth session for the next edit while the user looks at the
        previews (the relief is the last an edit asks for).

        A cold open factors the depth map's fill without the update matrices
        that make a later scribble's re-solve an update (half the time, and
        the open is what the user waits for); this factors it again keeping
        them, in a thread of its own, unless a depth map is being computed.
        An arrow meanwhile does not wait for it; a change that needs it does.
        """
        lock = self._locks["depth"]
        if not lock.acquire(blocking=False):
            return
        try:
            with self._state:
                chain = None if self._closed else self._chain
            if chain is not None:
                chain.prepare_depth(background=True)
        finally:
            lock.release()

    def _depth_first(self):
        """Wait a little for a depth map being computed before starting a relief.

        After an arrow the page asks for both at once; on two cores the re-solve
        took 0.3-0.5 s at 1 Mpx beside the relief instead of 0.2 s alone, and
        the relief has time to spare. A depth map that takes longer (a fresh
        factorization after a scribble) is not waited for past
        :data:`_DEPTH_WAIT`.
        """
        end = time.monotonic() + _DEPTH_WAIT
        while (self._locks["depth"].locked() and not self._closed
               and time.monotonic() < end):
            time.sleep(_POLL)

    def _draft(self, chain, digest):
        """The depth draft's bytes and whether they are a draft, not the full map.

        The full map when it is known for this document, or when the fill
        that answered the draft was the full one (a cold open): then encoded
        once, as the full request's answer.
        """
        artefact = _PREVIEW["depth.png"]
        full, half = ("depth.png", digest), ("depth.png", ("draft", True), digest)
        for key, drafted in ((full, False), (half, True)):
            with self._files_lock:
                if key in self._files:
                    self._files.move_to_end(key)
                    return self._files[key], drafted
        result = artefact.make(chain, draft=True)
        drafted = result.info.get("draft", False)
        return self._encoded(half if drafted else full,
                             lambda: artefact.encode(result, draft=drafted)), drafted

    def _encoded(self, key, make):
        """The file bytes of a preview of a document, kept by the document's digest.

        The same document always gives the same bytes, so undo answers without
        asking the chain or encoding again.
        """
        with self._files_lock:
            if key in self._files:
                self._files.move_to_end(key)
                return self._files[key]
        body = make()
        with self._files_lock:
            if key not in self._files:
                self._files[key] = body
                self._files_size += len(body)
            while self._files_size > _FILES_BYTES and len(self._files) > 1:
                self._files_size -= len(self._files.popitem(last=False)[1])
        return body

    def newest(self, compute, *, lock, wrap=True):
        """``compute(chain, digest)`` for the newest generation; an edit during it starts it again.

        For work on the session's chain beside the previews (the Pose mode's
        pictures): ``lock`` is ``"depth"`` or ``"relief"``, the stages it
        shares a lock with; with ``wrap`` the value ``(body, media type)``
        (or ``(body, media type, draft)``) comes back as a :class:`Preview`.
        """
        while True:
            with self._state:
                if self._closed:
                    raise InkrayError("the editor is closing")
                generation, chain, digest = self.generation, self._chain, self._digest
            with self._locks[lock]:
                if self.generation != generation:
                    continue  # superseded while waiting: never compute stale work
                start = time.perf_counter()
                try:
                    value = compute(chain, digest)
                except _Superseded:
                    continue  # stopped at a stage boundary; finished stages stay cached
                ms = (time.perf_counter() - start) * 1000
            if self.generation == generation:
                break
        if not wrap:
            return dict(value, generation=generation, compute_ms=ms)
        body, media_type, *drafted = value
        return Preview(body=body, media_type=media_type, generation=generation, compute_ms=ms,
                       draft=bool(drafted and drafted[0]))


class _Superseded(BaseException):
    """A newer document arrived while this one's preview was computing.

    A BaseException, so that no stage's error handling mistakes it for a failure.
    """


class _Watch(Progress):
    """The progress of one document's chain: it stops the chain's work once a newer
    document replaced it (at the next stage or progress step)."""

    def __init__(self, session):
        super().__init__(quiet=True)
        self._session = session

    def _check(self):
        if self._session._watch is not self:
            raise _Superseded()

    def update(self, done, total):
        self._check()

    @contextmanager
    def stage(self, name):
        self._check()
        with super().stage(name):
            yield self


#: preview -> the artefact it shows (:data:`inkray.artefacts.ARTEFACTS`)
_PREVIEW = {"labels.png": ARTEFACTS["labels"], "depth.png": ARTEFACTS["depth"],
            "relief.glb": ARTEFACTS["relief"]}


def _relation(r, labels):
    """A relation as JSON; a prediction gets the arrow that accepting it would add."""
    points = r.points
    if points is None:
        points = (_inside(labels, r.front, r.where), _inside(labels, r.back, r.where))
    return {"front": r.front_name, "back": r.back_name, "front_index": int(r.front),
            "back_index": int(r.back), "kind": r.kind, "source": r.source,
            "confidence": round(float(r.confidence), 4), "entry": r.entry, "label": r.label,
            "where": [round(float(v), 2) for v in r.where],
            "points": [[round(float(v), 2) for v in p] for p in points]}


def _inside(labels, region, where):
    """A pixel of ``region`` near ``where``, well inside its outline where it can be."""
    h, w = labels.shape
    x, y = int(round(where[0])), int(round(where[1]))
    r = _SUGGEST_RADIUS
    y0, y1, x0, x1 = max(y - r, 0), min(y + r + 1, h), max(x - r, 0), min(x + r + 1, w)
    mask = labels[y0:y1, x0:x1] == region
    if not mask.any():
        rows, cols = np.nonzero(labels == region)
        k = int(np.argmin((rows - y) ** 2 + (cols - x) ** 2))
        return float(cols[k]), float(rows[k])
    depth = ndimage.distance_transform_edt(np.pad(mask, 1))[1:-1, 1:-1]
    ok = depth >= min(_SUGGEST_DEPTH, depth.max() / 2)
    rows, cols = np.nonzero(ok)
    k = int(np.argmin((rows + y0 - y) ** 2 + (cols + x0 - x) ** 2))
    return float(cols[k] + x0), float(rows[k] + y0)


def _majority(parts, points, *, every=False):
    """The paper part under most pixels of the polyline ``points`` (None on ink only);
    with ``every``, the set of all parts it touches."""
    rows, cols = polyline_pixels(np.asarray(points, float).reshape(-1, 2), parts.shape)
    found = parts[rows, cols]
    found = found[found > 0]
    if every:
        return set(found.tolist())
    if not len(found):
        return None
    return int(np.bincount(found).argmax())


def _outline_path(labels, start, end):
    """The shortest 8-connected way along one region's outline between the pixels of
    that outline nearest ``start`` and ``end``; ``(polyline, region)``."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra
    from scipy.spatial import cKDTree
    from skimage.measure import approximate_polygon

    h, w = labels.shape
    inner = np.zeros(labels.shape, bool)  # a region's pixels with a 4-neighbour of another label
    inner[:, 1:] |= labels[:, 1:] != labels[:, :-1]
    inner[:, :-1] |= labels[:, :-1] != labels[:, 1:]
    inner[1:, :] |= labels[1:, :] != labels[:-1, :]
    inner[:-1, :] |= labels[:-1, :] != labels[1:, :]
    inner &= labels >= 0
    rows, cols = np.nonzero(inner)
    if not len(rows):
        raise InputError("boundary: no region outline in the segmentation to follow")
    tree = cKDTree(np.column_stack([cols, rows]))
    ends = [np.clip(np.asarray(p, float), 0, [w - 1, h - 1]) for p in (start, end)]
    best = None
    near = [tree.query_ball_point(p, _SNAP_RADIUS) for p in ends]
    for region in set(labels[rows[near[0]], cols[near[0]]].tolist()):
        snapped = []
        for p, idx in zip(ends, near):
            idx = [k for k in idx if labels[rows[k], cols[k]] == region]
            if not idx:
                break
            d = np.hypot(cols[idx] - p[0], rows[idx] - p[1])
            snapped.append((float(d.min()), idx[int(d.argmin())]))
        if len(snapped) == 2:
            cost = snapped[0][0] + snapped[1][0]
            if best is None or cost < best[0]:
                best = (cost, region, snapped[0][1], snapped[1][1])
    if best is None:
        raise InputError(f"boundary: no region outline passes within {_SNAP_RADIUS} px of both "
                         f"({ends[0][0]:g}, {ends[0][1]:g}) and ({ends[1][0]:g}, {ends[1][1]:g})")
    _, region, a, b = best
    own = np.flatnonzero(labels[rows, cols] == region)
    index = np.full(labels.shape, -1, np.int64)
    index[rows[own], cols[own]] = np.arange(len(own))
    src, dst, weight = [], [], []
    for dy, dx in ((0, 1), (1, -1), (1, 0), (1, 1)):
        y2, x2 = rows[own] + dy, cols[own] + dx
        ok = (y2 >= 0) & (y2 < h) & (x2 >= 0) & (x2 < w)
        j = np.full(len(own), -1)
        j[ok] = index[y2[ok], x2[ok]]
        keep = j >= 0
        src.append(np.flatnonzero(keep))
        dst.append(j[keep])
        weight.append(np.full(int(keep.sum()), np.hypot(dx, dy)))
    src, dst, weight = (np.concatenate(v) for v in (src, dst, weight))
    graph = coo_matrix((weight, (src, dst)), shape=(len(own), len(own))).tocsr()
    ia, ib = int(index[rows[a], cols[a]]), int(index[rows[b], cols[b]])
    dist, pred = dijkstra(graph, directed=False, indices=ia, return_predecessors=True)
    if not np.isfinite(dist[ib]):
        raise InputError(f"boundary: the two points lie on separate outlines of region "
                         f"{region} ({ends[0][0]:g}, {ends[0][1]:g}) and "
                         f"({ends[1][0]:g}, {ends[1][1]:g})")
    walk = [ib]
    while walk[-1] != ia:
        walk.append(int(pred[walk[-1]]))
    walk.reverse()
    pixels = np.column_stack([cols[own][walk], rows[own][walk]]).astype(float)
    path = approximate_polygon(pixels, tolerance=_PATH_TOLERANCE)
    return [[float(x), float(y)] for x, y in path], int(region)


def plain_contradiction(message, doc, labels, names):
    """A contradiction among the user's entries in plain words, naming the parts and places.

    Parameters
    ----------
    message : str
        The one-line error naming the cycle of entries (``order[0] -> order[4] -> order[0]``).
    doc : dict
        The document the entries are in.
    labels : (H, W) int array
        The segmentation (-1 background), to name the part under each end.
    names : sequence of str

    Returns
    -------
    str or None
        None when ``message`` names no cycle of ``order``/``equal`` entries.

    Examples
    --------
    >>> import numpy as np
    >>> labels = np.zeros((10, 20), int); labels[:, 10:] = 1
    >>> doc = {"order": [{"front": [2, 5], "back": [15, 5]}, {"front": [16, 4], "back": [3, 4]}]}
    >>> plain_contradiction("order: ... order[0] -> order[1] -> order[0] (a > b > a)",
    ...                     doc, labels, ["a", "b"])
    'the arrow at (8, 5) says a is in front of b, but the arrow at (10, 4) says b is in front of a'
    """
    cycle = re.search(r"((?:(?:order|equal)\[\d+\] -> )+(?:order|equal)\[\d+\])", message)
    if cycle is None:
        return None
    keys = cycle.group(1).split(" -> ")
    if keys[0] == keys[-1]:
        keys = keys[:-1]
    h, w = labels.shape

    def part(p):
        k = labels[min(max(int(round(p[1])), 0), h - 1), min(max(int(round(p[0])), 0), w - 1)]
        return "the background" if k < 0 else names[k]

    said = []
    for key in keys:
        kind, k = key.split("[")
        try:
            e = doc[kind][int(k[:-1])]
        except (KeyError, IndexError):
            return None
        a, b = (e["front"], e["back"]) if kind == "order" else (e["a"], e["b"])
        where = f"({(a[0] + b[0]) / 2:.0f}, {(a[1] + b[1]) / 2:.0f})"
        if kind == "order":
            said.append((where, "arrow", f"{part(a)} is in front of {part(b)}", part(a), part(b)))
        else:
            said.append((where, "equal mark", f"{part(a)} and {part(b)} are at the same depth",
                         part(a), part(b)))
    first, rest = said[0], said[1:]
    text = f"the {first[1]} at {first[0]} says {first[2]}"
    if not rest:
        return text
    marks = {m for _, m, *_ in rest}
    kind = ("arrows" if marks == {"arrow"} else "marks") if len(rest) > 1 else rest[0][1]
    places = " and ".join(w for w, *_ in rest)
    verb = "say" if len(rest) > 1 else "says"
    if len(rest) == 1:
        claim = rest[0][2]
    else:
        claim = "; ".join(r[2] for r in rest)
        claim = f"{first[4]} is in front of {first[3]} ({claim})"
    return f"{text}, but the {kind} at {places} {verb} {claim}"


def dump_annotations(doc):
    """The annotation document as compact, deterministic JSON text (format v1).

    Objects take a line per key (2-space indent, keys in their order); a
    point and a polyline take one line each, their coordinates rounded to
    0.1 px (integral values written as integers). Comment keys (``_...``)
    are kept as they are.

    Parameters
    ----------
    doc : dict

    Returns
    -------
    str

    Examples
    --------
    >>> print(dump_annotations({"size": [4, 3], "order": [{"front": [1.04, 2], "back": [3.0, 1.25]}],
    ...                         "background": [[[0, 0], [2.333, 1]]]}), end="")
    {
      "size": [4, 3],
      "order": [
        {"front": [1, 2], "back": [3, 1.2]}
      ],
      "background": [
        [[0, 0], [2.3, 1]]
      ]
    }
    """
    return _json_value(doc, "", False) + "\n"


def _json_value(value, indent, coordinates):
    if isinstance(value, dict):
        items = [(k, v) for k, v in value.items()]
        inner = [f"{json.dumps(k, ensure_ascii=False)}: "
                 f"{_json_value(v, indent + '  ', coordinates or k in _COORDINATE_KEYS)}"
                 if not k.startswith("_") else
                 f"{json.dumps(k, ensure_ascii=False)}: {json.dumps(v, ensure_ascii=False)}"
                 for k, v in items]
        if not inner:
            return "{}"
        if coordinates and all(_flat(v) for _, v in items):  # an order or equal entry
            return "{" + ", ".join(inner) + "}"
        return "{\n" + ",\n".join(indent + "  " + i for i in inner) + "\n" + indent + "}"
    if isinstance(value, list):
        if _flat(value):
            return "[" + ", ".join(_json_value(v, indent, coordinates) for v in value) + "]"
        if not value:
            return "[]"
        return ("[\n" + ",\n".join(indent + "  " + _json_value(v, indent + "  ", coordinates)
                                    for v in value) + "\n" + indent + "]")
    if coordinates and isinstance(value, float) and np.isfinite(value):
        value = round(value, 1)
        return str(int(value)) if value.is_integer() else repr(value)
    return json.dumps(value, ensure_ascii=False)


_COORDINATE_KEYS = ("scribbles", "background", "order", "equal", "boundaries", "path", "front",
                    "back", "a", "b")


def _flat(value):
    """Written on one line: a number, a string, a point, a polyline (a list of points)."""
    if isinstance(value, list):
        return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value) or \
            all(isinstance(v, list) and _flat(v) and all(not isinstance(u, list) for u in v)
                for v in value)
    return not isinstance(value, dict)


def _relative(path, start):
    import os

    try:
        return os.path.relpath(Path(path).resolve(), Path(start).resolve())
    except ValueError:  # another drive (Windows)
        return str(Path(path).resolve())
