"""The sweep file's schema and loader: a base scenario, overrides to vary, seeds.

Example (``sweeps/kalman_b_distance.yaml``)::

    scenario: ../scenarios/wave.yaml     # relative to this file
    set: {duration: 4.0}                 # fixed overrides, every run
    grid:                                # cartesian product of these values
      filter.b: [2.75, 27.5, 275.0]
      human.distance: [0.8, 1.2, 2.0]
    list:                                # and/or: explicit override sets (x the grid)
      - {cameras.noise_std: 0.0}
      - {cameras.noise_std: 4.0}
    seeds: 3                             # seeds 0, 1, 2 (or a list: [3, 7])
    metrics: [tracking.*.filtered_rmse_mm]

Keys are the scenario's dotted keys (as ``--set`` takes them). Unknown keys and bad values are
errors naming the sweep file, its line and the dotted key (:class:`ScenarioError`, exit 2).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from humimic.errors import closest
from humimic.scenario.errors import ScenarioError, from_validation_error, yaml_line
from humimic.scenario.load import read_yaml_mapping

#: A scenario key as ``--set`` takes it: ``human.distance``, ``human.motion.frames.0.t``.
DOTTED_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z0-9_]+)*$")
#: Keys a sweep may not override (the sweep sets them itself).
RESERVED_KEYS = {"seed": "use the sweep's 'seeds' instead"}
#: Key metrics shown in summary.md and plotted when the sweep file names none. ``*`` matches
#: one dotted segment, ``**`` any number; patterns that match nothing are ignored.
DEFAULT_METRICS = (
    "realtime_factor",
    "tracking.*.raw_rmse_mm",
    "tracking.*.filtered_rmse_mm",
    "mimicry.*.rmse_mm",
    "mimicry.*.lag_ms",
    "latency_ms.end_to_end",
)

Overrides = dict[str, Any]


def _check_keys(overrides: Overrides) -> Overrides:
    for key in overrides:
        if not DOTTED_KEY.match(key):
            raise ValueError(f"{key!r} is not a dotted scenario key (e.g. human.distance)")
        if key in RESERVED_KEYS:
            raise ValueError(f"{key!r} cannot be overridden here: {RESERVED_KEYS[key]}")
    return overrides


class SweepConfig(BaseModel):
    """A sweep: runs = (grid points x list entries) x seeds, each one ``run_one`` call."""

    model_config = ConfigDict(extra="forbid")

    scenario: Path
    """Base scenario file, relative to the sweep file."""
    name: str | None = Field(None, pattern=r"^[A-Za-z0-9_.\-]+$", max_length=80)
    """Default: the sweep file's name without extension."""
    description: str = ""
    set: Overrides = Field(default_factory=dict)
    """Fixed overrides applied to every run (before the grid and list)."""
    grid: dict[str, Annotated[list[Any], Field(min_length=1)]] = Field(default_factory=dict)
    """Dotted key -> values; every combination is a grid point (in the order written)."""
    cases: list[Overrides] = Field(default_factory=list, alias="list")
    """Explicit override sets; combined with every grid point."""
    seeds: Annotated[int, Field(ge=1, le=10_000)] | Annotated[
        list[Annotated[int, Field(ge=0)]], Field(min_length=1)] | None = None
    """``n``: seeds 0..n-1; a list: those seeds; absent: the scenario's own seed."""
    metrics: list[str] = Field(default_factory=lambda: list(DEFAULT_METRICS))
    """Key metrics (dotted, with ``*`` / ``**`` wildcards) for summary.md, the table, plots."""
    plots: bool = False
    """Write each run's PNG plots (sets ``output.plots``; the sweep's own plots are always
    written)."""
    rerun: bool = False
    """Save each run's ``run.rrd`` (``--rerun save``); off by default: sweeps are for numbers."""

    @field_validator("set", "grid")
    @classmethod
    def _keys(cls, value: dict) -> dict:
        return _check_keys(value)

    @field_validator("cases")
    @classmethod
    def _case_keys(cls, value: list[Overrides]) -> list[Overrides]:
        for case in value:
            _check_keys(case)
        return value

    @field_validator("seeds")
    @classmethod
    def _unique_seeds(cls, value):
        if isinstance(value, list) and len(set(value)) != len(value):
            raise ValueError(f"seeds must be distinct, got {value}")
        return value

    def seed_list(self, scenario_seed: int) -> list[int]:
        if self.seeds is None:
            return [scenario_seed]
        if isinstance(self.seeds, int):
            return list(range(self.seeds))
        return list(self.seeds)


@dataclass(frozen=True)
class Sweep:
    """A loaded sweep file: its config, where it is and its text (for error lines)."""

    config: SweepConfig
    path: Path
    text: str

    @property
    def name(self) -> str:
        return self.config.name or self.path.stem

    @property
    def scenario_path(self) -> Path:
        p = self.config.scenario
        return p if p.is_absolute() else (self.path.parent / p).resolve()

    def error(self, key_path: list[str], key: str, problem: str, value: Any = None,
              allowed: str | None = None, suggestion: str | None = None) -> ScenarioError:
        """A one-line error at ``key_path`` of this sweep file."""
        return ScenarioError(self.path, key, problem, value, allowed, suggestion,
                             yaml_line(self.text, key_path))


def load_sweep(path: str | Path) -> Sweep:
    """Read and validate a sweep file (raises :class:`ScenarioError`, exit status 2)."""
    path = Path(path)
    text, data = read_yaml_mapping(path, "sweep",
                                   "a YAML mapping with scenario, grid, list, seeds, set, ...")
    try:
        config = SweepConfig.model_validate(data)
    except ValidationError as err:
        raise _sweep_error(err, path, text) from None
    sweep = Sweep(config=config, path=path, text=text)
    if not sweep.scenario_path.is_file():
        raise sweep.error(["scenario"], "scenario", "scenario file not found",
                          str(config.scenario), "a scenario YAML path relative to the sweep file")
    return sweep


def _sweep_error(err: ValidationError, path: Path, text: str) -> ScenarioError:
    """Like a scenario error, but a grid/set/list key is one YAML key (it contains dots), the
    ``list`` field is named by its alias, and ``seeds`` hides pydantic's union member names."""
    e = err.errors()[0]
    loc = tuple(str(p) for p in e["loc"])
    out = from_validation_error(err, SweepConfig, path, text)
    if e["type"] == "extra_forbidden" and len(loc) == 1:
        names = sorted(f.alias or n for n, f in SweepConfig.model_fields.items())
        return ScenarioError(path, loc[0], "unknown key", out.value, ", ".join(names),
                             closest(loc[0], names), out.line)
    if loc and loc[0] == "seeds":
        return ScenarioError(path, "seeds", "must be a number of seeds (>= 1, giving seeds "
                             "0..n-1) or a list of distinct seeds >= 0", e.get("input"),
                             None, None, yaml_line(text, ["seeds"]))
    if loc and loc[0] in ("grid", "set", "list") and len(loc) >= 2:
        depth = 3 if loc[0] == "list" else 2  # list.<i>.<key>
        key_path = list(loc[:depth])
        key = ".".join(loc[:depth])
        return ScenarioError(path, key, out.problem, out.value, out.allowed, out.suggestion,
                             yaml_line(text, key_path))
    return out
