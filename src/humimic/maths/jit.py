"""One place for how humimic compiles its hot loops with numba.

`njit` is `numba.njit` with the project's options: compiled code is cached on disk (so only
the first run after a change pays the compile time), releases the GIL (the perception worker
runs beside the servo loop), and keeps numpy's error model (division by zero gives inf/nan like
numpy instead of raising). No `parallel=True`: the machine has two cores and the runner already
uses both.

Where the cache lives. numba keys a cached kernel on the timestamp of the file that defines it
alone: an edit to a kernel it calls in another file, or to a module constant it reads (frozen
into the compiled code), would leave a stale kernel in use. So unless ``NUMBA_CACHE_DIR`` is
set, the cache goes to ``<humimic cache>/numba/<digest>`` (:func:`humimic.cache.cache_dir`),
the digest a SHA-256 of the source of every humimic module that compiles kernels and of the
humimic modules those import: any such edit starts a fresh cache.
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
from pathlib import Path

import numba

_PACKAGE = Path(__file__).resolve().parents[1]
_IMPORT = re.compile(rb"^\s*from humimic\.([\w.]+) import|^\s*import humimic\.([\w.]+)", re.M)


def _module_path(package: Path, dotted: bytes) -> Path | None:
    base = package.joinpath(*dotted.decode().split("."))
    for p in (base.with_suffix(".py"), base / "__init__.py"):
        if p.is_file():
            return p
    return None


def kernel_sources_digest(package: Path = _PACKAGE) -> str:
    """SHA-256 (hex, 16 characters) of the modules under ``package`` that use :data:`njit`
    and of the humimic modules they import (module docstring)."""
    users = sorted(p for p in package.rglob("*.py") if b"maths.jit import" in p.read_bytes())
    files = set(users)
    for p in users:
        for m in _IMPORT.finditer(p.read_bytes()):
            dep = _module_path(package, m.group(1) or m.group(2))
            if dep is not None:
                files.add(dep)
    h = hashlib.sha256()
    for p in sorted(files):
        h.update(str(p.relative_to(package)).encode() + b"\0" + p.read_bytes() + b"\0")
    return h.hexdigest()[:16]


if not os.environ.get("NUMBA_CACHE_DIR"):
    from humimic.cache import cache_dir

    os.environ["NUMBA_CACHE_DIR"] = str(cache_dir() / "numba" / kernel_sources_digest())
    numba.config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]     # read when a kernel is defined

njit = functools.partial(numba.njit, cache=True, nogil=True, error_model="numpy")
