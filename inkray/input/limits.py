"""Documented bounds on the input, checked before any heavy stage.

Every bound keeps one command's time and memory in proportion to what an
artist's file needs: the bundled drawings (up to 1.6 Mpx, a few hundred
points per scribble) are far inside them. A file over a bound is rejected
with the key path (or file) that exceeds it and the option that raises it
(``--max-pixels``, ``--max-points``), before anything is decoded or solved.

| bound | default | what it protects |
| --- | --- | --- |
| ``pixels`` | 16,777,216 (4096 x 4096) | decoding and every per-pixel stage (a relief near the bound takes minutes and several GB) |
| ``file_bytes`` | 64 MiB | reading an annotation file or a legend |
| ``mesh_bytes`` | 256 MiB | reading a mesh file (and the files it refers to) |
| ``points`` | 20,000 per polyline | outlines snapped to boundary paths, scribble rasterization |
| ``total_points`` | 1,000,000 per file | the same, summed |
| ``entries`` | 10,000 per list | regions, ``order``, ``equal``, ``boundaries``, ``background`` |
| ``depth`` | 64 levels of JSON nesting | the parser |
| ``values`` | 3 per ``total_points`` + 100 per ``entries`` (4,000,000) | the parser's memory: JSON values in an annotation file |
"""

from dataclasses import dataclass

from inkray.errors import InputError

__all__ = ["Limits", "DEFAULT_LIMITS"]


@dataclass(frozen=True)
class Limits:
    """Bounds on one input; see the module docstring for the defaults.

    Examples
    --------
    >>> Limits(pixels=1000).check_pixels((40, 40), "d.png")
    Traceback (most recent call last):
    ...
    inkray.errors.InputError: d.png: 40x40 = 1600 pixels exceeds the limit of 1000 (raise it with limits.pixels)
    """

    pixels: int = 4096 * 4096
    file_bytes: int = 64 << 20
    mesh_bytes: int = 256 << 20
    points: int = 20_000
    total_points: int = 1_000_000
    entries: int = 10_000
    depth: int = 64

    def __post_init__(self):
        for key in ("pixels", "file_bytes", "mesh_bytes", "points", "total_points", "entries",
                    "depth"):
            value = getattr(self, key)
            if not (isinstance(value, int) and not isinstance(value, bool) and value > 0):
                raise InputError(f"limits.{key}: expected a positive integer, got {value!r}")

    @property
    def values(self):
        """JSON values per annotation file: three per point (a list of two numbers), 100 per entry.

        What the parser holds grows with the number of values, not with the
        file's size (``[{},{},...]`` takes 24 times its bytes).
        """
        return 3 * self.total_points + 100 * self.entries

    def check_pixels(self, size, where):
        """Raise when a ``(width, height)`` image exceeds :attr:`pixels`."""
        w, h = (int(v) for v in size)
        if w * h > self.pixels:
            raise InputError(f"{where}: {w}x{h} = {w * h} pixels exceeds the limit of "
                             f"{self.pixels}", fix=("raise it with {}", "limits.pixels"))

    def check_bytes(self, n, where):
        """Raise when a file of ``n`` bytes exceeds :attr:`file_bytes`."""
        if n > self.file_bytes:
            raise InputError(f"{where}: {n} bytes exceeds the limit of {self.file_bytes} "
                             f"for this kind of file")


DEFAULT_LIMITS = Limits()
