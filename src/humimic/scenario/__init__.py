"""Scenario files: schema, loading and one-line errors.

Names are imported lazily so that stage packages can import :mod:`humimic.scenario.base`
for their config sections without importing the whole schema (which imports them).
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "Scenario": "humimic.scenario.schema",
    "ScenarioError": "humimic.scenario.errors",
    "dump_scenario": "humimic.scenario.load",
    "load_scenario": "humimic.scenario.load",
    "validate_scenario": "humimic.scenario.load",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'humimic.scenario' has no attribute {name!r}")
