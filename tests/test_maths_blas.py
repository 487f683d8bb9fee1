"""``maths.blas.one_blas_thread``: every BLAS library loaded in the process (threadpoolctl's
own census, taken independently) runs on one thread inside, as before outside."""

from __future__ import annotations

import scipy.linalg  # noqa: F401  -- scipy's own OpenBLAS loaded, as in a run
from threadpoolctl import threadpool_info

from humimic.maths.blas import one_blas_thread


def _blas() -> list[dict]:
    return [i for i in threadpool_info() if i["user_api"] == "blas"]


def test_one_blas_thread_limits_every_loaded_blas_and_restores_it():
    before = {i["filepath"]: i["num_threads"] for i in _blas()}
    assert before
    with one_blas_thread():
        inside = _blas()
        assert {i["filepath"] for i in inside} == set(before)
        assert all(i["num_threads"] == 1 for i in inside)
    assert {i["filepath"]: i["num_threads"] for i in _blas()} == before
