"""BLAS on one thread for the calls inside: OpenBLAS splits a product's sums across its
threads, so its results depend on the thread count (measured: 30 x 300 products, 900-sized
solves and dots differ in the last bits between one and two threads), and the same seed would
give other bits in a process with another ``OPENBLAS_NUM_THREADS`` or on a machine with
another core count. The filters here work on small matrices, where one thread is also not
slower. Entering and leaving costs ~13 us (CPU)."""

from __future__ import annotations

from threadpoolctl import ThreadpoolController

_CONTROLLER: ThreadpoolController | None = None


def one_blas_thread():
    """Context manager: BLAS limited to one thread inside, restored after. The BLAS libraries
    are looked up at the first call (not at import, when numpy's or scipy's might not be
    loaded yet: the limit would silently cover nothing) and again while none is found. The
    limit is process-wide (OpenBLAS has one setting): two threads entering and leaving it at
    once could leave it at one thread (never the other way round)."""
    global _CONTROLLER
    if _CONTROLLER is None or not _CONTROLLER.lib_controllers:   # the census, BLAS only
        _CONTROLLER = ThreadpoolController().select(user_api="blas")
    return _CONTROLLER.limit(limits=1)
