"""Compose a run's one-page report: a verdict table, tracking errors with the filter's ±2σ band,
filter NEES with chi-square bounds, and the run's own plots (mimicry, error budget, ground
truth), as ``report.png`` and ``report.html`` in the run directory.

Verdict thresholds are the accuracy goals of the issues (e.g. detection rate ≥ 0.98, filtered
RMSE ≤ 25 mm, mimicry RMSE ≤ 25 mm and lag ≤ 50 ms): they are guides for a glance, not tests.
"""

from __future__ import annotations

import html
import json
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from humimic.errors import InputError  # noqa: E402
from humimic.report.nees import chi2_bounds, moving_mean, nees  # noqa: E402

#: Frames averaged for the NEES window (0.5 s at 60 Hz).
NEES_WINDOW = 30
#: Seconds after a filter (re)start that are left out of the NEES plot (huge initial P).
SETTLE_S = 0.5
#: Embedded plots, in order, when the run wrote them.
EMBED = ("slam_*.png", "mimic_*.png", "ground_truth.png")
STATUS_COLOUR = {"ok": "#2e7d32", "warn": "#f9a825", "bad": "#c62828", "info": "#546e7a"}


class NotARunError(InputError):
    """The directory is not a finished humimic run."""


@dataclass
class Verdict:
    label: str
    value: str
    status: str  # ok | warn | bad | info


@dataclass
class Run:
    path: Path
    metrics: dict
    archive: object | None = None
    images: list[Path] = field(default_factory=list)


def load_run(run_dir: str | Path) -> Run:
    path = Path(run_dir)
    metrics_file = path / "metrics.json"
    if not path.is_dir() or not metrics_file.is_file():
        raise NotARunError(f"{path}: not a humimic run directory (no metrics.json); "
                           "run `python -m humimic.run SCENARIO.yaml --out DIR` first")
    try:
        metrics = json.loads(metrics_file.read_text())
    except json.JSONDecodeError as err:
        raise NotARunError(f"{metrics_file}: unreadable metrics.json ({err.msg}, line "
                           f"{err.lineno}); was the run killed?") from None
    if not isinstance(metrics, dict) or "scenario" not in metrics:
        raise NotARunError(f"{metrics_file}: not a humimic metrics file (no 'scenario' key)")
    archive = None
    if (path / "tracking.npz").is_file():
        from humimic.perception.blobs.archive import load_archive

        archive = load_archive(path / "tracking.npz")
    images = []
    for pattern in EMBED:
        images.extend(sorted(p for p in path.glob(pattern) if p.name != "report.png"))
    return Run(path, metrics, archive, images)


# ---- verdicts ------------------------------------------------------------------------------
def _grade(value: float | None, good: float, bad: float, higher_is_better: bool = False) -> str:
    if value is None:
        return "bad"
    if higher_is_better:
        return "ok" if value >= good else ("warn" if value >= bad else "bad")
    return "ok" if value <= good else ("warn" if value <= bad else "bad")


def verdicts(metrics: dict) -> list[Verdict]:
    """What went well and what did not, from ``metrics.json``."""
    out = [Verdict("run", f"{metrics.get('sim_time_s', 0):.2f} s simulated, "
                          f"{metrics.get('realtime_factor', 0):.2f}x real time",
                   "bad" if metrics.get("interrupted") else "info")]
    warnings = metrics.get("mujoco_warnings") or {}
    out.append(Verdict("MuJoCo warnings", ", ".join(f"{k}: {v}" for k, v in warnings.items())
                       or "none", "bad" if warnings else "ok"))
    for target, s in (metrics.get("tracking") or {}).items():
        rate = s.get("detection_rate")
        out.append(Verdict(f"{target}: detection rate", "never detected" if rate is None or
                           s.get("time_to_first_detection_s") is None else f"{rate:.3f}",
                           _grade(rate, 0.98, 0.9, higher_is_better=True)))
        f = s.get("filtered_rmse_mm")
        if f is not None or s.get("raw_rmse_mm") is not None:
            raw = s.get("raw_rmse_mm")
            value = (f"filtered {f:.1f} mm" if f is not None else "no filter") + (
                f", raw {raw:.1f} mm" if raw is not None else "")
            out.append(Verdict(f"{target}: 3-D RMSE", value, _grade(f if f is not None
                                                                    else raw, 25.0, 50.0)))
    for site, s in (metrics.get("mimicry") or {}).items():
        if not isinstance(s, dict) or "rmse_mm" not in s:
            continue
        if s.get("status", "ok") != "ok":
            out.append(Verdict(f"mimicry {site}", s.get("reason", s["status"]), "bad"))
            continue
        out.append(Verdict(f"mimicry {site}: RMSE / lag",
                           f"{s['rmse_mm']:.1f} mm / {s.get('lag_ms', float('nan')):.0f} ms",
                           max((_grade(s["rmse_mm"], 25.0, 50.0),
                                _grade(abs(s.get("lag_ms") or 0.0), 50.0, 100.0)),
                               key=["ok", "warn", "bad"].index)))
    joints = (metrics.get("mimicry") or {}).get("joints")
    if joints:
        bad = joints.get("limit_violations", 0) or not joints.get("finite", True)
        out.append(Verdict("robot joints", "NaN!" if not joints.get("finite", True) else
                           f"{joints.get('limit_violations', 0)} limit violations",
                           "bad" if bad else "ok"))
    slam = metrics.get("slam")
    if slam and slam.get("frames"):
        ate, head = slam.get("ate_rmse_m"), slam.get("heading_rmse_deg")
        out.append(Verdict(f"SLAM ({slam.get('mode')}): head position / heading RMSE",
                           f"{100 * ate:.1f} cm / {head:.2f} deg" if ate is not None
                           and head is not None else "no estimate",
                           max((_grade(ate, 0.03, 0.10), _grade(head, 2.0, 5.0)),
                               key=["ok", "warn", "bad"].index)))
        if slam.get("mode") != "inertial":
            lost = slam.get("frames_without_features", 0)
            out.append(Verdict("SLAM features measured per frame",
                               f"{slam.get('features_per_frame', 0):.1f}; {lost} frames "
                               "without one", "ok" if lost == 0 else "warn"))
    e2e = (metrics.get("latency_ms") or {}).get("end_to_end")
    if e2e is not None:
        out.append(Verdict("end-to-end latency", f"{e2e:.0f} ms", _grade(e2e, 50.0, 100.0)))
    return out


