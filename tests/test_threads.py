import numpy as np
from threadpoolctl import threadpool_info

from inkray.numerics.threads import one_blas_thread


def test_one_blas_thread_inside_and_restored_after():
    before = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    with one_blas_thread():
        inside = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
        assert np.linalg.solve(np.eye(3) * 2, np.ones(3)).tolist() == [0.5] * 3
    after = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    assert all(n == 1 for n in inside) and after == before


def test_thread_map_keeps_the_order_and_raises_the_first_error():
    import time

    from inkray.numerics.threads import thread_map

    # the later items finish first: the results still come in the items' order
    assert thread_map(lambda x: time.sleep(0.02 * (4 - x)) or x * 10, range(5)) == \
        [0, 10, 20, 30, 40]

    def fail(x):
        if x in (1, 3):
            raise ValueError(f"item {x}")
        return x

    try:
        thread_map(fail, range(5))
    except ValueError as e:
        assert str(e) == "item 1"
    else:
        raise AssertionError("no error raised")


def test_thread_map_limits_blas_in_its_workers_and_restores_it():
    from inkray.numerics.threads import thread_map

    def blas():
        return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]

    before = blas()
    # workers that limit BLAS themselves, as the stitching's solves do
    def work(_):
        with one_blas_thread():
            np.linalg.solve(np.eye(50) * 2, np.ones(50))
        return blas()

    inside = thread_map(work, range(6))
    assert all(n == 1 for threads in inside for n in threads)
    assert blas() == before


def test_thread_imap_yields_in_order_and_drops_what_has_not_started_when_stopped():
    import threading
    import time

    from inkray.numerics.threads import thread_imap

    started = []
    lock = threading.Lock()

    def work(x):
        with lock:
            started.append(x)
        time.sleep(0.01)
        return x

    results = thread_imap(work, range(20))
    assert [next(results), next(results)] == [0, 1]
    results.close()  # the caller stops, as a superseded edit's progress does
    time.sleep(0.05)
    assert len(started) < 20


def _most_at_once(work_s=0.02, items=6, during=None):
    """The most calls of one thread_map running at once, with ``during`` (a context
    manager or None) held by another thread for the whole map."""
    import threading
    import time

    from inkray.numerics.threads import thread_map

    lock = threading.Lock()
    now, most = [0], [0]

    def work(x):
        with lock:
            now[0] += 1
            most[0] = max(most[0], now[0])
        time.sleep(work_s)
        with lock:
            now[0] -= 1
        return x

    held, done = threading.Event(), threading.Event()

    def hold():
        with during:
            held.set()
            done.wait(10)

    holder = threading.Thread(target=hold) if during is not None else None
    if holder is not None:
        holder.start()
        held.wait(10)
    try:
        assert thread_map(work, range(items)) == list(range(items))
    finally:
        done.set()
        if holder is not None:
            holder.join()
    return most[0]


def test_reserve_core_leaves_a_map_the_other_cores_and_all_of_them_after():
    import os

    import pytest

    from inkray.numerics.threads import reserve_core

    cores = os.cpu_count() or 1
    if cores < 2:
        pytest.skip("one core: maps run in the calling thread")
    # two workers: both at once, unless a core is kept and only one is left
    assert _most_at_once() == 2
    assert _most_at_once(during=reserve_core()) == (1 if cores == 2 else 2)
    assert _most_at_once() == 2  # the reservation ended with its thread's block


def test_reserve_core_lets_a_waiting_call_start_when_it_ends():
    import os
    import threading
    import time

    import pytest

    from inkray.numerics.threads import reserve_core, thread_map

    if (os.cpu_count() or 1) != 2:
        pytest.skip("the reservation leaves a map one call at a time on two cores")
    first_started, second_started, release, kept = (threading.Event() for _ in range(4))

    def work(x):
        if x == 0:
            first_started.set()
            return second_started.wait(10)  # still running when the second starts?
        second_started.set()
        return True

    def reserve():
        with reserve_core():
            kept.set()
            release.wait(10)

    holder = threading.Thread(target=reserve)
    holder.start()
    out = []
    mapper = threading.Thread(target=lambda: out.extend(thread_map(work, range(2))))
    try:
        assert kept.wait(10)
        mapper.start()
        assert first_started.wait(10)
        time.sleep(0.1)
        assert not second_started.is_set()  # one call at a time while the core is kept
    finally:
        release.set()
        holder.join()
        mapper.join()
    assert out == [True, True]  # the second started beside the first once it was released
