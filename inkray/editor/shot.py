"""A shot in the editor: any frame opens with its annotation carried from the nearest key.

A shot is a folder of drawings, one per frame, in name order; a frame with its
own ``<frame>.inkray.json`` beside it is a key. Every other frame's annotation
is carried frame by frame from the nearest key, forward from an earlier one
or backward from a later one, exactly as ``inkray batch`` carries it
(:func:`inkray.batch.plan_shot`, :func:`inkray.batch.carry_state`: the
as-rigid-as-possible registration of Sýkora, Dingliana and Collins, NPAR
2009, in :mod:`inkray.transfer`). The entries whose match is low are named as
the entries to check. Saving a frame writes its own annotation file, which
makes it a key: the frames after it are then carried from it.
"""

import glob
import os
import threading
from pathlib import Path

from inkray.batch import _IMAGES, _chain_of, carry_state, find_frames, key_state, plan_shot
from inkray.errors import InputError
from inkray.formats.annotation_file import annotation_document

__all__ = ["Shot", "open_shot"]


class Shot:
    """The frames of a shot, its keys, and the carried annotation of any frame.

    Parameters
    ----------
    frame : str or pathlib.Path
        A drawing of the shot; the shot is every drawing of its folder with
        the same suffix.

    Attributes
    ----------
    folder : pathlib.Path
    current : str
        The frame being edited (its name: the file name without suffix).

    Raises
    ------
    InputError
        The drawing is missing, or no frame of the folder has an annotation.

    Examples
    --------
    >>> from inkray.examples import example_path
    >>> walk = example_path().parents[1] / "shots" / "krita_walkcycle"
    >>> shot = Shot(walk / "0002.png")
    >>> shot.current, list(shot.plan())[:3], shot.plan()["0003"]["source"]
    ('0002', ['0001', '0002', '0003'], '0002')
    """

    def __init__(self, frame):
        frame = Path(frame)
        if not frame.is_file():
            raise InputError(f"{frame}: no such drawing")
        if frame.suffix.lower() not in _IMAGES:
            raise InputError(f"{frame}: not a drawing (expected one of {', '.join(_IMAGES)})")
        self.folder = frame.parent
        self._pattern = os.path.join(glob.escape(str(self.folder)), "*" + frame.suffix)
        self.current = frame.name[:-len(frame.suffix)]
        self._states = {}  # (frame, key, key's stat) -> carried state, as batch makes it
        self._lock = threading.Lock()
        self._opening = threading.Lock()
        self.plan()  # fails early on a folder without a key

    def plan(self):
        """Which key each frame is carried from (:func:`inkray.batch.plan_shot`).

        Returns
        -------
        dict
            By frame name, in order: ``{"drawing", "annotation", "key", "source"}``.
        """
        frames = find_frames(self._pattern)
        if not any(Path(f.annotation).with_suffix(".inkray.json").is_file() for f in frames):
            raise InputError(f"{self.folder}: no key frame (save the annotation of one frame as "
                             f"<frame>.inkray.json beside its drawing)")
        return plan_shot(frames, ())

    def annotation_path(self, name):
        """The annotation file of frame ``name`` (it makes the frame a key once written)."""
        return Path(self.plan()[name]["drawing"]).with_suffix(".inkray.json")

    def carry(self, name):
        """The annotation of frame ``name`` carried from its key, and the transfer's report.

        Parameters
        ----------
        name : str

        Returns
        -------
        document : dict or None
            The carried annotation document (None for a key frame).
        report : dict or None
            :func:`inkray.formats.annotation_file.transfer_report` of the last
            step (the matches multiplied along the chain); None for a key.

        Raises
        ------
        InputError
            An unknown frame, or a key or frame that cannot be read.
        """
        plan = self.plan()
        if name not in plan:
            raise InputError(f"frame: no frame {name!r} in {self.folder} "
                             f"(frames {', '.join(plan)})")
        step = plan[name]
        if step["source"] is None:
            return None, None
        signature = _signature(step["key"])
        with self._lock:
            # States carried from a key that changed, or from what is no longer the frame's
            # key (a frame saved between them), are stale.
            self._states = {k: v for k, v in self._states.items()
                            if plan.get(k[0], {}).get("key") == k[1] and k[1:] == _signature(k[1])}
            state = None
            for frame in _chain_of(plan, name):
                cached = self._states.get((frame,) + signature)
                if cached is None:
                    if state is None:
                        cached = key_state(plan[frame]["annotation"])
                    else:
                        cached = carry_state(state, plan[frame]["drawing"])
                    if cached["error"] is not None:
                        raise InputError(cached["error"])
                    self._states[(frame,) + signature] = cached
                state = cached
        drawing = Path(step["drawing"]).name
        return annotation_document(state["annotations"], drawing=drawing), state["transfer"]

    def describe(self):
        """The shot as the editor's page shows it.

        Returns
        -------
        dict
            ``{"folder", "frames": [names], "keys": [names], "current", "key"
            (the key file the current frame is carried from, None for a key),
            "carried_from" (the neighbouring frame), "check" (one line per
            entry to check), "entries" (every entry's match)}``.
        """
        plan = self.plan()
        step = plan.get(self.current, {"source": None, "key": None})
        report = self.carry(self.current)[1] if step["source"] is not None else None
        return {"folder": str(self.folder), "frames": list(plan),
                "keys": [n for n, s in plan.items() if s["source"] is None],
                "current": self.current,
                "key": None if step["source"] is None else Path(step["key"]).name,
                "carried_from": step["source"],
                "check": [] if report is None else list(report["check"]),
                "entries": [] if report is None else report["entries"]}

    def open(self, session, name):
        """Make ``session`` edit frame ``name``: its own annotation, or the carried one.

        Parameters
        ----------
        session : inkray.editor.session.EditSession
        name : str

        Returns
        -------
        dict
            :meth:`describe` of the frame opened.
        """
        with self._opening:  # one frame after the other: the session and ``current`` agree
            document, _ = self.carry(name)
            plan = self.plan()
            session.switch(self.annotation_path(name), drawing=plan[name]["drawing"],
                           document=document)
            self.current = name
            return self.describe()


