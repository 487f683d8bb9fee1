"""One run of a sweep: the same :func:`humimic.run.run_one` the CLI uses, made resumable and
failure-tolerant.

A run directory is *complete* when its ``metrics.json`` parses, says ``interrupted: false``,
and its ``scenario.resolved.yaml`` is the scenario the sweep would run now (so editing the sweep
file's fixed overrides reruns the affected runs instead of silently reusing stale numbers).
A run that raises leaves ``error.txt`` (the traceback) and is reported, never propagated.
"""

from __future__ import annotations

from humimic import select_gl_backend

select_gl_backend()  # also the entry of a sweep's worker processes (before mujoco is imported)

import json
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

from humimic.run import run_one
from humimic.scenario import Scenario, dump_scenario

METRICS = "metrics.json"
ERROR = "error.txt"
RESOLVED = "scenario.resolved.yaml"


@dataclass
class RunOutcome:
    name: str
    status: str
    """``ok``, ``failed`` or ``interrupted``."""
    cached: bool = False
    """True when a complete earlier result was reused (the run was skipped)."""
    metrics: dict = field(default_factory=dict)
    error: str = ""
    """``ExceptionType: message`` (first line) of a failed run."""
    wall_s: float = 0.0


def completed_metrics(out_dir: Path, scenario: Scenario) -> dict | None:
    """The metrics of a complete earlier run of ``scenario`` in ``out_dir``, else None."""
    try:
        metrics = json.loads((out_dir / METRICS).read_text())
        resolved = (out_dir / RESOLVED).read_text()
    except (OSError, ValueError):
        return None
    if not isinstance(metrics, dict) or metrics.get("interrupted", True) is not False:
        return None
    if "sim_time_s" not in metrics or resolved != dump_scenario(scenario):
        return None
    return metrics


def execute_run(name: str, scenario: Scenario, out_dir: str | Path,
                rerun: str = "off") -> RunOutcome:
    """Run one scenario into ``out_dir`` with :func:`run_one`; never raises (but Ctrl-C)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for stale in (METRICS, ERROR):
        (out / stale).unlink(missing_ok=True)
    t0 = time.perf_counter()
    try:
        metrics = run_one(scenario, out, rerun=rerun, progress=False)
    except Exception as exc:  # noqa: BLE001  (a failed run is data, the sweep goes on)
        (out / ERROR).write_text(traceback.format_exc())
        message = f"{type(exc).__name__}: {exc}".strip().splitlines()[0]
        return RunOutcome(name, "failed", error=message, wall_s=time.perf_counter() - t0)
    status = "interrupted" if metrics.get("interrupted") else "ok"
    return RunOutcome(name, status, metrics=metrics, error="" if status == "ok" else
                      "interrupted", wall_s=time.perf_counter() - t0)


def ensure_result_files(out_dir: Path, scenario: Scenario, outcome: RunOutcome) -> None:
    """Write ``metrics.json`` and ``scenario.resolved.yaml`` where the driver sees them when
    the run executed elsewhere (a Ray worker on another node without a shared file system):
    resuming relies on them."""
    if outcome.status != "ok" or (out_dir / METRICS).is_file():
        return
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / RESOLVED).write_text(dump_scenario(scenario))
    (out_dir / METRICS).write_text(json.dumps(outcome.metrics, indent=2, allow_nan=False))
