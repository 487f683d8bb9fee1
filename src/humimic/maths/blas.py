"""BLAS on one thread for the calls inside: OpenBLAS splits a product's sums across its
threads, so its results depend on the thread count (measured: 30 x 300 products, 900-sized
solves and dots differ in the last bits between one and two threads), and the same seed would
give other bits in a process with another ``OPENBLAS_NUM_THREADS`` or on a machine with
another core count. The filters here work on small matrices, where one thread is also not
slower. Entering and leaving costs ~13 us (CPU)."""

from __future__ import annotations

from threadpoolctl import ThreadpoolController

_CONTROLLER = ThreadpoolController()


def one_blas_thread():
    """Context manager: BLAS limited to one thread inside, restored after."""
    return _CONTROLLER.limit(limits=1, user_api="blas")
