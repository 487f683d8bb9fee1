"""PNG plots of a run: trajectories per axis, errors over time, the mimicry error budget.

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
    # a figure is freed only when the garbage collector finds its reference cycles: its
    # artists (a long run's lines) go now, not after the next few plots have stacked on them
    fig.clear()
    return path


def _label(quantity: str, unit: str) -> str:
    """``x [m]`` for a bare unit; ``x, position (m)`` when a full label is given."""
    return f"{quantity} [{unit}]" if " " not in unit.strip() else f"{quantity}, {unit}"


#: Points drawn per line at most (a longer series is drawn every k-th sample: a 10-minute run
#: at 840 Hz would otherwise hold half a million points per line in matplotlib).
MAX_POINTS = 6000


def _split(times: np.ndarray, series: Series) -> tuple[np.ndarray, np.ndarray]:
    t, v = (series if isinstance(series, tuple) else (times, series))
    step = max(1, -(-len(t) // MAX_POINTS))
    return np.asarray(t[::step], dtype=float), np.asarray(v[::step], dtype=float)


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


def plot_error_budget(path: Path | str, sites: Sequence[str],
                      rms: Mapping[str, Sequence[float]], shares: Mapping[str, Sequence[float]],
                      totals: Sequence[float], unit: str = "mm") -> Path:
    """The mimicry error budget, one row per robot site, two panels that answer two questions.

    Left, *how large is each term*: the RMS of every stage term (``rms``: term -> one value per
    site) beside the total's RMS (``totals``). Right, *how much of the total does each term
    make*: its share of the total's mean square (``shares``, fractions adding up to 1),
    stacked: positive shares up from 0, negative ones (terms that cancel others) down, the sum
    marked at 100 %. The RMS values do not add up to the total; the shares do.
    """
    names = list(rms)
    fig = _figure(10.0, 1.0 + 2.6 * len(sites))
    axes = fig.subplots(len(sites), 2, squeeze=False, width_ratios=[1.25, 1.0])
    colours = {n: f"C{k}" for k, n in enumerate(names)}
    for row, site in enumerate(sites):
        ax, ax_s = axes[row]
        y = np.arange(len(names) + 1)
        values = [float(rms[n][row]) for n in names] + [float(totals[row])]
        ax.barh(y, values, color=[colours[n] for n in names] + ["0.15"], height=0.7)
        for yi, v in zip(y, values, strict=True):
            ax.annotate(f"{v:.3g}", (v, yi), xytext=(3, 0), textcoords="offset points",
                        va="center", fontsize="small")
        ax.set_yticks(y, names + ["total"])
        ax.invert_yaxis()
        ax.set_xlabel(f"RMS [{unit}]")
        ax.margins(x=0.18)
        ax.grid(True, axis="x", alpha=0.3)
        ax.set_title(f"{site}: RMS of each term (terms partly cancel: no sum)",
                     fontsize="medium")
        up = down = 0.0
        for n in names:
            v = 100.0 * float(shares[n][row])
            if not np.isfinite(v):
                continue
            bottom = up if v >= 0 else down
            ax_s.bar(0, v, bottom=bottom, color=colours[n], width=0.5, label=n)
            if abs(v) >= 4.0:
                ax_s.annotate(f"{n} {v:.0f} %", (0.27, bottom + v / 2), va="center",
                              fontsize="small")
            up, down = (up + v, down) if v >= 0 else (up, down + v)
        ax_s.axhline(100.0, color="0.15", linewidth=1.2, linestyle="--")
        ax_s.annotate("total = 100 %", (1.05, 100.0), xytext=(0, -3), textcoords="offset points",
                      ha="right", va="top", fontsize="small")
        ax_s.set_ylim(min(down, 0.0) - 8.0, max(up, 100.0) + 8.0)
        ax_s.axhline(0.0, color="0.3", linewidth=0.8)
        ax_s.set_xlim(-0.4, 1.1)
        ax_s.set_xticks([])
        ax_s.set_ylabel("share of total mean square [%]")
        ax_s.grid(True, axis="y", alpha=0.3)
        ax_s.set_title("share of the total: mean(term·total) / mean(|total|²)",
                       fontsize="medium")
    fig.suptitle("Mimicry error budget: robot site vs the mapped truth, split by stage")
    return _save(fig, path)


def plot_track2d(path: Path | str, times: np.ndarray, error_px: np.ndarray, visible: np.ndarray,
                 state: np.ndarray, states: Sequence[str], title: str) -> Path:
    """A 2-D tracker over time: its centre error (px, NaN where it reports nothing) with the
    frames where the target is hidden shaded, and its state (index into ``states``) below."""
    fig = _figure(8.0, 4.5)
    ax_err, ax_state = fig.subplots(2, 1, sharex=True, height_ratios=(3, 1))
    t, e = _split(times, error_px)
    ax_err.plot(t, e, linewidth=1.2, label="centre error")
    _, hid = _split(times, ~np.asarray(visible, bool))
    if hid.any():
        ax_err.fill_between(t, 0, 1, where=hid > 0.5, transform=ax_err.get_xaxis_transform(),
                            color="0.6", alpha=0.3, linewidth=0, label="target hidden")
    ax_err.set_ylabel(_label("centre error", "px"))
    ax_err.set_ylim(bottom=0)
    ax_err.grid(True, alpha=0.3)
    ax_err.set_title(title)
    ax_err.legend(loc="upper right", fontsize="small")
    _, s = _split(times, state)
    ax_state.step(t, s, where="post", linewidth=1.2, color="0.2")
    ax_state.set_yticks(range(len(states)), list(states))
    ax_state.set_ylim(-0.5, len(states) - 0.5)
    ax_state.set_xlabel("time [s]")
    ax_state.grid(True, alpha=0.3)
    return _save(fig, path)
