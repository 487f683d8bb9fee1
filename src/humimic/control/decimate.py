"""Which calls of a servo-rate hook do work: a controller running at ``servo_rate / every``."""

from __future__ import annotations


class Decimator:
    """Call once per servo tick: returns this tick's turn (0, 1, 2, ...) on the first tick and
    every ``every``-th after it, and None on the ticks in between."""

    def __init__(self, every: int):
        self.every = max(1, int(every))
        self.calls = 0

    def __call__(self) -> int | None:
        call = self.calls
        self.calls += 1
        return None if call % self.every else call // self.every
