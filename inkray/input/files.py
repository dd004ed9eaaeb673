"""Opening input files safely: regular files only, read with a byte bound.

A FIFO, a device such as ``/dev/zero`` or a directory given where a file is
expected would block or grow without bound; each gets a one-line error
instead, before anything is read.
"""

import os
import stat
from pathlib import Path

from inkray.errors import InputError

__all__ = ["regular_file", "read_bytes"]

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a device"),
          (stat.S_ISBLK, "a device"), (stat.S_ISSOCK, "a socket"))


def regular_file(path, what):
    """Check that ``path`` is an existing regular file (links followed).

    Parameters
    ----------
    path : str or pathlib.Path
    what : str
        What the file is, for the message (``"annotation file"``).

    Returns
    -------
    (pathlib.Path, int)
        The path and its size in bytes.

    Raises
    ------
    InputError
        Missing, not a regular file, or not accessible.

    Examples
    --------
    >>> regular_file("/dev/null", "drawing")
    Traceback (most recent call last):
    ...
    inkray.errors.InputError: /dev/null: not a regular file (a device); expected a drawing
    """
    path = Path(path)
    try:
        st = os.stat(path)
    except (ValueError, UnicodeEncodeError):  # a NUL or a lone surrogate: no file has that name
        raise InputError(f"{ascii(str(path))}: not a valid file name for a {what}") from None
    except FileNotFoundError:
        raise InputError(f"{path}: no such {what}") from None
    except OSError as e:
        raise InputError(f"{path}: cannot open the {what} ({e.strerror})") from None
    if not stat.S_ISREG(st.st_mode):
        kind = next((k for test, k in _KINDS if test(st.st_mode)), "not a file")
        raise InputError(f"{path}: not a regular file ({kind}); expected a {what}")
    return path, st.st_size


def read_bytes(path, what, *, limit):
    """Read a regular file of at most ``limit`` bytes.

    Parameters
    ----------
    path : str or pathlib.Path
    what : str
    limit : int

    Returns
    -------
    bytes

    Raises
    ------
    InputError
        As :func:`regular_file`, or the file is larger than ``limit``.
    """
    path, size = regular_file(path, what)
    if size > limit:
        raise InputError(f"{path}: {size} bytes exceeds the limit of {limit} for a {what}")
    try:
        with open(path, "rb") as fh:
            data = fh.read(limit + 1)
    except OSError as e:
        raise InputError(f"{path}: cannot read the {what} ({e.strerror})") from None
    if len(data) > limit:  # it grew while we read it
        raise InputError(f"{path}: more than {limit} bytes; too large for a {what}")
    return data
