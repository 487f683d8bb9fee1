"""Shared pieces of the benchmark scripts: timing over repeats, result rows, skipped rows.

A *row* is one measured quantity: the median over ``repeats`` and the spread as the
interquartile range (q1-q3) of the repeats; each repeat is the mean over ``inner`` calls
(so a repeat is long enough for the clock). Rows whose subject is missing (a stage not
implemented yet, an optional package absent) are kept as skipped rows with a note.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field


@dataclass
class Row:
    group: str
    name: str
    unit: str
    median: float | None = None
    q1: float | None = None
    q3: float | None = None
    repeats: int = 0
    note: str = ""
    extra: dict = field(default_factory=dict)
    """Anything else measured alongside (errors, agreement), JSON-serialisable."""

    @property
    def skipped(self) -> bool:
        return self.median is None

    def as_dict(self) -> dict:
        return asdict(self)


def per_call(fn: Callable[[], object], repeats: int, inner: int, warmup: int = 1,
             clock: str = "wall") -> list[float]:
    """Seconds per call of ``fn``: ``repeats`` values, each the mean over ``inner`` calls.
    ``clock``: ``wall`` (perf_counter) or ``cpu`` (the process's CPU time, all threads: on a
    shared machine, the cost without the waits for a core)."""
    now = time.perf_counter if clock == "wall" else time.process_time
    for _ in range(warmup):
        fn()
    out = []
    for _ in range(repeats):
        t0 = now()
        for _ in range(inner):
            fn()
        out.append((now() - t0) / inner)
    return out


def row(group: str, name: str, values: list[float], unit: str, scale: float = 1.0,
        note: str = "", **extra) -> Row:
    v = sorted(x * scale for x in values)
    if len(v) >= 2:
        q1, _, q3 = statistics.quantiles(v, n=4, method="inclusive")
    else:
        q1 = q3 = v[0]
    return Row(group, name, unit, statistics.median(v), q1, q3, len(v), note, extra)


def skipped(group: str, name: str, unit: str, note: str) -> Row:
    return Row(group, name, unit, note=f"skipped: {note}")


@dataclass
class Peer:
    """Ours vs a peer on the same inputs: the ratio ours / peer of their medians."""

    group: str
    name: str
    ours: Row
    peer: Row
    note: str = ""

    @property
    def ratio(self) -> float | None:
        if self.ours.skipped or self.peer.skipped or not self.peer.median:
            return None
        return self.ours.median / self.peer.median

    def as_dict(self) -> dict:
        return {"group": self.group, "name": self.name, "ours": self.ours.as_dict(),
                "peer": self.peer.as_dict(), "ratio": self.ratio, "note": self.note}


def fmt(x: float | None) -> str:
    if x is None:
        return "-"
    if x == 0 or 0.01 <= abs(x) < 1e5:
        return f"{x:.3g}" if abs(x) < 100 else f"{x:.0f}"
    return f"{x:.2e}"
