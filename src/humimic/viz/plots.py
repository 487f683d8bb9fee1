"""PNG plots of a run: trajectories per axis, errors over time, stacked error budgets.

Figures are built with :class:`matplotlib.figure.Figure` on an explicit Agg canvas, never
through ``pyplot``: nothing global is touched (no backend switch, no figure registry), so the
functions are safe in tests, worker processes and alongside an interactive session.
Every function writes one PNG (creating its directory) and returns its path.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

DPI = 110
AXES = ("x", "y", "z")

#: A series is either values on the shared time base or its own ``(times, values)`` pair.
Series = np.ndarray | tuple[np.ndarray, np.ndarray]


def _figure(width_in: float, height_in: float) -> Figure:
    fig = Figure(figsize=(width_in, height_in), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)  # explicit Agg canvas, per figure
    return fig


def _save(fig: Figure, path: Path | str) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    return path


def _label(quantity: str, unit: str) -> str:
    """``x [m]`` for a bare unit; ``x, position (m)`` when a full label is given."""
    return f"{quantity} [{unit}]" if " " not in unit.strip() else f"{quantity}, {unit}"


def _split(times: np.ndarray, series: Series) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(series, tuple):
        return np.asarray(series[0], dtype=float), np.asarray(series[1], dtype=float)
    return np.asarray(times, dtype=float), np.asarray(series, dtype=float)


def plot_trajectories(path: Path | str, times: np.ndarray, series: Mapping[str, Series],
                      title: str, ylabel: str = "m") -> Path:
    """x/y/z against time (s) in three stacked panels, one line per series.

    ``series`` maps a label (``"head (true)"``, ``"head (filtered)"``) to (N, 3) values on
    ``times`` or to its own ``(times_i, values_i)``; NaN rows show as gaps.
    """
    fig = _figure(8.0, 6.5)
    axes = fig.subplots(3, 1, sharex=True)
    for label, s in series.items():
        t, v = _split(times, s)
        for i, ax in enumerate(axes):
            ax.plot(t, v[:, i], label=label, linewidth=1.2)
    for i, ax in enumerate(axes):
        ax.set_ylabel(_label(AXES[i], ylabel))
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title)
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:  # below the panels, never over the data
        fig.legend(handles, labels, loc="outside lower center", fontsize="small",
                   ncols=min(4, len(handles)))
    return _save(fig, path)


def plot_errors(path: Path | str, times: np.ndarray, errors: Mapping[str, Series],
                band: Mapping[str, Series] | None = None, title: str = "error",
                ylabel: str = "m", n_sigma: float = 2.0) -> Path:
    """Errors (N,) against time (s), one line each, optionally with a shaded ±n_sigma band.

    ``band`` maps an error's label to its standard deviation (N,) (same time base as the
    error, or its own ``(times, sigma)``): the band ``±n_sigma·σ`` is drawn around zero in
    the line's colour, so a consistent estimator's error stays mostly inside it.
    """
    fig = _figure(8.0, 4.0)
    ax = fig.add_subplot()
    for label, e in errors.items():
        t, v = _split(times, e)
        (line,) = ax.plot(t, v, label=label, linewidth=1.2)
        if band is not None and label in band:
            tb, sigma = _split(times, band[label])
            ax.fill_between(tb, -n_sigma * sigma, n_sigma * sigma, color=line.get_color(),
                            alpha=0.15, linewidth=0, label=f"±{n_sigma:g}σ {label}")
    ax.axhline(0.0, color="0.3", linewidth=0.8)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(_label("error", ylabel))
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    fig.legend(loc="outside right upper", fontsize="small")  # never over the data
    return _save(fig, path)


def plot_stacked_bar(path: Path | str, categories: Sequence[str],
                     parts: Mapping[str, Sequence[float]], title: str,
                     ylabel: str = "mm", quantity: str = "error") -> Path:
    """One bar per category, stacked from ``parts`` (label -> one value per category).

    Made for the error budget (perception, filtering, IK, servo per robot site); the total
    is printed above each bar.
    """
    fig = _figure(max(6.5, 1.2 * len(categories) + 4.0), 4.5)
    ax = fig.add_subplot()
    x = np.arange(len(categories))
    bottom = np.zeros(len(categories))
    for label, values in parts.items():
        v = np.asarray(values, dtype=float)
        ax.bar(x, v, bottom=bottom, label=label, width=0.6)
        bottom += v
    for xi, total in zip(x, bottom, strict=True):
        ax.annotate(f"{total:.3g}", (xi, total), textcoords="offset points", xytext=(0, 3),
                    ha="center", fontsize="small")
    ax.set_xticks(x, list(categories))
    ax.set_ylabel(_label(quantity, ylabel))
    fig.suptitle(title, fontsize="medium")
    ax.margins(y=0.12)
    ax.grid(True, axis="y", alpha=0.3)
    handles, labels = ax.get_legend_handles_labels()  # top part first, beside the bars
    fig.legend(handles[::-1], labels[::-1], loc="outside right center", fontsize="small")
    return _save(fig, path)
