"""Threads: BLAS limited to one thread around small solves, and independent solves two at a time.

Most of the factorizations here are small (fronts of a few hundred rows):
two BLAS threads on them are slower than one, and on a busy machine a
multithreaded Cholesky of a 300x300 matrix was measured 400x slower than a
single-threaded one (0.67 s vs 1.8 ms). Finding the loaded BLAS libraries
takes milliseconds, so it is done once per process. The BLAS limit is
process-wide, so threads inside :func:`one_blas_thread` at once share one
limit: the first in sets it, the last out restores it.

SuperLU and LAPACK let go of the GIL while they factor and solve, so
independent systems (one per mesh part) solved by two threads take about
half the time on two cores (:func:`thread_map`).
"""

import os
import threading
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from functools import lru_cache

from threadpoolctl import ThreadpoolController

__all__ = ["one_blas_thread", "thread_map"]

_limit_lock = threading.Lock()
_limit = {"inside": 0, "limiter": None}


@lru_cache(maxsize=1)
def _controller():
    return ThreadpoolController()


@contextmanager
def one_blas_thread():
    """A context manager that limits BLAS to one thread inside it.

    Safe to enter from several threads at once: BLAS gets its limit back
    once the last of them leaves.

    Examples
    --------
    >>> import numpy as np
    >>> with one_blas_thread():
    ...     float(np.linalg.cholesky(np.eye(2))[0, 0])
    1.0
    """
    with _limit_lock:
        if _limit["inside"] == 0:
            _limit["limiter"] = _controller().limit(limits=1, user_api="blas")
        _limit["inside"] += 1
    try:
        yield
    finally:
        with _limit_lock:
            _limit["inside"] -= 1
            if _limit["inside"] == 0:
                _limit["limiter"].restore_original_limits()
                _limit["limiter"] = None


def thread_map(function, items, *, workers=2):
    """``[function(x) for x in items]``, computed by up to ``workers`` threads.

    The results come in the order of ``items`` and each is computed as it
    would be alone, so the list is the same whatever the scheduling. With
    one item, one worker or one CPU it runs in the calling thread. The first
    exception (in the order of ``items``) is raised once the calls under way
    end; the calls not yet started are dropped.

    Parameters
    ----------
    function : callable
        Of one argument.
    items : iterable
    workers : int, default 2

    Returns
    -------
    list

    Examples
    --------
    >>> thread_map(lambda x: x * x, range(5))
    [0, 1, 4, 9, 16]
    """
    items = list(items)
    workers = min(workers, len(items), os.cpu_count() or 1)
    if workers <= 1:
        return [function(x) for x in items]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        jobs = [pool.submit(function, x) for x in items]
        try:
            return [job.result() for job in jobs]
        except BaseException:
            pool.shutdown(cancel_futures=True)
            raise
