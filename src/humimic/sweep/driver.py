"""Run a sweep: plan (validate everything), skip complete runs, execute the rest on a backend,
write the summary. Results are recorded as runs finish; a failed run never stops the others.

Output directory layout::

    DIR/sweep.json                 what was asked: sweep file, base scenario, every run's
                                   overrides and seed, and each run's status
    DIR/<run>/                     that run's own outputs (metrics.json, scenario.resolved.yaml,
                                   plots / run.rrd if enabled, error.txt if it failed)
    DIR/summary.csv, summary.md    one row per run; mean +- std per point
    DIR/plots/<metric>.png         key metrics vs the swept parameter
"""

from __future__ import annotations

import datetime as _dt
import json
import platform
from dataclasses import dataclass
from pathlib import Path

from rich.console import Console
from tqdm import tqdm

from humimic.sweep.backends import check_backend, default_jobs, run_map
from humimic.sweep.config import Sweep
from humimic.sweep.plan import PlannedRun, plan_sweep
from humimic.sweep.plots import sweep_plots
from humimic.sweep.runs import RunOutcome, completed_metrics, ensure_result_files, execute_run
from humimic.sweep.summary import (
    flatten,
    group_rows,
    is_number,
    print_table,
    run_rows,
    select_metrics,
    write_csv,
    write_markdown,
)


@dataclass
class SweepResult:
    out_dir: Path
    planned: list[PlannedRun]
    outcomes: dict[str, RunOutcome]

    @property
    def failed(self) -> list[RunOutcome]:
        return [o for o in self.outcomes.values() if o.status != "ok"]

    @property
    def executed(self) -> list[RunOutcome]:
        return [o for o in self.outcomes.values() if not o.cached]


def default_out_dir(sweep: Sweep) -> Path:
    return Path("runs") / "sweeps" / sweep.name


def run_sweep(sweep: Sweep, out_dir: str | Path | None = None, jobs: int | None = None,
              backend: str = "local", address: str | None = None, force: bool = False,
              progress: bool = True, console: Console | None = None) -> SweepResult:
    """Run every run of ``sweep`` that is not complete yet; write and print the summary."""
    console = console or Console()
    check_backend(backend, address)  # before anything is planned or written
    out = Path(out_dir) if out_dir is not None else default_out_dir(sweep)
    planned = plan_sweep(sweep, out)  # raises ScenarioError before anything runs
    out.mkdir(parents=True, exist_ok=True)
    jobs = jobs or default_jobs()
    outcomes: dict[str, RunOutcome] = {}
    todo = []
    for p in planned:
        metrics = None if force else completed_metrics(p.out_dir, p.scenario)
        if metrics is not None:
            outcomes[p.name] = RunOutcome(p.name, "ok", cached=True, metrics=metrics)
        else:
            todo.append(p)
    by_name = {p.name: p for p in planned}
    rerun = "save" if sweep.config.rerun else "off"
    bar = tqdm(total=len(planned), initial=len(planned) - len(todo), unit="run",
               desc=sweep.name, disable=None if progress else True, dynamic_ncols=True)
    try:
        args = [(p.name, p.scenario, p.out_dir, rerun) for p in todo]
        for outcome in run_map(backend, execute_run, args, jobs, address):
            outcomes[outcome.name] = outcome
            ensure_result_files(by_name[outcome.name].out_dir, by_name[outcome.name].scenario,
                                outcome)
            bar.update(1)
            failed = sum(o.status != "ok" for o in outcomes.values())
            if failed:
                bar.set_postfix(failed=failed)
    finally:
        bar.close()
        result = SweepResult(out, planned, outcomes)
        write_summary(sweep, result, backend, jobs, console)
    return result


def write_summary(sweep: Sweep, result: SweepResult, backend: str, jobs: int,
                  console: Console) -> None:
    """sweep.json, summary.csv, summary.md, plots; print the key-metric table."""
    out, planned = result.out_dir, result.planned
    specs = [p.spec for p in planned]
    point_keys = list(dict.fromkeys(o.key for s in specs for o in s.point))
    rows = run_rows(specs, result.outcomes)
    numeric = sorted({k for o in result.outcomes.values() for k, v in flatten(o.metrics).items()
                      if is_number(v)})
    metrics = select_metrics(sweep.config.metrics, numeric)
    unmatched = [p for p in sweep.config.metrics if not select_metrics([p], numeric)]
    groups = group_rows(specs, rows)
    n_ok = sum(r["status"] == "ok" for r in rows)
    n_cached = sum(bool(r["cached"]) for r in rows)
    seeds = sorted({s.seed for s in specs})
    facts = [f"sweep file: `{sweep.path}`", f"base scenario: `{sweep.scenario_path}`",
             f"{len(rows)} runs: {n_ok} ok ({n_cached} reused from an earlier invocation), "
             f"{len(rows) - n_ok} not ok", f"seeds: {seeds}",
             f"fixed overrides: {sweep.config.set or 'none'}",
             f"backend: {backend}, jobs: {jobs}; {platform.node()}, "
             f"{_dt.datetime.now().isoformat(timespec='seconds')}"]
    if unmatched:
        facts.append(f"key-metric patterns that matched no metric: {', '.join(unmatched)}")
    if sweep.config.description:
        facts.insert(0, sweep.config.description.strip())
    (out / "sweep.json").write_text(json.dumps({
        "name": sweep.name, "sweep_file": str(sweep.path.resolve()),
        "scenario": str(sweep.scenario_path), "set": sweep.config.set,
        "runs": [{"name": s.name, "seed": s.seed, "overrides": s.point_values,
                  "status": r["status"], "cached": r["cached"]} for s, r in zip(specs, rows,
                                                                                strict=True)],
    }, indent=2, default=str))
    write_csv(out / "summary.csv", rows, point_keys)
    plots = sweep_plots(out / "plots", metrics, groups, point_keys, f"sweep {sweep.name}")
    write_markdown(out / "summary.md", f"Sweep `{sweep.name}`", facts, groups, point_keys,
                   metrics, rows, plots)
    print_table(console, f"sweep {sweep.name}: mean ± std over seeds", groups, point_keys,
                metrics)
    if unmatched and n_ok:
        console.print(f"[dim]key-metric patterns that matched no metric: "
                      f"{', '.join(unmatched)}[/dim]")
    for r in rows:
        if r["status"] != "ok":
            console.print(f"[red]{r['status']}[/red] {r['run']}: {r['error']}")
    console.print(f"{n_ok}/{len(rows)} runs ok ({n_cached} reused); summary in "
                  f"[bold]{out / 'summary.md'}[/bold] and {out / 'summary.csv'}")
