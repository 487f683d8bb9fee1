"""Give the C heap's free memory back to the operating system between a run's phases.

glibc's ``malloc`` keeps freed memory in its arenas for reuse; after a long run's scores free
their whole-run columns, tens of MB stay resident although nothing uses them, and a later phase
that asks for large blocks (a figure's pixel buffer is ``mmap``-ed) adds to them instead of
reusing them. :func:`release_free_heap` collects Python's garbage and calls glibc's
``malloc_trim(0)``, which returns every free page of every arena (measured: 20-45 MB after
the scores of a 60 s run; 20 MB in the middle of a run's loop, which :func:`trim_heap` does
every few simulated seconds). Elsewhere (musl, macOS, Windows) they only collect garbage.

:func:`tune_heap` (once per run) fixes glibc's mmap threshold at :data:`MMAP_THRESHOLD_BYTES`
and caps its arenas at :data:`ARENA_MAX`. By default glibc raises the threshold to the size of
every large block freed (up to 32 MB): after the first ground-truth chunk or image buffer is
freed, blocks of that size come from the arenas instead of ``mmap`` and leave holes between the
long-lived blocks that ``malloc_trim`` cannot return. Fixed, a large block is its own mapping,
unmapped when freed. Measured on a 120-s ``mimic_tracked_wave``: the loop's resident set
546 -> 517 MiB, the run's peak (its report) 628 -> 583 MiB.

:func:`purge_freed_pages_at_once` (an entry point, before ``rerun`` or ``pyarrow`` is imported)
sets ``MIMALLOC_PURGE_DELAY=0`` unless the user set it: the rerun SDK (and pyarrow) allocate with
their own mimalloc, which keeps freed pages for a while before returning them; while a run
streams images to the recording they pile up. Measured, 36 000 JPEG-sized images and their
overlays logged (ten minutes of eye frames): +55 MiB resident with the default, +7 MiB with 0,
for +3.4 s of system time.
"""

from __future__ import annotations

import ctypes
import gc
import os
import platform
import sys
from functools import cache

#: Blocks from this size up are mapped on their own (glibc's initial threshold, kept fixed).
MMAP_THRESHOLD_BYTES = 128 << 10
#: glibc malloc arenas at most (its default: 8 per core).
ARENA_MAX = 2
_M_MMAP_THRESHOLD, _M_ARENA_MAX = -3, -8  # glibc's <malloc.h>


@cache
def _glibc(name: str, argtypes: tuple):
    """glibc's function ``name`` or None where the C library is not glibc."""
    if not sys.platform.startswith("linux") or platform.libc_ver()[0] != "glibc":
        return None
    try:
        fn = getattr(ctypes.CDLL(None), name)  # the process's own C library
    except (OSError, AttributeError):
        return None
    fn.argtypes, fn.restype = list(argtypes), ctypes.c_int
    return fn


def purge_freed_pages_at_once() -> None:
    """mimalloc returns freed pages to the OS at once (module doc); call before anything imports
    ``rerun`` or ``pyarrow`` (their allocators read it when they start). A user's own
    ``MIMALLOC_PURGE_DELAY`` is kept."""
    os.environ.setdefault("MIMALLOC_PURGE_DELAY", "0")


def _malloc_trim():
    return _glibc("malloc_trim", (ctypes.c_size_t,))


@cache
def tune_heap() -> bool:
    """Fix glibc's mmap threshold and cap its arenas (module doc; process-wide, once); whether
    the C library could."""
    mallopt = _glibc("mallopt", (ctypes.c_int, ctypes.c_int))
    if mallopt is None:
        return False
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)
                and mallopt(_M_ARENA_MAX, ARENA_MAX))


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
