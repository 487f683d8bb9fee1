"""One place for how humimic compiles its hot loops with numba.

`njit` is `numba.njit` with the project's options: compiled code is cached on disk (so only
the first run after a change pays the compile time), releases the GIL (the perception worker
runs beside the servo loop), and keeps numpy's error model (division by zero gives inf/nan like
numpy instead of raising). No `parallel=True`: the machine has two cores and the runner already
uses both.

Where the cache lives. numba keys a cached kernel on the timestamp of the file that defines it
alone: an edit to a kernel it calls in another file, or to a module constant it reads (frozen
into the compiled code), would leave a stale kernel in use. So unless the user set
``NUMBA_CACHE_DIR``, the cache goes to ``<humimic cache>/numba/<digest>``
(:func:`humimic.cache.cache_dir`; the temporary directory if that cannot be written, no cache
if neither can), the digest a SHA-256 of the source of every humimic module that compiles
kernels and of the humimic modules those import: any such edit starts a fresh cache
(:func:`cache_location`).
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
import tempfile
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


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            return True
    except OSError:
        return False


def cache_location(environ, digest: str) -> str | None:
    """Where numba caches compiled kernels: the user's ``NUMBA_CACHE_DIR`` if they set one
    (not one a humimic parent process chose and exported with an older digest), else
    ``<humimic cache>/numba/<digest>``, else the temporary directory's
    ``humimic-numba-<uid>/<digest>``; ``None`` (compile in every process) when neither can
    be written -- never numba's own fallback beside the sources, which would go stale."""
    user = environ.get("NUMBA_CACHE_DIR")
    if user and user != environ.get(_CHOSEN):
        return user
    from humimic.cache import cache_dir

    uid = getattr(os, "getuid", lambda: "user")()
    for base in (cache_dir() / "numba", Path(tempfile.gettempdir()) / f"humimic-numba-{uid}"):
        if _writable(base / digest):
            return str(base / digest)
    return None


_CHOSEN = "HUMIMIC_NUMBA_CACHE_DIR"
_location = cache_location(os.environ, kernel_sources_digest())
if _location is not None:
    os.environ["NUMBA_CACHE_DIR"] = os.environ[_CHOSEN] = _location    # child processes too
    numba.config.CACHE_DIR = _location                 # read when a kernel is defined

njit = functools.partial(numba.njit, cache=_location is not None, nogil=True,
                         error_model="numpy")
