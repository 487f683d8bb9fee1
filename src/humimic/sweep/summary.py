"""A sweep's results: ``summary.csv`` (one row per run), ``summary.md`` (mean +- std per point
for the key metrics) and the same table printed with rich.

Metrics are flattened to dotted columns (``tracking.right_hand.filtered_rmse_mm``; list items
get their index: ``raw_std_mm.0``). Key metrics are chosen by patterns in which ``*`` matches
one dotted segment and ``**`` any number of them. Statistics use the runs that finished
(``status == ok``); the standard deviation is the sample one (n - 1) over seeds.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from humimic.metrics.flatten import flatten_metrics as flatten
from humimic.sweep.grid import RunSpec
from humimic.sweep.runs import RunOutcome

LEAD = ("run", "status", "cached", "seed")
SKIP_METRICS = {"seed", "scenario"}


def is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def pattern_regex(pattern: str) -> re.Pattern:
    parts = re.split(r"(\*\*|\*)", pattern)
    rx = "".join(".*" if p == "**" else "[^.]*" if p == "*" else re.escape(p) for p in parts)
    return re.compile(rf"^{rx}$")


def select_metrics(patterns: list[str], columns: list[str]) -> list[str]:
    """Columns matching ``patterns``, in pattern order (each pattern's matches sorted)."""
    out: list[str] = []
    for pattern in patterns:
        rx = pattern_regex(pattern)
        out += [c for c in sorted(columns) if rx.match(c) and c not in out]
    return out


def run_rows(specs: list[RunSpec], outcomes: dict[str, RunOutcome]) -> list[dict[str, Any]]:
    """One row per run, in sweep order: lead columns, the point's keys, error, metrics."""
    rows = []
    for spec in specs:
        o = outcomes.get(spec.name) or RunOutcome(spec.name, "not run")
        row: dict[str, Any] = {"run": spec.name, "status": o.status, "cached": o.cached,
                               "seed": spec.seed}
        row.update(spec.point_values)
        row["error"] = o.error
        for k, v in flatten(o.metrics).items():
            if k not in SKIP_METRICS and k not in row:
                row[k] = v
        rows.append(row)
    return rows


def write_csv(path: Path, rows: list[dict[str, Any]], point_keys: list[str]) -> Path:
    fixed = [*LEAD, *point_keys, "error"]
    metric_cols = sorted({k for r in rows for k in r} - set(fixed))
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fixed + metric_cols, restval="")
        writer.writeheader()
        for r in rows:
            writer.writerow({k: "" if v is None else v for k, v in r.items()})
    return path


@dataclass
class Group:
    """The runs of one point (all seeds) and their statistics."""

    values: dict[str, Any]
    runs: list[dict[str, Any]] = field(default_factory=list)

    @property
    def n_ok(self) -> int:
        return sum(r["status"] == "ok" for r in self.runs)

    @property
    def n_failed(self) -> int:
        return len(self.runs) - self.n_ok

    def stats(self, column: str) -> tuple[float, float, int]:
        """Mean, sample std (0 for one value) and count of a column over the finished runs."""
        xs = [r[column] for r in self.runs if r["status"] == "ok" and is_number(r.get(column))]
        if not xs:
            return math.nan, math.nan, 0
        mean = sum(xs) / len(xs)
        var = sum((x - mean) ** 2 for x in xs) / (len(xs) - 1) if len(xs) > 1 else 0.0
        return mean, math.sqrt(var), len(xs)


def group_rows(specs: list[RunSpec], rows: list[dict[str, Any]]) -> list[Group]:
    groups: dict[str, Group] = {}
    for spec, row in zip(specs, rows, strict=True):
        groups.setdefault(spec.point_id, Group(spec.point_values)).runs.append(row)
    return list(groups.values())


