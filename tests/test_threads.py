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
