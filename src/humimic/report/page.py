"""Compose a run's one-page report, ``report.png`` and ``report.html`` in the run directory:
verdicts, each beside its stated threshold; per tracked target its filtered error with the
filter's ±2σ band and its NEES against the chi-square band; then the run's own plots (mimicry,
error budget, trackers, ground truth), each under a heading saying what it shows.

Verdicts and their thresholds: :mod:`humimic.report.verdicts`. Figures are drawn on explicit
Agg canvases (no pyplot, no global backend).
"""

from __future__ import annotations

import html
import json
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from scipy.ndimage import uniform_filter1d

from humimic.errors import InputError
from humimic.maths.stats import chi2_band, nees
from humimic.metrics.flatten import flatten_metrics
from humimic.metrics.tracking import FILTER_SETTLE_S
from humimic.report.verdicts import STATUS_COLOUR, Verdict, verdicts
from humimic.viz.plots import MAX_POINTS

#: Frames averaged for the NEES window (0.5 s at 60 Hz).
NEES_WINDOW = 30
#: Position NEES: 3 degrees of freedom.
NEES_DOF = 3
#: What NEES is, in one line, on the page.
NEES_LINE = ("NEES = eᵀP⁻¹e, the squared error measured in the filter's own covariance P: "
             f"a consistent filter averages {NEES_DOF} for a position ({NEES_DOF} dof) and "
             "stays inside the 95 % χ² band; above it the filter is over-confident, below it "
             "too cautious.")
#: Run plots embedded in the page, in order: file pattern and its section heading.
EMBED = (("slam_table2.png", "Sugiyama & Miura's Table II: the paper's estimated positions beside "
                              "ours"),
         ("slam_trajectory.png", "Wearable SLAM: the head camera's path in the paper's W, "
                                 "estimated and true, and its errors"),
         ("mimic_error_budget.png", "Mimicry error budget: which stage the robot's error "
                                    "comes from"),
         ("mimic_*.png", "Mimicry of {name}: the robot site's displacement vs the person's "
                         "(mapped), the estimate and the command"),
         ("tracker_*.png", "Tracker {name}: its error against the ground truth over time"),
         ("ground_truth.png", "Ground truth: the person's head and hands in the robot's base "
                              "frame"))


class NotARunError(InputError):
    """The directory is not a finished humimic run."""


@dataclass
class Run:
    path: Path
    metrics: dict
    tracking: Path | None = None
    """The run's ``tracking.npz`` (None: none written); the page reads a target's series from
    it column by column (:func:`tracking_series`), never the whole archive."""
    images: list[tuple[Path, str]] = field(default_factory=list)
    """Embedded plots and their section headings."""


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
    tracking = path / "tracking.npz" if (path / "tracking.npz").is_file() else None
    images, seen = [], set()
    for pattern, heading in EMBED:
        for p in sorted(path.glob(pattern)):
            if p not in seen:
                seen.add(p)
                images.append((p, heading.format(name=p.stem.split("_", 1)[-1])))
    return Run(path, metrics, tracking, images)


# ---- tracking panels -----------------------------------------------------------------------
def _filtered_targets(npz: Path | None) -> list[str]:
    """Targets of the archive ``npz`` the filter estimated at least once, with their truth."""
    if npz is None:
        return []
    with np.load(npz, allow_pickle=False) as z:
        if "f_targets" not in z.files:
            return []
        valid = z["f_valid"]  # (F, T) bool: small
        with_truth = {str(t) for t in z["truth_targets"] if f"ftruth_{t}" in z.files}
        targets = [str(t) for t in z["f_targets"]]
    return [t for i, t in enumerate(targets) if len(valid) and valid[:, i].any()
            and t in with_truth]


