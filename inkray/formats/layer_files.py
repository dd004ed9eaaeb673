"""Layered files of cut-out stacks: PSD or OpenRaster, chosen by the file's suffix.

One entry point for the layer stacks of :mod:`inkray.relief.cutout`:
``.psd`` goes through :mod:`inkray.formats.psd` (psd-tools), ``.ora``
through :mod:`inkray.formats.openraster`. Writes are atomic.
"""

from pathlib import Path

from inkray.errors import InputError
from inkray.formats.atomic import atomic_outputs
from inkray.formats.openraster import ora_bytes, read_ora
from inkray.formats.psd import psd_bytes, read_psd

__all__ = ["LAYER_SUFFIXES", "write_layers", "read_layers"]

#: The layered formats by suffix: (encoder, reader).
_FORMATS = {".psd": (psd_bytes, read_psd), ".ora": (ora_bytes, read_ora)}
LAYER_SUFFIXES = tuple(_FORMATS)


def write_layers(cutout, path, *, outputs=None):
    """Write a cut-out stack as ``path`` (``.psd`` or ``.ora``), all or nothing.

    Parameters
    ----------
    cutout : inkray.relief.cutout.Cutout
    path : str or Path
    outputs : optional
        An open :func:`inkray.formats.atomic.atomic_outputs` group.

    Returns
    -------
    list of Path

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from inkray.relief.cutout import Cutout, CutoutLayer
    >>> px = np.full((2, 2, 4), 255, np.uint8)
    >>> stack = Cutout([CutoutLayer("a", 0, 1, 1, px, np.zeros((2, 2), bool))], (4, 3))
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "parts.ora"
    >>> [layer.name for layer in read_layers(write_layers(stack, out)[0]).layers]
    ['a']
    """
    encode, _ = _format(path)
    if outputs is None:
        with atomic_outputs() as group:
            return write_layers(cutout, path, outputs=group)
    outputs.write_bytes(path, encode(cutout))
    return [Path(path)]


def read_layers(path):
    """Read a ``.psd`` or ``.ora`` file's layers, back to front.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    inkray.relief.cutout.Cutout
        Layers with ``region`` and ``hidden`` None (a file does not say).
    """
    _, read = _format(path)
    return read(path)


def _format(path):
    suffix = Path(path).suffix.lower()
    if suffix not in _FORMATS:
        raise InputError(f"{path}: unsupported layered file type {suffix or '(none)'} "
                         f"(expected {', '.join(LAYER_SUFFIXES)})")
    return _FORMATS[suffix]
