"""The editor's Pose mode on the server: posed pictures of the newest document, and pose files.

A drag in the page sends the handles (points on the drawing) and their
targets; the answer is the posed drawing as PNG (:mod:`inkray.view.posed`,
as-rigid-as-possible after Igarashi et al., SIGGRAPH 2005). The rig and its
factorization are kept per document generation and handle set, so a drag is
one warm-started solve and one picture.
"""

import json
import struct
import threading
import time
import zlib

import numpy as np

from inkray.errors import InputError
from inkray.formats.atomic import write_text
from inkray.input.pose import parse_pose, pose_path
from inkray.view.posed import PosedDrawing

__all__ = ["PoseSession"]

_STORED = 300_000  # px: pictures up to this size are sent uncompressed


class PoseSession:
    """Posed pictures and pose files of an :class:`~inkray.editor.session.EditSession`.

    Parameters
    ----------
    session : inkray.editor.session.EditSession
    """

    def __init__(self, session):
        self.session = session
        self._lock = threading.Lock()
        self._posed = None  # (generation, handles key, PosedDrawing)

    def picture(self, handles, targets, *, scale=1.0):
        """The posed drawing of the newest document as PNG bytes.

        Parameters
        ----------
        handles, targets : list of [x, y]
        scale : float, default 1
            Output pixels per drawing pixel: the page asks for a smaller
            picture while a handle moves and the full one when it stops.

        Returns
        -------
        body : bytes
        compute_ms : float
        generation : int

        Raises
        ------
        InputError
            Bad points, a handle on no part, or a document without regions.
        """
        if not (isinstance(scale, (int, float)) and not isinstance(scale, bool)
                and 0.05 <= scale <= 1):
            raise InputError(f"scale: expected a number within 0.05..1, got {scale!r}")
        doc = parse_pose({"format": "inkray-pose", "version": 1, "handles": handles,
                          "keys": [{"frame": 0, "to": targets}]},
                         size=tuple(self.session.drawing.size))

        def compute(chain, digest):
            if not chain.annotations.regions:
                raise InputError("regions: posing needs at least one region")
            key = doc.handles.tobytes()
            with self._lock:
                cached = self._posed
                if cached is None or cached[0] != digest or cached[1] != key:
                    posed = PosedDrawing(chain.relief, chain.completion, chain.relations,
                                         chain.drawing, doc.handles,
                                         boundaries=chain.annotations.boundaries)
                    self._posed = cached = (digest, key, posed)
                posed = cached[2]
                rgba = posed.image(posed.positions(doc.keys[0].to), scale=scale)
            # a picture of a quarter megapixel (what the page asks while a handle moves) is
            # stored: deflating it takes longer than the loopback takes to carry it
            return _png(rgba, level=0 if rgba.shape[0] * rgba.shape[1] <= _STORED else 1), \
                "image/png"

        start = time.perf_counter()
        p = self.session.newest(compute, lock="relief")
        return p.body, (time.perf_counter() - start) * 1000, p.generation

    def save(self, document):
        """Write ``document`` (a pose file's JSON) beside the annotation file; its path.

        Raises
        ------
        InputError
            The document breaks the pose format (key path in the message).
        """
        parse_pose(document, size=tuple(self.session.drawing.size))
        path = pose_path(self.session.path)
        write_text(path, json.dumps(document, indent=1) + "\n")
        return path


def _png(rgba, *, level):
    """RGBA as a PNG file (ISO/IEC 15948), every row unfiltered, deflated at zlib ``level``."""
    h, w = rgba.shape[:2]
    rows = np.zeros((h, 4 * w + 1), np.uint8)  # a leading 0 per row: filter type None
    rows[:, 1:] = rgba.reshape(h, 4 * w)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)  # 8 bits, RGBA, no interlace
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(rows.tobytes(), level)) + chunk(b"IEND", b""))
