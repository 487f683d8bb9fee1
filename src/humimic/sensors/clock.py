"""One multi-rate scheduler in simulated time.

Time advances in integer physics ticks (no floating-point drift). A stream at ``rate`` Hz takes
its k-th sample at the first physics tick at or after ``k / rate`` seconds, and the sample's
timestamp is that tick's time. With the default 840 Hz physics, 420/210/120/60/30 Hz streams
are exact; other rates (180 Hz IMU, 100 Hz Wii remote) jitter by less than one physics step
(1.19 ms) around their nominal times while keeping the exact mean rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class Clock:
    physics_rate: float = 840.0
    tick: int = 0

    @property
    def dt(self) -> float:
        return 1.0 / self.physics_rate

    @property
    def t(self) -> float:
        return self.tick / self.physics_rate

    def time_of(self, tick: int) -> float:
        return tick / self.physics_rate

    def ticks_for(self, duration_s: float) -> int:
        """Number of physics steps covering ``duration_s`` (rounded to the nearest step)."""
        return int(round(duration_s * self.physics_rate))


def sample_tick(k: int, rate: float, physics_rate: float) -> int:
    """Physics tick of a stream's k-th sample (k = 0, 1, ...)."""
    return math.ceil(k * physics_rate / rate - 1e-9)


@dataclass
class Schedule:
    """When a stream at ``rate`` Hz is due, in physics ticks. Call :meth:`due` once per tick."""

    rate: float
    physics_rate: float = 840.0
    k: int = 0
    _next: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        if not 0.0 < self.rate <= self.physics_rate:
            raise ValueError(f"rate must be in (0, {self.physics_rate}] Hz, got {self.rate}")
        self._next = sample_tick(self.k, self.rate, self.physics_rate)

    def due(self, tick: int) -> bool:
        """True (and advance) when a sample falls on ``tick``."""
        if tick < self._next:
            return False
        self.k += 1
        self._next = sample_tick(self.k, self.rate, self.physics_rate)
        return True

    def ticks(self, n_ticks: int) -> list[int]:
        """All sample ticks in ``[0, n_ticks)`` (does not change the schedule)."""
        out, k = [], 0
        while (tick := sample_tick(k, self.rate, self.physics_rate)) < n_ticks:
            out.append(tick)
            k += 1
        return out