# ---- tracking panels -----------------------------------------------------------------------
def _filtered_targets(archive) -> list[str]:
    fa = archive.filter if archive is not None else None
    if fa is None or len(fa.t) == 0:
        return []
    return [t for i, t in enumerate(fa.targets)
            if fa.valid[:, i].any() and t in archive.filter_truth]


def tracking_series(archive, target: str) -> dict[str, np.ndarray]:
    """Times, per-axis filtered error (m), its 1σ (m) and the state NEES (9 dof) of a target."""
    fa = archive.filter
    i = fa.targets.index(target)
    p, v, a = archive.filter_truth[target]
    keep = fa.valid[:, i]
    x, P = fa.x[keep, i], fa.P[keep, i]
    truth = np.concatenate([p, v, a], axis=1)[keep]
    err = x - truth
    settled = fa.since_init[keep, i] >= SETTLE_S
    values = nees(err, P)
    values[~settled] = np.nan
    sigma = np.sqrt(np.clip(np.diagonal(P[:, :3, :3], axis1=1, axis2=2), 0.0, None))
    return {"t": fa.t[keep], "err": err[:, :3], "sigma": sigma, "nees": values}


def _plot_tracking(fig: Figure, gs_row, archive, target: str) -> float | None:
    s = tracking_series(archive, target)
    ax_e = fig.add_subplot(gs_row[0])
    for k, (axis, colour) in enumerate(zip("xyz", ("#1f77b4", "#ff7f0e", "#2ca02c"),
                                           strict=True)):
        ax_e.fill_between(s["t"], -2e3 * s["sigma"][:, k], 2e3 * s["sigma"][:, k],
                          color=colour, alpha=0.15, linewidth=0)
        ax_e.plot(s["t"], 1e3 * s["err"][:, k], color=colour, linewidth=0.9,
                  label=f"{axis} error")
    ax_e.set_title(f"{target}: filtered error, base frame (band: filter ±2σ)", fontsize=9)
    ax_e.set_xlabel("time (s)")
    ax_e.set_ylabel("mm")
    ax_e.legend(fontsize=7, ncols=3, loc="upper right")
    ax_e.grid(alpha=0.3)

    ax_n = fig.add_subplot(gs_row[1])
    lo, hi = chi2_bounds(9, NEES_WINDOW)
    ax_n.semilogy(s["t"], s["nees"], ".", markersize=2, color="#90a4ae", label="NEES per frame")
    mean = moving_mean(s["nees"], NEES_WINDOW)
    ax_n.semilogy(s["t"], mean, color="#37474f", linewidth=1.2,
                  label=f"mean over {NEES_WINDOW} frames")
    ax_n.axhline(9.0, color="#2e7d32", linewidth=0.8, linestyle="--", label="expected (9)")
    ax_n.axhspan(lo, hi, color="#2e7d32", alpha=0.12, label="95 % χ² bounds")
    ax_n.set_title(f"{target}: NEES of (p, v, a), 9 dof", fontsize=9)
    ax_n.set_xlabel("time (s)")
    ax_n.legend(fontsize=7, loc="upper right")
    ax_n.grid(alpha=0.3, which="both")
    ok = np.isfinite(mean)
    return float(np.mean((mean[ok] >= lo) & (mean[ok] <= hi))) if ok.any() else None


