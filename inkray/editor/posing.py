"""The editor's Pose mode on the server: posed pictures of the newest document, and pose files.

A drag in the page sends the handles (points on the drawing) and their
targets; the answer is the posed drawing as PNG (:mod:`inkray.view.posed`,
as-rigid-as-possible after Igarashi et al., SIGGRAPH 2005), or only the posed
meshes' vertices, which the page draws itself with the parts' textured meshes
(:meth:`PoseSession.meshes`, asked once per document) while a handle moves.
The rig, its layers and colours are kept per document generation and the
factorization per handle set, so a drag is one warm-started solve (and one
picture).
"""

import base64
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
        self._drawing = None  # (document digest, PosedDrawing without handles)
        self._posed = None  # (document digest, handles key, PosedDrawing)
        self._solved = None  # (targets key, rig positions) of the last drag

    def _prepared(self, chain, digest, handles=None):
        """The newest document's :class:`PosedDrawing`, for ``handles`` when given (under
        ``self._lock``)."""
        if not chain.annotations.regions:
            raise InputError("regions: posing needs at least one region")
        if self._drawing is None or self._drawing[0] != digest:
            self._drawing = (digest, PosedDrawing(chain.relief, chain.completion, chain.relations,
                                                  chain.drawing, None,
                                                  boundaries=chain.annotations.boundaries))
        if handles is None:
            return self._drawing[1]
        key = handles.tobytes()
        if self._posed is None or self._posed[:2] != (digest, key):
            self._posed = (digest, key, self._drawing[1].with_handles(handles))
            self._solved = None
        return self._posed[2]

    def _positions(self, posed, targets):
        """The rig positions with the handles at ``targets`` (under ``self._lock``): the last
        drag's again when they are its targets, so that the picture where a handle stops is
        the pose the page drew while it moved."""
        key = targets.tobytes()
        if self._solved is None or self._solved[0] != key:
            self._solved = (key, posed.positions(targets))
        return self._solved[1]

    def _targets(self, handles, targets):
        """The handles and targets as a one-key pose document (bad points raise InputError)."""
        return parse_pose({"format": "inkray-pose", "version": 1, "handles": handles,
                           "keys": [{"frame": 0, "to": targets}]},
                          size=tuple(self.session.drawing.size))

    def meshes(self):
        """The newest document's parts as textured meshes, for the page to draw poses with.

        Returns
        -------
        dict
            ``size`` ``[w, h]``, ``height`` ``[low, high]`` (the relief's heights) and
            ``parts``, back to front: per part ``name``, ``vertices`` (how many),
            ``faces`` (flat vertex indices, three per face), ``inner`` (how many of
            the faces are its front triangles; the rest are its skirt),
            ``texcoords`` (flat ``x, y`` per vertex, pixels of its texture) and
            ``texture`` (``origin`` ``[x, y]`` on the drawing, ``size`` ``[w, h]``, ``png``
            base64: RGBA, not premultiplied); with ``generation`` and ``compute_ms``.

        Raises
        ------
        InputError
            A document without regions.
        """
        def compute(chain, digest):
            with self._lock:
                posed = self._prepared(chain, digest)
            meshes = posed.meshes()
            z = np.concatenate([np.asarray(p.vertices, float)[:, 2]
                                for p in posed.rig.relief.parts] or [np.zeros(1)])
            return {"size": list(self.session.drawing.size),
                    "height": [float(z.min()), float(z.max())],
                    "parts": [{"name": m.name, "vertices": len(m.texcoords),
                               "faces": m.faces.ravel().tolist(), "inner": m.inner,
                               "texcoords": np.round(m.texcoords - m.origin, 4).ravel().tolist(),
                               "texture": {"origin": list(m.origin),
                                           "size": [m.texture.shape[1], m.texture.shape[0]],
                                           "png": base64.b64encode(
                                               _png(m.texture, level=1)).decode("ascii")}}
                              for m in meshes]}

        return self.session.newest(compute, lock="relief", wrap=False)

    def vertices(self, handles, targets):
        """The newest document's posed meshes' vertices with the handles at ``targets``: as
        :meth:`picture`, with the body per part of :meth:`meshes`, in its order, every
        vertex's ``x, y, height`` as little-endian float32 (the same solve as the picture of
        these targets)."""
        doc = self._targets(handles, targets)

        def compute(chain, digest):
            with self._lock:
                posed = self._prepared(chain, digest, doc.handles)
                drawn = posed.drawn_vertices(self._positions(posed, doc.keys[0].to))
            body = np.concatenate([v.ravel() for v in drawn] or [np.zeros(0)])
            return body.astype("<f4").tobytes(), "application/octet-stream"

        start = time.perf_counter()
        p = self.session.newest(compute, lock="relief")
        return p.body, (time.perf_counter() - start) * 1000, p.generation

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
        doc = self._targets(handles, targets)

        def compute(chain, digest):
            with self._lock:
                posed = self._prepared(chain, digest, doc.handles)
                rgba = posed.image(self._positions(posed, doc.keys[0].to), scale=scale)
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
