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
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from inkray.artefacts import ARTEFACTS
from inkray.chain import ChainOptions, ReliefChain
from inkray.errors import InkrayError, InputError
from inkray.formats.atomic import write_text
from inkray.formats.labels import label_palette
from inkray.input.annotations import FORMAT, VERSION, decode_annotations, parse_annotations
from inkray.input.drawing import load_drawing
from inkray.input.files import read_bytes
from inkray.input.limits import DEFAULT_LIMITS
from inkray.progress import Progress

__all__ = ["EditSession", "Preview", "PREVIEWS", "autosave_path", "entry_paths"]

#: The previews a session computes, by the name of their endpoint file.
PREVIEWS = ("labels.png", "depth.png", "relief.glb")

_ENTRY = re.compile(r"\b(regions|background|order|equal|boundaries)\[(\d+)\]")
_SUGGEST_RADIUS = 40  # px around a prediction's pixel searched for its arrow's ends
_SUGGEST_DEPTH = 3.0  # px an accepted arrow's end lies inside its region, where it can
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
    """

    body: bytes
    media_type: str
    generation: int
    compute_ms: float


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

    def __init__(self, path, *, drawing=None):
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
        if doc is None:
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
        self._set(doc)
        if self.autosave.is_file():
            try:
                self._set(self._read(self.autosave))
                self.restored = True
                self.saved = False
            except InputError:
                pass  # a broken autosave is left where it is; the file itself was loaded

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

        Returns
        -------
        pathlib.Path
        """
        with self._state:
            text = _dump(self._doc)
            generation = self.generation
        write_text(self.path, text)
        with self._state:
            if self.generation == generation:
                self.saved = True
                self.autosave.unlink(missing_ok=True)
        return self.path

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
            before the full one.

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
        return self._newest(lambda chain, digest: (self._encoded(
            (*key, digest), lambda: artefact.preview(chain, **params)), artefact.media_type),
            lock="depth" if name == "depth.png" else "relief")

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

        return self._newest(compute, lock="relief", wrap=False)

    # -- internals ------------------------------------------------------------------

    def _read(self, path):
        raw = read_bytes(path, "annotation file", limit=DEFAULT_LIMITS.file_bytes)
        return decode_annotations(raw, where=str(path))

    def _set(self, doc, *, write_autosave=False):
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
            text = _dump(doc) if write_autosave else None
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
        free.
        """
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

    def _newest(self, compute, *, lock, wrap=True):
        """``compute(chain)`` for the newest generation; an edit during it starts it again."""
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
        body, media_type = value
        return Preview(body=body, media_type=media_type, generation=generation, compute_ms=ms)


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
    """A pixel of ``region`` near ``where``, a few pixels inside its outline where it can be."""
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
    ok = depth >= min(_SUGGEST_DEPTH, depth.max())
    rows, cols = np.nonzero(ok)
    k = int(np.argmin((rows + y0 - y) ** 2 + (cols + x0 - x) ** 2))
    return float(cols[k] + x0), float(rows[k] + y0)


def _dump(doc):
    return json.dumps(doc, indent=2, ensure_ascii=False) + "\n"


def _relative(path, start):
    import os

    try:
        return os.path.relpath(Path(path).resolve(), Path(start).resolve())
    except ValueError:  # another drive (Windows)
        return str(Path(path).resolve())
