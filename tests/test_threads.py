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