def window_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Trailing mean over ``n`` samples ignoring NaN (shorter at the start; NaN where a window
    holds none): sums and counts by :func:`scipy.ndimage.uniform_filter1d`."""
    x = np.asarray(x, float)
    ok = np.isfinite(x)
    origin = (n - 1) // 2  # the window ends at the sample: a trailing mean
    s = uniform_filter1d(np.where(ok, x, 0.0), n, mode="constant", origin=origin)
    c = uniform_filter1d(ok.astype(float), n, mode="constant", origin=origin)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(c > 0.5 / n, s / c, np.nan)


def tracking_series(npz: Path, target: str) -> dict[str, np.ndarray]:
    """Times, per-axis filtered error (m), its 1σ (m) and the position NEES (3 dof, NaN in the
    first :data:`~humimic.metrics.tracking.FILTER_SETTLE_S` after a (re)start) of a target,
    from the archive ``npz``: the target's columns only, read a block of frames at a time."""
    from humimic.perception.blobs.archive import read_rows

    with np.load(npz, allow_pickle=False) as z:
        i = [str(t) for t in z["f_targets"]].index(target)
        keep = z["f_valid"][:, i]
        t, p = z["f_t"][keep], z[f"ftruth_{target}"][0][keep]
    err = read_rows(npz, "f_x", lambda a: a[:, i, :3])[keep] - p
    P = read_rows(npz, "f_P", lambda a: a[:, i, :3, :3])[keep]
    values = nees(err, P)
    values[read_rows(npz, "f_since_init", lambda a: a[:, i])[keep] < FILTER_SETTLE_S] = np.nan
    sigma = np.sqrt(np.clip(np.diagonal(P, axis1=1, axis2=2), 0.0, None))
    return {"t": t, "err": err, "sigma": sigma, "nees": values}


