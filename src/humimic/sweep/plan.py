"""Validate every run of a sweep up front: the scenario each run will execute, or an error.

Each run's scenario is the base scenario file with the sweep's ``set`` overrides, then the
run's point overrides, then its seed, validated exactly as ``python -m humimic.run --set``
would. An error caused by an override names the sweep file, its line and the override (e.g.
``grid.filter.b``); an error in the base scenario itself names the scenario file. Nothing runs
until every scenario is valid.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

import yaml

from humimic.scenario import Scenario, ScenarioError, load_scenario, validate_scenario
from humimic.scenario.load import apply_override
from humimic.sweep.config import Sweep
from humimic.sweep.grid import Override, RunSpec, expand


@dataclass(frozen=True)
class PlannedRun:
    spec: RunSpec
    scenario: Scenario
    out_dir: Path

    @property
    def name(self) -> str:
        return self.spec.name


def plan_sweep(sweep: Sweep, out_dir: str | Path) -> list[PlannedRun]:
    """Every run of ``sweep`` with its validated scenario and output directory."""
    path = sweep.scenario_path
    base = load_scenario(path)  # the base alone must be valid (errors name the scenario)
    text = path.read_text()
    data = yaml.safe_load(text)
    out_dir = Path(out_dir).resolve()
    planned = []
    for spec in expand(sweep, base.seed):
        scenario = build_scenario(sweep, data, path, spec, text)
        planned.append(PlannedRun(spec, scenario, out_dir / spec.name))
    return planned


def build_scenario(sweep: Sweep, data: dict, path: Path, spec: RunSpec, text: str = ""
                   ) -> Scenario:
    """The validated scenario of one run (raises :class:`ScenarioError`)."""
    data = copy.deepcopy(data)
    apply_override(data, "output.plots", sweep.config.plots)
    for o in spec.overrides:
        try:
            apply_override(data, o.key, copy.deepcopy(o.value))
        except (ScenarioError, AttributeError, IndexError, KeyError, TypeError, ValueError):
            raise sweep.error(list(o.where), o.label, "cannot be set in the scenario "
                              f"{_rel(path)} (a part of the key is not a mapping or the "
                              "list index is out of range)", o.value) from None
    try:
        return validate_scenario(data, path, text, seed=spec.seed)
    except ScenarioError as err:
        culprit = _culprit(err.key, spec.overrides)
        if culprit is None:
            raise
        at = f" (at {err.key})" if err.key != culprit.key else ""
        raise sweep.error(list(culprit.where), culprit.label,
                          f"{err.problem} in scenario {_rel(path)}{at}", culprit.value,
                          err.allowed, err.suggestion) from None


def _culprit(key: str, overrides: tuple[Override, ...]) -> Override | None:
    """The override (the most specific, the latest) whose key covers or contains ``key``."""
    if not key:
        return None
    hits = [o for o in overrides
            if key == o.key or key.startswith(o.key + ".") or o.key.startswith(key + ".")]
    if not hits:
        return None
    return max(reversed(hits), key=lambda o: len(o.key))


def _rel(path: Path) -> str:
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)
