"""Progress and per-stage timing on stderr for long work (silenced by ``--quiet``)."""

import sys
import time
from contextlib import contextmanager

__all__ = ["Progress"]


class Progress:
    """Report stages, a progress bar and a timing summary.

    Parameters
    ----------
    quiet : bool, default False
        Print nothing.
    stream : file, optional
        Defaults to ``sys.stderr``.

    Examples
    --------
    >>> p = Progress(quiet=True)
    >>> with p.stage("segment"):
    ...     p.update(1, 2)
    >>> [name for name, _ in p.timings]
    ['segment']
    """

    def __init__(self, *, quiet=False, stream=None):
        self.quiet = quiet
        self.stream = stream if stream is not None else sys.stderr
        self.timings = []
        self._current = None
        self._bar_shown = False

    @contextmanager
    def stage(self, name):
        """Time the work inside the block under ``name``."""
        self._current = name
        self._say(f"{name} ...")
        start = time.perf_counter()
        try:
            yield self
        finally:
            self.timings.append((name, time.perf_counter() - start))
            self._end_bar()
            self._current = None

    def update(self, done, total):
        """Draw the progress bar of the current stage at ``done`` of ``total``."""
        if self.quiet or total <= 0 or not self.stream.isatty():
            return
        width = 30
        fill = int(width * min(done, total) / total)
        self.stream.write(f"\r  [{'#' * fill}{'.' * (width - fill)}] {done}/{total}")
        self.stream.flush()
        self._bar_shown = True

    def summary(self):
        """Print the per-stage timing table."""
        if self.quiet or not self.timings:
            return
        total = sum(t for _, t in self.timings)
        width = max(len(n) for n, _ in self.timings)
        lines = [f"  {n:<{width}}  {t:8.3f} s" for n, t in self.timings]
        lines.append(f"  {'total':<{width}}  {total:8.3f} s")
        self._say("timings:\n" + "\n".join(lines))

    def _end_bar(self):
        if self._bar_shown:
            self.stream.write("\n")
            self._bar_shown = False

    def _say(self, text):
        if not self.quiet:
            print(text, file=self.stream, flush=True)
