"""The stage interface and per-stage compute timing.

A stage is built from its scenario section, subscribes to the topics it consumes, publishes
what it produces, and reports its scores at the end. Stages never call each other.

After the loop the runner calls, in this order and each with one job: :meth:`Stage.finish`
(complete pending work), :meth:`Stage.metrics` (scores only, no side effects),
:meth:`Stage.log` (end-of-run series to rerun), :meth:`Stage.archive` (data files, written
whether or not plots are on) and, when plots are on, :meth:`Stage.plots` (PNG files only).
"""

from __future__ import annotations

import time
from collections import defaultdict
from contextlib import contextmanager


class Stage:
    """Base class. Subclasses set ``name`` and override what they need."""

    name = "stage"

    def attach(self, bus, timer: StageTimer) -> None:
        """Subscribe to topics on ``bus``. Called once before the loop starts."""

    def servo(self, t: float, bus) -> None:
        """Called at the servo rate (control stages)."""

    def finish(self) -> None:
        """Called once when the loop ends (also after Ctrl-C): complete pending work, e.g. a
        frame still being processed in a worker."""

    def metrics(self) -> dict:
        """Scores for ``metrics.json`` (merged at the top level), computed after the run.
        No side effects: nothing logged, nothing written."""
        return {}

    def log(self, rlog) -> None:
        """Log end-of-run results (error series, commanded vs reached) to the recording
        ``rlog`` (a :class:`~humimic.viz.rerun_log.RerunLog`, possibly disabled)."""

    def archive(self, out_dir) -> list:
        """Write the stage's data files into ``out_dir`` (always, plots or not); return their
        paths."""
        return []

    def plots(self, out_dir) -> list:
        """Write PNG plots into ``out_dir`` (nothing else); return their paths."""
        return []

    def close(self) -> None:
        """Release resources (renderers, files)."""


class StageTimer:
    """Accumulates wall-clock compute time per named stage."""

    def __init__(self) -> None:
        self.total_s: dict[str, float] = defaultdict(float)
        self.calls: dict[str, int] = defaultdict(int)

    @contextmanager
    def time(self, name: str):
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.total_s[name] += time.perf_counter() - t0
            self.calls[name] += 1

    def add(self, name: str, seconds: float, calls: int = 1) -> None:
        self.total_s[name] += seconds
        self.calls[name] += calls

    def summary(self) -> dict[str, dict[str, float]]:
        """``{stage: {mean_ms, calls, total_s}}``."""
        return {
            name: {
                "mean_ms": 1e3 * self.total_s[name] / max(self.calls[name], 1),
                "calls": int(self.calls[name]),
                "total_s": self.total_s[name],
            }
            for name in sorted(self.total_s)
        }
