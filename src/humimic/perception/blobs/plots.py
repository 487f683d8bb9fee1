"""Tracking plots: per-axis 3-D errors with the filter's ±2σ band, and p/v/a vs ground truth
(Ude & Atkeson's Fig. 1). Same conventions as :mod:`humimic.viz.plots` (explicit Agg canvas,
never pyplot)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from humimic.viz.plots import AXES, _figure, _save


def plot_tracking_errors(path: Path | str, target: str, t_raw: np.ndarray, raw_err: np.ndarray,
                         t_est: np.ndarray, est_err: np.ndarray, est_sigma: np.ndarray,
                         n_sigma: float = 2.0) -> Path:
    """Raw (dots) and filtered (line) errors per base axis (mm) with the filter's ±n_sigma
    band (its own position standard deviation, mm)."""
    fig = _figure(8.0, 6.5)
    axes = fig.subplots(3, 1, sharex=True)
    t_est, est_err, est_sigma = _with_gaps(t_est, est_err, est_sigma)
    for i, ax in enumerate(axes):
        if len(t_est):
            ax.fill_between(t_est, -n_sigma * est_sigma[:, i], n_sigma * est_sigma[:, i],
                            color="tab:blue", alpha=0.2, linewidth=0,
                            label=f"±{n_sigma:g}σ filter")
        if len(t_raw):
            ax.plot(t_raw, raw_err[:, i], ".", color="0.45", markersize=2.0, label="raw")
        if len(t_est):
            ax.plot(t_est, est_err[:, i], color="tab:blue", linewidth=1.0, label="filtered")
        ax.axhline(0.0, color="0.3", linewidth=0.7)
        ax.set_ylabel(f"{AXES[i]} error [mm]")
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(f"{target}: 3-D error, robot base frame")
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside lower center", ncols=3, fontsize="small")
    return _save(fig, path)


def plot_pva(path: Path | str, target: str, t_est: np.ndarray, x_est: np.ndarray,
             t_true: np.ndarray, p_true: np.ndarray, v_true: np.ndarray,
             a_true: np.ndarray) -> Path:
    """3x3 panels: position (mm), velocity (mm/s), acceleration (mm/s^2) per base axis, the
    filter's estimates (line) over the truth (dashed) -- Ude & Atkeson's Fig. 1. The y range
    shows the truth and the estimates' 1-99 % range (the start-up transient may leave it)."""
    fig = _figure(11.0, 7.5)
    axes = fig.subplots(3, 3, sharex=True)
    titles = ("position [mm]", "velocity [mm/s]", "acceleration [mm/s²]")
    for col, (truth, title) in enumerate(zip((p_true, v_true, a_true), titles, strict=True)):
        for row in range(3):
            ax = axes[row, col]
            ax.plot(t_true, 1e3 * truth[:, row], "--", color="0.2", linewidth=1.0,
                    label="ground truth")
            if len(t_est):
                est = 1e3 * _with_gaps(t_est, x_est)[1][:, 3 * col + row]
                ax.plot(_with_gaps(t_est)[0], est, color="tab:red", linewidth=0.9,
                        label="Kalman filter")
                ax.set_ylim(*_robust_limits(1e3 * truth[:, row], est[np.isfinite(est)]))
            ax.grid(True, alpha=0.3)
            if row == 0:
                ax.set_title(title)
            if col == 0:
                ax.set_ylabel(AXES[row])
        axes[-1, col].set_xlabel("time [s]")
    fig.suptitle(f"{target}: estimated p, v, a vs ground truth (robot base frame)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=2, fontsize="small")
    return _save(fig, path)


def _robust_limits(truth: np.ndarray, est: np.ndarray, pad: float = 0.15
                   ) -> tuple[float, float]:
    """Y limits covering the truth and the estimates' 1-99 % range (start-up transients of
    v and a would otherwise flatten the plot), padded."""
    lo = min(float(np.min(truth)), float(np.percentile(est, 1)))
    hi = max(float(np.max(truth)), float(np.percentile(est, 99)))
    span = max(hi - lo, 1e-6)
    return lo - pad * span, hi + pad * span


def _with_gaps(t: np.ndarray, *series: np.ndarray) -> tuple[np.ndarray, ...]:
    """``t`` and ``series`` (rows per time) with a NaN row inserted wherever the time step is
    more than 1.5 times the usual one, so lines and bands break across missing estimates."""
    if len(t) < 3:
        return (t, *series)
    dt = np.diff(t)
    cut = np.flatnonzero(dt > 1.5 * np.median(dt)) + 1
    t_out = np.insert(np.asarray(t, float), cut, np.nan)
    return (t_out, *(np.insert(np.asarray(v, float), cut, np.nan, axis=0) for v in series))
