"""humimic.heap.release_free_heap gives glibc's free pages back to the operating system."""

from __future__ import annotations

import platform
import subprocess
import sys

import pytest

from humimic.heap import release_free_heap

_CHILD = """
import os
from humimic.heap import release_free_heap

def rss_mib():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20

blocks = [bytes(4000) for _ in range(50_000)]  # 200 MB of malloc-ed blocks
kept = blocks[::8]  # every 8th kept: the freed 7/8 are holes the heap's top cannot shrink past
del blocks
before = rss_mib()
ok = release_free_heap()
print(ok, before - rss_mib(), len(kept))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux") or platform.libc_ver()[0] != "glibc",
                    reason="malloc_trim is glibc's")
def test_freed_holes_in_the_heap_are_returned():
    """175 MB freed in 28 kB holes between kept blocks: glibc keeps them resident until
    malloc_trim(0) (measured: 145 MiB returned; asserted: more than 70)."""
    out = subprocess.run([sys.executable, "-c", _CHILD], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out[0] == "True"
    assert float(out[1]) > 70.0


def test_release_without_glibc_only_collects(monkeypatch):
    import humimic.heap as heap

    monkeypatch.setattr(heap, "_malloc_trim", lambda: None)
    assert release_free_heap() is False


_TUNE_CHILD = """
import os, sys
from humimic.heap import tune_heap

def rss_mib():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20

tuned = tune_heap() if sys.argv[1] == "tune" else None
big = bytearray(4 << 20)  # one 4 MiB block freed: untuned glibc raises its mmap threshold
del big
before = rss_mib()
blocks, kept = [], []
for _ in range(100):  # 1 MiB blocks, each followed by a small block that stays
    blocks.append(bytearray(1 << 20))
    kept.append(bytearray(1024))  # past pymalloc: from the C heap too
del blocks  # freed between kept blocks: holes, unless each block was a mapping of its own
print(tuned, rss_mib() - before, len(kept))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux") or platform.libc_ver()[0] != "glibc",
                    reason="mallopt is glibc's")
def test_tuned_heap_returns_large_blocks_when_freed():
    """100 MiB of 1 MiB blocks freed between small blocks that stay: once a 4 MiB block was
    freed, untuned glibc serves them from its heap and keeps them resident (measured: +100
    MiB); tuned, each is unmapped when freed (measured: +0 MiB; asserted: < 20)."""
    def grown(mode):
        out = subprocess.run([sys.executable, "-c", _TUNE_CHILD, mode], capture_output=True,
                             text=True, check=True).stdout.split()
        return out[0], float(out[1])

    tuned, untuned = grown("tune"), grown("default")
    assert tuned[0] == "True" and tuned[1] < 20.0
    assert untuned[1] > 80.0  # what the tuning changes
