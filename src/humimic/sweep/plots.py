"""Sweep plots: each key metric against a swept parameter, mean with +-1 std error bars.

The x axis is the first swept key whose values are all numbers (logarithmic when they are all
positive and span a factor of 20 or more); every combination of the other swept keys is one
line. Without a numeric key the points are categories on the x axis; a seeds-only sweep plots
the metric per seed with its mean and +-1 std band. Figures use matplotlib's ``Figure`` API on
an Agg canvas (no pyplot, no global state), like the run plots.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from humimic.sweep.summary import Group, fmt_value, is_number

DPI = 110


def _figure() -> Figure:
    fig = Figure(figsize=(6.4, 4.0), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def numeric_key(groups: list[Group], point_keys: list[str]) -> str | None:
    for k in point_keys:
        vals = [g.values.get(k) for g in groups]
        if vals and all(is_number(v) for v in vals) and len(set(vals)) > 1:
            return k
    return None


def file_name(metric: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.\-]+", "_", metric) + ".png"


def plot_metric(path: Path, metric: str, groups: list[Group], point_keys: list[str],
                title: str) -> Path | None:
    """One PNG for ``metric``; None when no run has a value for it."""
    if not any(g.stats(metric)[2] for g in groups):
        return None
    fig = _figure()
    ax = fig.add_subplot()
    x_key = numeric_key(groups, point_keys)
    if not point_keys:
        _per_seed(ax, groups[0], metric)
    elif x_key is None:
        _categorical(ax, groups, point_keys, metric)
    else:
        _lines(ax, groups, point_keys, x_key, metric)
    ax.set_ylabel(metric)
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    return path


def line_keys(groups: list[Group], point_keys: list[str], x_key: str) -> list[str]:
    """The swept keys that tell the lines apart: every key but ``x_key`` and those it
    determines (Table 1's cases set every tracker's particles and iterations together: one
    x value, one value of each -- naming them in each line's label only hides the axes)."""
    def determined(k: str) -> bool:
        seen: dict = {}
        return all(seen.setdefault(repr(g.values.get(x_key)), repr(g.values.get(k)))
                   == repr(g.values.get(k)) for g in groups)
    return [k for k in point_keys if k != x_key and not determined(k)]


def _lines(ax, groups, point_keys, x_key, metric) -> None:
    others = line_keys(groups, point_keys, x_key)
    series: dict[str, list[tuple[float, float, float]]] = {}
    for g in groups:
        mean, std, n = g.stats(metric)
        if n:
            label = ", ".join(f"{k}={fmt_value(g.values.get(k))}" for k in others)
            series.setdefault(label, []).append((g.values[x_key], mean, std))
    for label, pts in series.items():
        pts.sort()
        xs, ms, ss = zip(*pts, strict=True)
        ax.errorbar(xs, ms, yerr=ss, marker="o", capsize=3, label=label or None)
    xs_all = [g.values[x_key] for g in groups]
    if min(xs_all) > 0 and max(xs_all) / min(xs_all) >= 20:
        ax.set_xscale("log")
    ax.set_xlabel(x_key)
    if any(series):
        ax.legend(fontsize=8)


def _categorical(ax, groups, point_keys, metric) -> None:
    labels, ms, ss = [], [], []
    for g in groups:
        mean, std, n = g.stats(metric)
        labels.append("\n".join(f"{k}={fmt_value(g.values.get(k))}" for k in point_keys))
        ms.append(mean if n else math.nan)
        ss.append(std if n else 0.0)
    xs = list(range(len(groups)))
    ax.errorbar(xs, ms, yerr=ss, marker="o", capsize=3, linestyle="none")
    ax.set_xticks(xs, labels, fontsize=7)


def _per_seed(ax, group: Group, metric) -> None:
    pts = sorted((r["seed"], r[metric]) for r in group.runs
                 if r["status"] == "ok" and is_number(r.get(metric)))
    mean, std, _ = group.stats(metric)
    xs, ys = zip(*pts, strict=True)
    ax.plot(xs, ys, "o", label="runs")
    ax.axhline(mean, color="k", lw=1, label=f"mean {mean:.4g}")
    ax.axhspan(mean - std, mean + std, color="k", alpha=0.1, label=f"±1 std ({std:.2g})")
    ax.set_xlabel("seed")
    ax.legend(fontsize=8)


def sweep_plots(out_dir: Path, metrics: list[str], groups: list[Group], point_keys: list[str],
                title: str) -> list[Path]:
    paths = []
    for metric in metrics:
        p = plot_metric(out_dir / file_name(metric), metric, groups, point_keys, title)
        if p is not None:
            paths.append(p)
    return paths