# ---- the page ------------------------------------------------------------------------------
def write_report(run_dir: str | Path) -> tuple[Path, Path]:
    """Write ``report.png`` and ``report.html`` into ``run_dir``; return their paths."""
    run = load_run(run_dir)
    items = verdicts(run.metrics)
    targets = _filtered_targets(run.archive)
    images = [mpimg.imread(p) for p in run.images]
    width = 11.0
    heights = [0.3 * len(items) + 0.5] + [3.0] * len(targets) + [
        0.9 * width * im.shape[0] / im.shape[1] for im in images]
    total = sum(heights) + 0.6 * len(heights)
    fig = Figure(figsize=(width, total), dpi=90)
    FigureCanvasAgg(fig)
    gs = fig.add_gridspec(len(heights), 2, height_ratios=heights, hspace=0.6 * len(heights)
                          / sum(heights), wspace=0.18, top=1.0 - 0.5 / total,
                          bottom=0.2 / total, left=0.06, right=0.98)

    head = fig.add_subplot(gs[0, :])
    head.axis("off")
    m = run.metrics
    head.set_title(f"humimic run: {m.get('scenario')}  (seed {m.get('seed')})",
                   loc="left", fontsize=13, fontweight="bold")
    for k, v in enumerate(items):
        y = 1.0 - (k + 0.5) / len(items)
        head.text(0.0, y, "●", color=STATUS_COLOUR[v.status], fontsize=12, va="center",
                  transform=head.transAxes)
        head.text(0.03, y, v.label, fontsize=10, va="center", transform=head.transAxes)
        head.text(0.40, y, v.value, fontsize=10, va="center", transform=head.transAxes)

    consistency = {}
    for row, target in enumerate(targets, start=1):
        consistency[target] = _plot_tracking(fig, gs[row, :].subgridspec(1, 2, wspace=0.2),
                                             run.archive, target)
    for row, (path, im) in enumerate(zip(run.images, images, strict=True),
                                     start=1 + len(targets)):
        ax = fig.add_subplot(gs[row, :])
        ax.imshow(im)
        ax.axis("off")
        ax.set_title(path.name, fontsize=8, loc="left", color="#546e7a")
    png = run.path / "report.png"
    fig.savefig(png)
    html_path = run.path / "report.html"
    html_path.write_text(_html(run, items, consistency))
    return png, html_path


def _flatten(d: dict, prefix: str = "") -> list[tuple[str, str]]:
    rows = []
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            rows.extend(_flatten(v, key + "."))
        elif isinstance(v, float):
            rows.append((key, f"{v:.4g}"))
        else:
            rows.append((key, str(v)))
    return rows


def _html(run: Run, items: list[Verdict], consistency: dict[str, float | None]) -> str:
    m = run.metrics
    verdict_rows = "".join(
        f"<tr><td style='color:{STATUS_COLOUR[v.status]}'>●</td><td>{html.escape(v.label)}"
        f"</td><td>{html.escape(v.value)}</td></tr>" for v in items)
    nees_rows = "".join(
        f"<li>{html.escape(t)}: {'-' if f is None else f'{100 * f:.0f} %'} of "
        f"{NEES_WINDOW}-frame windows inside the 95 % χ² bounds</li>"
        for t, f in consistency.items())
    metric_rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{html.escape(v)}</td></tr>"
                          for k, v in _flatten(m) if not k.startswith("stages."))
    stage_rows = "".join(
        f"<tr><td>{html.escape(k)}</td><td>{v['mean_ms']:.3f} ms x {v['calls']}</td></tr>"
        for k, v in (m.get("stages") or {}).items())
    return f"""<!doctype html>
<html><head><meta charset="utf-8"><title>humimic: {html.escape(str(m.get('scenario')))}</title>
<style>body{{font-family:sans-serif;max-width:1000px;margin:auto}}
table{{border-collapse:collapse}}td{{padding:2px 10px;border-bottom:1px solid #eee}}</style>
</head><body>
<h1>{html.escape(str(m.get('scenario')))} <small>seed {m.get('seed')}</small></h1>
<table>{verdict_rows}</table>
<ul>{nees_rows}</ul>
<p><img src="report.png" style="width:100%"></p>
<h2>Stage costs</h2><table>{stage_rows}</table>
<h2>All metrics</h2><table>{metric_rows}</table>
<p>Recording: <code>rerun {html.escape(str(run.path / 'run.rrd'))}</code></p>
</body></html>
"""
