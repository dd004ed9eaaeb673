"""Limiting BLAS to one thread around small dense and sparse solves.

Most of the factorizations here are small (fronts of a few hundred rows):
two BLAS threads on them are slower than one, and on a busy machine a
multithreaded Cholesky of a 300x300 matrix was measured 400x slower than a
single-threaded one (0.67 s vs 1.8 ms). Finding the loaded BLAS libraries
takes milliseconds, so it is done once per process.
"""

from functools import lru_cache

from threadpoolctl import ThreadpoolController

__all__ = ["one_blas_thread"]


@lru_cache(maxsize=1)
def _controller():
    return ThreadpoolController()


def one_blas_thread():
    """A context manager that limits BLAS to one thread inside it.

    Examples
    --------
    >>> import numpy as np
    >>> with one_blas_thread():
    ...     float(np.linalg.cholesky(np.eye(2))[0, 0])
    1.0
    """
    return _controller().limit(limits=1, user_api="blas")
