"""Timestamped values: the only thing that flows between pipeline stages.

A stage consumes :class:`Stamped` values and produces new ones. ``t`` is the simulated time
(s) at which the data was *sampled* (the photon time for a camera frame); ``t_ready`` is the
simulated time at which a consumer may first use it (``t`` plus every upstream processing
latency). Data flows one way: a stage never reaches back into the stage that fed it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Generic, TypeVar

T = TypeVar("T")


@dataclass(frozen=True, slots=True)
class Stamped(Generic[T]):
    t: float
    """Sample time in simulated seconds."""
    value: T
    t_ready: float = -1.0
    """When a consumer may use it (s); defaults to ``t`` (no latency)."""

    def __post_init__(self) -> None:
        if self.t_ready < 0.0:
            object.__setattr__(self, "t_ready", self.t)

    def delayed(self, latency_s: float) -> Stamped[T]:
        """The same value, usable ``latency_s`` later."""
        return replace(self, t_ready=self.t_ready + latency_s)

    def then(self, value: object, latency_s: float = 0.0) -> Stamped:
        """A downstream value derived from this one: same sample time, added latency."""
        return Stamped(self.t, value, self.t_ready + latency_s)
