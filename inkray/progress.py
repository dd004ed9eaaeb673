"""Progress on a terminal and per-stage timings for long work.

On a terminal each stage shows one status line that is redrawn in place: the
stage's name, a bar when the stage reports how far it is, and the elapsed
time, refreshed a few times a second even by stages that cannot report
(so nothing looks stuck). Piped or redirected, nothing is drawn. The timing
table is printed only when asked for (``--timings``).
"""

import sys
import threading
import time
from contextlib import contextmanager

__all__ = ["Progress"]


class Progress:
    """Report stages with a live status line and keep their timings.

    Parameters
    ----------
    quiet : bool, default False
        Draw nothing (timings are still kept).
    stream : file, optional
        Defaults to ``sys.stderr``; drawing happens only when it is a terminal.
    timings : bool, default False
        :meth:`summary` prints the timing table.

    Examples
    --------
    >>> p = Progress(quiet=True)
    >>> with p.stage("segment"):
    ...     p.update(1, 2)
    >>> [name for name, _ in p.timings]
    ['segment']
    """

    _TICK = 0.25  # seconds between redraws of the status line

    def __init__(self, *, quiet=False, stream=None, timings=False):
        self.quiet = quiet
        self.stream = stream if stream is not None else sys.stderr
        self.show_timings = timings
        self.timings = []
        self._lock = threading.Lock()
        self._current = None
        self._fraction = None
        self._start = 0.0
        self._ticker = None
        self._drawn = False

    @property
    def _live(self):
        isatty = getattr(self.stream, "isatty", None)
        return not self.quiet and isatty is not None and isatty()

    @contextmanager
    def stage(self, name):
        """Time the work inside the block under ``name`` (nested stages are timed too)."""
        outer = (self._current, self._fraction, self._start)
        self._current, self._fraction = name, None
        start = self._start = time.perf_counter()
        stop = self._start_ticker()
        try:
            yield self
        finally:
            self.timings.append((name, time.perf_counter() - start))
            if stop is not None:
                stop.set()
                self._ticker.join()
                self._ticker = None
                self._clear()
            self._current, self._fraction, self._start = outer

    def update(self, done, total):
        """Set how far the current stage is: ``done`` of ``total``."""
        if total > 0:
            self._fraction = min(max(done / total, 0.0), 1.0)

    def summary(self):
        """Print the per-stage timing table when timings were asked for."""
        if not self.show_timings or not self.timings:
            return
        total = sum(t for _, t in self.timings)
        width = max(len(n) for n, _ in self.timings)
        lines = [f"  {n:<{width}}  {t:8.3f} s" for n, t in self.timings]
        lines.append(f"  {'total':<{width}}  {total:8.3f} s")
        self._clear()
        print("timings:\n" + "\n".join(lines), file=self.stream, flush=True)

    def _start_ticker(self):
        if not self._live or self._ticker is not None:
            return None
        stop = threading.Event()

        def run():
            while not stop.wait(self._TICK):
                self._draw()

        self._ticker = threading.Thread(target=run, name="inkray-progress", daemon=True)
        self._ticker.start()
        return stop

    def _draw(self):
        name, fraction = self._current, self._fraction
        if name is None:
            return
        elapsed = time.perf_counter() - self._start
        bar = ""
        if fraction is not None:
            fill = int(24 * fraction)
            bar = f" [{'#' * fill}{'.' * (24 - fill)}] {100 * fraction:3.0f}%"
        with self._lock:
            self.stream.write(f"\r\x1b[K{name}{bar} {elapsed:5.1f} s")
            self.stream.flush()
            self._drawn = True

    def _clear(self):
        with self._lock:
            if self._drawn:
                self.stream.write("\r\x1b[K")
                self.stream.flush()
                self._drawn = False