def _plot_tracking(sub, npz: Path, target: str) -> None:
    s = tracking_series(npz, target)
    mean = window_mean(s["nees"], NEES_WINDOW)
    d = slice(None, None, max(1, -(-len(s["t"]) // MAX_POINTS)))  # what is drawn: <= MAX_POINTS
    s, mean = {k: v[d] for k, v in s.items()}, mean[d]
    ax_e, ax_n = sub.subplots(1, 2)
    for k, (axis, colour) in enumerate(zip("xyz", ("#1f77b4", "#ff7f0e", "#2ca02c"),
                                           strict=True)):
        ax_e.fill_between(s["t"], -2e3 * s["sigma"][:, k], 2e3 * s["sigma"][:, k],
                          color=colour, alpha=0.15, linewidth=0)
        ax_e.plot(s["t"], 1e3 * s["err"][:, k], color=colour, linewidth=0.9,
                  label=f"{axis} error (band: ±2σ)")
    ax_e.set_title("filtered error, robot base frame", fontsize=9)
    ax_e.set_xlabel("time [s]")
    ax_e.set_ylabel("error [mm]")
    ax_e.legend(fontsize=7, ncols=3, loc="upper center", bbox_to_anchor=(0.5, -0.22))
    ax_e.grid(alpha=0.3)

    lo, hi = chi2_band(NEES_DOF)
    lo_w, hi_w = chi2_band(NEES_DOF, NEES_WINDOW)
    ax_n.semilogy(s["t"], s["nees"], ".", markersize=2, color="#90a4ae", label="per frame")
    ax_n.semilogy(s["t"], mean, color="#37474f", linewidth=1.2,
                  label=f"mean of {NEES_WINDOW} frames")
    ax_n.axhspan(lo, hi, color="#2e7d32", alpha=0.08, label="95 % band, one frame")
    ax_n.axhspan(lo_w, hi_w, color="#2e7d32", alpha=0.2, label=f"95 % band, {NEES_WINDOW} frames")
    ax_n.axhline(NEES_DOF, color="#2e7d32", linewidth=0.8, linestyle="--",
                 label=f"expected ({NEES_DOF})")
    ax_n.set_title(f"position NEES ({NEES_DOF} dof)", fontsize=9)
    ax_n.set_xlabel("time [s]")
    ax_n.set_ylabel("NEES")
    ax_n.legend(fontsize=7, ncols=3, loc="upper center", bbox_to_anchor=(0.5, -0.22))
    ax_n.grid(alpha=0.3, which="both")
    sub.suptitle(f"Tracking {target}: filtered error and filter consistency", fontsize=11,
                 x=0.01, ha="left", fontweight="bold")


# ---- the page ------------------------------------------------------------------------------
def _draw_verdicts(sub, run: Run, items: list[Verdict]) -> None:
    ax = sub.subplots()
    ax.axis("off")
    m = run.metrics
    sub.suptitle(f"humimic run: {m.get('scenario')}  (seed {m.get('seed')})", fontsize=13,
                 x=0.01, ha="left", fontweight="bold")
    n = len(items) + 1
    for k, v in enumerate(items):
        y = 1.0 - (k + 0.5) / n
        ax.text(0.0, y, "●", color=STATUS_COLOUR[v.status], fontsize=12, va="center",
                transform=ax.transAxes)
        ax.text(0.025, y, v.label, fontsize=9, va="center", transform=ax.transAxes)
        ax.text(0.27, y, v.value, fontsize=9, va="center", transform=ax.transAxes)
        ax.text(1.0, y, v.threshold, fontsize=8, va="center", ha="right", color="#546e7a",
                transform=ax.transAxes)
    if _nees_shown(items):
        ax.text(0.0, 0.5 / n, NEES_LINE, fontsize=8, va="center", style="italic",
                color="#37474f", transform=ax.transAxes, wrap=True)


def _nees_shown(items: list[Verdict]) -> bool:
    """Whether a verdict speaks of NEES (the line explaining it is then shown)."""
    return any("NEES" in v.value for v in items)


def write_report(run_dir: str | Path) -> tuple[Path, Path]:
    """Write ``report.png`` and ``report.html`` into ``run_dir``; return their paths."""
    run = load_run(run_dir)
    items = verdicts(run.metrics)
    targets = _filtered_targets(run.tracking)
    images = [mpimg.imread(p) for p, _ in run.images]
    width = 12.0
    heights = [0.27 * (len(items) + 1) + 0.6] + [3.4] * len(targets) + [
        0.9 * width * im.shape[0] / im.shape[1] + 0.4 for im in images]
    fig = Figure(figsize=(width, sum(heights)), dpi=90, layout="constrained")
    FigureCanvasAgg(fig)
    subs = fig.subfigures(len(heights), 1, height_ratios=heights)
    subs = np.atleast_1d(subs)
    _draw_verdicts(subs[0], run, items)
    for sub, target in zip(subs[1:], targets, strict=False):
        _plot_tracking(sub, run.tracking, target)
    for sub, (_, heading), im in zip(subs[1 + len(targets):], run.images, images, strict=True):
        ax = sub.subplots()
        ax.imshow(im)
        ax.axis("off")
        sub.suptitle(heading, fontsize=11, x=0.01, ha="left", fontweight="bold")
    png = run.path / "report.png"
    fig.savefig(png)
    html_path = run.path / "report.html"
    html_path.write_text(_html(run, items))
    return png, html_path


def _fmt(value) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def _html(run: Run, items: list[Verdict]) -> str:
    m = run.metrics
    verdict_rows = "".join(
        f"<tr><td style='color:{STATUS_COLOUR[v.status]}'>●</td><td>{html.escape(v.label)}"
        f"</td><td>{html.escape(v.value)}</td><td style='color:#546e7a'>"
        f"{html.escape(v.threshold)}</td></tr>" for v in items)
    metric_rows = "".join(
        f"<tr><td>{html.escape(k)}</td><td>{html.escape(_fmt(v))}</td></tr>"
        for k, v in flatten_metrics({k: v for k, v in m.items() if k != "stages"}).items())
    stage_rows = "".join(
        f"<tr><td>{html.escape(k)}</td><td>{v['mean_ms']:.3f} ms x {v['calls']}</td></tr>"
        for k, v in (m.get("stages") or {}).items())
    return f"""<!doctype html>
<html><head><meta charset="utf-8"><title>humimic: {html.escape(str(m.get('scenario')))}</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:auto}}
table{{border-collapse:collapse}}td{{padding:2px 10px;border-bottom:1px solid #eee}}</style>
</head><body>
<h1>{html.escape(str(m.get('scenario')))} <small>seed {m.get('seed')}</small></h1>
<h2>Verdicts</h2><table>{verdict_rows}</table>
{f"<p><i>{html.escape(NEES_LINE)}</i></p>" if _nees_shown(items) else ""}
<p><img src="report.png" style="width:100%"></p>
<h2>Stage costs</h2><table>{stage_rows}</table>
<h2>All metrics</h2><table>{metric_rows}</table>
<p>Recording: <code>rerun {html.escape(str(run.path / 'run.rrd'))}</code></p>
</body></html>
"""
