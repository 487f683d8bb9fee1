"""Give the C heap's free memory back to the operating system between a run's phases.

glibc's ``malloc`` keeps freed memory in its arenas for reuse; after a long run's scores free
their whole-run columns, tens of MB stay resident although nothing uses them, and a later phase
that asks for large blocks (a figure's pixel buffer is ``mmap``-ed) adds to them instead of
reusing them. :func:`release_free_heap` collects Python's garbage and calls glibc's
``malloc_trim(0)``, which returns every free page of every arena (measured: 20-45 MB after
the scores of a 60 s run; 20 MB in the middle of a run's loop, which :func:`trim_heap` does
every few simulated seconds). Elsewhere (musl, macOS, Windows) they only collect garbage.
"""

from __future__ import annotations

import ctypes
import gc
import platform
import sys
from functools import cache


@cache
def _malloc_trim():
    """glibc's ``malloc_trim`` or None where the C library is not glibc."""
    if not sys.platform.startswith("linux") or platform.libc_ver()[0] != "glibc":
        return None
    try:
        fn = ctypes.CDLL(None).malloc_trim  # the process's own C library
    except (OSError, AttributeError):
        return None
    fn.argtypes, fn.restype = [ctypes.c_size_t], ctypes.c_int
    return fn


def trim_heap() -> bool:
    """Return the C heap's free pages to the OS (glibc's ``malloc_trim(0)``; a few ms); whether
    the C library could. Cheap enough to call every few simulated seconds of a run's loop,
    where freed per-frame buffers otherwise stay resident between the blocks still in use."""
    trim = _malloc_trim()
    if trim is None:
        return False
    trim(0)
    return True


def release_free_heap() -> bool:
    """Collect Python's garbage, then :func:`trim_heap` (between a run's phases)."""
    gc.collect()
    return trim_heap()
