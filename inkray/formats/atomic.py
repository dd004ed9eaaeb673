"""Atomic output files: all outputs of a command appear together or not at all.

Outputs are collected in memory while a command runs; on success each is
written to a hidden temporary beside its target and the temporaries are
renamed into place one after the other, so a failed, interrupted or killed
run leaves no partial file (the only window is the final write, milliseconds
long, and any exception or handled signal in it removes the temporaries).
Targets are checked before any work: a target that is one of the command's
inputs, repeats another target, is a directory or cannot be created is a
one-line :class:`~inkray.errors.InputError`.
"""

import contextlib
import io
import mmap
import os
import tempfile
import threading
from pathlib import Path

from inkray.errors import InputError

__all__ = ["COMMITTING", "atomic_outputs", "check_targets", "memory_outputs", "write_bytes",
           "write_text"]

#: ``COMMITTING[0]`` counts the groups whose files are being written into
#: place. A shared one-byte map, so a forked watchdog (the command line's,
#: which kills a process a signal cannot reach inside a long native call) sees
#: it and waits for a commit to end rather than leave temporaries behind.
COMMITTING = mmap.mmap(-1, 1)
_COMMITTING_LOCK = threading.Lock()


@contextlib.contextmanager
def _committing():
    with _COMMITTING_LOCK:
        COMMITTING[0] = min(255, COMMITTING[0] + 1)
    try:
        yield
    finally:
        with _COMMITTING_LOCK:
            COMMITTING[0] = max(0, COMMITTING[0] - 1)


def _same(a, b):
    a, b = Path(a), Path(b)
    try:
        return os.path.samefile(a, b)
    except OSError:
        return a.resolve() == b.resolve()


def _existing_ancestor(path):
    for parent in Path(path).absolute().parents:
        if parent.exists():
            return parent
    return Path("/")


def check_targets(targets, *, inputs=()):
    """Check output paths before a command does its work.

    Parameters
    ----------
    targets : iterable of path
        Every file the command will write (``None`` entries are skipped).
    inputs : iterable of path
        Files the command reads; none of them may be overwritten.

    Raises
    ------
    InputError
        A target is an input, repeats another target, is a directory, or its
        folder cannot be created or written (probed with a temporary file that
        is removed at once).

    Examples
    --------
    >>> check_targets(["depth.png", "maps/../depth.png"])
    Traceback (most recent call last):
    ...
    inkray.errors.InputError: depth.png: written twice by this command (also as maps/../depth.png)
    """
    seen = []
    probed = set()
    for target in targets:
        if target is None:
            continue
        target = Path(target)
        for source in inputs:
            if source is not None and _same(target, source):
                raise InputError(f"{target}: is an input of this command ({source}); "
                                 f"choose another output name")
        for other in seen:
            if _same(target, other):
                raise InputError(f"{other}: written twice by this command (also as {target})")
        seen.append(target)
        if target.is_dir():
            raise InputError(f"{target}: is a directory; expected a file name")
        folder = target.parent if target.parent.exists() else _existing_ancestor(target)
        if folder in probed:
            continue
        if not folder.is_dir():
            raise InputError(f"{target}: cannot be created ({folder} is not a directory)")
        try:
            fd, tmp = tempfile.mkstemp(prefix=".inkray-probe.", dir=folder)
            os.close(fd)
            os.unlink(tmp)
        except OSError as e:
            raise InputError(f"{target}: cannot write in {folder} ({e.strerror})") from None
        probed.add(folder)


class _Outputs:
    def __init__(self, inputs):
        self._inputs = tuple(inputs)
        self._pending = {}  # target -> bytes, in the order written

    def write_bytes(self, target, data):
        """Add ``target`` with contents ``data`` to the group."""
        target = Path(target)
        check_targets([*self._pending, target], inputs=self._inputs)
        self._pending[target] = bytes(data)

    def write_text(self, target, text):
        """Add ``target`` with UTF-8 ``text`` to the group."""
        self.write_bytes(target, text.encode("utf-8"))

    def write_with(self, target, writer):
        """Add ``target`` written by ``writer(file)``, a writer that takes a binary file.

        For libraries that write to file objects (Pillow's ``save``,
        ``numpy.save``).
        """
        buffer = io.BytesIO()
        writer(buffer)
        self.write_bytes(target, buffer.getvalue())

    def _commit(self):
        with _committing():
            self._write_all()

    def _write_all(self):
        mode = _default_mode()
        temps = []
        try:
            for target, data in self._pending.items():
                target.parent.mkdir(parents=True, exist_ok=True)
                fd, tmp = tempfile.mkstemp(prefix=f".{target.stem[:100]}.",
                                           suffix=f".tmp{target.suffix[:16]}", dir=target.parent)
                temps.append((Path(tmp), target))
                with os.fdopen(fd, "wb") as fh:
                    fh.write(data)
                    fh.flush()
                    os.fsync(fh.fileno())
                # mkstemp makes 0600 files; outputs get the usual permissions
                # (an existing target's, else 0666 minus the umask).
                try:
                    os.chmod(tmp, os.stat(target).st_mode & 0o7777)
                except FileNotFoundError:
                    os.chmod(tmp, mode)
            while temps:
                tmp, target = temps[0]
                os.replace(tmp, target)
                temps.pop(0)
        except OSError as e:
            raise InputError(f"{temps[0][1] if temps else 'output'}: cannot be written "
                             f"({e.strerror})") from None
        finally:
            for tmp, _ in temps:
                with contextlib.suppress(OSError):
                    tmp.unlink()
            self._pending = {}


def _default_mode():
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextlib.contextmanager
def atomic_outputs(*, inputs=()):
    """Group output files so that either all of them appear or none.

    Yields an object with ``write_bytes(target, data)``, ``write_text(target,
    text)`` and ``write_with(target, writer)``. Contents stay in memory until
    the block ends without an exception; then every file is written to a
    temporary beside its target and renamed onto it (``os.replace``, atomic
    on one file system). On an exception nothing is written.

    Parameters
    ----------
    inputs : iterable of path, optional
        Files that must not be overwritten (the command's inputs).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_outputs() as out:
    ...     out.write_text(d / "a.txt", "hello")
    >>> (d / "a.txt").read_text()
    'hello'
    """
    out = _Outputs(inputs)
    yield out
    out._commit()


class _MemoryOutputs(_Outputs):
    def __init__(self):
        super().__init__(())

    def write_bytes(self, target, data):
        """Add ``target`` with contents ``data`` to the group."""
        target = Path(target)
        if target in self._pending:
            raise InputError(f"{target}: written twice by this command")
        self._pending[target] = bytes(data)

    def files(self):
        """The files added so far, ``{posix path: bytes}``, in the order written."""
        return {target.as_posix(): data for target, data in self._pending.items()}


@contextlib.contextmanager
def memory_outputs():
    """An output group like :func:`atomic_outputs` whose files stay in memory.

    For outputs sent elsewhere (a batch task returns its files' bytes to the
    process that writes them): the same writers give the same bytes.

    Examples
    --------
    >>> with memory_outputs() as out:
    ...     out.write_text("maps/a.txt", "hello")
    >>> out.files()
    {'maps/a.txt': b'hello'}
    """
    yield _MemoryOutputs()


def write_bytes(target, data):
    """Write ``data`` to ``target`` atomically."""
    with atomic_outputs() as out:
        out.write_bytes(target, data)


def write_text(target, text):
    """Write ``text`` (UTF-8) to ``target`` atomically."""
    with atomic_outputs() as out:
        out.write_text(target, text)
