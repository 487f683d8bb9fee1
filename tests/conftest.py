"""Shared fixtures. The test session chooses a headless OpenGL backend before any test imports
mujoco (`select_gl_backend`, as the entry points do)."""

from __future__ import annotations

from pathlib import Path

import pytest

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "data"


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The real data shipped in the repository (``data/``)."""
    return DATA
