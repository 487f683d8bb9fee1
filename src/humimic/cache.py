"""A small on-disk cache for models humimic learns from renders (eigenfaces, colour models).

Entries live in ``$HUMIMIC_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/humimic`` (default
``~/.cache/humimic``), one ``.npz`` per entry, named by a SHA-256 of everything that went into
it (:func:`key`): change an input and a new entry is made; delete the directory at any time.
Writes go through a temporary file and an atomic rename, so parallel runs never read half a
file.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np


def cache_dir() -> Path:
    env = os.environ.get("HUMIMIC_CACHE_DIR")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "humimic"


def key(*parts: Any) -> str:
    """SHA-256 (hex, 24 characters) of the parts: bytes as they are, files by content,
    anything else by ``repr``."""
    h = hashlib.sha256()
    for p in parts:
        if isinstance(p, bytes):
            data = p
        elif isinstance(p, Path):
            data = p.read_bytes()
        else:
            data = repr(p).encode()
        h.update(len(data).to_bytes(8, "little"))
        h.update(data)
    return h.hexdigest()[:24]


def path(kind: str, digest: str) -> Path:
    return cache_dir() / f"{kind}-{digest}.npz"


def load(kind: str, digest: str) -> dict[str, np.ndarray] | None:
    """The arrays stored under ``kind``/``digest``, or None when there is no (readable) entry."""
    p = path(kind, digest)
    if not p.exists():
        return None
    try:
        with np.load(p, allow_pickle=False) as f:
            return {k: f[k] for k in f.files}
    except (OSError, ValueError):
        return None


def save(kind: str, digest: str, arrays: dict[str, np.ndarray]) -> Path:
    """Store arrays atomically; returns the file."""
    p = path(kind, digest)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=p.parent, suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez_compressed(f, **arrays)
        os.replace(tmp, p)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return p
