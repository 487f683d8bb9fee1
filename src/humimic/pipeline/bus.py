"""A one-way message bus in simulated time.

Stages publish :class:`~humimic.stamped.Stamped` values on named topics. A value is delivered
to the topic's subscribers at the first physics tick whose time is at or after its
``t_ready`` (so a declared processing latency delays every consumer), in publication order.
The bus also remembers the latest *ready* value per topic for stages that poll at their own
rate (the servo).
"""

from __future__ import annotations

import heapq
import itertools
from collections import defaultdict
from collections.abc import Callable

from humimic.stamped import Stamped

Handler = Callable[[str, Stamped], None]


class Bus:
    def __init__(self) -> None:
        self._subscribers: dict[str, list[Handler]] = defaultdict(list)
        self._pending: list[tuple[float, int, str, Stamped]] = []
        self._latest: dict[str, Stamped] = {}
        self._counter = itertools.count()
        self.published: dict[str, int] = defaultdict(int)

    def subscribe(self, topic: str, handler: Handler) -> None:
        self._subscribers[topic].append(handler)

    def publish(self, topic: str, msg: Stamped) -> None:
        self.published[topic] += 1
        heapq.heappush(self._pending, (msg.t_ready, next(self._counter), topic, msg))

    def deliver(self, now: float, eps: float = 1e-9) -> int:
        """Deliver every value ready at ``now`` (including ones published while delivering)."""
        n = 0
        while self._pending and self._pending[0][0] <= now + eps:
            _, _, topic, msg = heapq.heappop(self._pending)
            self._latest[topic] = msg
            for handler in self._subscribers.get(topic, ()):
                handler(topic, msg)
            n += 1
        return n

    def latest(self, topic: str) -> Stamped | None:
        """The most recent value on ``topic`` that has been delivered (None before the first)."""
        return self._latest.get(topic)