def open_shot(frame):
    """An editing session of the drawing ``frame`` of a shot, and the shot.

    Parameters
    ----------
    frame : str or pathlib.Path
        A drawing in a folder of frames of which at least one has its
        ``<frame>.inkray.json``.

    Returns
    -------
    inkray.editor.session.EditSession
        Editing ``<frame>.inkray.json``: the frame's own annotation when it is
        a key, else the annotation carried to it (unsaved until saved).
        Its ``shot`` attribute is the :class:`Shot`.

    Raises
    ------
    InputError

    Examples
    --------
    >>> import shutil, tempfile, pathlib
    >>> from inkray.examples import example_path
    >>> walk = example_path().parents[1] / "shots" / "krita_walkcycle"
    >>> shot = pathlib.Path(tempfile.mkdtemp())
    >>> for name in ("0001.inkray.json", "0001.png", "0002.png"):
    ...     _ = shutil.copy(walk / name, shot / name)
    >>> session = open_shot(shot / "0002.png")
    >>> session.path.name, session.saved, session.shot.describe()["keys"]
    ('0002.inkray.json', False, ['0001'])
    """
    from inkray.editor.session import EditSession

    shot = Shot(frame)
    document, _ = shot.carry(shot.current)
    frame = Path(frame)
    session = EditSession(frame.with_name(shot.current + ".inkray.json"), drawing=frame,
                          document=document)
    session.shot = shot
    return session


def _signature(key):
    """The key file as its carried states depend on it: path, time written and size."""
    try:
        stat = os.stat(key)
    except OSError as e:
        raise InputError(f"{key}: cannot read the key ({e.strerror or e})") from None
    return (key, stat.st_mtime_ns, stat.st_size)
