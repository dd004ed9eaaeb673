"""Atomic output files: everything is written to a temporary file beside its
target and renamed into place only when all outputs of a command are
complete, so a failed or interrupted run never leaves a partial file."""

import contextlib
import os
import tempfile
from pathlib import Path

__all__ = ["atomic_outputs", "write_bytes", "write_text"]


class _Outputs:
    def __init__(self):
        self._pending = []  # (temp path, final path)

    def path(self, target):
        """Return a temporary path to write ``target`` to; it is renamed on commit.

        The temporary keeps ``target``'s suffix so writers that pick a format
        by extension (Pillow, numpy, trimesh) behave as for the target.
        """
        target = Path(target)
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=f".tmp{target.suffix}",
                                   dir=target.parent)
        os.close(fd)
        self._pending.append((Path(tmp), target))
        return Path(tmp)

    def write_bytes(self, target, data):
        tmp = self.path(target)
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())

    def write_text(self, target, text):
        self.write_bytes(target, text.encode("utf-8"))

    def _commit(self):
        mode = _default_mode()
        for tmp, target in self._pending:
            # mkstemp makes 0600 files; outputs get the usual permissions
            # (an existing target's, else 0666 minus the umask).
            try:
                os.chmod(tmp, os.stat(target).st_mode & 0o7777)
            except FileNotFoundError:
                os.chmod(tmp, mode)
            os.replace(tmp, target)
        self._pending = []

    def _abort(self):
        for tmp, _ in self._pending:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
        self._pending = []


def _default_mode():
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextlib.contextmanager
def atomic_outputs():
    """Group output files so that either all of them appear or none.

    Yields an object with ``path(target)`` (a temporary path to write to),
    ``write_bytes(target, data)`` and ``write_text(target, text)``. On normal
    exit every temporary is renamed onto its target (``os.replace``, atomic on
    one file system); on an exception all temporaries are deleted.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_outputs() as out:
    ...     out.write_text(d / "a.txt", "hello")
    >>> (d / "a.txt").read_text()
    'hello'
    """
    out = _Outputs()
    try:
        yield out
    except BaseException:
        out._abort()
        raise
    out._commit()


def write_bytes(target, data):
    """Write ``data`` to ``target`` atomically."""
    with atomic_outputs() as out:
        out.write_bytes(target, data)


def write_text(target, text):
    """Write ``text`` (UTF-8) to ``target`` atomically."""
    with atomic_outputs() as out:
        out.write_text(target, text)