def fmt_value(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def fmt_stat(mean: float, std: float, n: int, n_runs: int | None = None) -> str:
    """``mean ± std``; ``(n=k)`` added when fewer than the point's ``n_runs`` ok runs have it."""
    if n == 0:
        return "-"
    text = f"{mean:.4g}" if n == 1 else f"{mean:.4g} ± {std:.2g}"
    return text + (f" (n={n})" if n_runs is not None and n < n_runs else "")


def table_rows(groups: list[Group], point_keys: list[str], metrics: list[str]
               ) -> list[list[str]]:
    out = []
    for g in groups:
        runs = f"{g.n_ok}" + (f" (+{g.n_failed} failed)" if g.n_failed else "")
        out.append([fmt_value(g.values.get(k, "")) for k in point_keys] + [runs]
                   + [fmt_stat(*g.stats(m), g.n_ok) for m in metrics])
    return out


def write_markdown(path: Path, title: str, facts: list[str], groups: list[Group],
                   point_keys: list[str], metrics: list[str], rows: list[dict[str, Any]],
                   plots: list[Path]) -> Path:
    header = [*point_keys, "runs ok", *metrics]
    lines = [f"# {title}", "", *[f"- {f}" for f in facts], "",
             "## Key metrics (mean ± sample std over seeds)", "",
             "(n=k): only k of the point's finished runs report that metric.", ""]
    if metrics:
        lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        lines += ["| " + " | ".join(r) + " |" for r in table_rows(groups, point_keys, metrics)]
    else:
        lines.append("No key metric was found in the runs' metrics.")
    failed = [r for r in rows if r["status"] != "ok"]
    if failed:
        lines += ["", "## Failed runs", "", "| run | status | error |", "|---|---|---|"]
        lines += [f"| {r['run']} | {r['status']} | {str(r['error']).replace('|', '/')} |"
                  for r in failed]
        lines += ["", "Each failed run's traceback is in `<run>/error.txt`."]
    if plots:
        lines += ["", "## Plots", ""]
        lines += [f"![{p.stem}]({p.relative_to(path.parent).as_posix()})" for p in plots]
    path.write_text("\n".join(lines) + "\n")
    return path


def common_prefix(keys: list[str]) -> str:
    """The longest dotted prefix (ending in a dot) shared by all ``keys``; '' for fewer than 2."""
    if len(keys) < 2:
        return ""
    parts = [k.split(".")[:-1] for k in keys]
    n = 0
    while all(len(p) > n and p[n] == parts[0][n] for p in parts):
        n += 1
    return "".join(f"{x}." for x in parts[0][:n])


def print_table(console: Console, title: str, groups: list[Group], point_keys: list[str],
                metrics: list[str], max_header: int = 18) -> None:
    """The key-metric table; split into several tables (each repeating the point columns)
    when the metrics do not fit the console's width side by side."""
    body = table_rows(groups, point_keys, metrics)
    n_point = len(point_keys) + 1
    prefix = common_prefix(metrics)
    if prefix:
        title += f" (metrics under {prefix})"
    headers = [*point_keys, "runs ok", *(m[len(prefix):] for m in metrics)]

    def width(i: int) -> int:
        return max([min(len(headers[i]), max_header)] + [len(r[i]) for r in body]) + 3

    fixed = sum(width(i) for i in range(n_point)) + 1
    chunks: list[list[int]] = [[]]
    used = fixed
    for j in range(n_point, len(headers)):
        if chunks[-1] and used + width(j) > console.width:
            chunks.append([])
            used = fixed
        chunks[-1].append(j)
        used += width(j)
    for c, cols in enumerate(chunks):
        part = f" ({c + 1}/{len(chunks)})" if len(chunks) > 1 else ""
        table = Table(title=title + part)
        for i in range(n_point):
            table.add_column(headers[i], style="cyan" if i < n_point - 1 else None,
                             justify="right", no_wrap=True)
        for j in cols:
            table.add_column(headers[j], justify="right", overflow="fold",
                             min_width=width(j) - 3, max_width=width(j) - 3)
        for r in body:
            table.add_row(*r[:n_point], *(r[j] for j in cols))
        console.print(table)
