"""Threads: BLAS limited to one thread around small solves, and independent solves two at a time.

Most of the factorizations here are small (fronts of a few hundred rows):
two BLAS threads on them are slower than one, and on a busy machine a
multithreaded Cholesky of a 300x300 matrix was measured 400x slower than a
single-threaded one (0.67 s vs 1.8 ms). Finding the loaded BLAS libraries
takes milliseconds, so it is done once per process.

SuperLU and LAPACK let go of the GIL while they factor and solve, so
independent systems (one per mesh part) solved by two threads take about
half the time on two cores (:func:`thread_map`).

A thread whose result is awaited first (an interactive preview) can keep a
core for itself (:func:`reserve_core`): meanwhile a map runs no more calls
at a time than the cores left, so on two cores its calls run one at a time
instead of taking both cores from it.
"""

import os
import threading
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from functools import lru_cache

from threadpoolctl import ThreadpoolController

__all__ = ["one_blas_thread", "reserve_core", "thread_imap", "thread_map"]


@lru_cache(maxsize=1)
def _controller():
    return ThreadpoolController()


def one_blas_thread():
    """A context manager that limits BLAS to one thread inside it.

    Each thread that enters sets the limit and restores it itself (OpenBLAS
    0.3.30 keeps a limit that another thread restores).

    Examples
    --------
    >>> import numpy as np
    >>> with one_blas_thread():
    ...     float(np.linalg.cholesky(np.eye(2))[0, 0])
    1.0
    """
    return _controller().limit(limits=1, user_api="blas")


# Cores kept by reserve_core, and the condition the maps' calls wait on for them.
_gate = threading.Condition()
_reserved = 0


@contextmanager
def reserve_core():
    """A context manager that keeps one core for the calling thread's work inside it.

    Meanwhile every :func:`thread_imap` runs at most as many of its calls at
    a time as the cores not kept (and always at least one): on two cores, one
    at a time. Calls already under way finish; the results do not change.

    Examples
    --------
    >>> with reserve_core():
    ...     thread_map(lambda x: x + 1, range(3))
    [1, 2, 3]
    """
    global _reserved
    with _gate:
        _reserved += 1
    try:
        yield
    finally:
        with _gate:
            _reserved -= 1
            _gate.notify_all()


def _gated(function, cores):
    """``function`` as a map's call that waits while another call of the same map
    runs and :func:`reserve_core` leaves no core for a second."""
    running = [0]

    def call(x):
        with _gate:
            while running[0] and running[0] >= cores - _reserved:
                _gate.wait()
            running[0] += 1
        try:
            return function(x)
        finally:
            with _gate:
                running[0] -= 1
                _gate.notify_all()

    return call


def thread_imap(function, items, *, workers=2):
    """``function(x) for x in items``, computed by up to ``workers`` threads, yielded in order.

    Each result is yielded as soon as it and those before it are done, so the
    caller can report progress (or stop) between them; each is computed as it
    would be alone, so the results are the same whatever the scheduling. BLAS
    is limited to one thread meanwhile (:func:`one_blas_thread`). With one
    item, one worker or one CPU it runs in the calling thread. The first
    exception (in the order of ``items``) is raised once the calls under way
    end; when it is raised, or the caller stops iterating, the calls not yet
    started are dropped.

    Parameters
    ----------
    function : callable
        Of one argument.
    items : iterable
    workers : int, default 2

    Yields
    ------
    object
        ``function(x)``, in the order of ``items``.

    Examples
    --------
    >>> [y for y in thread_imap(lambda x: x * x, range(5))]
    [0, 1, 4, 9, 16]
    """
    items = list(items)
    cores = os.cpu_count() or 1
    workers = min(workers, len(items), cores)
    if workers <= 1:
        for x in items:
            yield function(x)
        return
    # BLAS limited by the calling thread for the whole map: two threads each
    # limiting and restoring it on their own leave one of them running with two
    # BLAS threads (the limit is the process's), which cost the stitching's
    # solves four times their time.
    with one_blas_thread(), ThreadPoolExecutor(max_workers=workers) as pool:
        call = _gated(function, cores)
        jobs = [pool.submit(call, x) for x in items]
        try:
            for job in jobs:
                yield job.result()
        except BaseException:  # an error, or the caller stopped (GeneratorExit)
            pool.shutdown(cancel_futures=True)
            raise


def thread_map(function, items, *, workers=2):
    """``[function(x) for x in items]``, computed by up to ``workers`` threads
    (:func:`thread_imap`, its results as a list).

    Examples
    --------
    >>> thread_map(lambda x: x * x, range(5))
    [0, 1, 4, 9, 16]
    """
    return list(thread_imap(function, items, workers=workers))
