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


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Under pytest-xdist's ``--dist loadgroup`` (the default, pyproject's ``addopts``): the
    tests that use a module- or class-scoped fixture of their file run on one worker (the
    fixture is built once); every other test is scheduled on its own, so no long test file
    (``test_scenarios.py``: a whole scenario per test) sets the suite's wall time alone."""
    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        if info is None:
            continue
        shared = any(d.scope in ("module", "class", "package")
                     for name in info.names_closure for d in info.name2fixturedefs.get(name, ()))
        if shared:
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
