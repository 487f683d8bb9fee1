"""Expand a sweep into named runs: (grid points x list entries) x seeds.

Each run has a *point* (the overrides that vary across the sweep, in the order the sweep file
writes them) and a seed. Its name is deterministic and filesystem-safe, built from the shortest
unambiguous suffix of each varying key, its value and the seed, e.g.
``b=27.5__distance=1.2__seed=0``; values that do not make a short name (lists, mappings, long
text) are replaced by a hash of their exact value, and names that would still collide get one.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import re
from dataclasses import dataclass, field
from typing import Any

from humimic.sweep.config import Sweep

_UNSAFE = re.compile(r"[^A-Za-z0-9._+\-]+")
MAX_VALUE_CHARS = 32
MAX_NAME_CHARS = 150


@dataclass(frozen=True)
class Override:
    """One ``key = value`` and where the sweep file wrote it (for error messages)."""

    key: str
    value: Any
    where: tuple[str, ...]
    """Path of the key in the sweep file, e.g. ``("grid", "filter.b")``, ``("list", "0", k)``."""

    @property
    def label(self) -> str:
        """``grid.filter.b``, ``list.0.cameras.noise_std``, ``set.duration``."""
        return ".".join(self.where)


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep: fixed overrides, the point's overrides and a seed."""

    name: str
    seed: int
    point: tuple[Override, ...]
    fixed: tuple[Override, ...] = field(default=())

    @property
    def overrides(self) -> tuple[Override, ...]:
        """Everything to apply, in order: fixed (``set``) first, then the point."""
        return self.fixed + self.point

    @property
    def point_values(self) -> dict[str, Any]:
        return {o.key: o.value for o in self.point}

    @property
    def point_id(self) -> str:
        """Identifies the point regardless of seed (runs grouped for mean +- std)."""
        return _canonical(self.point_values)


def _canonical(value: Any) -> str:
    return json.dumps(value, sort_keys=True, default=str, separators=(",", ":"))


def _digest(value: Any, n: int = 8) -> str:
    return hashlib.sha1(_canonical(value).encode()).hexdigest()[:n]


def short_keys(keys: list[str]) -> dict[str, str]:
    """The shortest dotted suffix of each key that no other key ends with."""
    out = {}
    for key in keys:
        parts = key.split(".")
        for n in range(1, len(parts) + 1):
            suffix = ".".join(parts[-n:])
            others = [k for k in keys if k != key]
            if not any(k == suffix or k.endswith("." + suffix) for k in others):
                out[key] = suffix
                break
        else:
            out[key] = key
    return out


def value_text(value: Any) -> str:
    """A short filesystem-safe rendering of an override value (or a hash of it)."""
    if isinstance(value, bool) or value is None:
        text = json.dumps(value)
    elif isinstance(value, int | float):
        text = repr(value)
    elif isinstance(value, str):
        text = value
    else:
        text = _canonical(value)
    safe = _UNSAFE.sub("_", text).strip("_")
    if not safe or len(safe) > MAX_VALUE_CHARS or safe != text and not isinstance(
            value, list | tuple):
        return "h" + _digest(value)
    return safe


def run_name(point: tuple[Override, ...], seed: int, short: dict[str, str]) -> str:
    parts = [f"{short[o.key]}={value_text(o.value)}" for o in point] + [f"seed={seed}"]
    name = "__".join(parts)
    if len(name) > MAX_NAME_CHARS:
        name = name[: MAX_NAME_CHARS - 10] + "__" + _digest([[o.key, o.value] for o in point])
    return name


def expand(sweep: Sweep, scenario_seed: int = 0) -> list[RunSpec]:
    """Every run of ``sweep`` in a deterministic order (points in file order, then seeds).

    Raises :class:`~humimic.scenario.ScenarioError` if a list entry repeats a grid key.
    """
    cfg = sweep.config
    fixed = tuple(Override(k, v, ("set", k)) for k, v in cfg.set.items())
    grid_keys = list(cfg.grid)
    grid_points = list(itertools.product(*(cfg.grid[k] for k in grid_keys))) or [()]
    for key, values in cfg.grid.items():
        seen = [_canonical(v) for v in values]
        if len(set(seen)) != len(seen):
            raise sweep.error(["grid", key], f"grid.{key}", "values repeat", values,
                              "distinct values")
    cases = list(enumerate(cfg.cases)) or [(None, {})]
    seen_cases = [_canonical(c) for c in cfg.cases]
    for i, case in cases:
        if i is not None and seen_cases.index(seen_cases[i]) != i:
            j = seen_cases.index(seen_cases[i])
            raise sweep.error(["list", str(i)], f"list.{i}", f"repeats list entry {j}", case,
                              "distinct entries")
        for key in case:
            if key in cfg.grid:
                raise sweep.error(["list", str(i), key], f"list.{i}.{key}",
                                  "also varied by the grid: give each key in one place",
                                  case[key], "a key that is not in 'grid'")
    points = []
    for values in grid_points:
        for i, case in cases:
            point = [Override(k, v, ("grid", k)) for k, v in zip(grid_keys, values, strict=True)]
            point += [Override(k, v, ("list", str(i), k)) for k, v in case.items()]
            points.append(tuple(point))
    varying = list(dict.fromkeys(o.key for p in points for o in p))
    short = short_keys(varying)
    runs = [RunSpec(run_name(p, s, short), s, p, fixed)
            for p in points for s in cfg.seed_list(scenario_seed)]
    return _dedupe(runs)


def _dedupe(runs: list[RunSpec]) -> list[RunSpec]:
    """Give runs whose names collide (but whose overrides differ) a hash suffix."""
    counts: dict[str, int] = {}
    for r in runs:
        counts[r.name] = counts.get(r.name, 0) + 1
    out = []
    for r in runs:
        if counts[r.name] > 1:
            r = RunSpec(f"{r.name}__{_digest([r.point_id, r.seed])}", r.seed, r.point, r.fixed)
        out.append(r)
    return out
